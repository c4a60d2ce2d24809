"""Input validation shared by the public entry points of :mod:`perception` (private).

Every helper takes the argument name first and raises a :class:`~perception.errors.PerceptionError`
subclass whose message names the argument, the index of a bad element (where there is one) and
the offending value.

* :func:`real_array`, :func:`vector3`, :func:`spd` -- finite float64 arrays (any, (3,), SPD);
  ``None`` in a shape is any length.
* :func:`real_scalar` -- a finite real scalar as ``float``: ``minimum`` / ``maximum``
  (inclusive), ``positive`` (``> 0``), ``max_abs``.
* :func:`integer` -- an int (not bool or float) in ``[minimum, maximum]``.

:func:`real_array`, :func:`real_scalar`, :func:`integer` and :func:`generator` have the same
signatures, rules and messages as their namesakes in ``worldgraph._checks`` and
``radialopt._checks`` (only the error class differs); ``tests/repo/test_checks_parity.py`` holds
the three to that.
* :func:`image_size` -- ``(width, height)`` in pixels.
* :func:`boolean`, :func:`generator`, :func:`name_string`, :func:`file_path`, :func:`sequence`.
* :func:`check_transform` and the rotation rule (:func:`rotation_errors`, :func:`rigid_defect`).
"""

from __future__ import annotations

import numbers
import operator
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import (
    PerceptionError,
)
from .tolerances import RIGID_TOLERANCE, SPD_RTOL, SYM_RTOL


def _short(value: Any, limit: int = 200) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _index(idx: tuple[int | np.integer, ...]) -> str:
    return "[" + ", ".join(str(int(i)) for i in idx) + "]" if idx else ""  # a 0-d array: no index


def _shape_ok(shape: tuple[int, ...], want: tuple[int | str | None, ...]) -> bool:
    return len(shape) == len(want) and all(w is None or isinstance(w, str) or w == s
                                           for s, w in zip(shape, want, strict=True))


def _shape_text(want: tuple[int | str | None, ...]) -> str:
    dims = ", ".join("n" if w is None else str(w) for w in want)
    return f"({dims},)" if len(want) == 1 else f"({dims})"


