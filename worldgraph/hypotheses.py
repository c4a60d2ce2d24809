"""Moved to :mod:`worldgraph.association.hypotheses`; this module keeps the old import path.

``worldgraph.hypotheses`` is the same module object as ``worldgraph.association.hypotheses``
(so patching either patches both).
"""

import sys

from .association import hypotheses as _home
from .association.hypotheses import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
