"""Moved to :mod:`worldgraph.pose.gravity`; this module keeps the old import path.

``worldgraph.gravity`` is the same module object as ``worldgraph.pose.gravity``
(so patching either patches both).
"""

import sys

from .pose import gravity as _home
from .pose.gravity import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
