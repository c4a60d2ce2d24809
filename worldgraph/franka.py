"""Moved to :mod:`worldgraph.importers.franka`; this module keeps the old import path.

``worldgraph.franka`` is the same module object as ``worldgraph.importers.franka``
(so patching either patches both).
"""

import sys

from .importers import franka as _home
from .importers.franka import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
