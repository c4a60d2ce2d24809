"""Moved to :mod:`worldgraph.association.consistency`; this module keeps the old import path.

``worldgraph.consistency`` is the same module object as ``worldgraph.association.consistency``
(so patching either patches both).
"""

import sys

from .association import consistency as _home
from .association.consistency import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