def real_array(name: str, value: Any, shape: tuple[int | str | None, ...] | None = None, *,
               ndim: tuple[int, ...] | None = None, max_abs: float | None = None, min_size: int = 0,
               like: str = "") -> NDArray[np.float64]:
    """``value`` as a new finite float64 array.

    ``shape`` entries are lengths, or ``None`` (shown as ``n``) or a label such as ``"k"`` for
    any length; ``like`` names the argument the expected shape comes from (for the message);
    ``ndim`` lists accepted dimension counts; ``min_size`` is the least number of elements and
    ``max_abs`` bounds every element's magnitude.  Raises :class:`PerceptionError`
    for None, str, bool, complex or non-numeric elements, ragged input, a wrong shape, NaN or
    inf, naming the index and value of the first bad element.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise PerceptionError(f"{name} must be an array of real numbers, got {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise PerceptionError(f"{name} must be a rectangular array of real numbers, "
                    f"got {_short(value)}") from exc
    if raw.dtype.kind == "b":
        raise PerceptionError(f"{name} must hold real numbers, not booleans, got {_short(value)}")
    if raw.dtype.kind == "c":
        imaginary = np.argwhere(np.imag(raw) != 0)
        where = _index(tuple(imaginary[0])) if len(imaginary) and raw.ndim else ""
        raise PerceptionError(f"{name}{where} must be real, got complex values {_short(value)}")
    if raw.dtype.kind not in "iufO":
        raise PerceptionError(f"{name} must be an array of real numbers, got dtype {raw.dtype} "
                    f"{_short(value)}")
    if raw.dtype.kind == "O":
        for k, item in enumerate(raw.reshape(-1)):
            idx = np.unravel_index(k, raw.shape) if raw.ndim else ()
            if isinstance(item, (bool, np.bool_, complex)) or not isinstance(item, numbers.Real):
                raise PerceptionError(f"{name}{_index(idx)} must be a real number, got {_short(item)}")
            try:
                float(item)
            except OverflowError as exc:
                raise PerceptionError(f"{name}{_index(idx)} = {_short(item)} does not fit a float64") from exc
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise PerceptionError(f"{name} must hold real numbers representable as float64, "
                    f"got {_short(value)}") from exc
    if ndim is not None and arr.ndim not in ndim:
        raise PerceptionError(f"{name} must have {' or '.join(map(str, ndim))} dimension(s), "
                    f"got shape {arr.shape}")
    if shape is not None and not _shape_ok(arr.shape, shape):
        like_text = f" like {like}" if like else ""
        raise PerceptionError(f"{name} must have shape {_shape_text(shape)}{like_text}, "
                    f"got shape {arr.shape}")
    if arr.size < min_size:
        raise PerceptionError(f"{name} must hold at least {min_size} element(s), got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(np.argwhere(bad)[0]) if arr.ndim else ()
        raise PerceptionError(f"{name}{_index(idx)} must be finite, got {float(arr[idx])!r}")
    if max_abs is not None:
        over = np.abs(arr) > max_abs
        if over.any():
            idx = tuple(np.argwhere(over)[0]) if arr.ndim else ()
            raise PerceptionError(f"{name}{_index(idx)} must be <= {max_abs:g} in magnitude, "
                        f"got {float(arr[idx])!r}")
    return arr


def real_scalar(name: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
                positive: bool = False, max_abs: float | None = None) -> float:
    """``value`` (a real number or a 0-d real array; not bool, complex, str or None) as a finite
    Python float: ``> 0`` with ``positive``, in ``[minimum, maximum]`` (inclusive; either may be
    None) and at most ``max_abs`` in magnitude, else :class:`PerceptionError`.
    """
    if isinstance(value, np.ndarray):
        ok = value.shape == () and value.dtype.kind in "iuf"
    else:
        ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok:
        raise PerceptionError(f"{name} must be a real number, got {_short(value)} ({type(value).__name__})")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:  # a Python int above ~1.8e308
        raise PerceptionError(f"{name} = {_short(value)} does not fit a float64") from exc
    if not np.isfinite(x):
        raise PerceptionError(f"{name} must be finite, got {x!r}")
    if positive and x <= 0:
        raise PerceptionError(f"{name} must be > 0, got {x!r}")
    if minimum is not None and x < minimum:
        raise PerceptionError(f"{name} must be >= {minimum:g}, got {x!r}")
    if maximum is not None and x > maximum:
        raise PerceptionError(f"{name} must be <= {maximum:g}, got {x!r}")
    if max_abs is not None and abs(x) > max_abs:
        raise PerceptionError(f"{name} must be <= {max_abs:g} in magnitude, got {x!r}")
    return x


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` (a Python or numpy integer; not bool, float (even 2.0), None or str) as a Python
    int in ``[minimum, maximum]`` (inclusive; either may be None), else :class:`PerceptionError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise PerceptionError(f"{name} must be an integer, got {_short(value)} ({type(value).__name__})")
    n = operator.index(value)
    if minimum is not None and n < minimum:
        raise PerceptionError(f"{name} must be >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise PerceptionError(f"{name} must be <= {maximum}, got {n}")
    return n


def generator(name: str, value: Any) -> np.random.Generator:
    """``value`` if it is a :class:`numpy.random.Generator` (seeds, strings and the legacy
    ``RandomState`` are refused), else :class:`PerceptionError`."""
    if not isinstance(value, np.random.Generator):
        raise PerceptionError(f"{name} must be a numpy.random.Generator, "
                    f"got {_short(value)} ({type(value).__name__})")
    return value


def image_size(value: Any, maximum: int) -> tuple[int, int]:
    """``value`` (a pair) as ``(width, height)``, two integers in ``[1, maximum]`` pixels."""
    if value is None or isinstance(value, (str, bytes)):
        raise PerceptionError(f"image_size must be (width, height), got {_short(value)}")
    try:
        items = list(value)
    except TypeError as exc:
        raise PerceptionError(f"image_size must be (width, height), got {_short(value)}") from exc
    if len(items) != 2:
        raise PerceptionError(f"image_size must be two integers (width, height), got {_short(value)}")
    return (integer("image_size[0] (width)", items[0], minimum=1, maximum=maximum),
            integer("image_size[1] (height)", items[1], minimum=1, maximum=maximum))


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
