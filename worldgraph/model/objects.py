"""The objects of a world model: :class:`ObjectModel` (one landmark), :class:`ObjectTable` (many,
in arrays), :func:`box_vertices`, and the checks of their values (type names, sizes, rotations,
ids) with the limits :data:`DEFAULT_SIZE` and :data:`MAX_COORDINATE`."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.head.chain import rotation_defect, rotation_errors

from .. import _checks, _rigid
from ..errors import (
    WorldGraphError,
)
from ..tolerances import RIGID_TOLERANCE

#: Bounding-box extents (metres) given to objects built from bare positions.
DEFAULT_SIZE = 0.05
#: Largest allowed ``|coordinate|`` (metres) of an object position, a box size, a class-geometry
#: vertex or a room corner: beyond it squared distances lose every digit (and overflow past 1e154).
MAX_COORDINATE = 1e6
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def box_vertices(size: ArrayLike) -> NDArray[np.float64]:
    """The 8 corners ``(8, 3)`` of an axis-aligned box of extents ``size (3,)`` (metres, finite,
    ``>= 0``, at most :data:`~worldgraph.model.MAX_COORDINATE`) centred at 0."""
    half = 0.5 * _check_size("size", size)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    return signs * half


def _check_size(name: str, value: Any) -> NDArray[np.float64]:
    """A box size ``(3,)`` in metres: finite, ``>= 0``, at most :data:`MAX_COORDINATE`."""
    size = _checks.real_array(name, value, (3,), max_abs=MAX_COORDINATE)
    if (size < 0).any():
        k = int(np.argmax(size < 0))
        raise WorldGraphError(f"{name}[{k}] must be >= 0, got {float(size[k])!r}")
    return size


def _check_rotations(name: str, rot: NDArray[np.float64]) -> None:
    """Raise :class:`~worldgraph.errors.WorldGraphError` naming the first rotation of a finite stack
    ``(n, 3, 3)`` that is not proper within :data:`~worldgraph.tolerances.RIGID_TOLERANCE`."""
    bad = rotation_errors(rot, RIGID_TOLERANCE)[2]
    if bad.any():
        k = int(np.argmax(bad))
        raise WorldGraphError(f"{name}[{k}] must be a rotation (R^T R = I, det R = +1), but it "
                              f"{rotation_defect(rot[k], RIGID_TOLERANCE)}")


def _check_unique_ids(ids: list[str], what: str) -> None:
    """Raise naming the first repeated id and both of its indices."""
    first: dict[str, int] = {}
    for k, x in enumerate(ids):
        if x in first:
            raise WorldGraphError(f"ids must be unique: {x!r} appears more than once, at {what}[{first[x]}] "
                                  f"and {what}[{k}]")
        first[x] = k


def _name_list(name: str, value: Any, n: int) -> list[str]:
    """``n`` names (non-empty ``str`` without NUL) from a sequence or array; one ``str`` is a list of one."""
    if isinstance(value, str):
        value = [value]
    if value is None or isinstance(value, bytes | Mapping) or not isinstance(value, Iterable):
        raise WorldGraphError(f"{name} must be a sequence of {n} strings, got {_checks._short(value)}")
    items = value.reshape(-1).tolist() if isinstance(value, np.ndarray) else list(value)
    if len(items) != n:
        raise WorldGraphError(f"{name} must have length {n} to match positions of shape ({n}, 3), "
                              f"got length {len(items)}")
    return [str(_checks.name_string(f"{name}[{k}]", x)) for k, x in enumerate(items)]


def _check_type_name(value: Any, what: str) -> str:
    """A type name: a non-empty ``str`` without NUL characters (numpy string arrays would drop
    trailing NULs and merge types)."""
    return _checks.name_string(what, value)


def _object_index(index: ArrayLike, n: int, minimum: int) -> NDArray[np.intp]:
    """``index`` as an int array of object indices ``minimum <= k < n`` (errors name the entry)."""
    idx = _checks.int_array("index", index, (None,), minimum=minimum)
    if idx.size and int(idx.max()) >= n:
        k = int(np.argmax(idx >= n))
        raise WorldGraphError(f"index[{k}] = {int(idx[k])} must be < the number of objects, {n}")
    return idx


# ----------------------------------------------------------------------------------------------
# objects
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ObjectModel:
    """One landmark of the world model.

    Parameters
    ----------
    id : str
        Unique name (e.g. the scene-graph node name).
    type : str
        Landmark class (``"door"``, ``"handle"``, ``"knob"``, ...); associations match types.
    pose : (4, 4) float
        ``world_from_object``, rigid (rotation orthonormal with determinant +1 within 1e-6, last
        row ``0 0 0 1``: scaled, sheared or reflected poses raise
        :class:`~worldgraph.errors.WorldGraphError`); its origin (metres, ``|x| <=``
        :data:`MAX_COORDINATE`) is the centre of the object's bounding box.
    size : (3,) float
        Extents (metres) of the bounding box along the object axes, ``>= 0``, at most
        :data:`MAX_COORDINATE`.
    geometry : str
        Key of the class geometry in :attr:`WorldModel.class_vertices` (e.g. ``"box"``).

    ``id``, ``type`` and ``geometry`` are non-empty strings without NUL characters.
    """

    id: str
    type: str
    pose: NDArray[np.float64]
    size: NDArray[np.float64]
    geometry: str = "box"

    def __post_init__(self) -> None:
        _checks.name_string("ObjectModel.id", self.id)
        _check_type_name(self.type, f"ObjectModel {self.id!r} type")
        _checks.name_string(f"ObjectModel {self.id!r} geometry", self.geometry)
        pose = _rigid.rigid_transform(f"ObjectModel {self.id!r} pose", self.pose,
                                       max_translation=MAX_COORDINATE)
        pose[3] = _LAST_ROW
        size = _check_size(f"ObjectModel {self.id!r} size", self.size)
        pose.setflags(write=False)
        size.setflags(write=False)
        object.__setattr__(self, "pose", pose)
        object.__setattr__(self, "size", size)

    @classmethod
    def _trusted(cls, id: str, type: str, pose: NDArray[np.float64], size: NDArray[np.float64],
                 geometry: str) -> ObjectModel:
        """Build without validation from read-only float64 arrays the caller has checked."""
        obj = object.__new__(cls)
        fields = {"id": id, "type": type, "pose": pose, "size": size, "geometry": geometry}
        for name, value in fields.items():
            object.__setattr__(obj, name, value)
        return obj

    @property
    def position(self) -> NDArray[np.float64]:
        """Centre of the bounding box in the world frame, ``(3,)``."""
        return self.pose[:3, 3]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ObjectModel):
            return NotImplemented
        return (self.id == other.id and self.type == other.type and self.geometry == other.geometry
                and np.array_equal(self.pose, other.pose) and np.array_equal(self.size, other.size))

    __hash__ = None  # type: ignore[assignment]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the ``objects`` entries of the file format)."""
        return {"id": self.id, "type": self.type, "pose": self.pose.tolist(), "size": self.size.tolist(),
                "geometry": self.geometry}


