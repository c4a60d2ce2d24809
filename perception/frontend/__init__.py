"""From a detector's output to percepts: the depth (RGB-D) and the stereo front ends.

A detector (any: a segmentation network, a box detector, :func:`perception.detect`) gives
:class:`~perception.Detection` objects per image.  Two front ends turn them into
:class:`~perception.Percept` objects in the ego frame, each with a full 3x3 covariance:

- :func:`rgbd_percepts`: detections plus a depth image registered to them (metres), the
  camera matrix and ``ego_from_camera``;
- :func:`stereo_percepts`: detections in the left and the right image of a
  :class:`~perception.StereoRig`, matched by type and the epipolar constraint and triangulated.

**What a percept's position means.** A world model places an object at the centre of its
visual geometry (:meth:`worldgraph.WorldModel.from_file`), but a camera sees its front surface:
a door's front lies half its thickness before that centre, a cylindrical handle's visible
half about two thirds of its radius: enough, uncorrected, to break the association.  Both front ends
therefore refer each percept to the object's centre, ``centre = anchor + d n``, with the anchor
the visible part's centroid along ``n`` and the middle of its extent across ``n`` (RGB-D: on
gravity-aligned axes, as a box around the visible part is centred; stereo: the centroid), ``n``
the direction away from the camera (the visible surface's normal when it is flat, else the
viewing ray) and ``d`` the *centre offset* of the object's type, a prior with its uncertainty
(:class:`CentreOffset`; ``centre_offset={type: CentreOffset(...)}`` or ``{type: d}``): from the
map (:meth:`worldgraph.WorldModel.centre_depths`, half the thinnest extent), measured for your
detector's classes, or measured on renders (:meth:`perception.mujoco.MujocoScene.centre_offsets`).
A door with a protruding handle has its centre *in front* of the visible leaf.  Types
without a prior use the visible surface's own depth relief (exact for rounded objects, zero for
a flat front) with :data:`CENTRE_DEPTH_SIGMA` of uncertainty.

**Errors an object's views share.** What we do not know about ``d`` and the offset of the
visible part's centroid from the centre's image (perspective, a mask's bleeding edge) is the
same each time the object is seen: it is carried as a shared loading with the reserved id
:data:`~perception.OBJECT_VIEW` (:class:`~perception.Percept`'s ``shared``), which
:func:`perception.fuse_percepts` adds coherently over an object's views instead of averaging
it away.  The covariance of each percept includes it.

**Dropped detections** are reported with their reason (:class:`Dropped`): ``"cut_off"`` (the
region touches the image border, so its centroid is biased; ``keep_cut_off=True`` keeps it
with a covariance that covers where the centre may be), ``"occluded"`` (a nearer surface hides
part of it), ``"too_few_pixels"``, ``"no_depth"`` (too few valid depth readings in it),
``"no_stereo_match"``, ``"behind_camera"``.

Modules: :mod:`~perception.frontend.detection` (a detector's output), :mod:`~perception.frontend.percept`
(what comes out), :mod:`~perception.frontend.detection_percepts` (what both front ends share),
:mod:`~perception.frontend.rgbd` and :mod:`~perception.frontend.stereo_pairs` (the two front ends),
:mod:`~perception.frontend.outline` (an object's disparity from its outline) and
:mod:`~perception.frontend.fusion` (one percept per object from many views).
"""

from .detection import Detection
from .detection_percepts import (
    CENTRE_DEPTH_SIGMA,
    CENTRE_OFFSET_SCALE,
    DEPTH_CORRELATION_PX,
    DEPTH_NOISE,
    CentreOffset,
    DetectionPercepts,
    Dropped,
    DropReason,
)
from .fusion import FusionDrop, FusionReport, fuse_percepts, fuse_percepts_report
from .outline import DisparityError, OutlineDisparity, fit_disparity_errors, outline_disparity
from .percept import OBJECT_VIEW, Percept
from .rgbd import rgbd_percepts
from .stereo_pairs import DISPARITY_STD_PX, DisparitySource, StereoMatch, match_stereo, stereo_percepts

__all__ = [
    "CENTRE_DEPTH_SIGMA",
    "CENTRE_OFFSET_SCALE",
    "CentreOffset",
    "DEPTH_CORRELATION_PX",
    "DEPTH_NOISE",
    "DISPARITY_STD_PX",
    "Detection",
    "DetectionPercepts",
    "DisparityError",
    "DisparitySource",
    "DropReason",
    "Dropped",
    "FusionDrop",
    "FusionReport",
    "OBJECT_VIEW",
    "OutlineDisparity",
    "Percept",
    "StereoMatch",
    "fit_disparity_errors",
    "fuse_percepts",
    "fuse_percepts_report",
    "match_stereo",
    "outline_disparity",
    "rgbd_percepts",
    "stereo_percepts",
]
