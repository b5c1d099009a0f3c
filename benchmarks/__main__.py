"""``python -m benchmarks NAME [ARGS]``: run one measuring script; ``--list`` lists them."""

from __future__ import annotations

import importlib
import sys

from . import NAMES


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "--list"):
        width = max(map(len, NAMES))
        print("usage: python -m benchmarks NAME [ARGS]   (NAME --help for its arguments)\n")
        for name, summary in NAMES.items():
            print(f"  {name:<{width}}  {summary}")
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in NAMES:
        print(
            f"python -m benchmarks: unknown benchmark {name!r}; expected one of {', '.join(NAMES)}",
            file=sys.stderr,
        )
        return 2
    importlib.import_module(f"benchmarks.{name}").main(rest)
    return 0


if __name__ == "__main__":
    sys.exit(main())
