"""Recognition from images: rendered box scenes, colour segmentation, Gaussian classification.

The path from pixels to percepts that the paper's recognition components take (section 2,
"Gaussian classification over characteristic feature spaces extracted from ... the
eigenvectors from color-segmented regions in stereo images"):

1. :func:`~perception.render_stereo` (:mod:`perception.simulation.render`) draws a scene of
   coloured boxes (doors, handles, clutter) into a stereo pair with OpenCV: corners projected
   by ``cv2.projectPoints``, back faces culled, faces filled by ``cv2.fillConvexPoly`` far to
   near (painter's algorithm with a plane-side ordering test), Lambertian shading and seeded
   lighting noise.
2. :func:`detect` segments each image by colour (``cv2.inRange`` in HSV), splits the masks
   into connected regions (``cv2.connectedComponentsWithStats``), describes every region by
   the eigen-decomposition of its pixel covariance (elongation, orientation), its area, fill
   ratio and mean colour, and classifies it with a :class:`GaussianClassifier` that rejects
   regions whose log-likelihood is below a per-class threshold (clutter).  The segmentation
   and the features live in :mod:`~perception.recognition.segmentation`, the classifier in
   :mod:`~perception.recognition.classifier`.
3. :func:`~perception.match_stereo` (:mod:`perception.frontend.stereo_pairs`) pairs left and
   right detections of the same type under the epipolar constraint (fundamental matrix from
   the rig) with positive depth in both cameras.
4. :func:`recognize` triangulates the pairs with ``rig.triangulate`` and attaches the eq. 6
   deviation ``sigma = rho**2 / depth_factor`` (rho = depth along the left optical axis,
   eq. 7) and a full covariance, returning :class:`~perception.frontend.percept.Percept` objects. The
   covariance maps two pixel errors through the triangulation Jacobian: the centroid's
   quantisation noise, independent per image (:data:`~perception.frontend.DISPARITY_STD_PX`), and the offset
   between the region's centroid and the image of the object's centre, the same in both
   images and proportional to the region's extent (:data:`CENTROID_OFFSET_SCALE`).

Frames follow ``docs/conventions.md``: the scene (world) frame has z up; cameras are OpenCV
(x right, y down, z forward); the stereo rig maps ``X_right = R X_left + T``.
"""

from .classifier import GaussianClassifier
from .pipeline import CENTROID_OFFSET_SCALE, detect, recognize, train_classifier
from .segmentation import COLOR_RANGES, FEATURE_NAMES, ColorRange, region_features

__all__ = [
    "CENTROID_OFFSET_SCALE",
    "COLOR_RANGES",
    "ColorRange",
    "FEATURE_NAMES",
    "GaussianClassifier",
    "detect",
    "recognize",
    "region_features",
    "train_classifier",
]
