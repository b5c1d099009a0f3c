"""The frames of a mobile-scan map: a rig's recording along a trajectory with the registration
error of a mobile scanner (:mod:`genie_gl.motion.registration`) applied to every frame's pose.

Each frame's ``world_from_camera`` becomes the *estimated* pose the scanner's registration
would give it, so its points land where a real map would put them; ``meta`` keeps the true
pose (``true_world_from_camera``) and the predicted misplacement at mid range
(``registration_sigma_m``). The map itself is fused downstream
(:func:`genie_gl.cloud.fusion.fuse`): voxel-reduced to a mobile scanner's density, then cut
into chunks as the paper's real data was.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ..frame import Frame
from ..motion.registration import MID_RANGE_M, RegistrationError
from ..motion.trajectory import Trajectory
from .trajectory import Shot


def registration_rng(seed: int) -> np.random.Generator:
    """The generator of a recording's error path (independent of every frame's noise)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0x7265_6769]))  # "regi"


def with_registration(
    recording: Iterable[tuple[Shot, Frame]],
    trajectory: Trajectory,
    model: RegistrationError | None,
    *,
    rng: np.random.Generator,
) -> Iterator[tuple[Shot, Frame]]:
    """The recording with each frame moved to its estimated pose (``model`` None: unchanged
    poses, the true pose still recorded)."""
    path = None if model is None else model.sample(trajectory.length_m, rng=rng)
    for shot, frame in recording:
        meta = dict(frame.meta or {})
        meta["true_world_from_camera"] = shot.world_from_camera
        if path is None:
            meta["registration_sigma_m"] = 0.0
            yield shot, frame.replace(meta=meta)
            continue
        meta["registration_sigma_m"] = float(model.sigma_m(shot.distance_m, MID_RANGE_M))
        pose = path.apply(shot.world_from_camera, shot.world_from_body, shot.distance_m)
        yield shot, frame.replace(world_from_camera=pose, meta=meta)
