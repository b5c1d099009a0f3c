"""Strategy files: JSON, validated on load, with errors naming the file and the JSON path.

A strategy::

    {
      "name": "assembly_line",
      "root": {"width": 60, "height": 30, "type": "hall", "orientation": "up"},
      "region_types": {"hall": {"color": "#e0e0e0"},
                       "car": {"final": true, "color": "#d04040", "semantic": 3, "asset_group":
                       "car"}},
      "levels": [
        {"hall": {"generator": "assembly_line", "args": {...},
                  "children": {"line": "line", "path": {"sequential": ["forklift_lane",
                  "str_lane"]}},
                  "orientation": "suggested"}},
        "merge"
      ],
      "scene": {...}          # read by the scene stage (asset randomisation)
    }

Levels run broad to detailed (paper Algorithm 1); each maps region types to a rule (a
generator, its ``args``, a type provider per slot, an orientation provider) or is ``"merge"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ..errors import ConfigError, did_you_mean, json_path
from ..resources import read_json, resolve
from ..scene_options import scene_options
from .generators import GENERATORS, Generator, get_generator
from .model import ORIENTATIONS, RegionType
from .providers import OrientationProvider, TypeProvider


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


Span = Union[
    float, tuple[float, float]
]  # a value, or a range [min, max] drawn from the scene's Generator
Count = Union[int, tuple[int, int]]


class FillSpec(_Strict):
    """How a region of this type is furnished (the scene stage reads it).

    ``mode``: ``one`` asset in the middle (the default); a ``row`` along the region's long
    side; a ``grid`` over the region; a ``stack`` (one footprint stacked up to ``stack_m``).
    ``spacing_m``: clearance between neighbours; ``count``: at most this many (default: as
    many as fit); ``stack_m``: stack stackable classes (pallet, KLT, stillage) up to this
    height; ``load``: what each shelf of a rack carries, ``{class or "empty": weight}``,
    each loaded object its own instance of its own class. Ranges are ``[min, max]``.
    """

    mode: Literal["one", "row", "grid", "stack"] = "one"
    spacing_m: Span = 0.1
    count: Count | None = None
    stack_m: Span | None = None
    load: dict[str, float] | None = None

    @field_validator("spacing_m", "stack_m")
    @classmethod
    def _span(cls, v):
        if v is None:
            return v
        lo, hi = (v, v) if isinstance(v, (int, float)) else v
        if lo < 0 or hi < lo:
            raise ValueError(
                f"expected a value >= 0 or a range [min, max] with 0 <= min <= max, got {v!r}"
            )
        return v

    @field_validator("count")
    @classmethod
    def _count(cls, v):
        if v is None:
            return v
        lo, hi = (v, v) if isinstance(v, int) else v
        if lo < 1 or hi < lo:
            raise ValueError(
                f"expected a count >= 1 or a range [min, max] with 1 <= min <= max, got {v!r}"
            )
        return v

    @field_validator("load")
    @classmethod
    def _load(cls, v):
        if v is None:
            return v
        if not v or any(p < 0 for p in v.values()) or sum(v.values()) <= 0:
            raise ValueError(
                f"expected {{class or 'empty': weight >= 0}} with a positive sum, got {v!r}"
            )
        return v


class RegionTypeSpec(_Strict):
    final: bool = False
    color: Union[str, list[int]] = "#c8c8c8"
    semantic: int | None = Field(default=None, ge=0, le=65535)
    asset_group: str | None = None
    fill: FillSpec | None = None
    description: str | None = None


class RootSpec(_Strict):
    width: float = Field(gt=0)
    height: float = Field(gt=0)
    type: str
    x: float = 0.0
    y: float = 0.0
    orientation: Literal["up", "down", "left", "right"] = "up"


class RuleSpec(_Strict):
    generator: str
    args: dict[str, Any] = {}
    children: dict[str, Any] = Field(min_length=1)
    orientation: Any = "inherit"


class MergeSpec(_Strict):
    """What the ``"merge"`` levels do with two leaves of one type and orientation that
    border along part of an edge only (their union an L or a T): ``keep`` them apart (the
    default), or ``strip``: cut each where the other's edge ends, so the bordering parts
    merge into one strip and the rest stays as its own region (once per merge level)."""

    l_shape: Literal["keep", "strip"] = "keep"


class StrategySpec(_Strict):
    name: str
    description: str | None = None
    root: RootSpec
    region_types: dict[str, RegionTypeSpec] = Field(min_length=1)
    levels: list[Union[Literal["merge"], dict[str, RuleSpec]]] = Field(min_length=1)
    merge: MergeSpec = MergeSpec()
    scene: dict[str, Any] = {}


def json_schema() -> dict[str, Any]:
    """The published JSON Schema of strategy files (``genie layout --schema``)."""
    schema = StrategySpec.model_json_schema()
    schema["title"] = "genie-gl layout strategy"
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    return schema


@dataclass
class Rule:
    generator: Generator
    generator_name: str
    children: dict[str, TypeProvider]
    orientation: OrientationProvider


@dataclass
class Strategy:
    """A validated strategy: region types, levels of rules (or "merge"), scene options."""

    name: str
    root: RootSpec
    region_types: dict[str, RegionType]
    levels: list[Union[str, dict[str, Rule]]]
    scene: dict[str, Any] = field(default_factory=dict)
    source: str = "<dict>"
    l_shape: str = "keep"


def _color(value: Any, where: str) -> tuple[int, int, int]:
    if isinstance(value, str):
        s = value.lstrip("#")
        if len(s) == 6:
            try:
                return tuple(int(s[i : i + 2], 16) for i in (0, 2, 4))  # type: ignore[return-value]
            except ValueError:
                pass
    elif (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(c, int) and 0 <= c <= 255 for c in value)
    ):
        return tuple(value)  # type: ignore[return-value]
    raise ConfigError(f"{where}: expected a colour '#rrggbb' or [r, g, b] (0-255), got {value!r}")


def _fill(fill: FillSpec, source: str, name: str) -> dict[str, Any]:
    """The fill as a plain dict (it travels in layout JSON; the scene stage checks the load's
    class names, which the layout stage does not know)."""
    out = fill.model_dump()
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in out.items()}


def _model_at(loc: tuple) -> type[BaseModel]:
    """The strategy model that validates the object at JSON path ``loc``."""
    if not loc:
        return StrategySpec
    if loc[0] == "root":
        return RootSpec
    if loc[0] == "merge":
        return MergeSpec
    if loc[0] == "region_types":
        return FillSpec if len(loc) > 2 and loc[2] == "fill" else RegionTypeSpec
    if loc[0] == "levels":
        return RuleSpec
    return StrategySpec


def non_finite(data: Any, loc: tuple = ()) -> tuple | None:
    """The JSON path (as a tuple) of the first number in ``data`` that is not finite (JSON's
    ``Infinity``, ``-Infinity``, ``NaN``), or None."""
    stack = [(data, loc)]
    while stack:  # depth-first without recursion: a deeply nested file cannot overflow the stack
        value, at = stack.pop()
        if isinstance(value, float) and not math.isfinite(value):
            return at
        if isinstance(value, dict):
            stack.extend((v, at + (k,)) for k, v in reversed(list(value.items())))
        elif isinstance(value, (list, tuple)):
            stack.extend((v, at + (i,)) for i, v in reversed(list(enumerate(value))))
    return None


def parse_strategy(data: Any, source: str = "<dict>") -> Strategy:
    """Validate strategy data (already parsed JSON); errors give ``source`` and a JSON path.

    Every number must be finite (JSON's ``Infinity`` and ``NaN`` are refused here, once, for
    every command and generator)."""
    bad = non_finite(data)
    if bad is not None:
        value = data
        for part in bad:
            value = value[part]
        raise ConfigError(
            f"{source}: {json_path(bad)}: {value} is not a finite number; expected a finite number"
        )
    try:
        spec = StrategySpec.model_validate(data)
    except ValidationError as exc:
        # the most specific problem: a level's rule with a bad key fails both the "merge" branch
        # and the rule's own field; the latter is the one to name
        errors = exc.errors()
        e = max(errors, key=lambda e: (e["type"] != "literal_error", len(e["loc"])))
        loc = tuple(p for p in e["loc"] if p not in ("literal['merge']", "dict[str,RuleSpec]"))
        if e["type"] == "extra_forbidden":
            known = tuple(_model_at(loc[:-1]).model_fields)
            raise ConfigError(
                f"{source}: {json_path(loc)}: unknown key{did_you_mean(str(loc[-1]), known)} "
                "(known here: "
                f"{', '.join(known)})"
            ) from None
        if len(loc) == 2 and loc[0] == "levels" and isinstance(e.get("input"), str):
            raise ConfigError(
                f'{source}: {json_path(loc)}: {e["input"]!r:.40}: expected "merge" or a level (an '
                "object "
                f"of rules){did_you_mean(e['input'], ['merge'])}"
            ) from None
        raise ConfigError(
            f"{source}: {json_path(loc)}: {e['msg']} (got {e.get('input')!r:.80})"
        ) from None
    types = {}
    for name, t in spec.region_types.items():
        types[name] = RegionType(
            name,
            t.final,
            _color(t.color, f"{source}: $.region_types.{name}.color"),
            t.semantic,
            t.asset_group,
            None if t.fill is None else _fill(t.fill, source, name),
        )

    def known(name: str, where: str) -> None:
        if name not in types:
            raise ConfigError(
                f"{source}: {where}: region type {name!r} is not declared in "
                f"$.region_types{did_you_mean(name, types)}"
            )

    known(spec.root.type, "$.root.type")
    levels: list[Union[str, dict[str, Rule]]] = []
    for i, level in enumerate(spec.levels):
        if level == "merge":
            levels.append("merge")
            continue
        if not level:
            raise ConfigError(
                f'{source}: $.levels[{i}]: empty level; give at least one rule or "merge"'
            )
        rules = {}
        for tname, rule in level.items():
            where = f"$.levels[{i}].{tname}"
            known(tname, where)
            if types[tname].final:
                raise ConfigError(
                    f"{source}: {where}: region type {tname!r} is final and cannot have a generator"
                )
            cls = get_generator(rule.generator, f"{source}: {where}.generator")
            unknown = (
                sorted(set(rule.args) - set(cls.arguments)) if cls.arguments is not None else []
            )
            if unknown:
                raise ConfigError(
                    f"{source}: {where}.args.{unknown[0]}: not an argument of {rule.generator}"
                    f"{did_you_mean(unknown[0], cls.arguments)} (it takes: "
                    f"{', '.join(cls.arguments)})"
                )
            try:
                gen = cls(**rule.args)
                gen.check(f"{source}: {where}")
            except ConfigError:
                raise
            except (
                TypeError,
                ValueError,
                KeyError,
                IndexError,
                OverflowError,
            ) as exc:  # an argument of the wrong kind
                raise ConfigError(
                    f"{source}: {where}.args{_culprit(cls, rule.args, where)}: {rule.generator} "
                    "cannot use "
                    f"this value ({type(exc).__name__}: {exc})"
                ) from None
            providers = {}
            for slot, pspec in rule.children.items():
                if cls.slots and slot not in cls.slots:
                    raise ConfigError(
                        f"{source}: {where}.children.{slot}: generator {rule.generator!r} makes no "
                        f"slot {slot!r}{did_you_mean(slot, cls.slots)} (slots: "
                        f"{', '.join(cls.slots)})"
                    )
                tp = TypeProvider(pspec, f"{source}: {where}.children.{slot}")
                for t in tp.types():
                    known(t, f"{where}.children.{slot}")
                providers[slot] = tp
            orient = OrientationProvider(rule.orientation, f"{source}: {where}.orientation")
            if orient.kind == "face":
                for t in orient.values:
                    known(t, f"{where}.orientation.face")
            if i == 0 and tname == spec.root.type:
                gen.check_fits(spec.root.width, spec.root.height, f"{source}: {where}")
            rules[tname] = Rule(gen, rule.generator, providers, orient)
        levels.append(rules)
    scene_options(spec.scene, f"{source}: $.scene")  # checked here, typed where it is used
    return Strategy(spec.name, spec.root, types, levels, spec.scene, source, spec.merge.l_shape)


def _culprit(cls, args: dict[str, Any], where: str) -> str:
    """``.name (got value)`` of the first argument that fails the generator's check alone."""
    for k, v in args.items():
        try:
            cls(**{k: v}).check(where)
        except Exception:  # noqa: BLE001  (any failure names this argument)
            return f".{k} (got {v!r:.40})"
    return ""


def load_strategy(path_or_name: str | Path) -> Strategy:
    """Load and validate a strategy file, or a shipped one by name (``"assembly_line"``)."""
    path = resolve(path_or_name, "layouts", (".json",))
    data = read_json(path, "strategy JSON")
    return parse_strategy(_anchor_assets(data, Path(path).resolve().parent), str(path))


def _anchor_assets(data: Any, base: Path) -> Any:
    """Make the relative file paths of ``scene.assets`` (the scene stage's) relative to ``base``."""
    scene = data.get("scene") if isinstance(data, dict) else None
    assets = scene.get("assets") if isinstance(scene, dict) else None
    if not isinstance(assets, dict):
        return data

    def anchor(e: Any) -> Any:
        if isinstance(e, str):
            return str(base / e)  # an absolute path stays as it is
        if isinstance(e, dict) and isinstance(e.get("path"), str):
            return {**e, "path": str(base / e["path"])}
        return e

    fixed = {c: [anchor(e) for e in es] if isinstance(es, list) else es for c, es in assets.items()}
    return {**data, "scene": {**scene, "assets": fixed}}


__all__ = [
    "GENERATORS",
    "ORIENTATIONS",
    "Strategy",
    "json_schema",
    "load_strategy",
    "parse_strategy",
]
