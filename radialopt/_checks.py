"""Input validation shared by every public entry point of :mod:`radialopt` (one copy).

Each helper converts a value, checks type, shape, finiteness and range, and raises a
:class:`~radialopt.errors.RadialError` subclass whose message names the argument, the index of
the first bad element and its value, e.g. ``"sigmas[2] = 1e-300 is below ..."``.

* :func:`real_array`, :func:`point3` -- finite float64 arrays, bounded by :data:`MAX_LENGTH`.
* :func:`real_scalar` -- a finite real scalar as ``float``: ``minimum`` / ``maximum``
  (inclusive), ``positive`` (``> 0``), ``max_abs``.
* :func:`integer` -- an int (not bool or float) in ``[minimum, maximum]``.
* :func:`sigma_range`, :func:`instance`, :func:`dataclass_fields` (options dataclasses).
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


def _index(idx: tuple[int | np.integer, ...]) -> str:
    return "[" + ", ".join(str(int(i)) for i in idx) + "]" if idx else ""


def real_array(name: str, value: Any, shape: tuple[int | str | None, ...] | None = None,
               ndim: tuple[int, ...] | None = None, max_abs: float | None = MAX_LENGTH,
               like: str = "") -> NDArray[np.float64]:
    """``value`` as a float64 array of real, finite numbers.

    ``shape`` may hold None (shown as ``n``) or a label such as ``"k"`` for any length;
    ``like`` names the argument the expected shape comes from (for the message).
    ``ndim`` lists accepted dimension counts.  Bools, complex numbers, strings, None, ragged
    sequences, NaN, infinities and magnitudes above ``max_abs`` raise :class:`RadialError`.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise RadialArgumentError(f"{name} must be an array of real numbers, got {value!r}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise RadialArgumentError(f"{name} must be an array of real numbers, got {value!r:.200}") from exc
    if raw.dtype.kind == "b":
        raise RadialArgumentError(f"{name} must hold real numbers, not booleans, got {raw.tolist()!r:.200}")
    if raw.dtype.kind == "c":
        bad = np.argwhere(np.imag(raw) != 0)
        where = _index(tuple(bad[0])) if len(bad) else ""
        raise RadialArgumentError(f"{name}{where} must be real, got complex values {raw.tolist()!r:.200}")
    if raw.dtype.kind not in "iuf":
        if raw.dtype.kind == "O":
            flat = list(raw.reshape(-1))
            for k, v in enumerate(flat):
                if isinstance(v, (bool, np.bool_, complex, str, bytes)) or v is None or \
                        not isinstance(v, numbers.Real):
                    where = _index(np.unravel_index(k, raw.shape)) if raw.ndim else ""
                    raise RadialArgumentError(f"{name}{where} must be a real number, got {v!r:.100}")
        else:
            raise RadialArgumentError(f"{name} must be an array of real numbers, got dtype {raw.dtype} "
                                      f"({value!r:.200})")
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise RadialArgumentError(f"{name} must be an array of real numbers, got {value!r:.200}") from exc
    if ndim is not None and arr.ndim not in ndim:
        raise RadialArgumentError(f"{name} must have {' or '.join(map(str, ndim))} dimension(s), got shape "
                                  f"{arr.shape}")
    if shape is not None and (arr.ndim != len(shape) or any(
            isinstance(want, int) and got != want for got, want in zip(arr.shape, shape, strict=True))):
        want_s = "(" + ", ".join("n" if w is None else str(w) for w in shape) + ("," if len(shape) == 1
                                                                                  else "") + ")"
        raise RadialArgumentError(f"{name} must have shape {want_s}{f' like {like}' if like else ''}, "
                                  f"got shape {arr.shape}")
    finite = np.isfinite(arr)
    if not np.all(finite):
        idx = tuple(np.argwhere(~finite)[0])
        raise RadialArgumentError(f"{name}{_index(idx)} = {float(arr[idx])!r} must be finite")
    if max_abs is not None and arr.size and float(np.max(np.abs(arr))) > max_abs:
        idx = tuple(np.argwhere(np.abs(arr) > max_abs)[0])
        raise RadialArgumentError(f"{name}{_index(idx)} = {arr[idx]:.6g} exceeds the usable magnitude "
                                  f"{max_abs:g} (metres)")
    return arr


def real_scalar(name: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
                positive: bool = False, max_abs: float | None = None) -> float:
    """``value`` as a finite Python float: ``> 0`` with ``positive``, in ``[minimum, maximum]``
    (either bound may be None) and at most ``max_abs`` in magnitude."""
    if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, (str, bytes, complex)) \
            or not isinstance(value, (numbers.Real, np.ndarray)):
        raise RadialArgumentError(f"{name} must be a real number, got {value!r:.100}")
    if isinstance(value, np.ndarray):
        if value.shape != () or value.dtype.kind not in "iuf":
            raise RadialArgumentError(f"{name} must be a real number, got {value!r:.100}")
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise RadialArgumentError(f"{name} must be a real number representable as a float, got "
                                  f"{value!r:.100}") from exc
    if not np.isfinite(out):
        raise RadialArgumentError(f"{name} = {out!r} must be finite")
    if positive and out <= 0:
        raise RadialArgumentError(f"{name} = {out!r} must be > 0")
    if minimum is not None and out < minimum:
        raise RadialArgumentError(f"{name} = {out!r} must be >= {minimum:g}")
    if maximum is not None and out > maximum:
        raise RadialArgumentError(f"{name} = {out!r} must be <= {maximum:g}")
    if max_abs is not None and abs(out) > max_abs:
        raise RadialArgumentError(f"{name} = {out:.6g} exceeds the usable magnitude {max_abs:g}")
    return out


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` as a Python int in ``[minimum, maximum]``; bools, floats (even 3.0), None, str rejected."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise RadialArgumentError(f"{name} must be an integer, got {value!r:.100} ({type(value).__name__})")
    out = operator.index(value)
    if minimum is not None and out < minimum:
        raise RadialArgumentError(f"{name} = {out!r} must be >= {minimum}")
    if maximum is not None and out > maximum:
        raise RadialArgumentError(f"{name} = {out!r} must be <= {maximum}")
    return out


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
    """``value`` if it is an instance of ``cls``, else a :class:`RadialError` naming both."""
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
