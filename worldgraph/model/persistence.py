"""World-model files: :meth:`WorldModel.to_dict <worldgraph.model.WorldModel.to_dict>`,
``save``, ``load`` and ``from_dict`` call these functions (the JSON format is described in
:mod:`worldgraph.model`; :data:`FILE_FORMAT`, :data:`FILE_VERSION`); the binary ``.npz`` format
is read and written by :mod:`worldgraph.model.binary_files`."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..errors import MalformedFileError, WorldGraphError
from . import binary_files
from .objects import ObjectModel

FILE_FORMAT = "worldgraph.WorldModel"
FILE_VERSION = 1


def _check_path(path: Any) -> str:
    """A file path as ``str`` (``worldgraph._checks.file_path``)."""
    return _checks.file_path("path", path)


def world_to_dict(world: Any) -> dict[str, Any]:
    """The body of :meth:`WorldModel.to_dict <worldgraph.model.WorldModel.to_dict>`; ``world`` is a
    :class:`~worldgraph.model.WorldModel` (not imported: the world module imports this one)."""
    out: dict[str, Any] = {
        "format": FILE_FORMAT,
        "version": FILE_VERSION,
        "max_link_length": world.max_link_length,
        "link_margin": world.link_margin,
        "class_vertices": {k: v.tolist() for k, v in world.class_vertices.items()},
        "objects": [o.to_dict() for o in world.objects],
    }
    if world.room is not None:
        out["room"] = {"lower": world.room.lower.tolist(), "upper": world.room.upper.tolist()}
    if world.gravity_aligned:
        out["gravity_aligned"] = True
    return out


def save_world(world: Any, path: str | os.PathLike[str]) -> None:
    """The body of :meth:`WorldModel.save <worldgraph.model.WorldModel.save>`; ``world`` is a
    :class:`~worldgraph.model.WorldModel` (not imported: the world module imports this one).
    A name ending in ``.npz`` is written in the binary format (:mod:`.binary_files`), any other
    as JSON."""
    path = _check_path(path)
    if binary_files.binary_path(path):
        binary_files.save_binary(world, path)
        return
    try:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(world.to_dict(), fh, indent=1, allow_nan=False)
    except OSError as exc:
        raise WorldGraphError(f"{path}: cannot write: {exc}") from exc


def load_world(cls: Any, path: str | os.PathLike[str]) -> Any:
    """The body of :meth:`WorldModel.load <worldgraph.model.WorldModel.load>`; ``cls`` is the
    :class:`~worldgraph.model.WorldModel` class (or subclass) to build."""
    try:
        path = _check_path(path)
    except WorldGraphError as exc:
        raise MalformedFileError(str(exc)) from exc
    try:
        binary = binary_files.is_binary_file(path)
    except OSError as exc:
        raise MalformedFileError(f"{path}: cannot read: {exc}") from exc
    if binary:  # the zip magic: an .npz archive, whatever the file's name
        return binary_files.load_binary(cls, path)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except json.JSONDecodeError as exc:
        raise MalformedFileError(f"{path}: not valid JSON: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise MalformedFileError(f"{path}: not UTF-8 text: {exc}") from exc
    except RecursionError as exc:
        raise MalformedFileError(f"{path}: JSON nested too deeply to read") from exc
    except (OSError, ValueError) as exc:
        raise MalformedFileError(f"{path}: cannot read: {exc}") from exc
    return cls.from_dict(data, source=path)


def world_from_dict(cls: Any, data: Any, source: str = "data") -> Any:
    """The body of :meth:`WorldModel.from_dict <worldgraph.model.WorldModel.from_dict>`; ``cls`` is the
    :class:`~worldgraph.model.WorldModel` class (or subclass) to build."""
    if not isinstance(source, str):
        raise WorldGraphError(f"source must be a str (the name used in messages), "
                              f"got {type(source).__name__}")

    def bad(msg: str) -> MalformedFileError:
        return MalformedFileError(f"{source}: {msg}")

    try:
        return cls._from_dict(data, bad)
    except MalformedFileError:
        raise
    except WorldGraphError as exc:
        raise bad(str(exc)) from exc
    except RecursionError as exc:
        raise bad("nested too deeply") from exc
    except (TypeError, ValueError, KeyError, IndexError, AttributeError, OverflowError) as exc:
        # only reachable from hand-made dictionaries holding non-JSON objects
        raise bad(f"unreadable value ({type(exc).__name__}: {exc})") from exc


def _world_from_dict(cls: Any, data: Any, bad: Callable[[str], MalformedFileError]) -> Any:
    """The body of :meth:`WorldModel._from_dict <worldgraph.model.WorldModel._from_dict>`; ``cls``
    is the :class:`~worldgraph.model.WorldModel` class (or subclass) to build."""
    if not isinstance(data, dict):
        raise bad(f"top level must be a JSON object, got {type(data).__name__}")
    for key in ("version", "max_link_length", "objects", "class_vertices"):
        if key not in data:
            raise bad(f"missing key {key!r}")
    if data.get("format", FILE_FORMAT) != FILE_FORMAT:
        raise bad(f"format must be {FILE_FORMAT!r}, got {_checks._short(data['format'])}")
    if type(data["version"]) is not int or data["version"] != FILE_VERSION:
        raise bad(f"unsupported version {_checks._short(data['version'])}, this reader reads version "
                  f"{FILE_VERSION}")

    def number(value: Any, what: str) -> float:
        try:
            return _checks.real_scalar(what, value)
        except WorldGraphError as exc:
            raise bad(f"{exc} (a finite number is needed)") from exc

    def array(value: Any, shape: tuple[int | None, ...], what: str) -> NDArray[np.float64]:
        try:
            return _checks.real_array(what, value, shape)
        except WorldGraphError as exc:
            raise bad(str(exc)) from exc

    mll = number(data["max_link_length"], "max_link_length")
    margin = number(data.get("link_margin", 0.0), "link_margin")
    if not isinstance(data["class_vertices"], dict):
        raise bad("class_vertices must be an object mapping geometry keys to vertex lists")
    cv = {k: array(v, (None, 3), f"class_vertices[{k!r}]") for k, v in data["class_vertices"].items()}
    if not isinstance(data["objects"], list):
        raise bad("objects must be a list")
    objs = []
    for k, entry in enumerate(data["objects"]):
        if not isinstance(entry, dict):
            raise bad(f"objects[{k}] must be an object, got {entry!r}")
        for key in ("id", "type", "pose", "size", "geometry"):
            if key not in entry:
                raise bad(f"objects[{k}] is missing key {key!r}")
        name = f"objects[{k}] ({_checks._short(entry['id'], 60)})"
        for key in ("id", "type", "geometry"):
            try:
                _checks.name_string(f"{name}.{key}", entry[key])
            except WorldGraphError as exc:
                raise bad(str(exc)) from exc
        pose = array(entry["pose"], (4, 4), f"{name}.pose")
        size = array(entry["size"], (3,), f"{name}.size")
        try:
            objs.append(ObjectModel(entry["id"], entry["type"], pose, size, entry["geometry"]))
        except WorldGraphError as exc:
            raise bad(f"{name}: {exc}") from exc
    room: Any = data.get("room")  # the JSON value, then the (lower, upper) pair WorldModel checks
    if room is not None:
        if not isinstance(room, dict) or set(room) != {"lower", "upper"}:
            raise bad("room must be null or an object with keys 'lower' and 'upper', "
                      f"got {_checks._short(room)}")
        room = (array(room["lower"], (3,), "room.lower"), array(room["upper"], (3,), "room.upper"))
    gravity = data.get("gravity_aligned", False)
    if not isinstance(gravity, bool):
        raise bad(f"gravity_aligned must be true or false, got {_checks._short(gravity)}")
    try:
        return cls(tuple(objs), max_link_length=mll, class_vertices=cv, link_margin=margin, room=room,
                   gravity_aligned=gravity)
    except WorldGraphError as exc:
        raise bad(str(exc)) from exc
