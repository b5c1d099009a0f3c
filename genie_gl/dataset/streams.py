"""The random streams of one dataset scene: one frozen record, made from (dataset seed,
scene index) alone, so scene 17 can be made again by itself and no worker count or executor
changes a byte.

Every stream is a child of ``SeedSequence([seed, index])``, by its place in :data:`STREAMS`.
The layout, scene and cloud stages and the class balance take a generator of their stream
(``rng=``); placement, capture and a moving capture's trajectory take a seed (their public
entry points do): the first 31-bit draw of their stream. The trajectory and the class
balance share the sixth child (:data:`CHILD`), as datasets made so far were drawn. Capture seeds
frame i with ``SeedSequence([capture seed, i])``
(so its frames do not depend on how they are split over processes). The manifest's
description of the streams is :meth:`SceneStreams.describe`, written from this record.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

# the streams of a scene, in the order their SeedSequence children are spawned
STREAMS = ("layout", "scene", "placement", "capture", "cloud", "trajectory")
# stream name -> its child; the class balance draws from the trajectory's child
CHILD = {**{name: k for k, name in enumerate(STREAMS)}, "balance": STREAMS.index("trajectory")}
SEED_BITS = 31  # placement and capture seeds: a draw in [0, 2**31)


@dataclass(frozen=True)
class SceneStreams:
    """The generators and seeds of scene ``index`` of a dataset seeded with ``seed``.

    Attributes
    ----------
    seed : int, the dataset's seed (>= 0).
    index : int, the scene's index (>= 0).
    """

    seed: int
    index: int
    names: ClassVar[tuple[str, ...]] = STREAMS

    def sequence(self, name: str) -> np.random.SeedSequence:
        """The SeedSequence of stream ``name``."""
        return np.random.SeedSequence([int(self.seed), int(self.index)]).spawn(len(STREAMS))[
            CHILD[name]
        ]

    def rng(self, name: str) -> np.random.Generator:
        """A fresh generator of stream ``name`` (each call starts the stream again)."""
        return np.random.default_rng(self.sequence(name))

    @property
    def placement_seed(self) -> int:
        """The seed of the camera placement (``place_sensors(seed=)``)."""
        return int(self.rng("placement").integers(2**SEED_BITS))

    @property
    def capture_seed(self) -> int:
        """The seed of the capture (``capture(seed=)``: frame i draws from ``SeedSequence([it,
        i])``)."""
        return int(self.rng("capture").integers(2**SEED_BITS))

    @property
    def trajectory_seed(self) -> int:
        """The seed of a moving capture's trajectory (``make_trajectory(seed=)``)."""
        return int(self.rng("trajectory").integers(2**SEED_BITS))

    @classmethod
    def describe(cls) -> dict[str, str]:
        """How every stream of a scene is made, for the manifest."""
        root = "SeedSequence([seed, scene index])"
        out = {name: f"{root}.spawn({len(STREAMS)})[{k}]" for name, k in CHILD.items()}
        for name, use in (
            ("placement", "place_sensors(seed=)"),
            ("capture", "capture(seed=); frame i: SeedSequence([that seed, i])"),
            ("trajectory", "make_trajectory(seed=)"),
        ):
            out[name] = f"the first draw in [0, 2**{SEED_BITS}) of {out[name]}: {use}"
        return out
