import os

from hypothesis import HealthCheck, settings

os.environ.setdefault("RERUN_ANALYTICS", "0")
os.environ.setdefault("MPLBACKEND", "Agg")

# No test depends on wall time (issue 30: hypothesis deadlines of 200 ms failed correct tests at load 7-15 on 2 cores):
# every property test runs without a deadline and without the too_slow health check; speed belongs to benchmarks/.
# A test's own @settings(...) inherits these unless it names them, which tests/test_wall_time.py forbids.
settings.register_profile("lcnav", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("lcnav")
