"""Input validation shared by every public entry point of :mod:`radialopt` (one copy).

Each helper converts a value, checks type, shape, finiteness and range, and raises a
:class:`~radialopt.errors.RadialArgumentError` whose message names the argument, the index of
the first bad element and its value, e.g. ``"centers[0, 2] must be finite, got nan"``.

* :func:`real_array`, :func:`point3` -- finite float64 arrays, bounded by :data:`MAX_LENGTH`.
* :func:`real_scalar` -- a finite real scalar as ``float``: ``minimum`` / ``maximum``
  (inclusive), ``positive`` (``> 0``), ``max_abs``.
* :func:`integer` -- an int (not bool or float) in ``[minimum, maximum]``.
* :func:`sigma_range`, :func:`instance`, :func:`dataclass_fields` (options dataclasses).

:func:`real_array`, :func:`real_scalar` and :func:`integer` have the same signatures, rules and
messages as their namesakes in ``perception._checks`` and ``worldgraph._checks`` (only the error
class differs, and :func:`real_array` bounds magnitudes by :data:`MAX_LENGTH` unless told
otherwise); ``tests/repo/test_checks_parity.py`` holds the three to that.
"""

from __future__ import annotations

import numbers
import operator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import RadialArgumentError

#: Largest magnitude (metres) of a coordinate, radius or sigma radialopt accepts: beyond it
#: squared distances lose every significant digit of the ranges (and overflow near 1e154).
MAX_LENGTH = 1e9
#: Largest sigma (metres) a single GaussianSphere accepts; sets of spheres are held to the
#: relative range below.
MAX_SIGMA = 1e100
#: Smallest sigma relative to the length scale of the input (the largest coordinate or radius,
#: at least 1 m): a range known to 1e-12 of its size is at the resolution of float64.
MIN_SIGMA_RELATIVE = 1e-12


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
               ndim: tuple[int, ...] | None = None, max_abs: float | None = MAX_LENGTH, min_size: int = 0,
               like: str = "") -> NDArray[np.float64]:
    """``value`` as a new finite float64 array.

    ``shape`` entries are lengths, or ``None`` (shown as ``n``) or a label such as ``"k"`` for
    any length; ``like`` names the argument the expected shape comes from (for the message);
    ``ndim`` lists accepted dimension counts; ``min_size`` is the least number of elements and
    ``max_abs`` bounds every element's magnitude (default :data:`MAX_LENGTH`).  Raises
    :class:`RadialArgumentError` for None, str, bool, complex or non-numeric elements, ragged
    input, a wrong shape, NaN or inf, naming the index and value of the first bad element.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise RadialArgumentError(f"{name} must be an array of real numbers, got {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise RadialArgumentError(f"{name} must be a rectangular array of real numbers, "
                    f"got {_short(value)}") from exc
    if raw.dtype.kind == "b":
        raise RadialArgumentError(f"{name} must hold real numbers, not booleans, got {_short(value)}")
    if raw.dtype.kind == "c":
        imaginary = np.argwhere(np.imag(raw) != 0)
        where = _index(tuple(imaginary[0])) if len(imaginary) and raw.ndim else ""
        raise RadialArgumentError(f"{name}{where} must be real, got complex values {_short(value)}")
    if raw.dtype.kind not in "iufO":
        raise RadialArgumentError(f"{name} must be an array of real numbers, got dtype {raw.dtype} "
                    f"{_short(value)}")
    if raw.dtype.kind == "O":
        for k, item in enumerate(raw.reshape(-1)):
            idx = np.unravel_index(k, raw.shape) if raw.ndim else ()
            if isinstance(item, (bool, np.bool_, complex)) or not isinstance(item, numbers.Real):
                raise RadialArgumentError(f"{name}{_index(idx)} must be a real number, got {_short(item)}")
            try:
                float(item)
            except OverflowError as exc:
                raise RadialArgumentError(f"{name}{_index(idx)} = {_short(item)} does not fit a float64"
                                          ) from exc
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise RadialArgumentError(f"{name} must hold real numbers representable as float64, "
                    f"got {_short(value)}") from exc
    if ndim is not None and arr.ndim not in ndim:
        raise RadialArgumentError(f"{name} must have {' or '.join(map(str, ndim))} dimension(s), "
                    f"got shape {arr.shape}")
    if shape is not None and not _shape_ok(arr.shape, shape):
        like_text = f" like {like}" if like else ""
        raise RadialArgumentError(f"{name} must have shape {_shape_text(shape)}{like_text}, "
                    f"got shape {arr.shape}")
    if arr.size < min_size:
        raise RadialArgumentError(f"{name} must hold at least {min_size} element(s), got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(np.argwhere(bad)[0]) if arr.ndim else ()
        raise RadialArgumentError(f"{name}{_index(idx)} must be finite, got {float(arr[idx])!r}")
    if max_abs is not None:
        over = np.abs(arr) > max_abs
        if over.any():
            idx = tuple(np.argwhere(over)[0]) if arr.ndim else ()
            raise RadialArgumentError(f"{name}{_index(idx)} must be <= {max_abs:g} in magnitude, "
                        f"got {float(arr[idx])!r}")
    return arr


def real_scalar(name: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
                positive: bool = False, max_abs: float | None = None) -> float:
    """``value`` (a real number or a 0-d real array; not bool, complex, str or None) as a finite
    Python float: ``> 0`` with ``positive``, in ``[minimum, maximum]`` (inclusive; either may be
    None) and at most ``max_abs`` in magnitude, else :class:`RadialArgumentError`.
    """
    if isinstance(value, np.ndarray):
        ok = value.shape == () and value.dtype.kind in "iuf"
    else:
        ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok:
        raise RadialArgumentError(f"{name} must be a real number, got {_short(value)} "
                                  f"({type(value).__name__})")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:  # a Python int above ~1.8e308
        raise RadialArgumentError(f"{name} = {_short(value)} does not fit a float64") from exc
    if not np.isfinite(x):
        raise RadialArgumentError(f"{name} must be finite, got {x!r}")
    if positive and x <= 0:
        raise RadialArgumentError(f"{name} must be > 0, got {x!r}")
    if minimum is not None and x < minimum:
        raise RadialArgumentError(f"{name} must be >= {minimum:g}, got {x!r}")
    if maximum is not None and x > maximum:
        raise RadialArgumentError(f"{name} must be <= {maximum:g}, got {x!r}")
    if max_abs is not None and abs(x) > max_abs:
        raise RadialArgumentError(f"{name} must be <= {max_abs:g} in magnitude, got {x!r}")
    return x


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` (a Python or numpy integer; not bool, float (even 2.0), None or str) as a Python
    int in ``[minimum, maximum]`` (inclusive; either may be None), else :class:`RadialArgumentError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise RadialArgumentError(f"{name} must be an integer, got {_short(value)} ({type(value).__name__})")
    n = operator.index(value)
    if minimum is not None and n < minimum:
        raise RadialArgumentError(f"{name} must be >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise RadialArgumentError(f"{name} must be <= {maximum}, got {n}")
    return n



def point3(name: str, value: Any) -> NDArray[np.float64]:
    """A point of shape (3,) with finite coordinates of at most :data:`MAX_LENGTH` metres."""
    return real_array(name, value, shape=(3,))


def sigma_range(name: str, sigmas: NDArray[np.float64], length_scale: float) -> None:
    """Every sigma > 0 and within ``[MIN_SIGMA_RELATIVE, 1 / MIN_SIGMA_RELATIVE]`` times the length
    scale (the largest coordinate or radius, at least 1 m)."""
    s = np.asarray(sigmas, dtype=np.float64).reshape(-1)
    bad = np.flatnonzero(~(s > 0))
    if bad.size:
        raise RadialArgumentError(f"{name}[{bad[0]}] = {float(s[bad[0]])!r} must be > 0")
    scale = max(float(length_scale), 1.0)
    floor, ceiling = MIN_SIGMA_RELATIVE * scale, scale / MIN_SIGMA_RELATIVE
    bad = np.flatnonzero((s < floor) | (s > ceiling))
    if bad.size:
        k = int(bad[0])
        raise RadialArgumentError(
            f"{name}[{k}] = {s[k]:.6g} is outside the usable range [{floor:.3g}, {ceiling:.3g}] m "
            f"({MIN_SIGMA_RELATIVE:g} to {1 / MIN_SIGMA_RELATIVE:g} times the length scale {scale:.3g} m "
            "of the centres and radii)")


def instance(name: str, value: Any, cls: type | tuple[type, ...]) -> Any:
    """``value`` if it is an instance of ``cls``, else a :class:`RadialArgumentError` naming both."""
    if not isinstance(value, cls):
        names = cls.__name__ if isinstance(cls, type) else " or ".join(c.__name__ for c in cls)
        raise RadialArgumentError(f"{name} must be a {names}, got {type(value).__name__} ({value!r:.100})")
    return value


def dataclass_fields(obj: Any, ints: dict[str, tuple[int | None, int | None]],
                     floats: dict[str, tuple[float | None, float | None, bool]]) -> None:
    """Validate (and normalise to int / float) the fields of a frozen options dataclass.

    ``ints`` maps a field to ``(minimum, maximum)`` for :func:`integer`; ``floats`` maps a field
    to ``(minimum, maximum, positive)`` for :func:`real_scalar` (``positive``: ``> 0``, checked
    before ``minimum``).  Messages name the class and field, e.g. ``"EstimatorOptions.lm_max_iter
    must be an integer, got 2.5 (float)"``.
    """
    cls = type(obj).__name__
    for name, (lo, hi) in ints.items():
        object.__setattr__(obj, name, integer(f"{cls}.{name}", getattr(obj, name), minimum=lo, maximum=hi))
    for name, (flo, fhi, positive) in floats.items():
        object.__setattr__(obj, name, real_scalar(f"{cls}.{name}", getattr(obj, name), minimum=flo,
                                                  maximum=fhi, positive=positive))
