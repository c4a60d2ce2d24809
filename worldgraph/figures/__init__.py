"""Figures and rerun logging of a localisation.

* :mod:`worldgraph.figures.plots`: matplotlib top views of the world, the percepts and the
  estimate, and camera images with their detections.
* :mod:`worldgraph.figures.rerun_log`: :func:`~worldgraph.figures.rerun_log.log_rerun`, the same
  as 3D entities of a rerun recording.

Neither imports its optional dependency (matplotlib, rerun-sdk) before it is called.
"""

from . import plots, rerun_log

__all__ = ["plots", "rerun_log"]
