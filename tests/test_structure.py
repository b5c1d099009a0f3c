"""The package's structure, read from its source with ``ast``: every import points down the
pipeline (DESIGN.md's stage order), no module imports itself through others (no circle), and
an import inside a function only defers a heavy optional dependency, or, in a ``genie``
command, the pipeline until the command runs (so ``genie --help`` imports none of it).

``python tests/test_structure.py`` prints the summary (modules, arrows, circles, arrows back
up, imports inside functions by kind).
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "genie_gl"

# the stages in pipeline order (DESIGN.md): a module may import its own stage and those before it;
# the benchmarks measure everything, the command line included
STAGES = (
    "base",
    "layout",
    "scene",
    "sensors",
    "lens",
    "effects",
    "motion",
    "placement",
    "render",
    "capture",
    "cloud",
    "export",
    "view",
    "eval",
    "dataset",
    "studies",
    "card",
    "commands",
    "cli",
    "bench",
)
# the bottom of the package: the contracts every stage shares (top-level modules of genie_gl)
BASE = (
    "errors",
    "outputs",
    "resources",
    "validation",
    "limits",
    "processes",
    "labels",
    "camera",
    "frame",
    "triangles",
    "scene_options",
    "jit",
)
# optional dependencies (extras, or used only for pictures) that a function may import when it needs
# them
DEFERRABLE = (
    "matplotlib",
    "open3d",
    "ray",
    "pyrender",
    "OpenGL",
    "fast_simplification",
    "rosbags",
    "pye57",
    "laspy",
    "evo",
    "kiss_icp",
    "torch",
    "rerun",
    "rerun_cli",
)


@dataclass(frozen=True)
class Import:
    source: str  # importing module, dotted
    target: str  # imported module, dotted (ours) or the top-level name (third party)
    line: int
    in_function: bool
    ours: bool


def modules(root: Path = ROOT) -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package's __init__) of every module of the package."""
    out = {}
    for p in sorted((root / PACKAGE).rglob("*.py")):
        parts = list(p.relative_to(root).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    return out


def imports(root: Path = ROOT) -> list[Import]:
    """Every import statement of the package (``if TYPE_CHECKING:`` blocks left out)."""
    mods = modules(root)
    out: list[Import] = []

    def known(name: str) -> str:
        while name not in mods and "." in name:
            name = name.rsplit(".", 1)[0]
        return name

    for mod, (path, is_pkg) in mods.items():

        def visit(node: ast.AST, in_function: bool) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                    continue
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    for target in _targets(mod, is_pkg, child, mods):
                        ours = target.split(".")[0] == PACKAGE
                        out.append(
                            Import(
                                mod,
                                known(target) if ours else target.split(".")[0],
                                child.lineno,
                                in_function,
                                ours,
                            )
                        )
                else:
                    visit(
                        child,
                        in_function
                        or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)),
                    )

        visit(ast.parse(path.read_text()), False)
    return out


def _targets(mod: str, is_pkg: bool, node: ast.Import | ast.ImportFrom, mods: dict) -> list[str]:
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if node.level:
        base = mod.split(".") if is_pkg else mod.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        where = ".".join(base + ([node.module] if node.module else []))
    else:
        where = node.module or ""
    # ``from pkg import name``: the submodule pkg.name when there is one, else pkg itself
    return [f"{where}.{a.name}" if f"{where}.{a.name}" in mods else where for a in node.names]


def stage(module: str) -> str | None:
    """The pipeline stage of a module of the package (None: ``genie_gl`` itself, the public
    API, which names its modules as strings and imports them when a name is first used)."""
    parts = module.split(".")[1:]
    if not parts:
        return None
    return "base" if parts[0] in BASE else parts[0]


