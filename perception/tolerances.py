"""Every numerical tolerance of :mod:`perception`, in one module (docs/design.md#tolerances).

Fixed thresholds of the checks and iterations (symmetry and definiteness of covariances,
rigidity of transforms, convergence, rounding), each with what it guards; functions that let a
caller tune one take it as ``tol=`` with the constant as default.  They are named here so that
they are found, not so that they are tuned.  Ranges of accepted input (sigmas in
``[1e-150, 1e150]``, :data:`~perception.frontend.fusion.SIGMA_RANGE`) are limits of the domain, not
tolerances, and stay with their checks.
"""

from __future__ import annotations

#: Floor of a denominator, norm or scale that may be exactly zero (keeps a quotient finite).
TINY = 1e-300
#: Relative floor of the smallest eigenvalue of a covariance (numerical positive definiteness).
SPD_RTOL = 1e-14
#: Relative tolerance of the symmetry check of a covariance, ``|C - C^T| <= SYM_RTOL max|C|``.
SYM_RTOL = 1e-8
#: A covariance (scaled to max entry 1) whose smallest eigenvalue is below ``-PSD_ATOL`` is not
#: positive semidefinite.
PSD_ATOL = 1e-12
#: A covariance minus the shared loadings may dip this far (times its largest eigenvalue) below
#: zero by rounding.
SHARED_RTOL = 1e-9
#: A percept's ``sigma`` given with a ``covariance`` must lie within this factor (either way)
#: of the range standard deviation the covariance gives, ``sqrt(u^T C u)``: wide enough for
#: what the library's own front ends build, narrow enough to refuse a sigma 10 times off
#: (docs/design.md#defaults).
SIGMA_COVARIANCE_FACTOR = 5.0
#: Largest ``|R^T R - I|`` entry (and ``|det R - 1|``) of a rotation or rigid transform.
RIGID_TOLERANCE = 1e-6
#: Default ``tol`` of the mean shift: a point has converged when it moves less (bandwidth units).
MEAN_SHIFT_TOL = 1e-6
#: Mean shift: the k-d tree is queried this much (relative) beyond the kernel support; the exact
#: test follows.
QUERY_SLACK = 1e-9
#: Blob features: floor of the smaller eigenvalue of a blob's second moments (pixels^2).
EIGENVALUE_FLOOR = 1e-12
#: Triangulation: a 2x2 normal-equation determinant at most this is singular (parallel rays).
PARALLEL_RAYS = 1e-15
#: Nearest depth (m) in front of a camera that counts as in front of it (the renderer's near
#: plane; a triangulated point nearer than this is behind the camera).
NEAR_PLANE = 0.05
#: Renderer: a vertex within this of a face's plane is on it (depth ordering).
PLANE_EPS = 1e-9
#: Iterative undistortion stops at a step below this (normalised image units).
UNDISTORT_EPS = 1e-15
#: Largest deviation of a unit URDF axis from a frame axis that still counts as that axis.
AXIS_TOL = 1e-9

#: A rig must triangulate a point on the left optical axis (2 m ahead, or 20 baselines for a wide
#: rig) back to itself within this relative error when it is made; one that cannot (a focal
#: length of 1e-300 px projects every point to the principal point) is refused.
RIG_ROUND_TRIP_RTOL = 1e-6

#: Depth front end: an isotropic floor, this fraction of the depth noise, added to a percept's own
#: covariance (the depth error alone spans one direction; the floor keeps it positive definite).
DEPTH_COVARIANCE_FLOOR = 1e-3

#: :meth:`perception.mujoco.MujocoScene.look`: slack (radians) when a look's fan of neck yaws is
#: compared with the neck's reach (a fan exactly as wide as the reach fits).
ANGLE_SLACK = 1e-9
