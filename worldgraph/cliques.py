"""Moved to :mod:`worldgraph.association.cliques`; this module keeps the old import path.

``worldgraph.cliques`` is the same module object as ``worldgraph.association.cliques``
(so patching either patches both).
"""

import sys

from .association import cliques as _home
from .association.cliques import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
