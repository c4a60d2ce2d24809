"""Moved to :mod:`worldgraph.pose.certificate`; this module keeps the old import path.

``worldgraph.pose_certificate`` is the same module object as ``worldgraph.pose.certificate``
(so patching either patches both).
"""

import sys

from .pose import certificate as _home
from .pose.certificate import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
