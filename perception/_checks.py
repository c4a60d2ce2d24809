"""Input validation shared by the public entry points of :mod:`perception` (private).

Every helper takes the argument name first and raises a :class:`~perception.errors.PerceptionError`
subclass whose message names the argument, the index of a bad element (where there is one) and
the offending value.

* :func:`real_array`, :func:`vector3`, :func:`spd` -- finite float64 arrays (any, (3,), SPD).
* :func:`real_scalar` -- a finite real scalar as ``float``: ``minimum`` / ``maximum``
  (inclusive), ``positive`` (``> 0``), ``max_abs``, and perception's ``nonnegative`` (``>= 0``).
* :func:`integer` -- an int (not bool or float) in ``[minimum, maximum]``.
* :func:`boolean`, :func:`generator`, :func:`name_string`, :func:`file_path`, :func:`sequence`.
* :func:`check_transform` and the rotation rule (:func:`rotation_errors`, :func:`rigid_defect`).
"""

from __future__ import annotations

import numbers
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import (
    PerceptionError,
)
from .tolerances import RIGID_TOLERANCE, SPD_RTOL, SYM_RTOL


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 200 else text[:200] + "..."


def _index(idx: tuple[int, ...]) -> str:
    return "[" + ", ".join(str(int(i)) for i in idx) + "]" if idx else ""  # a 0-d array: no index


