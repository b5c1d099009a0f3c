"""Suite-wide settings: the hypothesis profiles, and fresh caches under mutation testing.

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

settings.register_profile("ci", derandomize=True, max_examples=40, deadline=timedelta(seconds=5),
                          print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("mutants", derandomize=True, max_examples=15, deadline=None,
                          suppress_health_check=list(HealthCheck))
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
