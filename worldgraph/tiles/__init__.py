"""Tiled localisation: a large world split into tiles (buildings, storeys) localised in parallel.

:func:`split` cuts a :class:`~worldgraph.model.WorldModel` into tiles by a label per object (the
building or storey of :class:`worldgraph.scenes.Site`), each tile a world model of its objects
plus, with ``halo > 0``, the objects of other labels within ``halo`` metres of them (so that a
robot at a tile's border still finds the landmarks it sees).  :func:`localize_tiled` runs
:func:`~worldgraph.localize` on every tile at once -- on local processes by default,
on a Dask cluster with ``scheduler="tcp://host:8786"`` or a ``distributed.Client`` (as
:func:`radialopt.comparison.compare_solvers` does) -- maps the answers back to global object
indices and ranks the tiles' best poses together by the rule of :func:`localize`:

* every tile answer with a pose (status ``"ok"``, ``"weak"`` or ``"ambiguous"``) gets the robust
  cost of its validated fit, ``sum_p min(d_p^2, CHI2_3_GATE)`` over the percepts of the world's
  types (:func:`~worldgraph.pose.validation.fit_hypothesis` re-run from the tile's pose on its
  inliers; a percept whose type the tile lacks counts the cap, as it would against a far-away
  object of the whole world);
* the cheapest answer wins; another tile's answer whose cost is within
  ``tol.ambiguity_margin`` at a distinct pose (outside the winner's 3-sigma ellipsoid,
  6D NEES > ``CHI2_6_GATE``) makes the result ``"ambiguous"`` (its pose joins
  ``alternatives``);
* tiles without a pose drop out; when no tile has one, the most informative failure is
  returned (see :data:`FAILURE_ORDER`).

When the tiles are far apart compared with the sensor range (or the halo covers it), the
tiled answer equals the answer of :func:`localize` on the whole world, at the cost of one
world per tile in memory.  What the whole world sees that tiles cannot: a clique of percepts
spanning two tiles (use a halo), and the default region (each tile's own bounds, not the
whole world's, unless ``region`` is given).
"""

from .cluster import ClusterTiles
from .dispatch import localize_tiled
from .files import TileEntry, TileIndex, append_tiles, load_tile, read_index, save_tiles
from .pool import TilePool
from .prefilter import TileSummary, TileVisit, summarize, tiles_to_visit
from .ranking import FAILURE_ORDER
from .tiling import MAX_TILES, Tile, split

__all__ = ["FAILURE_ORDER", "MAX_TILES", "ClusterTiles", "Tile", "TileEntry", "TileIndex", "TilePool",
           "TileSummary", "TileVisit", "append_tiles", "load_tile", "localize_tiled", "read_index",
           "save_tiles", "split", "summarize", "tiles_to_visit"]
