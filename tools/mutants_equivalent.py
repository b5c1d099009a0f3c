"""Why each mutant that survives `make mutants` cannot change a number the package reports.

Each entry: (mutant name glob, regex that the mutated line ("+ ...") must match, reason). A
survivor matching none is printed as UNCLASSIFIED: it needs a test that kills it, or an entry
here saying why no test can (it changes no output). Entries are narrow on purpose (function and
text), so a new survivor in the same function is not waved through by an old reason.
"""
from __future__ import annotations

import fnmatch
import re

EQUIVALENT: list[tuple[str, str, str]] = [
]


def classify(name: str, diff: list[str]) -> str | None:
    """The reason ``name`` (its diff lines, "-" old and "+" new) is equivalent, or None."""
    added = "\n".join(line[1:] for line in diff if line.startswith("+"))
    for glob, pattern, reason in EQUIVALENT:
        if fnmatch.fnmatch(name, glob) and re.search(pattern, added):
            return reason
    return None


def main(argv: list[str]) -> int:
    """Classify the survivors of a saved `make mutants` report: python tools/mutants_equivalent.py REPORT"""
    import sys

    text = open(argv[0]).read().splitlines() if argv else sys.stdin.read().splitlines()
    survivors: list[tuple[str, list[str]]] = []
    for line in text:
        m = re.match(r"\s*survived: (\S+)", line)
        if m:
            survivors.append((m.group(1), []))
        elif survivors and re.match(r"\s{4}[+-]", line):
            survivors[-1][1].append(line.strip())
    open_ = 0
    for name, diff in survivors:
        reason = classify(name, diff)
        open_ += reason is None
        print(f"{name}\n    " + "\n    ".join(diff) + f"\n    {'equivalent: ' + reason if reason else 'UNCLASSIFIED'}")
    print(f"{len(survivors)} survivors, {len(survivors) - open_} classified equivalent, {open_} unclassified")
    return 1 if open_ else 0


if __name__ == "__main__":
    import sys

    sys.exit(main(sys.argv[1:]))
