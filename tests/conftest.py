"""Shared pytest configuration: hypothesis profiles.

``ci`` (the default) is derandomised and has no deadline, so a noisy shared machine never
fails a run on timing.  ``dev`` runs many more random examples for local bug hunting:
``HYPOTHESIS_PROFILE=dev pytest``.
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    deadline=None,
    derandomize=True,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", deadline=None, max_examples=2000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
