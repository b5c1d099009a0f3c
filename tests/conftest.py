"""Suite-wide settings: the hypothesis profiles.

``ci`` (the default): derandomized (the examples are a fixed function of each test, so a run
is repeatable and its time bounded), a per-example deadline and a bounded number of examples.
``dev`` (HYPOTHESIS_PROFILE=dev): random examples, many more of them, to hunt for new bugs;
a failure prints the seed that reproduces it (``@reproduce_failure``). ``mutants`` (set by
``make mutants``): fixed examples, fewer, no deadline (mutmut's tracing slows the code).
"""
import os
from datetime import timedelta

from hypothesis import HealthCheck, settings

settings.register_profile("ci", derandomize=True, max_examples=40, deadline=timedelta(seconds=5),
                          print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("mutants", derandomize=True, max_examples=15, deadline=None,
                          suppress_health_check=list(HealthCheck))
settings.register_profile("dev", max_examples=500, deadline=timedelta(seconds=10), print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
