"""Validation helpers of :mod:`worldgraph` (private): one place for argument checks.

Every helper takes the ARGUMENT NAME first and raises a :class:`~worldgraph.errors.WorldGraphError`
subclass whose message names the argument, the index of a bad element (where there is one) and
the offending value.  They return the validated value in a canonical form (``float``, ``int``,
a float64 array, a :class:`numpy.random.Generator`).

* :func:`real_array` -- real, finite float64 array of a given shape (``None`` = any length),
  optionally bounded by ``max_abs``; complex, bool, str, None, ragged input rejected.
* :func:`int_array` -- an ``intp`` array of a given shape.
* :func:`real_scalar` -- a finite real scalar (int or float, not bool) as ``float``, with
  ``minimum`` / ``maximum`` (inclusive), ``positive`` (``> 0``) and ``max_abs`` bounds;
  :func:`real_float` -- a real scalar that may be infinite (not NaN), without bounds.
* :func:`integer` -- an integer (Python or numpy int, not bool/float/NaN/None/str) in
  ``[minimum, maximum]``.
* ``worldgraph._rigid.rigid_transform`` -- a (4, 4) rigid transform: finite, last row
  ``0 0 0 1``, rotation orthonormal with determinant +1 (no scale, shear or reflection); apart,
  because its default tolerance lives in :mod:`worldgraph.tolerances`, which uses these checks.
* :func:`generator`, :func:`rng_from_seed` -- a :class:`numpy.random.Generator`, or a seed.
* :func:`name_string` -- a non-empty ``str`` without NUL characters.

:func:`real_array`, :func:`real_scalar`, :func:`integer` and :func:`generator` have the same
signatures, rules and messages as their namesakes in ``perception._checks`` and
``radialopt._checks`` (only the error class differs); ``tests/repo/test_checks_parity.py`` holds
the three to that.
"""

from __future__ import annotations

import math
import numbers
import operator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from perception import Percept

from .errors import (
    WorldGraphError,
)

