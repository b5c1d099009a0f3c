"""Property providers: the region type and orientation of each generated child.

Region-type providers (strategy JSON → provider):

* ``"pallet"`` — constant;
* ``{"random": ["car", "empty"]}`` — uniform;
* ``{"stochastic": {"car": 0.95, "empty": 0.05}}`` — weighted;
* ``{"sequential": ["car", "empty"]}`` — a repeating pattern along the children.

Orientation providers: ``"inherit"`` (the parent's; also the paper's ``AUTO``), a fixed
``"up"|"down"|"left"|"right"``, ``"suggested"`` (what the generator proposes, e.g. along the
line, else inherit), ``{"random": [...]}``, and ``{"face": ["path", ...]}`` — towards the
nearest sibling of one of those types.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigError
from .model import DIRECTION, ORIENTATIONS, Region


class TypeProvider:
    def __init__(self, spec: Any, where: str) -> None:
        self.where = where
        if isinstance(spec, str):
            self.kind, self.values, self.p = "constant", [spec], None
            return
        if not isinstance(spec, dict) or len(spec) != 1:
            raise ConfigError(
                f"{where}: expected a type name or one of {{'random': [...]}}, "
                f"{{'stochastic': {{...}}}}, {{'sequential': [...]}}; got {spec!r}"
            )
        ((kind, val),) = spec.items()
        if kind in ("random", "sequential"):
            if not isinstance(val, list) or not val or not all(isinstance(v, str) for v in val):
                raise ConfigError(
                    f"{where}.{kind}: expected a non-empty list of type names, got {val!r}"
                )
            self.kind, self.values, self.p = kind, list(val), None
        elif kind == "stochastic":
            if not isinstance(val, dict) or not val or any(float(p) < 0 for p in val.values()):
                raise ConfigError(
                    f"{where}.stochastic: expected {{type: probability >= 0}}, got {val!r}"
                )
            total = sum(float(p) for p in val.values())
            if total <= 0:
                raise ConfigError(f"{where}.stochastic: probabilities sum to 0")
            self.kind, self.values = kind, list(val)
            self.p = np.array([float(p) / total for p in val.values()])
        else:
            raise ConfigError(
                f"{where}: unknown type provider {kind!r}; expected random, stochastic or "
                "sequential"
            )

    def types(self) -> list[str]:
        return list(self.values)

    def choose(self, n: int, rng: np.random.Generator) -> list[str]:
        """Types for ``n`` children in generation order (constant and sequential draw nothing)."""
        if self.kind == "constant":
            return self.values * n
        if self.kind == "sequential":
            return [self.values[i % len(self.values)] for i in range(n)]
        if n == 0:
            return []
        if self.kind == "random":
            return [self.values[i] for i in rng.integers(0, len(self.values), n)]
        return [self.values[i] for i in rng.choice(len(self.values), size=n, p=self.p)]

    def choose_index(self, rank: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Array form of :meth:`choose` for many parents at once: ``rank`` is each child's
        position among its parent's children of this slot; returns indices into ``values``."""
        n = len(rank)
        if self.kind == "constant":
            return np.zeros(n, np.int64)
        if self.kind == "sequential":
            return rank % len(self.values)
        if n == 0:
            return np.zeros(0, np.int64)
        if self.kind == "random":
            return rng.integers(0, len(self.values), n)
        return rng.choice(len(self.values), size=n, p=self.p)


class OrientationProvider:
    def __init__(self, spec: Any, where: str) -> None:
        self.where = where
        if spec in (None, "inherit", "AUTO", "auto"):
            self.kind, self.values = "inherit", []
        elif spec == "suggested":
            self.kind, self.values = "suggested", []
        elif isinstance(spec, str):
            if spec not in ORIENTATIONS:
                raise ConfigError(
                    f"{where}: orientation {spec!r} is unknown; expected inherit, suggested, "
                    f"{', '.join(ORIENTATIONS)}, {{'random': [...]}} or {{'face': [types]}}"
                )
            self.kind, self.values = "fixed", [spec]
        elif isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("random", "face"):
            ((kind, val),) = spec.items()
            if not isinstance(val, list) or not val:
                raise ConfigError(f"{where}.{kind}: expected a non-empty list, got {val!r}")
            if kind == "random" and any(v not in ORIENTATIONS for v in val):
                raise ConfigError(
                    f"{where}.random: orientations must be among {', '.join(ORIENTATIONS)}, got "
                    f"{val!r}"
                )
            self.kind, self.values = kind, list(val)
        else:
            raise ConfigError(f"{where}: cannot read orientation provider {spec!r}")

    def choose_index(
        self, parent_orient: np.ndarray, suggested: np.ndarray, rng: np.random.Generator
    ) -> np.ndarray | None:
        """Array form of :meth:`choose` for many children at once (indices into ORIENTATIONS;
        ``suggested`` is -1 where the generator proposes none); None for ``face``, which
        needs each parent's children together."""
        n = len(parent_orient)
        if self.kind == "inherit":
            return parent_orient.astype(np.int8)
        if self.kind == "suggested":
            return np.where(suggested >= 0, suggested, parent_orient).astype(np.int8)
        if self.kind == "fixed":
            return np.full(n, ORIENTATIONS.index(self.values[0]), np.int8)
        if self.kind == "random":
            idx = np.array([ORIENTATIONS.index(v) for v in self.values], np.int8)
            return idx[rng.integers(0, len(self.values), n)] if n else np.zeros(0, np.int8)
        return None

    def choose(
        self,
        parent: Region,
        children: list[Region],
        suggested: list[str | None],
        rng: np.random.Generator,
    ) -> list[str]:
        n = len(children)
        if self.kind == "inherit":
            return [parent.orientation] * n
        if self.kind == "suggested":
            return [s or parent.orientation for s in suggested]
        if self.kind == "fixed":
            return self.values * n
        if self.kind == "random":
            return [self.values[i] for i in rng.integers(0, len(self.values), n)] if n else []
        # face the nearest sibling of the given types
        targets = [c for c in children if c.type in self.values]
        out = []
        for c in children:
            others = [t for t in targets if t is not c]
            if not others:
                out.append(parent.orientation)
                continue
            cx, cy = c.centre
            t = min(others, key=lambda o: (o.centre[0] - cx) ** 2 + (o.centre[1] - cy) ** 2)
            dx, dy = t.centre[0] - cx, t.centre[1] - cy
            out.append(max(ORIENTATIONS, key=lambda o: DIRECTION[o][0] * dx + DIRECTION[o][1] * dy))
        return out
