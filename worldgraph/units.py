"""Moved to :mod:`worldgraph.model.units`; this module keeps the old import path.

``worldgraph.units`` is the same module object as ``worldgraph.model.units``
(so patching either patches both).
"""

import sys

from .model import units as _home
from .model.units import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