class ObjectTable(Sequence[ObjectModel]):
    """The objects of a world as arrays, without a Python object per landmark.

    What :meth:`WorldModel.from_arrays` (and so the building and campus scenes) stores: typed
    boxes with the identity rotation whose geometry key is their type; and what
    :meth:`WorldModel.from_trimesh` (and so :meth:`WorldModel.from_file`) stores: boxes with
    their node rotations and geometry keys.  Indexing makes the :class:`ObjectModel` on demand
    (``table[k]``); iterating makes them all, so hot paths read :attr:`codes`,
    :attr:`positions` and :attr:`sizes` instead.  An ``ObjectTable`` equals any sequence of the
    same objects.

    Parameters
    ----------
    type_names : sequence of str
        The distinct types, sorted; non-empty strings without NUL characters.
    codes : (n,) int
        ``type_names[codes[k]]`` is object ``k``'s type.
    positions, sizes : (n, 3) float
        Box centres (metres, ``|x| <=`` :data:`MAX_COORDINATE`) and extents (``>= 0``).
    ids : sequence of str, optional
        Unique object ids; default ``f"{type}_{number}"`` with ``number`` from ``numbers``.
    numbers : (n,) int, optional
        Distinct non-negative numbers of the default ids (default ``0 .. n-1``); ignored when
        ``ids`` is given.
    rotations : (n, 3, 3) float, optional
        ``world_from_object`` rotations (proper: ``R^T R = I`` and ``det R = 1`` within
        :data:`~worldgraph.tolerances.RIGID_TOLERANCE`); default the identity for every
        object (then :attr:`rotations` is ``None``).
    geometries : (n,) str, optional
        Geometry keys (non-empty strings without NUL); default each object's type.

    Attributes
    ----------
    rotations : (n, 3, 3) float ndarray or None
        ``None`` when every rotation is the identity.
    geometry_names : tuple of str or None
        The distinct geometry keys, sorted, with :attr:`geometry_codes` ``(n,)`` indexing them;
        both ``None`` when every object's geometry key is its type.
    """

    __slots__ = ("type_names", "codes", "positions", "sizes", "_ids", "_numbers", "rotations",
                 "geometry_names", "geometry_codes")
    type_names: tuple[str, ...]
    codes: NDArray[np.integer]
    positions: NDArray[np.float64]
    sizes: NDArray[np.float64]
    _ids: tuple[str, ...] | None
    _numbers: NDArray[np.int64] | None
    rotations: NDArray[np.float64] | None
    geometry_names: tuple[str, ...] | None
    geometry_codes: NDArray[np.integer] | None

    def __init__(self, type_names: Sequence[str], codes: ArrayLike, positions: ArrayLike, sizes: ArrayLike,
                 ids: Sequence[str] | None = None, numbers: ArrayLike | None = None, *,
                 rotations: ArrayLike | None = None, geometries: Sequence[str] | None = None) -> None:
        if isinstance(type_names, str | bytes) or not isinstance(type_names, Sequence):
            raise WorldGraphError(f"type_names must be a sequence of str, got {_checks._short(type_names)}")
        names = tuple(type_names)
        for k, t in enumerate(names):
            _check_type_name(t, f"type_names[{k}]")
        if list(names) != sorted(set(names)):
            raise WorldGraphError(f"type_names must be sorted and distinct, got {_checks._short(names)}")
        c = _checks.int_array("codes", codes, (None,), minimum=0)
        n = len(c)
        if n and int(c.max()) >= len(names):
            k = int(np.argmax(c >= len(names)))
            raise WorldGraphError(f"codes[{k}] = {int(c[k])} must be < len(type_names) = {len(names)}")
        pos = _checks.real_array("positions", positions, (n, 3), max_abs=MAX_COORDINATE)
        sz = _checks.real_array("sizes", sizes, (n, 3), max_abs=MAX_COORDINATE)
        if np.any(sz < 0):
            bad = np.argwhere(sz < 0)[0]
            raise WorldGraphError(f"sizes[{bad[0]}, {bad[1]}] must be >= 0, got {float(sz[tuple(bad)])!r}")
        id_list: tuple[str, ...] | None = None
        num = None
        if ids is not None:
            id_list = tuple(_name_list("ids", ids, n))
            _check_unique_ids(list(id_list), "ids")
        elif numbers is not None:
            num = _checks.int_array("numbers", numbers, (n,), minimum=0)
            if len(np.unique(num)) != n:
                first = np.unique(num, return_index=True)[1]
                k = int(np.setdiff1d(np.arange(n), first)[0])
                raise WorldGraphError(f"numbers[{k}] = {int(num[k])} repeats an earlier number")
        rot = None
        if rotations is not None:
            rot = _checks.real_array("rotations", rotations, (n, 3, 3))
            _check_rotations("rotations", rot)
        geometry_names, geometry_codes = None, None
        if geometries is not None:
            keys = _name_list("geometries", geometries, n)
            uniq, inverse = np.unique(np.array(keys, dtype=object), return_inverse=True)
            geometry_names, geometry_codes = tuple(str(g) for g in uniq), inverse.reshape(-1)
        self._set(names, c, pos, sz, id_list, num, rot, geometry_names, geometry_codes)

    def _set(self, names: tuple[str, ...], codes: NDArray[np.integer], positions: NDArray[np.float64],
             sizes: NDArray[np.float64], ids: tuple[str, ...] | None,
             numbers: NDArray[np.integer] | None, rotations: NDArray[np.float64] | None = None,
             geometry_names: tuple[str, ...] | None = None,
             geometry_codes: NDArray[np.integer] | None = None) -> None:
        codes = np.asarray(codes, dtype=np.int32 if len(names) < 2**31 else np.int64)
        if ids is None and numbers is None:
            numbers = np.arange(len(codes), dtype=np.int64)
        if rotations is not None and np.array_equal(rotations, np.broadcast_to(np.eye(3), rotations.shape)):
            rotations = None  # identity everywhere: as from_arrays stores it
        if geometry_names is not None:
            assert geometry_codes is not None  # set together
            geometry_codes = np.asarray(geometry_codes, dtype=np.int32 if len(geometry_names) < 2**31
                                        else np.int64)
            if geometry_names == names and np.array_equal(geometry_codes, codes):
                geometry_names, geometry_codes = None, None  # every geometry key is the type
        optional = (numbers, rotations, geometry_codes)
        arrays = [codes, positions, sizes] + [a for a in optional if a is not None]
        for a in arrays:
            a.setflags(write=False)
        for name, value in (("type_names", names), ("codes", codes), ("positions", positions),
                            ("sizes", sizes), ("_ids", ids), ("_numbers", numbers), ("rotations", rotations),
                            ("geometry_names", geometry_names), ("geometry_codes", geometry_codes)):
            object.__setattr__(self, name, value)

    @classmethod
    def _trusted(cls, names: tuple[str, ...], codes: NDArray[np.integer], positions: NDArray[np.float64],
                 sizes: NDArray[np.float64], ids: tuple[str, ...] | None = None,
                 numbers: NDArray[np.integer] | None = None, rotations: NDArray[np.float64] | None = None,
                 geometry_names: tuple[str, ...] | None = None,
                 geometry_codes: NDArray[np.integer] | None = None) -> ObjectTable:
        """Build without validation from arrays the caller has checked (copies are not made)."""
        table = object.__new__(cls)
        table._set(names, codes, np.asarray(positions, dtype=np.float64), np.asarray(sizes, dtype=np.float64),
                   ids, None if numbers is None else np.asarray(numbers, dtype=np.int64),
                   None if rotations is None else np.asarray(rotations, dtype=np.float64),
                   geometry_names, geometry_codes)
        return table

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"ObjectTable is read-only: cannot set {name!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        # pickling (tiles sent to processes or a Dask cluster): rebuilt by _trusted, not setattr
        return (ObjectTable._trusted, (self.type_names, self.codes, self.positions, self.sizes, self._ids,
                                       self._numbers, self.rotations, self.geometry_names,
                                       self.geometry_codes))

    def __len__(self) -> int:
        return len(self.codes)

    def id(self, k: int) -> str:
        """The id of object ``k``."""
        if self._ids is not None:
            return self._ids[k]
        assert self._numbers is not None  # one of the two is always set
        return f"{self.type_names[int(self.codes[k])]}_{int(self._numbers[k])}"

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, slice):
            return self.take(np.arange(len(self))[key])
        try:
            k = int(key.__index__())
        except (AttributeError, TypeError):
            raise WorldGraphError(f"an ObjectTable index must be an int or a slice, "
                                  f"got {_checks._short(key)}") from None
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"object index {k} out of range for {n} objects")
        k %= n
        pose = np.eye(4)
        if self.rotations is not None:
            pose[:3, :3] = self.rotations[k]
        pose[:3, 3] = self.positions[k]
        pose.setflags(write=False)
        size = self.sizes[k].copy()
        size.setflags(write=False)
        t = self.type_names[int(self.codes[k])]
        return ObjectModel._trusted(self.id(k), t, pose, size, self._geometry(k))

    def _geometry(self, k: int) -> str:
        if self.geometry_names is None:
            return self.type_names[int(self.codes[k])]
        assert self.geometry_codes is not None  # set together
        return self.geometry_names[int(self.geometry_codes[k])]

    def take(self, index: ArrayLike) -> ObjectTable:
        """The objects at ``index`` (an int array, in that order) as a new table; ids kept."""
        n = len(self)
        idx = _object_index(index, n, -n) % max(n, 1)
        ids = None if self._ids is None else tuple(self._ids[k] for k in idx.tolist())
        numbers = None if self._numbers is None else self._numbers[idx]
        rotations = None if self.rotations is None else self.rotations[idx]
        gcodes = None if self.geometry_codes is None else self.geometry_codes[idx]
        return ObjectTable._trusted(self.type_names, self.codes[idx], self.positions[idx], self.sizes[idx],
                                    ids, numbers, rotations, self.geometry_names, gcodes)

    @property
    def types(self) -> NDArray[np.str_]:
        """``(n,)`` the objects' types."""
        return np.asarray(self.type_names, dtype=str)[self.codes]

    @property
    def geometries(self) -> NDArray[np.str_]:
        """``(n,)`` the objects' geometry keys."""
        if self.geometry_names is None:
            return self.types
        return np.asarray(self.geometry_names, dtype=str)[self.geometry_codes]

    def rotation_array(self) -> NDArray[np.float64]:
        """``(n, 3, 3)`` the objects' rotations (a new array; identities when :attr:`rotations`
        is ``None``)."""
        if self.rotations is None:
            return np.tile(np.eye(3), (len(self), 1, 1))
        return self.rotations.copy()

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ObjectTable):
            if (len(self) != len(other) or not np.array_equal(self.positions, other.positions)
                    or not np.array_equal(self.sizes, other.sizes)
                    or not np.array_equal(self.types, other.types)
                    or not np.array_equal(self.geometries, other.geometries)):
                return False
            if (self.rotations is not None or other.rotations is not None) \
                    and not np.array_equal(self.rotation_array(), other.rotation_array()):
                return False
            if self._ids is None and other._ids is None and self._numbers is not None \
                    and other._numbers is not None:
                return bool(np.array_equal(self._numbers, other._numbers))
            return all(self.id(k) == other.id(k) for k in range(len(self)))
        if isinstance(other, Sequence) and not isinstance(other, str | bytes):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"ObjectTable({len(self)} objects of {len(self.type_names)} types)"
