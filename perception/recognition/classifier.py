"""The Gaussian classifier of :mod:`perception.recognition`: one multivariate Gaussian per class
with a log-likelihood rejection threshold (:class:`GaussianClassifier`).

Also importable from :mod:`perception.recognition`, which trains it on rendered scenes
(:func:`~perception.recognition.train_classifier`) and applies it to segmented regions
(:func:`~perception.recognition.detect`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import real_array, real_scalar, sequence, spd
from ..errors import (
    PerceptionError,
)

__all__ = ["GaussianClassifier"]


def _thresholds(value: Any, k: int) -> NDArray[np.float64]:
    """(k,) real thresholds; -inf (never reject) is allowed, NaN and +inf are not."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise PerceptionError(f"thresholds must have shape ({k},), got {value!r}") from exc
    if value is None or raw.dtype.kind not in "fiu":
        raise PerceptionError(f"thresholds must be real numbers of shape ({k},), got {value!r}")
    thr = np.array(raw, dtype=np.float64)
    if thr.shape != (k,):
        raise PerceptionError(f"thresholds must have shape ({k},), got shape {thr.shape}")
    bad = np.flatnonzero(np.isnan(thr) | (thr == np.inf))
    if bad.size:
        raise PerceptionError(f"thresholds[{bad[0]}] must be a number or -inf, got {thr[bad[0]]!r}")
    return thr


