"""The detection: one typed object found in one image, the input of the percept front ends.

Any detector's output maps onto a :class:`Detection`: an object type, where it is in the image
(a pixel ``mask``, a bounding ``box``, or only a centroid) and a ``score``.  The front ends of
:mod:`perception.frontend` turn detections plus a depth image or a stereo pair into
:class:`~perception.Percept` objects; :func:`perception.detect` (the colour-segmentation
recogniser of the paper) makes detections too.

Pixel coordinates follow OpenCV: ``u`` to the right (columns), ``v`` down (rows), the centre of
pixel ``(row v, column u)`` at ``(u, v)``; a box ``(u_min, v_min, u_max, v_max)`` spans the
pixel centres ``u_min <= u <= u_max`` and ``v_min <= v <= v_max``, so the one-pixel box at
column 3, row 5 is ``(3, 5, 3, 5)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._checks import name_string, real_array, real_scalar, spd
from ..errors import PerceptionError

__all__ = ["MAX_PIXEL_COORDINATE", "Detection"]

#: Largest magnitude of a pixel coordinate (centroid, box corner) accepted.
MAX_PIXEL_COORDINATE = 1e9


def _mask(value: object) -> NDArray[np.bool_]:
    """A 2D boolean mask (bool, or integers 0/1) with at least one pixel set."""
    if value is None or isinstance(value, (str, bytes)):
        raise PerceptionError(f"mask must be a 2D boolean array, got {value!r:.80}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise PerceptionError(f"mask must be a 2D boolean array, got {type(value).__name__}") from exc
    if raw.ndim != 2 or raw.shape[0] < 1 or raw.shape[1] < 1:
        raise PerceptionError(f"mask must be a 2D boolean array (height, width), got shape {raw.shape}")
    if raw.dtype.kind == "b":
        mask = raw.astype(bool, copy=True)
    elif raw.dtype.kind in "iu":
        bad = np.flatnonzero((raw != 0) & (raw != 1))
        if bad.size:
            r, c = np.unravel_index(int(bad[0]), raw.shape)
            raise PerceptionError(f"mask[{r}, {c}] = {raw[r, c]!r}: an integer mask must hold 0 and 1 only")
        mask = raw.astype(bool)
    else:
        raise PerceptionError(f"mask must be a boolean (or 0/1 integer) array, got dtype {raw.dtype}")
    if not mask.any():
        raise PerceptionError(f"mask is empty: no pixel of the {mask.shape[0]} x {mask.shape[1]} mask is set")
    return mask


def _box(value: object) -> NDArray[np.float64]:
    box = real_array("box", value, (4,))
    if np.any(np.abs(box) > MAX_PIXEL_COORDINATE):
        i = int(np.argmax(np.abs(box)))
        raise PerceptionError(f"box[{i}] = {float(box[i])!r} must be at most {MAX_PIXEL_COORDINATE:g} px")
    if box[2] < box[0] or box[3] < box[1]:
        raise PerceptionError("box must be (u_min, v_min, u_max, v_max) with u_min <= u_max and "
                              f"v_min <= v_max, got {box.tolist()}")
    return box


def _mask_moments(mask: NDArray[np.bool_]) -> tuple[NDArray[np.float64], float, NDArray[np.float64],
                                                     NDArray[np.float64]]:
    """Centroid (u, v), area, pixel covariance (second central moments + 1/12) and bounding box."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:  # no pixel: as np.nonzero of the whole mask gives (the caller refuses it)
        v, u = np.nonzero(mask)
    else:  # the pixels of the mask's bounding box only, in the same (row-major) order
        v, u = np.nonzero(mask[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1])
        v, u = v + rows[0], u + cols[0]
    uv = np.column_stack([u, v]).astype(np.float64)
    centroid = uv.mean(axis=0)
    d = uv - centroid
    cov = d.T @ d / len(uv) + np.eye(2) / 12.0
    box = np.array([u.min(), v.min(), u.max(), v.max()], dtype=np.float64)
    return centroid, float(len(uv)), cov, box


def _same(a: NDArray[np.generic] | None, b: NDArray[np.generic] | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(a, b))


