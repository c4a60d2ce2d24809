"""The detector model of a simulated scan: depth noise, and masks degraded like a real
detector's (missed objects, false detections, edges moved by a few pixels)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..frontend.detection import Detection
from .records import DEPTH_NOISE_BLOCK, DEPTH_NOISE_IID


def _noisy_depth(z: NDArray[np.float64], c: float, max_range: float, rng: np.random.Generator
                 ) -> NDArray[np.float64]:
    """``z`` plus the blockwise-correlated error ``c z^2 e`` (``e`` of unit variance); NaN where
    ``z`` is NaN, beyond ``max_range`` or not positive after the noise."""
    h, w = z.shape
    b = DEPTH_NOISE_BLOCK
    coarse = rng.standard_normal((-(-h // b), -(-w // b)))
    e = np.repeat(np.repeat(coarse, b, axis=0), b, axis=1)[:h, :w]
    e = (e + DEPTH_NOISE_IID * rng.standard_normal((h, w))) / math.sqrt(1.0 + DEPTH_NOISE_IID ** 2)
    with np.errstate(invalid="ignore"):
        out = z + c * z * z * e
        out[~(z <= max_range) | ~(out > 0)] = np.nan
    return out


class _Degrade:
    """Detections of the typed objects in an object-index image, degraded as asked."""

    def __init__(self, types: tuple[str, ...], rng: np.random.Generator, miss: float, false: float,
                 jitter: int, min_pixels: int) -> None:
        self.types = types
        self.scene_types = sorted(set(types))
        self.rng = rng
        self.miss, self.false, self.jitter, self.min_pixels = miss, false, jitter, min_pixels

    def _jittered(self, mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
        if self.jitter == 0:
            return mask
        import cv2

        k = int(self.rng.integers(-self.jitter, self.jitter + 1))
        if k == 0:
            return mask
        kernel = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
        img = mask.astype(np.uint8)
        out = cv2.dilate(img, kernel, iterations=k) if k > 0 else cv2.erode(img, kernel, iterations=-k)
        return np.asarray(out).astype(bool)

    def _blob(self, background: NDArray[np.bool_]) -> NDArray[np.bool_] | None:
        import cv2

        v, u = np.nonzero(background)
        if len(u) == 0:
            return None
        h, w = background.shape
        i = int(self.rng.integers(len(u)))
        top = max(3.0, 0.08 * min(w, h))
        axes = (int(round(self.rng.uniform(2.0, top))), int(round(self.rng.uniform(2.0, top))))
        angle = float(self.rng.uniform(0.0, 180.0))
        canvas = np.zeros((h, w), dtype=np.uint8)
        cv2.ellipse(canvas, (int(u[i]), int(v[i])), axes, angle, 0.0, 360.0, 1, -1)
        blob = canvas.astype(bool) & background
        return blob if blob.any() else None

    def __call__(self, objects: NDArray[np.int32]) -> tuple[tuple[Detection, ...], tuple[int, ...],
                                                            tuple[int, ...]]:
        from scipy import ndimage

        rng = self.rng
        seen = np.unique(objects[objects >= 0]).tolist()
        dets: list[Detection] = []
        truth: list[int] = []
        missed: list[int] = []
        masks: dict[int, NDArray[np.bool_]] = {}
        # each object's mask is made in its bounding box grown by the jitter (a dilation stays
        # inside, an erosion sees the background around it): the whole image's result, at a
        # fraction of the cost when an image holds dozens of objects
        h, w = objects.shape
        pad = self.jitter
        boxes = ndimage.find_objects(objects + 1)
        for k in seen:
            rows, cols = boxes[k]
            r0, r1 = max(0, rows.start - pad), min(h, rows.stop + pad)
            c0, c1 = max(0, cols.start - pad), min(w, cols.stop + pad)
            crop = self._jittered(objects[r0:r1, c0:c1] == k)
            mask = np.zeros((h, w), dtype=bool)
            mask[r0:r1, c0:c1] = crop
            masks[k] = mask
            if int(crop.sum()) < self.min_pixels or (self.miss > 0 and rng.random() < self.miss):
                missed.append(k)
                continue
            dets.append(Detection(type=self.types[k], mask=mask, score=1.0))
            truth.append(k)
        n_false = int(rng.binomial(len(seen), self.false)) if self.false > 0 and seen else 0
        background = objects < 0
        for _ in range(n_false):
            k = int(seen[int(rng.integers(len(seen)))])
            others = [t for t in self.scene_types if t != self.types[k]]
            fake: NDArray[np.bool_] | None
            if others and rng.random() < 0.5:
                fake, typ = masks[k], others[int(rng.integers(len(others)))]
            else:
                fake = self._blob(background)
                typ = self.scene_types[int(rng.integers(len(self.scene_types)))]
            if fake is None or int(fake.sum()) < self.min_pixels:
                continue
            dets.append(Detection(type=typ, mask=fake, score=1.0))
            truth.append(-1)
        return tuple(dets), tuple(truth), tuple(missed)
