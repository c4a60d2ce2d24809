"""Moved to :mod:`worldgraph.pose.validation`; this module keeps the old import path.

``worldgraph.validation`` is the same module object as ``worldgraph.pose.validation``
(so patching either patches both).
"""

import sys

from .pose import validation as _home
from .pose.validation import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
