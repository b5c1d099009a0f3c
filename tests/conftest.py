"""Suite-wide settings: the hypothesis profiles, fresh caches under mutation testing, and the
GL guard every test runs under.

``ci`` (the default): derandomized (the examples are a fixed function of each test, so a run
is repeatable and its time bounded), a per-example deadline and a bounded number of examples.
``dev`` (HYPOTHESIS_PROFILE=dev): random examples, many more of them, to hunt for new bugs;
a failure prints the seed that reproduces it (``@reproduce_failure``). ``mutants`` (set by
``make mutants``): fixed examples, fewer, no deadline (mutmut's tracing slows the code).
"""

import functools
import os
import sys
from datetime import timedelta

import pytest
from hypothesis import HealthCheck, settings

from genie_gl.render.gl.context import contexts_created, create_context, is_shared, live_contexts

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=40,
    deadline=timedelta(seconds=5),
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "mutants",
    derandomize=True,
    max_examples=15,
    deadline=None,
    suppress_health_check=list(HealthCheck),
)
settings.register_profile("dev", max_examples=500, deadline=timedelta(seconds=10), print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True)
def _fresh_caches_under_mutation():
    """Under ``make mutants`` (MUTANT_UNDER_TEST set) every test starts with the package's
    functools caches empty. mutmut 3.8 runs the unmutated tests in its own process and forks
    each mutant's run from it: a cache filled there (the lens's fold, rays, views) hands every
    mutant the unmutated result, so no mutant of a function reached through a cache could fail
    a test; and its stats run would credit a cached function only to the first test calling it.
    Outside mutation testing: nothing."""
    if os.environ.get("MUTANT_UNDER_TEST"):
        for name, module in list(sys.modules.items()):
            if name.startswith("genie_gl") and module is not None:
                for value in list(vars(module).values()):
                    if isinstance(value, functools._lru_cache_wrapper):
                        value.cache_clear()
    yield


@pytest.fixture(scope="session")
def gl():
    """One EGL context per test process, for tests that render into a given context."""
    context = create_context("egl")
    yield context
    context.release()


@pytest.fixture
def glctx(gl):
    """The session's EGL context (the GL guard checks it around the test)."""
    return gl


@pytest.fixture(autouse=True)
def _gl_guard(request):
    """Around every test: each GL context of this process has no GL error before and after
    it, and its state is reset after it (:meth:`GLContext.reset`); a test leaves no context
    it made unreleased (contexts ``shared_context`` keeps on purpose excepted); a test not
    marked ``gl`` starts no GL at all (non-GL stages never start GL)."""
    before, created = live_contexts(), contexts_created()
    for context in before:
        assert context.error() == "GL_NO_ERROR", (
            f"a GL error was pending before {request.node.nodeid}"
        )
    yield
    after = live_contexts()
    new = [c for c in after if all(c is not b for b in before)]
    errors = [(c.backend, e) for c in after if (e := c.error()) != "GL_NO_ERROR"]
    for context in after:
        context.reset()
    assert not errors, f"GL errors after the test: {errors}"
    leaked = [
        c
        for c in new
        if not is_shared(c) and not any(c is v for v in request.node.funcargs.values())
    ]
    assert not leaked, f"the test left {len(leaked)} GL context(s) unreleased"
    if request.node.get_closest_marker("gl") is None:
        assert contexts_created() == created, "the test started GL: mark it gl (pytest.mark.gl)"


# --- the fault-injection suite's counts (cases marked @pytest.mark.fault(kind=, guard=)) -------
_FAULTS: list[tuple[str, str, str]] = []  # (kind, guard, outcome)


@pytest.fixture(autouse=True)
def _fault_case(request):
    """Record a fault case's kind and guard on its report (they travel back from xdist workers)."""
    m = request.node.get_closest_marker("fault")
    if m is not None:
        request.node.user_properties.append(("fault", [m.kwargs["kind"], m.kwargs["guard"]]))
    yield


def pytest_runtest_logreport(report):
    props = dict(report.user_properties)
    if "fault" in props and (
        report.when == "call" or (report.when == "setup" and not report.passed)
    ):
        kind, guard = props["fault"]
        _FAULTS.append((kind, guard, report.outcome))


def pytest_terminal_summary(terminalreporter):
    if not _FAULTS:
        return
    ran = [f for f in _FAULTS if f[2] != "skipped"]
    kinds = {}
    for kind, _, _ in ran:
        kinds[kind] = kinds.get(kind, 0) + 1
    failed = {
        g: sum(1 for _, guard, o in ran if guard == g and o == "failed")
        for g in ("loss", "traceback", "hang", "wrong")
    }
    cases = {g: sum(1 for _, guard, _ in ran if guard == g) for g in failed}
    skipped = len(_FAULTS) - len(ran)
    terminalreporter.write_sep("-", "fault injection")
    terminalreporter.write_line(
        f"{len(ran)} cases run ({skipped} skipped): "
        + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items()))
    )
    terminalreporter.write_line(
        "failed: "
        + ", ".join(
            f"{failed[g]} {name} (of {cases[g]} guarded)"
            for g, name in (
                ("loss", "losses"),
                ("traceback", "tracebacks"),
                ("hang", "hangs or out-of-memory"),
                ("wrong", "silent wrongs"),
            )
        )
    )