@dataclass(frozen=True)
class Detection:
    """A typed object found in one image: where it is, how big, how sure.

    Give at least one of ``mask``, ``box`` and ``centroid_uv``; the others are derived (a mask
    gives its centroid, pixel count, second moments and bounding box; a box alone its centre,
    its area and the moments of a uniform rectangle).  The depth front end
    (:func:`perception.rgbd_percepts`) reads the mask (else the box); the stereo front end
    (:func:`perception.stereo_percepts`) the centroid and the moments.

    Parameters
    ----------
    type : str
        Object class, e.g. ``"door"``, ``"handle"``; the types of the world model.
    centroid_uv : (2,) float, optional
        Centroid of the object's pixels, ``(u, v)`` (OpenCV: pixel centres at integer
        coordinates). Default: from the mask, else the box's centre.
    area : float, optional
        Number of the object's pixels, > 0. Default: the mask's pixel count, else the box's area
        ``(u_max - u_min + 1) (v_max - v_min + 1)``.
    features : (d,) float, optional
        A feature vector (the colour recogniser's :data:`~perception.recognition.FEATURE_NAMES`); empty by
        default.
    log_likelihood : float
        The classifier's log-likelihood of the type, NaN when not known.
    shape_covariance : (2, 2) float, optional
        Covariance of the object's pixel coordinates ``(u, v)``, px^2 (second central moments plus
        1/12 for a pixel's extent). Default: from the mask, else a uniform rectangle over the box,
        else a square of ``area`` pixels (``area / 12 * I``).
    box : (4,) float, optional
        Bounding box ``(u_min, v_min, u_max, v_max)``, pixel centres, inclusive. Default: the
        mask's bounding box.
    mask : (height, width) bool, optional
        The object's pixels in the full image (a detector's instance mask, or the filled box);
        0/1 integers are accepted. Must not be empty.
    score : float
        The detector's confidence in [0, 1]; 1 by default. The front ends keep every detection
        (thresholding is the detector's job) and copy nothing of it into the percept.

    Raises
    ------
    PerceptionError
        Naming the field and the bad value: an empty or non-boolean mask, a box
        with ``u_max < u_min``, a centroid or box corner beyond :data:`MAX_PIXEL_COORDINATE`,
        no position at all, a score outside [0, 1].
    """

    type: str
    centroid_uv: NDArray[np.float64] | None = None
    area: float | None = None
    features: NDArray[np.float64] | None = None
    log_likelihood: float = float("nan")
    shape_covariance: NDArray[np.float64] | None = None
    box: NDArray[np.float64] | None = None
    mask: NDArray[np.bool_] | None = None
    score: float = 1.0

    def __post_init__(self) -> None:
        name_string("type", self.type)
        mask = None if self.mask is None else _mask(self.mask)
        box = None if self.box is None else _box(self.box)
        if mask is None and box is None and self.centroid_uv is None:
            raise PerceptionError("a Detection needs a mask, a box or a centroid_uv; got none of them")
        m_centroid = m_area = m_cov = None
        if mask is not None:
            m_centroid, m_area, m_cov, m_box = _mask_moments(mask)
            box = m_box if box is None else box
        if self.centroid_uv is not None:
            uv = real_array("centroid_uv", self.centroid_uv, (2,))
        elif m_centroid is not None:
            uv = m_centroid
        else:
            assert box is not None
            uv = 0.5 * (box[:2] + box[2:])
        if np.any(np.abs(uv) > MAX_PIXEL_COORDINATE):
            raise PerceptionError(f"centroid_uv must be at most {MAX_PIXEL_COORDINATE:g} px, "
                                  f"got {uv.tolist()}")
        if self.area is not None:
            area = real_scalar("area", self.area, positive=True, maximum=1e12)
        elif m_area is not None:
            area = m_area
        elif box is not None:
            area = float((box[2] - box[0] + 1.0) * (box[3] - box[1] + 1.0))
        else:
            raise PerceptionError("area must be given with a centroid_uv alone (no mask or box to count)")
        if self.shape_covariance is not None:
            shape = spd("shape_covariance", self.shape_covariance, 2)
        elif m_cov is not None:
            shape = m_cov
        elif box is not None:  # a uniform rectangle of (w x h) pixel centres, each 1 px wide
            w, h = box[2] - box[0] + 1.0, box[3] - box[1] + 1.0
            shape = np.diag([w * w / 12.0, h * h / 12.0])
        else:
            shape = np.eye(2) * (area / 12.0)
        feats = np.zeros(0) if self.features is None else real_array("features", self.features, (None,))
        ll = self.log_likelihood
        if not (isinstance(ll, float) and np.isnan(ll)):
            ll = real_scalar("log_likelihood", ll)
        score = real_scalar("score", self.score, minimum=0.0, maximum=1.0)
        object.__setattr__(self, "log_likelihood", float(ll))
        object.__setattr__(self, "score", score)
        object.__setattr__(self, "area", area)
        for name, arr in (("centroid_uv", uv), ("features", feats), ("shape_covariance", shape),
                          ("box", box), ("mask", mask)):
            if arr is not None:
                arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Detection):
            return NotImplemented
        return (self.type == other.type and self.score == other.score and self.area == other.area
                and all(_same(getattr(self, f), getattr(other, f)) for f in ("centroid_uv", "box", "mask")))

    __hash__ = None  # type: ignore[assignment]  # holds arrays
