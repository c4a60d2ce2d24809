"""Pose fits, validation, certificates, the gravity prior.

* :mod:`worldgraph.pose.frames`: rigid pose from matched points (the eq.-5 frames, weighted
  Kabsch, the ML refinement and its information); its public names are re-exported here, so
  ``worldgraph.pose`` keeps the names it had as a module.
* :mod:`worldgraph.pose.validation`: hypothesis validation (robust ML fits, 6D pose covariance,
  self-checks).
* :mod:`worldgraph.pose.certificate`: the rotation SDP's certificate of global optimality.
* :mod:`worldgraph.pose.gravity`: gravity as a per-call fact (which way is up, which search
  answers).
"""

from .frames import COLLINEAR_TOL as COLLINEAR_TOL  # re-exported: worldgraph.pose.COLLINEAR_TOL
from .frames import MAX_POSE_COORDINATE as MAX_POSE_COORDINATE
from .frames import (
    invert_transformation,
    percept_frame,
    pose_from_frames,
    pose_information,
    refine_pose,
    rotation_angle,
    transformation,
    weighted_kabsch,
    weighted_kabsch_batch,
    weighted_rotation,
)

__all__ = [
    "invert_transformation",
    "percept_frame",
    "pose_from_frames",
    "pose_information",
    "refine_pose",
    "rotation_angle",
    "transformation",
    "weighted_kabsch",
    "weighted_kabsch_batch",
    "weighted_rotation",
]
