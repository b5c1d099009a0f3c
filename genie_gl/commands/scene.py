"""``genie scene LAYOUT_JSON --seed S --out SCENE.usda``: a USD scene plus an overview picture."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ConfigError
from . import announce_compilation, seed, stages


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("layout", help="layout JSON written by `genie layout`")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--out", required=True, help="scene file (.usda text or .usdc binary)")
    p.add_argument("--no-picture", action="store_true", help="skip the overview PNG")
    p.add_argument("--no-progress", action="store_true")


def run(args: argparse.Namespace) -> int:
    from ..layout import Layout
    from ..scene import build_scene
    from ..outputs import check_replaceable, png_is_ours
    from ..scene.usd import write_usd, written_by_genie

    out = Path(args.out)
    if out.suffix not in (".usda", ".usdc", ".usd"):
        raise ConfigError(f"--out {out}: expected a .usda, .usdc or .usd file name")

    check_replaceable(out, written_by_genie, what="USD scene", option="--out")  # before any work
    if not args.no_picture:
        check_replaceable(out.with_suffix(".png"), png_is_ours, what="PNG picture", option="--out")
    layout = Layout.from_json(args.layout)
    announce_compilation("scene")
    names = ["build scene", "write USD"] + ([] if args.no_picture else ["render overview"])
    made = [p for p in (out.parent, *out.parent.parents) if not p.exists()]  # folders to make
    written = False
    try:
        with stages(names, title="genie scene", enabled=not args.no_progress) as step:
            step("build scene")
            scene = build_scene(layout, seed=args.seed)
            step("write USD")
            out.parent.mkdir(parents=True, exist_ok=True)
            write_usd(scene, out)
            written = True
            if not args.no_picture:
                step("render overview")
                png = _overview(scene, layout, out)
    except BaseException:  # a failed run leaves nothing it wrote: the scene, the folders it made
        if written and out.is_file():
            out.unlink()
        for folder in made:
            try:
                folder.rmdir()
            except OSError:  # not empty (or not ours to remove): left as it is
                break
        raise
    msg = f"scene: {len(scene.instances)} instances of {len(scene.meshes)} meshes -> {out}"
    if not args.no_picture:
        msg += f" (overview {png})"
    print(msg)
    return 0


def _overview(scene, layout, out: Path) -> Path:
    """The overview picture beside the scene file (``SCENE.png``)."""
    from PIL import Image

    from ..capture import render
    from ..dataset.previews import overview_pose
    from ..outputs import save_png
    from ..sensors.camera import Sensor

    frame = render(scene, Sensor.pinhole(1024, 640, 620.0, far_m=1e3), overview_pose(layout.bounds))
    return save_png(Image.fromarray(frame.rgb), out.with_suffix(".png"))
