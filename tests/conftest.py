import os

from hypothesis import HealthCheck, settings

# Numba compiles on first call (seconds), so no per-example deadline.  ELLIPSIM_EXAMPLES scales the
# search for longer local runs.
settings.register_profile(
    "ellipsim",
    deadline=None,
    max_examples=int(os.environ.get("ELLIPSIM_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
    derandomize=os.environ.get("ELLIPSIM_RANDOM") is None,
)
settings.load_profile("ellipsim")
