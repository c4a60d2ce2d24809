"""Moved to :mod:`worldgraph.association.filters`; this module keeps the old import path.

``worldgraph.filters`` is the same module object as ``worldgraph.association.filters``
(so patching either patches both).
"""

import sys

from .association import filters as _home
from .association.filters import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