__all__ = [
    "real_array",
    "generator",
    "int_array",
    "real_float",
    "name_string",
    "real_scalar",
    "rng_from_seed",
    "integer",
]



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
    ``max_abs`` bounds every element's magnitude.  Raises :class:`WorldGraphError`
    for None, str, bool, complex or non-numeric elements, ragged input, a wrong shape, NaN or
    inf, naming the index and value of the first bad element.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise WorldGraphError(f"{name} must be an array of real numbers, got {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise WorldGraphError(f"{name} must be a rectangular array of real numbers, "
                    f"got {_short(value)}") from exc
    if raw.dtype.kind == "b":
        raise WorldGraphError(f"{name} must hold real numbers, not booleans, got {_short(value)}")
    if raw.dtype.kind == "c":
        imaginary = np.argwhere(np.imag(raw) != 0)
        where = _index(tuple(imaginary[0])) if len(imaginary) and raw.ndim else ""
        raise WorldGraphError(f"{name}{where} must be real, got complex values {_short(value)}")
    if raw.dtype.kind not in "iufO":
        raise WorldGraphError(f"{name} must be an array of real numbers, got dtype {raw.dtype} "
                    f"{_short(value)}")
    if raw.dtype.kind == "O":
        for k, item in enumerate(raw.reshape(-1)):
            idx = np.unravel_index(k, raw.shape) if raw.ndim else ()
            if isinstance(item, (bool, np.bool_, complex)) or not isinstance(item, numbers.Real):
                raise WorldGraphError(f"{name}{_index(idx)} must be a real number, got {_short(item)}")
            try:
                float(item)
            except OverflowError as exc:
                raise WorldGraphError(f"{name}{_index(idx)} = {_short(item)} does not fit a float64") from exc
    try:
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise WorldGraphError(f"{name} must hold real numbers representable as float64, "
                    f"got {_short(value)}") from exc
    if ndim is not None and arr.ndim not in ndim:
        raise WorldGraphError(f"{name} must have {' or '.join(map(str, ndim))} dimension(s), "
                    f"got shape {arr.shape}")
    if shape is not None and not _shape_ok(arr.shape, shape):
        like_text = f" like {like}" if like else ""
        raise WorldGraphError(f"{name} must have shape {_shape_text(shape)}{like_text}, "
                    f"got shape {arr.shape}")
    if arr.size < min_size:
        raise WorldGraphError(f"{name} must hold at least {min_size} element(s), got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(np.argwhere(bad)[0]) if arr.ndim else ()
        raise WorldGraphError(f"{name}{_index(idx)} must be finite, got {float(arr[idx])!r}")
    if max_abs is not None:
        over = np.abs(arr) > max_abs
        if over.any():
            idx = tuple(np.argwhere(over)[0]) if arr.ndim else ()
            raise WorldGraphError(f"{name}{_index(idx)} must be <= {max_abs:g} in magnitude, "
                        f"got {float(arr[idx])!r}")
    return arr


def real_scalar(name: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
                positive: bool = False, max_abs: float | None = None) -> float:
    """``value`` (a real number or a 0-d real array; not bool, complex, str or None) as a finite
    Python float: ``> 0`` with ``positive``, in ``[minimum, maximum]`` (inclusive; either may be
    None) and at most ``max_abs`` in magnitude, else :class:`WorldGraphError`.
    """
    if isinstance(value, np.ndarray):
        ok = value.shape == () and value.dtype.kind in "iuf"
    else:
        ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok:
        raise WorldGraphError(f"{name} must be a real number, got {_short(value)} ({type(value).__name__})")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:  # a Python int above ~1.8e308
        raise WorldGraphError(f"{name} = {_short(value)} does not fit a float64") from exc
    if not np.isfinite(x):
        raise WorldGraphError(f"{name} must be finite, got {x!r}")
    if positive and x <= 0:
        raise WorldGraphError(f"{name} must be > 0, got {x!r}")
    if minimum is not None and x < minimum:
        raise WorldGraphError(f"{name} must be >= {minimum:g}, got {x!r}")
    if maximum is not None and x > maximum:
        raise WorldGraphError(f"{name} must be <= {maximum:g}, got {x!r}")
    if max_abs is not None and abs(x) > max_abs:
        raise WorldGraphError(f"{name} must be <= {max_abs:g} in magnitude, got {x!r}")
    return x


def integer(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """``value`` (a Python or numpy integer; not bool, float (even 2.0), None or str) as a Python
    int in ``[minimum, maximum]`` (inclusive; either may be None), else :class:`WorldGraphError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise WorldGraphError(f"{name} must be an integer, got {_short(value)} ({type(value).__name__})")
    n = operator.index(value)
    if minimum is not None and n < minimum:
        raise WorldGraphError(f"{name} must be >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise WorldGraphError(f"{name} must be <= {maximum}, got {n}")
    return n


def generator(name: str, value: Any) -> np.random.Generator:
    """``value`` if it is a :class:`numpy.random.Generator` (seeds, strings and the legacy
    ``RandomState`` are refused), else :class:`WorldGraphError`."""
    if not isinstance(value, np.random.Generator):
        raise WorldGraphError(f"{name} must be a numpy.random.Generator, "
                    f"got {_short(value)} ({type(value).__name__})")
    return value


def _real_scalar(name: str, value: Any) -> float:
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise WorldGraphError(f"{name} must be a real number, got {_short(value)} ({type(value).__name__})")
    try:
        return float(value)
    except OverflowError as exc:  # a Python int above ~1.8e308
        raise WorldGraphError(f"{name} = {_short(value)} does not fit a float64") from exc


def int_array(name: str, value: Any, shape: tuple[int | None, ...] | None = None, *,
              minimum: int | None = None) -> NDArray[np.intp]:
    """``value`` as a new ``intp`` array of ``shape``: integer dtype only (bool, float, str,
    None, complex rejected; an empty sequence is fine), elements ``>= minimum``."""
    if value is None or isinstance(value, str | bytes):
        raise WorldGraphError(f"{name} must be an array of integers, got {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise WorldGraphError(f"{name} must be a rectangular array of integers, got {_short(value)}") from exc
    if raw.size == 0 and raw.dtype.kind in "fO":
        raw = raw.astype(np.intp)
    if raw.dtype.kind not in "iu":
        raise WorldGraphError(f"{name} must hold integers, got dtype {raw.dtype} {_short(value)}")
    info = np.iinfo(np.intp)
    if raw.size and (int(raw.max()) > info.max or int(raw.min()) < info.min):
        raise WorldGraphError(f"{name} holds integers beyond the index range, max {int(raw.max())}")
    arr = np.array(raw, dtype=np.intp)
    if shape is not None and not _shape_ok(arr.shape, shape):
        raise WorldGraphError(f"{name} must have shape {_shape_text(shape)}, got shape {arr.shape}")
    if minimum is not None and arr.size and (arr < minimum).any():
        idx = tuple(np.argwhere(arr < minimum)[0])
        raise WorldGraphError(f"{name}{_index(idx)} must be >= {minimum}, got {int(arr[idx])}")
    return arr


def real_float(name: str, value: Any) -> float:
    """A real scalar as ``float`` that may be infinite but not NaN (bool, complex, str, None rejected)."""
    x = _real_scalar(name, value)
    if math.isnan(x):
        raise WorldGraphError(f"{name} must not be NaN, got {x!r}")
    return x


def rng_from_seed(name: str, value: Any) -> np.random.Generator:
    """A Generator from ``None`` (fresh entropy), a non-negative integer seed or a Generator."""
    if value is None:
        return np.random.default_rng()
    if isinstance(value, np.random.Generator):
        return value
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise WorldGraphError(f"{name} must be None, a non-negative integer seed or a "
                              f"numpy.random.Generator, got {_short(value)}")
    return np.random.default_rng(integer(name, value, minimum=0))


def name_string(name: str, value: Any, error: type[WorldGraphError] = WorldGraphError) -> str:
    """A non-empty ``str`` without NUL characters (``error`` otherwise)."""
    if not isinstance(value, str) or not value:
        raise error(f"{name} must be a non-empty string, got {_short(value)}")
    if "\x00" in value:
        raise error(f"{name} must not contain NUL characters, got {_short(value)}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise error(f"{name} must be valid Unicode text (UTF-8 encodable), got {_short(value)}: {exc.reason} "
                    f"at position {exc.start}") from exc
    return value


#: Longest file path accepted (characters).
MAX_PATH_LENGTH = 4096


def file_path(name: str, value: Any, kinds: str = "a str or os.PathLike") -> str:
    """A file path as ``str``: ``str`` or ``os.PathLike`` of ``str``, non-empty, without NUL,
    UTF-8 encodable, at most :data:`MAX_PATH_LENGTH` characters (:class:`WorldGraphError`)."""
    import os

    if isinstance(value, bytes) or not isinstance(value, str | os.PathLike):
        raise WorldGraphError(f"{name} must be {kinds}, got {_short(value)}")
    text = os.fspath(value)
    if not isinstance(text, str):
        raise WorldGraphError(f"{name} must be a str or os.PathLike of str, got {_short(value)}")
    name_string(name, text)
    if len(text) > MAX_PATH_LENGTH:
        raise WorldGraphError(f"{name} is {len(text)} characters long, more than {MAX_PATH_LENGTH}: "
                              f"{_short(text)}")
    return text


def as_list(name: str, value: Any, what: str, *, exclude: tuple[type, ...] = ()) -> list[Any]:
    """A sequence as a list: not None, a string, bytes, a dict or one of ``exclude`` (a lone
    element); :class:`WorldGraphError` saying it must be a sequence of ``what`` otherwise."""
    if value is None or isinstance(value, (str, bytes, dict, *exclude)):
        raise WorldGraphError(f"{name} must be a sequence of {what}, got {type(value).__name__} "
                              f"{_short(value, 80)}")
    try:
        return list(value)
    except TypeError as exc:
        raise WorldGraphError(f"{name} must be a sequence of {what}, got {type(value).__name__} "
                              f"{_short(value, 80)}") from exc


def percept_list(name: str, value: Any) -> list[Any]:
    """A sequence of :class:`perception.Percept` as a list; :class:`WorldGraphError` naming
    ``name`` (a lone Percept, not a sequence) or ``name[i]`` (an element that is no Percept)."""
    items = as_list(name, value, "perception.Percept", exclude=(Percept,))
    for k, p in enumerate(items):
        if not isinstance(p, Percept):
            raise WorldGraphError(f"{name}[{k}] must be a perception.Percept, "
                                  f"got {type(p).__name__} {_short(p, 80)}")
    return items
