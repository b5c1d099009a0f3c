"""``genie report-card --sensor NAME [--sensor NAME ...] [--out DIR] [--pages DIR] [--json]
[--captures DIR --calibration FILE --wall-distance M]``.

Renders the standard test scenes through each profile, measures them with the field's
depth-quality metrics and prints the card: every published figure of
``sensors/<name>.reference.yml`` beside ours, with its source and a verdict, then the
measurements. ``--sensor all`` takes every shipped profile that has a reference file.
``--out`` writes ``<name>.card.json`` and ``<name>.card.md`` per sensor and a
``manifest.json``; ``--pages`` writes the Markdown pages and PNG curves (``docs/sensors/``).
With ``--captures`` the card also measures a user's own depth PNGs of a wall and puts them in
the same table (one sensor at a time).
"""

from __future__ import annotations

import argparse
import json
import sys
from contextlib import ExitStack
from pathlib import Path

from ..errors import ConfigError
from . import count, positive, seed


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--sensor",
        action="append",
        required=True,
        help="profile name or path (repeat for several; 'all' = every shipped profile with a "
        "reference file)",
    )
    p.add_argument(
        "--references",
        help="a reference file to judge against (default: the shipped one of the profile)",
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--frames", type=count(1, 10_000), default=8, help="frames per test scene (>= 2; default 8)"
    )
    p.add_argument(
        "--quick", action="store_true", help="fewer distances and angles (a smoke test, not a card)"
    )
    p.add_argument("--out", help="folder for <name>.card.json, <name>.card.md and manifest.json")
    p.add_argument(
        "--pages", help="folder for the Markdown pages and PNG curves (e.g. docs/sensors)"
    )
    p.add_argument("--json", action="store_true", help="print the card as JSON instead of Markdown")
    p.add_argument(
        "--captures", help="folder of 16-bit depth PNGs of a flat wall from your own camera"
    )
    p.add_argument("--calibration", help="your camera's OpenCV calibration file (with --captures)")
    p.add_argument(
        "--wall-distance",
        type=positive(1e4),
        help="the wall's distance on the optical axis, m (with --captures)",
    )
    p.add_argument(
        "--depth-scale",
        type=positive(1e3),
        default=0.001,
        help="metres per depth PNG unit (default 0.001)",
    )


def _sensors(names: list[str]) -> list[str]:
    if "all" not in names:
        return names
    from ..resources import data_dir

    shipped = sorted(
        p.name[: -len(".reference.yml")] for p in data_dir("sensors").glob("*.reference.yml")
    )
    return shipped + [n for n in names if n != "all" and n not in shipped]


def run(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..card.report import CardSettings, report_card
    from ..card.captures import load_captures
    from ..card.pages import card_markdown, write_pages
    from ..card.references import load_references, reference_path
    from ..effects.profile import load_sensor

    if args.frames < 2:
        raise ConfigError(
            f"--frames: the temporal metrics need at least 2 frames, got {args.frames}"
        )
    names = _sensors(args.sensor)
    given = [x is not None for x in (args.captures, args.calibration, args.wall_distance)]
    if any(given) and not all(given):
        raise ConfigError(
            "--captures, --calibration and --wall-distance go together (your depth PNGs, your "
            "camera's calibration file and the wall's distance in metres)"
        )
    if args.captures and len(names) != 1:
        raise ConfigError(
            "--captures: compare your camera with one profile at a time (one --sensor)"
        )
    captures = (
        load_captures(
            args.captures, args.calibration, args.wall_distance, depth_scale=args.depth_scale
        )
        if args.captures
        else None
    )
    settings = CardSettings(frames=args.frames, seed=args.seed)
    if args.quick:
        settings = CardSettings(
            distances_m=(0.5, 1.0, 2.0),
            angles_deg=(30.0,),
            angle_distances_m=(1.0,),
            step_distances_m=(1.0,),
            bars_distances_m=(1.0,),
            panels_distances_m=(1.0,),
            frames=args.frames,
            seed=args.seed,
        )
    from ..outputs import atomic_write_text, claim_folder
    from ..card.pages import page_names

    if args.out and args.pages and Path(args.out).resolve() == Path(args.pages).resolve():
        raise ConfigError(
            "--out and --pages: give two different folders (the card files and the pages)"
        )
    stems = [Path(n).stem if n.endswith((".yaml", ".yml")) else n for n in names]
    out = pages = None
    if args.out:  # claimed before any work: a name of the user's is refused, not overwritten
        out = claim_folder(
            args.out, "report-card", [f"{s}.card{e}" for s in stems for e in (".json", ".md")]
        )
    if args.pages:
        pages = claim_folder(
            args.pages,
            "report-card",
            [n for s in stems for n in page_names(s)] + ["index.md"],
            option="--pages",
        )
    with ExitStack() as guard:  # a failed run leaves nothing it wrote, in either folder
        for folder in (out, pages):
            if folder is not None:
                guard.enter_context(folder.abandoning())
        cards, refs = [], {}
        from ..card.scanner_card import scanner_card, scanner_card_markdown, scanner_profile_file
        from ..effects.scanner_profile import load_scanner

        for name in names:
            if scanner_profile_file(name) is not None:  # a spinning scanner: its own card
                print(f"genie report-card: {name}: scanning the test scenes ...", file=sys.stderr)
                card = scanner_card(load_scanner(name), seed=args.seed)
                text = scanner_card_markdown(card)
                print(
                    json.dumps({**card, "rows": [list(r) for r in card["rows"]]}, indent=1)
                    if args.json
                    else text
                )
                if out is not None:
                    atomic_write_text(out.path / f"{card['sensor']}.card.md", text)
                if pages is not None:
                    atomic_write_text(pages.path / f"{card['sensor']}.md", text)
                    print(
                        f"genie report-card: wrote {pages.path / (card['sensor'] + '.md')}",
                        file=sys.stderr,
                    )
                continue
            sensor = load_sensor(name)
            ref = None
            if args.references:
                ref = load_references(args.references)
            elif reference_path(sensor.name).is_file():
                ref = load_references(sensor.name)
            print(
                f"genie report-card: {sensor.name}: rendering the test scenes ...", file=sys.stderr
            )
            card = report_card(sensor, settings=settings, references=ref, captures=captures)
            cards.append(card)
            if ref is not None:
                refs[sensor.name] = ref
            if args.json:
                print(json.dumps(card.to_dict(), indent=1))
            else:
                print(f"# {card.sensor}\n")
                print(card_markdown(card))
        if out is not None:
            for card in cards:
                atomic_write_text(
                    out.path / f"{card.sensor}.card.json",
                    json.dumps(card.to_dict(), indent=1) + "\n",
                )
                atomic_write_text(
                    out.path / f"{card.sensor}.card.md",
                    f"# {card.sensor}\n\n" + card_markdown(card),
                )
            out.finish(
                {
                    "version": __version__,
                    "sensors": [c.sensor for c in cards],
                    "seed": args.seed,
                    "frames": args.frames,
                    "quick": bool(args.quick),
                    "captures": args.captures,
                    "references": {c.sensor: c.references for c in cards},
                }
            )
        if pages is not None and cards:  # the cameras' pages and their index
            for page in write_pages(cards, pages, refs):
                print(f"genie report-card: wrote {page}", file=sys.stderr)
    return 0
