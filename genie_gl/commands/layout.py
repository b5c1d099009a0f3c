"""``genie layout STRATEGY --seed S --out DIR``: layout JSON, PNG and label raster."""

from __future__ import annotations

import argparse
import io
import json
import sys

from ..errors import ConfigError, LimitError
from ..limits import MAX_RASTER_CELLS, MAX_REGIONS
from . import count, positive, seed

OUTPUTS = ("layout.json", "layout.png", "labels.npy")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "strategy", nargs="?", help="strategy JSON file, or a shipped name (assembly_line, ...)"
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--out", help="output folder (layout.json, layout.png, labels.npy, manifest.json)"
    )
    p.add_argument(
        "--resolution", type=positive(1e3), default=0.1, help="label raster cell size in metres"
    )
    p.add_argument(
        "--max-nodes",
        type=count(1, 10**12),
        default=MAX_REGIONS,
        help="limit on the layout's regions (and work), checked before any work",
    )
    p.add_argument("--schema", action="store_true", help="print the strategy JSON Schema and exit")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..layout import generate_layout, json_schema, load_strategy, save_layout_png
    from ..outputs import atomic_write_bytes, claim_folder

    if args.schema:
        json.dump(json_schema(), sys.stdout, indent=2)
        print()
        return 0
    if not args.strategy or not args.out:
        raise ConfigError("give a STRATEGY and --out DIR (or --schema)")
    strategy = load_strategy(args.strategy)
    w, h = strategy.root.width, strategy.root.height
    cells = (w / args.resolution + 1) * (h / args.resolution + 1)
    if cells > MAX_RASTER_CELLS:
        raise LimitError(
            f"--resolution {args.resolution}: a {w:g} x {h:g} m hall makes a label raster of "
            f"{cells:.3g} "
            f"cells, more than {MAX_RASTER_CELLS:,}; use a coarser --resolution"
        )
    folder = claim_folder(args.out, "layout", OUTPUTS)  # before any work: refuse the user's names
    with folder.abandoning():  # a failed run leaves nothing it wrote
        layout = generate_layout(strategy, seed=args.seed, max_regions=args.max_nodes)
        raster = layout.label_raster(args.resolution)
        folder.reserve()
        out = folder.path
        layout.to_json(out / "layout.json")
        save_layout_png(layout, out / "layout.png")
        buf = io.BytesIO()
        np.save(buf, raster.labels)
        atomic_write_bytes(out / "labels.npy", buf.getvalue())
        folder.finish(
            {
                "strategy": str(strategy.source),
                "seed": args.seed,
                "raster": {
                    "resolution_m": args.resolution,
                    "origin_xy": raster.origin_xy,
                    "type_names": raster.type_names,
                },
                "nodes": len(layout),
                "leaves": len(layout.leaves()),
            }
        )
    print(f"layout: {len(layout)} regions, {len(layout.leaves())} leaves -> {out}")
    return 0
