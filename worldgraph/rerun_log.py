"""Moved to :mod:`worldgraph.figures.rerun_log`; this module keeps the old import path.

``worldgraph.rerun_log`` is the same module object as ``worldgraph.figures.rerun_log``
(so patching either patches both).
"""

import sys

from .figures import rerun_log as _home
from .figures.rerun_log import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
