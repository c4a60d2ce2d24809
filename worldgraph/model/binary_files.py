"""The binary world-model file (``.npz``): :meth:`WorldModel.save <worldgraph.model.WorldModel.save>`
writes it for a path ending in ``.npz``, :meth:`WorldModel.load <worldgraph.model.WorldModel.load>`
reads it whatever the name (the file's first bytes tell it from JSON).  The entries are listed in
:mod:`worldgraph.model` next to the JSON format.

Why a numpy ``.npz`` archive and not Parquet: numpy is already a dependency (Parquet would add
pyarrow), the world is numpy arrays in and numpy arrays out (no conversion of the ``(n, 3, 3)``
rotations to list columns and back), and an uncompressed archive is read by ``np.load`` at disk
speed.  The archive is read with ``allow_pickle=False`` only: an object array inside it (a
pickle) is refused, never unpickled.

Strings (ids, type names, geometry keys) are stored as one UTF-8 byte array each, the strings
joined by NUL (which no name may hold): 1M ids decode with one ``bytes.decode`` and one
``str.split``, where a numpy unicode array would make a Python string per element through
``tolist`` and hold 4 bytes per character.  Worlds whose ids are the default ``f"{type}_{k}"``
(what :meth:`WorldModel.from_arrays` and the scenes build) store only the numbers ``k``.

Every entry is checked on load with vectorised tests (dtype, shape, finite, within
:data:`~worldgraph.model.objects.MAX_COORDINATE`, rotations proper, codes in range, ids unique
and non-empty); every problem is a :class:`~worldgraph.errors.MalformedFileError` naming the
file and the problem.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from perception.head.chain import rotation_defect, rotation_errors

from .. import _checks
from ..errors import MalformedFileError, WorldGraphError
from ..tolerances import RIGID_TOLERANCE
from .objects import MAX_COORDINATE, ObjectModel, ObjectTable

#: ``format`` entry of a binary world file.
BINARY_FORMAT = "worldgraph.WorldModel.npz"
#: ``version`` entry of a binary world file this reader reads.
BINARY_VERSION = 1
#: The first bytes of a zip archive (an ``.npz`` file); JSON text never starts with them.
ZIP_MAGIC = b"PK\x03\x04"

_REQUIRED = ("format", "version", "max_link_length", "link_margin", "gravity_aligned", "type_names",
             "codes", "positions", "sizes", "class_vertex_keys", "class_vertex_offsets", "class_vertices")
_OPTIONAL = ("ids", "id_numbers", "rotations", "geometry_names", "geometry_codes", "room", "link_i", "link_j",
             "link_length")


def is_binary_file(path: str) -> bool:
    """Whether the file at ``path`` starts with the zip magic bytes (``OSError`` if unreadable)."""
    with open(path, "rb") as fh:
        return fh.read(len(ZIP_MAGIC)) == ZIP_MAGIC


def _join(names: Any) -> NDArray[np.uint8]:
    """Names joined by NUL as UTF-8 bytes (``uint8``)."""
    return np.frombuffer("\x00".join(names).encode("utf-8"), dtype=np.uint8)


def world_arrays(world: Any) -> dict[str, NDArray[Any]]:
    """The entries of the binary file of ``world`` (a :class:`~worldgraph.model.WorldModel`)."""
    objects = world.objects
    out: dict[str, NDArray[Any]] = {
        "format": np.array(BINARY_FORMAT),
        "version": np.array(BINARY_VERSION, dtype=np.int64),
        "max_link_length": np.array(world.max_link_length, dtype=np.float64),
        "link_margin": np.array(world.link_margin, dtype=np.float64),
        "gravity_aligned": np.array(world.gravity_aligned, dtype=np.bool_),
    }
    if isinstance(objects, ObjectTable):
        names: tuple[str, ...] = objects.type_names
        codes = objects.codes
        positions, sizes, rotations = objects.positions, objects.sizes, objects.rotations
        gnames, gcodes = objects.geometry_names, objects.geometry_codes
        if objects._ids is not None:
            out["ids"] = _join(objects._ids)
        else:
            assert objects._numbers is not None  # one of the two is always set
            out["id_numbers"] = objects._numbers
    else:
        objs: tuple[ObjectModel, ...] = tuple(objects)
        uniq, inverse = np.unique(np.array([o.type for o in objs], dtype=object), return_inverse=True)
        names, codes = tuple(str(t) for t in uniq), inverse.reshape(-1)
        poses = np.array([o.pose for o in objs], dtype=np.float64).reshape(-1, 4, 4)
        positions, sizes = poses[:, :3, 3], np.array([o.size for o in objs], dtype=np.float64).reshape(-1, 3)
        rotations = poses[:, :3, :3]
        guniq, ginverse = np.unique(np.array([o.geometry for o in objs], dtype=object), return_inverse=True)
        gnames, gcodes = tuple(str(g) for g in guniq), ginverse.reshape(-1)
        out["ids"] = _join(o.id for o in objs)
    out["type_names"] = _join(names)
    out["codes"] = np.ascontiguousarray(codes, dtype=np.int32)
    out["positions"] = np.ascontiguousarray(positions, dtype=np.float64)
    out["sizes"] = np.ascontiguousarray(sizes, dtype=np.float64)
    if rotations is not None and not np.array_equal(rotations, np.broadcast_to(np.eye(3), rotations.shape)):
        out["rotations"] = np.ascontiguousarray(rotations, dtype=np.float64)
    if gnames is not None and gcodes is not None:
        out["geometry_names"] = _join(gnames)
        out["geometry_codes"] = np.ascontiguousarray(gcodes, dtype=np.int32)
    cv: Mapping[str, NDArray[np.float64]] = world.class_vertices
    keys = list(cv)
    out["class_vertex_keys"] = _join(keys)
    counts = [len(cv[k]) for k in keys]
    out["class_vertex_offsets"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    out["class_vertices"] = (np.concatenate([cv[k] for k in keys]).astype(np.float64) if keys
                             else np.zeros((0, 3)))
    if world.room is not None:
        out["room"] = np.array([world.room.lower, world.room.upper], dtype=np.float64)
    links = world._links  # every link table's rows, in the tables' order
    # as int64, the dtype the tables hold (int32 rows halve them on disk, but converting them on
    # load costs more than reading twice the bytes)
    out["link_i"] = links._pi.astype(np.int64, copy=False)
    out["link_j"] = links._pj.astype(np.int64, copy=False)
    out["link_length"] = links._length
    return out


def save_binary(world: Any, path: str) -> None:
    """Write ``world`` as an uncompressed ``.npz`` archive at ``path`` (the name is kept as given)."""
    write_entries(path, world_arrays(world))


def write_entries(path: str, arrays: Mapping[str, NDArray[Any]]) -> None:
    """Write ``arrays`` as an uncompressed ``.npz`` archive at ``path`` (the name kept as given);
    a path that cannot be written raises :class:`~worldgraph.errors.WorldGraphError` naming it."""
    try:
        with open(path, "wb") as fh:  # a file object: np.savez does not append ".npz" to it
            np.savez(fh, **cast(dict[str, Any], dict(arrays)))  # (typed: allow_pickle shares the keywords)
    except OSError as exc:
        raise WorldGraphError(f"{path}: cannot write: {exc}") from exc


# ----------------------------------------------------------------------------------------------
# reading
# ----------------------------------------------------------------------------------------------
def read_entries(path: str, extra: tuple[str, ...] = ()) -> dict[str, NDArray[Any]]:
    """Every entry of the archive as an array, read by ``np.load`` with ``allow_pickle=False``
    (which checks each member's CRC-32 and refuses object arrays), or :class:`MalformedFileError`;
    ``extra`` names entries a file that builds on the world file may add (a tile file's)."""
    def bad(msg: str) -> MalformedFileError:
        return MalformedFileError(f"{path}: {msg}")

    try:
        with open(path, "rb") as fh:
            if fh.read(len(ZIP_MAGIC)) != ZIP_MAGIC:  # np.load would read it as .npy or a pickle
                raise bad("not a readable .npz archive (truncated or corrupt?): no zip magic bytes")
            fh.seek(0)
            with np.load(fh, allow_pickle=False) as data:
                names = list(data.files)
                for key in _REQUIRED:
                    if key not in names:
                        raise bad(f"missing entry {key!r} (a binary world file holds {list(_REQUIRED)})")
                unknown = sorted(set(names) - set(_REQUIRED) - set(_OPTIONAL) - set(extra))
                if unknown:
                    raise bad(f"unknown entries {unknown[:10]}")
                return {key: data[key] for key in names}
    except MalformedFileError:
        raise
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise bad(f"holds an object array (a pickle), which is never loaded: {exc}") from exc
        raise bad(f"not a readable .npz archive: {exc}") from exc
    except (zipfile.BadZipFile, EOFError, KeyError, UnicodeDecodeError) as exc:
        raise bad(f"not a readable .npz archive (truncated or corrupt?): "
                  f"{type(exc).__name__}: {exc}") from exc
    except OSError as exc:
        raise bad(f"cannot read: {exc}") from exc


def _array(data: Mapping[str, NDArray[Any]], key: str, kinds: str, shape: tuple[int | None, ...],
           bad: Any) -> NDArray[Any]:
    """Entry ``key`` checked for a dtype kind (``"f"``, ``"i"``, ``"u"``, ``"b"``, ``"U"``) and
    shape (``None``: any length)."""
    a = data[key]
    if a.dtype.kind not in kinds or a.dtype.hasobject:
        raise bad(f"entry {key!r} must have a dtype of kind {kinds!r}, got {a.dtype}")
    if a.ndim != len(shape) or any(w is not None and s != w for s, w in zip(a.shape, shape, strict=True)):
        want = ("(" + ", ".join("k" if w is None else str(w) for w in shape)
                + ("," if len(shape) == 1 else "") + ")")
        raise bad(f"entry {key!r} must have shape {want}, got {a.shape}")
    if a.dtype.kind == "f":
        a = a.astype(np.float64, copy=False)
        if not np.isfinite(a).all():
            k = np.unravel_index(int(np.argmax(~np.isfinite(a))), a.shape)
            raise bad(f"entry {key!r} holds a non-finite value at {tuple(int(x) for x in k)}: "
                      f"{float(a[k])!r}")
    return a


def _coordinates(data: Mapping[str, NDArray[Any]], key: str, shape: tuple[int | None, ...],
                 bad: Any) -> NDArray[np.float64]:
    a = _array(data, key, "f", shape, bad)
    if a.size and float(np.abs(a).max()) > MAX_COORDINATE:
        k = np.unravel_index(int(np.argmax(np.abs(a))), a.shape)
        raise bad(f"entry {key!r} at {tuple(int(x) for x in k)} is {float(a[k])!r}, beyond "
                  f"MAX_COORDINATE = {MAX_COORDINATE:g} m")
    return a


def _names(data: Mapping[str, NDArray[Any]], key: str, bad: Any, count: int | None = None) -> list[str]:
    """A NUL-joined UTF-8 entry as a list of non-empty names (``count`` of them when given)."""
    raw = _array(data, key, "u", (None,), bad)
    if raw.dtype != np.uint8:
        raise bad(f"entry {key!r} must be uint8 (UTF-8 text), got {raw.dtype}")
    try:
        text = raw.tobytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise bad(f"entry {key!r} is not UTF-8 text: {exc}") from exc
    names = text.split("\x00") if text else []
    if count is not None and len(names) != count:
        raise bad(f"entry {key!r} must hold {count} names, got {len(names)}")
    if "" in names:
        raise bad(f"entry {key!r} holds an empty name at index {names.index('')}")
    return names


def _codes(data: Mapping[str, NDArray[Any]], key: str, n: int, size: int, bad: Any) -> NDArray[np.int32]:
    codes = _array(data, key, "iu", (n,), bad)
    if n and (int(codes.min()) < 0 or int(codes.max()) >= size):
        k = int(np.argmax((codes < 0) | (codes >= size)))
        raise bad(f"entry {key!r}[{k}] = {int(codes[k])} must be in 0..{size - 1}")
    return codes.astype(np.int32, copy=False)


def _sorted_names(data: Mapping[str, NDArray[Any]], key: str, bad: Any) -> tuple[str, ...]:
    names = _names(data, key, bad)
    if names != sorted(set(names)):
        raise bad(f"entry {key!r} must hold sorted distinct names, got {_checks._short(names)}")
    return tuple(names)


def _scalar(data: Mapping[str, NDArray[Any]], key: str, kinds: str, bad: Any) -> Any:
    return _array(data, key, kinds, (), bad).item()


def load_binary(cls: Any, path: str, data: Mapping[str, NDArray[Any]] | None = None) -> Any:
    """Read a binary world file written by :func:`save_binary`; ``cls`` is the
    :class:`~worldgraph.model.WorldModel` class (or subclass) to build; ``data`` the file's
    entries when the caller has read them (:func:`read_entries`)."""
    def bad(msg: str) -> MalformedFileError:
        return MalformedFileError(f"{path}: {msg}")

    if data is None:
        data = read_entries(path)
    fmt = _array(data, "format", "U", (), bad).item()
    if fmt != BINARY_FORMAT:
        raise bad(f"format must be {BINARY_FORMAT!r}, got {_checks._short(fmt)}")
    version = _scalar(data, "version", "iu", bad)
    if version != BINARY_VERSION:
        raise bad(f"unsupported version {version!r}, this reader reads version {BINARY_VERSION}")
    mll = _scalar(data, "max_link_length", "f", bad)
    margin = _scalar(data, "link_margin", "f", bad)
    gravity = _scalar(data, "gravity_aligned", "b", bad)

    type_names = _sorted_names(data, "type_names", bad)
    positions = _coordinates(data, "positions", (None, 3), bad)
    n = len(positions)
    if n == 0:
        raise bad("holds no objects (a world needs one)")
    codes = _codes(data, "codes", n, len(type_names), bad)
    sizes = _coordinates(data, "sizes", (n, 3), bad)
    if (sizes < 0).any():
        k, a = np.argwhere(sizes < 0)[0]
        raise bad(f"entry 'sizes'[{k}, {a}] must be >= 0, got {float(sizes[k, a])!r}")
    rotations = None
    if "rotations" in data:
        rotations = _array(data, "rotations", "f", (n, 3, 3), bad)
        improper = rotation_errors(rotations, RIGID_TOLERANCE)[2]
        if improper.any():
            k = int(np.argmax(improper))
            raise bad(f"entry 'rotations'[{k}] is not a rotation: it "
                      f"{rotation_defect(rotations[k], RIGID_TOLERANCE)}")
    gnames, gcodes = None, None
    if ("geometry_names" in data) != ("geometry_codes" in data):
        raise bad("entries 'geometry_names' and 'geometry_codes' must be given together")
    if "geometry_names" in data:
        gnames = _sorted_names(data, "geometry_names", bad)
        gcodes = _codes(data, "geometry_codes", n, len(gnames), bad)
    ids: tuple[str, ...] | None = None
    numbers = None
    if ("ids" in data) == ("id_numbers" in data):
        raise bad("exactly one of the entries 'ids' and 'id_numbers' must be given")
    if "ids" in data:
        id_list = _names(data, "ids", bad, n)
        if len(set(id_list)) != n:
            seen: set[str] = set()
            for k, x in enumerate(id_list):
                if x in seen:
                    raise bad(f"ids must be unique: {x!r} appears more than once (again at index {k})")
                seen.add(x)
        ids = tuple(id_list)
    else:
        numbers = _array(data, "id_numbers", "iu", (n,), bad).astype(np.int64, copy=False)
        if n and int(numbers.min()) < 0:
            raise bad(f"entry 'id_numbers' must be >= 0, got {int(numbers.min())}")
        # the ids f"{type}_{number}" are unique when the (type, number) pairs are (0 .. n-1: the default)
        if not np.array_equal(numbers, np.arange(n)) and (np.diff(np.sort(
                codes.astype(np.int64) * (int(numbers.max()) + 1) + numbers)) == 0).any():
            raise bad("entry 'id_numbers' repeats a number within one type (the ids would repeat)")

    keys = _names(data, "class_vertex_keys", bad)
    offsets = _array(data, "class_vertex_offsets", "iu", (len(keys) + 1,), bad).astype(np.int64)
    verts = _coordinates(data, "class_vertices", (None, 3), bad)
    if offsets[0] != 0 or offsets[-1] != len(verts) or (np.diff(offsets) < 1).any():
        raise bad(f"entry 'class_vertex_offsets' must rise from 0 to {len(verts)} by at least 1 per key, "
                  f"got {_checks._short(offsets.tolist())}")
    if len(set(keys)) != len(keys):
        raise bad(f"entry 'class_vertex_keys' repeats a key: {_checks._short(keys)}")
    class_vertices = {k: verts[offsets[c]:offsets[c + 1]] for c, k in enumerate(keys)}
    room = None
    if "room" in data:
        corners = _coordinates(data, "room", (2, 3), bad)
        room = (corners[0], corners[1])

    if len({"link_i" in data, "link_j" in data, "link_length" in data}) != 1:
        raise bad("entries 'link_i', 'link_j' and 'link_length' must be given together")
    table = ObjectTable._trusted(type_names, codes, positions, sizes, ids, numbers, rotations, gnames, gcodes)
    world = cls.__new__(cls)
    if "link_i" in data:  # read by WorldModel._build_links: checked there, not searched again
        stored = (_array(data, "link_i", "iu", (None,), bad), _array(data, "link_j", "iu", (None,), bad),
                  _array(data, "link_length", "f", (None,), bad))
        object.__setattr__(world, "_stored_links", (*stored, path))
    try:
        world.__init__(table, max_link_length=mll, class_vertices=class_vertices, link_margin=margin,
                       room=room, gravity_aligned=bool(gravity))
    except MalformedFileError:
        raise
    except WorldGraphError as exc:
        raise bad(str(exc)) from exc
    return world


def binary_path(path: str | os.PathLike[str]) -> bool:
    """Whether :meth:`WorldModel.save <worldgraph.model.WorldModel.save>` writes ``path`` as binary
    (its name ends in ``.npz``, any case)."""
    return os.fspath(path).lower().endswith(".npz")