def graph(found: list[Import], root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> modules it makes Python import: its targets and their packages' ``__init__``
    (except its own packages, already being imported when it runs)."""
    mods = modules(root)
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for imp in found:
        if not imp.ours or imp.target == imp.source:
            continue
        edges[imp.source].add(imp.target)
        parts = imp.target.split(".")
        for k in range(2, len(parts)):
            parent = ".".join(parts[:k])
            if parent in mods and not imp.source.startswith(parent + ".") and parent != imp.source:
                edges[imp.source].add(parent)
    return edges


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            connect(v)
    return found


def upward(found: list[Import]) -> list[Import]:
    """Imports of a module of a later stage than the importer's."""
    out = []
    for imp in found:
        a, b = stage(imp.source), stage(imp.target)
        if imp.ours and a in STAGES and b in STAGES and STAGES.index(b) > STAGES.index(a):
            out.append(imp)
    return out


def deferred(found: list[Import]) -> dict[str, list[Import]]:
    """Imports inside functions, by kind: ``optional`` (a heavy optional dependency),
    ``command`` (the ``genie`` CLI or one of its commands deferring the pipeline until a
    command runs), ``other``."""
    out: dict[str, list[Import]] = {"optional": [], "command": [], "other": []}
    for imp in found:
        if not imp.in_function:
            continue
        if not imp.ours and imp.target in DEFERRABLE:
            out["optional"].append(imp)
        elif stage(imp.source) in ("commands", "cli"):
            out["command"].append(imp)
        else:
            out["other"].append(imp)
    return out


def test_every_module_has_a_stage():
    unknown = sorted({m for m in modules() if stage(m) is not None and stage(m) not in STAGES})
    assert unknown == [], f"modules outside DESIGN.md's stages: {unknown}"


def test_no_import_circle():
    assert circles(graph(imports())) == []


def test_no_arrow_back_up_the_pipeline():
    bad = [
        f"{i.source}:{i.line} imports {i.target} ({stage(i.source)} -> {stage(i.target)})"
        for i in upward(imports())
    ]
    assert bad == []


def test_imports_inside_functions_only_defer_optional_dependencies():
    bad = [
        f"{i.source}:{i.line} imports {i.target} inside a function"
        for i in deferred(imports())["other"]
    ]
    assert bad == []


def test_the_checker_sees_a_circle_an_arrow_up_and_a_deferred_import(tmp_path):
    """The checks above can fail: a planted package with each fault is caught."""
    pkg = tmp_path / PACKAGE
    (pkg / "sensors").mkdir(parents=True)
    (pkg / "render").mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "sensors" / "__init__.py").write_text("")
    (pkg / "render" / "__init__.py").write_text("")
    (pkg / "sensors" / "a.py").write_text("from ..render import b\n")  # up: sensors -> render
    (pkg / "render" / "b.py").write_text(
        "def f():\n    from ..sensors import a\n"
    )  # circle, deferred
    found = imports(tmp_path)
    assert [(i.source, i.target) for i in upward(found)] == [
        ("genie_gl.sensors.a", "genie_gl.render.b")
    ]
    assert [(i.source, i.target) for i in deferred(found)["other"]] == [
        ("genie_gl.render.b", "genie_gl.sensors.a")
    ]
    mods = {m for m in modules(tmp_path)}
    edges = {m: set() for m in mods}
    for i in found:
        edges[i.source].add(i.target)
    assert circles(edges) == [["genie_gl.render.b", "genie_gl.sensors.a"]]


def summary(root: Path = ROOT) -> str:
    found = imports(root)
    edges = graph(found, root)
    kinds = deferred(found)
    lines = [
        f"modules: {len(modules(root))}, arrows between them: "
        f"{sum(len(v) for v in edges.values())}",
        f"import circles: {len(circles(edges))}",
        f"arrows back up the pipeline: {len(upward(found))}",
        "imports inside functions: " + ", ".join(f"{k} {len(v)}" for k, v in kinds.items()),
    ]
    for k in ("optional", "other"):
        by = Counter(f"{i.source} -> {i.target}" for i in kinds[k])
        lines += [f"  {k}: {n} x {what}" for what, n in sorted(by.items())]
    return "\n".join(lines)


if __name__ == "__main__":
    print(summary(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT))


def test_every_help_imports_no_pipeline_module_and_no_numpy():
    """``genie --help`` and every ``genie COMMAND --help`` import only the command line, the
    command's module and the bottom of the package (no stage, no numpy)."""
    import subprocess

    from genie_gl.cli import COMMANDS

    code = (
        "import contextlib, io, sys\nfrom genie_gl.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n    main(sys.argv[1:] + ['--help'])\n"
        "print(' '.join(m for m in sys.modules if m == 'numpy' or (m.startswith('genie_gl.') and "
        "m.split('.')[1] not in ('cli', 'commands', *" + repr(BASE) + "))))"
    )
    for command in ["", *COMMANDS]:
        r = subprocess.run(
            [sys.executable, "-c", code, *command.split()],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=60,
        )
        assert r.returncode == 0, r.stderr[-500:]
        assert r.stdout.split() == [], f"genie {command} --help imports {r.stdout.split()}"
