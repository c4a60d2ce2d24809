"""Moved to :mod:`worldgraph.figures.plots`; this module keeps the old import path.

``worldgraph.plots`` is the same module object as ``worldgraph.figures.plots``
(so patching either patches both).
"""

import sys

from .figures import plots as _home
from .figures.plots import *  # noqa: F403  (the public names, for type checkers)

sys.modules[__name__] = _home
