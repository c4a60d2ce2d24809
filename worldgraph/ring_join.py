"""Moved to :mod:`worldgraph.model.ring_join`; this module keeps the old import path.

``worldgraph.ring_join`` is the same module object as ``worldgraph.model.ring_join``
(so patching either patches both).
"""

import sys

from .model import ring_join as _home
from .model.ring_join import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
