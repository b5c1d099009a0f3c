"""The README and the pages of docs/ as a new user meets them: every Python block runs exactly
as pasted (alone, in a fresh interpreter, in an empty folder), every ``genie`` command line
of their shell blocks parses with the CLI's own parser, and every file they link to is in the
repository."""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from genie_gl.cli import build_parser, command_of

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TEXT = {p: p.read_text() for p in PAGES}
BLOCKS = [(p, b) for p in PAGES for b in re.findall(r"```python\n(.*?)```", TEXT[p], re.S)]
SHELL = [(p, b) for p in PAGES for b in re.findall(r"```(?:bash|sh)?\n(.*?)```", TEXT[p], re.S)]


def command_lines() -> list[tuple[Path, str]]:
    """``genie ...`` lines of the shell blocks (continuations joined, comments cut), and the
    whole command lines quoted in the text (with an option, no ellipsis or placeholder)."""
    out = []
    for page, block in SHELL:
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("#", 1)[0].strip()
            if line.startswith("genie "):
                out.append((page, line))
    for page, text in TEXT.items():
        for line in re.findall(r"`(genie [^`]+)`", text.replace("\n", " ")):
            words = line.split()
            if " --" in line and not any(
                w in ("...", "…") or "[" in w or re.fullmatch(r"[A-Z][A-Z_]+", w) for w in words
            ):  # no ellipsis, no placeholder
                out.append((page, " ".join(line.split())))
    return out


LINES = command_lines()


def test_the_pages_have_blocks_and_command_lines():
    assert len([b for p, b in BLOCKS if p.name == "README.md"]) >= 3
    assert len(LINES) >= 10


@pytest.mark.gl
@pytest.mark.parametrize(
    "index", range(len(BLOCKS)), ids=[f"{p.name}-{i}" for i, (p, _) in enumerate(BLOCKS)]
)
def test_every_python_block_runs_as_pasted(index, tmp_path):
    page, block = BLOCKS[index]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run(
        [sys.executable, "-c", block],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert r.returncode == 0, f"{page.name} block:\n{block}\n{r.stderr[-2000:]}"


@pytest.mark.parametrize(
    "index", range(len(LINES)), ids=[f"{p.name}-{i}" for i, (p, _) in enumerate(LINES)]
)
def test_every_genie_command_line_parses(index):
    page, line = LINES[index]
    argv = shlex.split(line)[1:]
    try:
        build_parser(command_of(argv)).parse_args(argv)
    except SystemExit as exc:  # --help (status 0), or the parser's one-line error
        if exc.code:
            pytest.fail(f"{page.name}: `{line}` does not parse (exit {exc.code})")


def test_every_document_the_pages_refer_to_exists():
    missing = []
    for page, text in TEXT.items():
        links = [link for link in re.findall(r"\]\(([^)#\s]+)\)", text) if "://" not in link]
        missing += [f"{page.name}: {link}" for link in links if not (page.parent / link).exists()]
    assert not missing, f"pages refer to files that are not in the repository: {missing}"