def real_array(name: str, value: Any, shape: tuple[int, ...] | None = None) -> NDArray[np.float64]:
    """``value`` as a finite float64 array of ``shape`` (``-1`` matches any length).

    Rejects None, strings, booleans, complex numbers, ragged sequences, wrong shapes and
    NaN/inf, naming the index of the first bad element.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise PerceptionError(f"{name} must be a real float array, got {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise PerceptionError(f"{name} must be a real float array (not ragged), got {_short(value)}") from exc
    if raw.dtype.kind in "cbUSVMm" or (
        raw.dtype.kind == "O"
        and any(isinstance(v, (str, bytes, bool, np.bool_, complex, np.complexfloating)) or v is None
                for v in raw.ravel().tolist())
    ):
        raise PerceptionError(f"{name} must hold real numbers, got dtype {raw.dtype}: {_short(value)}")
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise PerceptionError(f"{name} must hold real numbers, got {_short(value)}") from exc
    if shape is not None:
        ok = arr.ndim == len(shape) and all(s < 0 or s == a for s, a in zip(shape, arr.shape, strict=False))
        if not ok:
            dims = ", ".join("N" if s < 0 else str(s) for s in shape)
            want = f"({dims},)" if len(shape) == 1 else f"({dims})"
            raise PerceptionError(f"{name} must have shape {want}, got shape {arr.shape}")
    finite = np.isfinite(arr)
    if not np.all(finite):
        idx = np.argwhere(~finite)[0]
        where = _index(tuple(idx)) if arr.ndim else ""
        raise PerceptionError(f"{name}{where} must be finite, got {arr[tuple(idx)]!r}")
    return arr


def real_scalar(
    name: str,
    value: Any,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    positive: bool = False,
    max_abs: float | None = None,
    nonnegative: bool = False,
) -> float:
    """``value`` as a finite Python float (not bool/str/None/complex), optionally range-checked.

    ``positive`` (``> 0``) and ``nonnegative`` (``>= 0``) raise :class:`PerceptionError`;
    ``minimum`` / ``maximum`` (inclusive) and ``max_abs`` (``|value| <=``) raise
    :class:`PerceptionError`.  ``nonnegative`` is perception's own addition to the signature the
    three packages share: it is not ``minimum=0.0``, whose violation is a range error.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        if not (isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "fiu"):
            raise PerceptionError(f"{name} must be a real number, got {type(value).__name__} {_short(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise PerceptionError(f"{name} must be a finite real number, got {_short(value)}") from exc
    if not np.isfinite(v):
        raise PerceptionError(f"{name} must be finite, got {v!r}")
    if positive and v <= 0:
        raise PerceptionError(f"{name} must be > 0, got {v!r}")
    if nonnegative and v < 0:
        raise PerceptionError(f"{name} must be >= 0, got {v!r}")
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        raise PerceptionError(f"{name} must lie in [{minimum}, {maximum}], got {v!r}")
    if max_abs is not None and abs(v) > max_abs:
        raise PerceptionError(f"{name} must satisfy |{name}| <= {max_abs:g}, got {v!r}")
    return v


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` as a Python int: rejects bool, float (even 2.0), NaN, None, str and out-of-range."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise PerceptionError(f"{name} must be an integer, got {type(value).__name__} {_short(value)}")
    v = int(value)
    if minimum is not None and v < minimum:
        raise PerceptionError(f"{name} must be >= {minimum}, got {v!r}")
    if maximum is not None and v > maximum:
        raise PerceptionError(f"{name} must be <= {maximum}, got {v!r}")
    return v


def boolean(name: str, value: Any) -> bool:
    """A real bool (Python or numpy)."""
    if not isinstance(value, (bool, np.bool_)):
        raise PerceptionError(f"{name} must be a bool, got {type(value).__name__} {_short(value)}")
    return bool(value)


def vector3(name: str, value: Any) -> NDArray[np.float64]:
    """A finite (3,) float vector."""
    return real_array(name, value, (3,))


def spd(name: str, value: Any, size: int = 3) -> NDArray[np.float64]:
    """A real, finite, symmetric (to ``SYM_RTOL``) positive definite ``(size, size)`` matrix.

    Positive definite numerically: the smallest eigenvalue exceeds ``SPD_RTOL`` times the
    largest. Returned exactly symmetrised.
    """
    C = real_array(name, value, (size, size))
    scale = float(np.max(np.abs(C))) if C.size else 0.0
    if scale == 0.0:
        raise PerceptionError(f"{name} must be symmetric positive definite, got the zero matrix")
    A = C / scale
    asym = float(np.max(np.abs(A - A.T)))
    if asym > SYM_RTOL:
        raise PerceptionError(
            f"{name} must be symmetric (max |C - C^T| / max|C| = {asym:.3g} > {SYM_RTOL:g}), got {C.tolist()}"
        )
    S = 0.5 * C + 0.5 * C.T
    eig = np.linalg.eigvalsh(S / scale) * scale
    if not eig[0] > SPD_RTOL * eig[-1] or eig[-1] <= 0:
        raise PerceptionError(
            f"{name} must be symmetric positive definite (smallest eigenvalue {eig[0]:.3g}, largest "
            f"{eig[-1]:.3g}), got {S.tolist()}"
        )
    return S


def generator(name: str, value: Any) -> np.random.Generator:
    """A ``numpy.random.Generator`` (seeds, strings and legacy RandomState are refused)."""
    if not isinstance(value, np.random.Generator):
        raise PerceptionError(
            f"{name} must be a numpy.random.Generator (e.g. numpy.random.default_rng(0)), got "
            f"{type(value).__name__} {_short(value)}"
        )
    return value


def name_string(name: str, value: Any, error: type[PerceptionError] = PerceptionError) -> str:
    """A non-empty string without NUL characters that encodes as UTF-8 (no lone surrogates)."""
    if not isinstance(value, str) or not value or "\0" in value:
        raise error(f"{name} must be a non-empty string without NUL characters, got {_short(value)}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise error(
            f"{name} must be encodable as UTF-8, got {_short(value)} (character {exc.start}: "
            f"{value[exc.start]!r})"
        ) from exc
    return value


#: Longest file path accepted, characters (Linux PATH_MAX).
MAX_PATH_LENGTH = 4096


def file_path(name: str, value: Any, error: type[PerceptionError] = PerceptionError) -> str:
    """A file path (str or os.PathLike of str) as a str: non-empty, without NUL characters,
    encodable by the file system (no lone surrogates the codec cannot map) and at most
    :data:`MAX_PATH_LENGTH` characters."""
    import os

    try:
        text = os.fspath(value) if isinstance(value, (str, os.PathLike)) else None
    except TypeError:
        text = None
    if not isinstance(text, str) or not text:
        raise error(f"{name} must be a non-empty str or os.PathLike of str, got {type(value).__name__} "
                    f"{_short(value)}")
    if "\0" in text:
        raise error(f"{name} must not contain NUL characters, got {_short(text)}")
    if len(text) > MAX_PATH_LENGTH:
        raise error(f"{name} must be at most {MAX_PATH_LENGTH} characters long, got {len(text)}: "
                    f"{_short(text)}")
    for codec in ("fs", "utf-8"):
        try:
            os.fsencode(text) if codec == "fs" else text.encode("utf-8")
        except UnicodeEncodeError as exc:
            raise error(
                f"{name} must be encodable ({codec}), got {_short(text)} (character {exc.start}: "
                f"{text[exc.start]!r})"
            ) from exc
    return text


def sequence(name: str, value: Any, kind: type | None = None) -> list[Any]:
    """A sequence (not a string or a lone ``kind``) as a list; every element an instance of
    ``kind``, or, when ``kind`` is None, a non-empty string without NUL characters."""
    what = "str" if kind is None else kind.__name__
    lone = (str, bytes) if kind is None else (str, bytes, kind)
    if value is None or isinstance(value, lone):
        raise PerceptionError(f"{name} must be a sequence of {what}, "
                              f"got {type(value).__name__} {_short(value)}")
    try:
        out = list(value)
    except TypeError as exc:
        raise PerceptionError(f"{name} must be a sequence of {what}, got {type(value).__name__}") from exc
    for i, item in enumerate(out):
        if kind is None:
            name_string(f"{name}[{i}]", item)
        elif not isinstance(item, kind):
            raise PerceptionError(f"{name}[{i}] must be a {what}, got {type(item).__name__}: {_short(item)}")
    return out


MAX_TRANSLATION = 1e150
"""Largest translation (metres) of a rigid transform accepted."""


def rotation_errors(rot: NDArray[np.float64], tol: float
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """``(max |R^T R - I|, det R, improper)`` of each rotation of a stack ``(..., 3, 3)``.

    The one rotation rule of the three packages: ``improper`` where ``max |R^T R - I| > tol`` or
    ``|det R - 1| > tol`` (scaled, sheared or reflected).  Entries above 2 in magnitude, which no
    rotation has, give an infinite orthogonality error instead of an overflow; NaN entries are
    improper.
    """
    rot = np.asarray(rot, dtype=np.float64)
    if rot.size == 0:
        shape = rot.shape[:-2]
        return np.zeros(shape), np.ones(shape), np.zeros(shape, dtype=bool)
    huge = np.abs(rot).max(axis=(-2, -1)) > 2.0
    safe = np.where(huge[..., None, None], 0.0, rot)
    gram = np.einsum("...ji,...jk->...ik", safe, safe)
    orth = np.where(huge, np.inf, np.abs(gram - np.eye(3)).max(axis=(-2, -1)))
    with np.errstate(invalid="ignore"):  # NaN entries give a NaN determinant: improper
        det = np.where(huge, np.nan, np.linalg.det(safe))
    improper = ~((orth <= tol) & (np.abs(det - 1.0) <= tol))
    return orth, det, improper


def rotation_defect(rot: NDArray[np.float64], tol: float) -> str | None:
    """Why a finite (3, 3) array is not a proper rotation within ``tol`` (:func:`rotation_errors`),
    or ``None``; the text is a predicate (``"is a reflection: det R = ..."``) with the measured
    numbers, for a sentence that names the argument."""
    orth, det, improper = rotation_errors(rot, tol)
    if not improper:
        return None
    if not np.isfinite(orth):
        return f"has entries up to {float(np.abs(rot).max()):.3g}, which no rotation has"
    kind = "a reflection" if det < 0 else "scaled or sheared"
    return f"is {kind}: det R = {float(det):.6g}, max |R^T R - I| = {float(orth):.3g} (tolerance {tol:g})"


def rigid_defect(value: NDArray[np.float64], tol: float
                 ) -> tuple[Literal["last row", "rotation"], str] | None:
    """Why a finite (4, 4) float array is not a rigid transform within ``tol``, or ``None``.

    The one rigidity rule of the three packages (:func:`check_transform` raises perception's
    errors with it, worldgraph's transform checks raise worldgraph's): the last row is
    ``[0, 0, 0, 1]`` within ``tol`` (else ``"last row"``), and the rotation block is proper by
    :func:`rotation_errors` (else ``"rotation"``).  The text gives the measured numbers, without
    the argument name.
    """
    if not np.abs(value[3] - (0.0, 0.0, 0.0, 1.0)).max() <= tol:
        return "last row", f"its last row must be [0, 0, 0, 1], got {value[3].tolist()}"
    why = rotation_defect(value[:3, :3], tol)
    return None if why is None else ("rotation", f"its rotation block {why}")


def check_transform(name: str, value: ArrayLike, atol: float = RIGID_TOLERANCE) -> NDArray[np.float64]:
    """Validate a 4x4 rigid transform and return it as float64.

    Raises
    ------
    PerceptionError
        Wrong shape, non-finite entries, or not a rigid motion (rotation block, last row).
    """
    if not isinstance(name, str):
        raise PerceptionError(f"name must be a str, got {type(name).__name__}")
    atol = real_scalar("atol", atol, positive=True)
    M = real_array(name, value, (4, 4))
    if np.any(np.abs(M[:3, 3]) > MAX_TRANSLATION):
        raise PerceptionError(
            f"{name}: translation must be at most {MAX_TRANSLATION:g} m, got {M[:3, 3].tolist()}"
        )
    defect = rigid_defect(M, atol)
    if defect is not None:
        raise PerceptionError(f"{name} must be a rigid transform: {defect[1]}")
    return M
