"""Make the README's pictures (``make docs-images``): one dataset scene (seed 0) gives the
layout, the overview, a camera's depth/labels/colour, the cloud from above and the histogram,
so every picture shows the same scene; the other strategies' layouts come from seed 0 too."""

import shutil
import sys
from pathlib import Path

from genie_gl.cli import main
from genie_gl.dataset.previews import layout_picture
from genie_gl.layout import generate_layout

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/docs")
images = Path(__file__).parent / "images"
shutil.rmtree(out, ignore_errors=True)
assert (
    main(
        [
            "dataset",
            "assembly_line",
            "--scenes",
            "1",
            "--cameras",
            "8",
            "--sensor",
            "realsense_d435",
            "--format",
            "ply",
            "--previews",
            "1",
            "--workers",
            "1",
            "--seed",
            "0",
            "--out",
            str(out),
        ]
    )
    == 0
)
for src, dst in (
    ("previews/scene_0000_layout.png", "layout_assembly_line.png"),
    ("previews/scene_0000_overview.png", "scene_overview.png"),
    ("previews/scene_0000_cam00.png", "camera_depth_label_rgb.png"),
    ("previews/scene_0000_cloud_top.png", "cloud_top.png"),
    ("histogram.png", "histogram.png"),
):
    shutil.copyfile(out / src, images / dst)
for name in ("storage_area", "logistics_lane"):
    layout = generate_layout(name, seed=0)
    layout_picture(
        layout,
        f"{name}: layout, seed 0 ({len(layout.leaves())} regions)",
        images / f"layout_{name}.png",
    )
print(f"pictures in {images}")