@dataclass(frozen=True)
class GaussianClassifier:
    """One multivariate Gaussian per class, with a log-likelihood rejection threshold.

    Parameters
    ----------
    classes : tuple of str
        Class names, in the order of the other arrays.
    means : (k, d) float
    covariances : (k, d, d) float
        Symmetric positive definite.
    log_priors : (k,) float
        Log class priors.
    thresholds : (k,) float
        A sample assigned to class c is rejected when its log-likelihood under c is below
        ``thresholds[c]``.
    """

    classes: tuple[str, ...]
    means: NDArray[np.float64]
    covariances: NDArray[np.float64]
    log_priors: NDArray[np.float64]
    thresholds: NDArray[np.float64]
    _chol: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _log_norm: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        classes = tuple(sequence("classes", self.classes))
        k = len(classes)
        if k == 0:
            raise PerceptionError(f"classes must be non-empty strings, got {classes!r}")
        if len(set(classes)) != k:
            raise PerceptionError(f"classes must be unique, got {classes!r}")
        means = real_array("means", self.means)
        if means.ndim != 2 or means.shape[0] != k:
            raise PerceptionError(
                f"means must have shape (k, d) with k = len(classes) = {k}, got shape {means.shape}"
            )
        d = means.shape[1]
        if d < 1:
            raise PerceptionError(f"means must have shape ({k}, d) with d >= 1, got shape {means.shape}")
        if np.any(np.abs(means) > 1e150):
            raise PerceptionError("means must be at most 1e150 in magnitude")
        covs_in = real_array("covariances", self.covariances)
        if covs_in.shape != (k, d, d):
            raise PerceptionError(
                f"covariances must have shape ({k}, {d}, {d}) (k = len(classes), d = means.shape[1]), "
                f"got shape {covs_in.shape}"
            )
        covs = np.stack([spd(f"covariances[{i}]", covs_in[i], d) for i in range(k)])
        if np.any(np.abs(covs) > 1e150) or np.any(np.abs(covs) < 1e-150 * (covs != 0)):
            raise PerceptionError("covariances entries must lie within [1e-150, 1e150] in magnitude")
        log_priors = real_array("log_priors", self.log_priors, (k,))
        thresholds = _thresholds(self.thresholds, k)
        try:
            chol = np.linalg.cholesky(covs)
        except np.linalg.LinAlgError as exc:
            raise PerceptionError("covariances must be positive definite") from exc
        log_norm = -0.5 * d * np.log(2 * np.pi) - np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)
        for name, arr in (
            ("means", means), ("covariances", covs), ("log_priors", log_priors), ("thresholds", thresholds),
            ("_chol", chol), ("_log_norm", log_norm),
        ):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "classes", classes)

    @property
    def n_features(self) -> int:
        """Feature dimension d."""
        return int(self.means.shape[1])

    @classmethod
    def fit(
        cls,
        features: ArrayLike,
        labels: Sequence[str],
        *,
        regularization: float = 1e-4,
        reject_quantile: float = 0.002,
        threshold_margin: float = 3.0,
    ) -> GaussianClassifier:
        """Maximum-likelihood Gaussians per class.

        Parameters
        ----------
        features : (n, d) float
        labels : (n,) str
        regularization : float
            Added to the covariance diagonal (features are O(1)), >= 0.
        reject_quantile : float
            Per class, the threshold is the ``reject_quantile`` quantile of the training
            log-likelihoods of that class's own samples ...
        threshold_margin : float
            ... minus this margin (nats).

        Returns
        -------
        GaussianClassifier
            Priors are the class frequencies.
        """
        x = real_array("features", features, (None, None))
        if x.shape[1] < 1:
            raise PerceptionError(f"features must have shape (n, d) with d >= 1, got shape {x.shape}")
        big = np.argwhere(np.abs(x) > 1e100)
        if big.size:
            i, j = big[0]
            raise PerceptionError(f"features[{i}, {j}] = {x[i, j]!r} exceeds 1e100 in magnitude")
        y = np.asarray(sequence("labels", labels) or [], dtype=object).reshape(-1)
        if y.shape != (x.shape[0],):
            raise PerceptionError(
                f"labels must have one entry per row of features (shape ({x.shape[0]},)), got shape {y.shape}"
            )
        if x.shape[0] == 0:
            raise PerceptionError("features must hold at least one sample per class, got none")
        regularization = real_scalar("regularization", regularization, minimum=0.0, maximum=1e100)
        reject_quantile = real_scalar("reject_quantile", reject_quantile, minimum=0.0, maximum=1.0)
        threshold_margin = real_scalar("threshold_margin", threshold_margin, minimum=0.0, maximum=1e100)
        classes = tuple(sorted({str(v) for v in y}))
        d = x.shape[1]
        means, covs, counts = [], [], []
        for c in classes:
            xc = x[y == c]
            if len(xc) < 2:
                raise PerceptionError(f"class {c!r} needs at least 2 samples, got {len(xc)}")
            mu = xc.mean(axis=0)
            diff = xc - mu
            means.append(mu)
            cov = diff.T @ diff / len(xc) + regularization * np.eye(d)
            try:
                spd(f"covariance of class {c!r}", cov, d)
            except PerceptionError as exc:
                raise PerceptionError(
                    f"class {c!r}: its features are degenerate (use regularization > 0): {exc}"
                ) from exc
            covs.append(cov)
            counts.append(len(xc))
        k = len(classes)
        prov = cls(
            classes=classes,
            means=np.array(means),
            covariances=np.array(covs),
            log_priors=np.log(np.array(counts) / x.shape[0]),
            thresholds=np.full(k, -np.inf),
        )
        ll = prov.log_likelihood(x)
        thresholds = np.empty(k)
        for i, c in enumerate(classes):
            own = ll[y == c, i]
            thresholds[i] = np.quantile(own, reject_quantile) - threshold_margin
        return cls(classes, prov.means, prov.covariances, prov.log_priors, thresholds)

    def log_likelihood(self, features: ArrayLike) -> NDArray[np.float64]:
        """Class-conditional log densities ``log N(x; mu_c, Sigma_c)``, shape (n, k)."""
        x = real_array("features", features)
        if x.ndim == 1:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != self.n_features:
            raise PerceptionError(f"features must have shape (n, {self.n_features}), got shape {x.shape}")
        big = np.argwhere(np.abs(x) > 1e100)
        if big.size:
            i, j = big[0]
            raise PerceptionError(f"features[{i}, {j}] = {x[i, j]!r} exceeds 1e100 in magnitude")
        diff = x[None, :, :] - self.means[:, None, :]  # (k, n, d)
        z = np.linalg.solve(self._chol, np.swapaxes(diff, 1, 2))  # (k, d, n)
        maha = np.einsum("kdn,kdn->kn", z, z)
        return (self._log_norm[:, None] - 0.5 * maha).T

    def predict(self, features: ArrayLike) -> tuple[list[str | None], NDArray[np.float64]]:
        """Maximum a-posteriori class of each sample, ``None`` where rejected.

        Returns
        -------
        labels : list of (str or None), length n
            The class maximising ``log N(x; c) + log prior(c)``, or ``None`` when the
            log-likelihood under that class is below its threshold.
        log_likelihood : (n,) float
            Log-likelihood under the chosen class.
        """
        ll = self.log_likelihood(features)
        best = np.argmax(ll + self.log_priors, axis=1)
        score = ll[np.arange(len(best)), best]
        accepted = score >= self.thresholds[best]
        labels = [self.classes[b] if ok else None for b, ok in zip(best, accepted, strict=True)]
        return labels, score
