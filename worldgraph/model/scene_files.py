"""Reading scene files into typed :class:`trimesh.Scene` s, for
:meth:`WorldModel.from_file <worldgraph.WorldModel.from_file>` (the formats, the type rules and
the errors are described in :mod:`worldgraph.importers`, whose public names live here; this
module does not build the world, so that the model reads files without an import cycle).
"""

from __future__ import annotations

import importlib.util
import os
import pathlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import PerceptionError
from perception.mujoco import body_meshes, geom_mesh, import_mujoco, object_geoms
from perception.type_rules import KNOWN_TYPES, default_type_of
from perception.type_rules import type_rule as _perception_type_rule

from .. import _checks
from ..errors import (
    ImporterError,
    MalformedFileError,
    WorldGraphError,
)

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

__all__ = [
    "typed_scene",
    "KNOWN_TYPES",
    "UP_AXES",
    "MJCF_OBJECTS",
    "MJCF_SUFFIXES",
    "OBJ_SUFFIXES",
    "TRIMESH_SUFFIXES",
    "default_type_of",
    "scene_from_file",
    "type_rule",
    "default_up_axis",
    "turn_scene",
    "write_scene",
    "z_up_from",
]

#: File suffixes read with :func:`trimesh.load_scene`.
TRIMESH_SUFFIXES = (".glb", ".gltf", ".ply", ".stl", ".off", ".dae")
#: File suffixes read by this module's OBJ reader.
OBJ_SUFFIXES = (".obj",)
#: File suffixes read as MJCF by MuJoCo's compiler.
MJCF_SUFFIXES = (".xml", ".mjcf")
#: Values of ``mjcf_objects``.
MJCF_OBJECTS = ("bodies", "geoms")

#: Values of ``up_axis``: the file axis that points up (against gravity).
UP_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
#: ``z_up_from(axis)[:3, :3]`` for each of :data:`UP_AXES`: a proper rotation taking the axis to
#: +z; ``"+y"`` (glTF, COLLADA ``Y_UP``) is ``(x, y, z) -> (x, -z, y)`` (glTF's +z, "front",
#: becomes -y), ``"-y"`` ``(x, y, z) -> (x, z, -y)``, ``"+x"`` COLLADA's ``X_UP``
#: (``(x, y, z) -> (-y, -z, x)``), ``"-x"`` ``(x, y, z) -> (y, -z, -x)``, ``"-z"`` half a turn
#: about x.
_UP_ROTATIONS = {
    "+z": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "-z": ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)),
    "+y": ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    "-y": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)),
    "+x": ((0.0, -1.0, 0.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0)),
    "-x": ((0.0, 1.0, 0.0), (0.0, 0.0, -1.0), (-1.0, 0.0, 0.0)),
}
#: The up axis of a format when the file does not say (COLLADA files say it in ``<up_axis>``).
_FORMAT_UP = {"glb": "+y", "gltf": "+y", "dae": "+y", "obj": "+z", "ply": "+z", "stl": "+z", "off": "+z",
              "xml": "+z", "mjcf": "+z"}
_COLLADA_UP = {"X_UP": "+x", "Y_UP": "+y", "Z_UP": "+z"}

_MJCF_PIP = "pip install gaussian-spheres[mjcf]"


# ----------------------------------------------------------------------------------------------
# typing rules (defined in perception.type_rules, shared with perception.mujoco)
# ----------------------------------------------------------------------------------------------
def type_rule(type_of: Any) -> Callable[[str], str | None]:
    """The callable ``name -> type or None`` that a ``type_of`` argument stands for.

    :func:`perception.type_rules.type_rule` with its errors as worldgraph's.

    Parameters
    ----------
    type_of : None, callable or mapping
        ``None`` gives :func:`default_type_of`; a callable is returned as is; a mapping of
        regex patterns (``str`` or compiled) to type names gives the rule "first pattern that
        :func:`re.search` finds in the name".

    Returns
    -------
    callable
        ``name -> type or None``.

    Raises
    ------
    WorldGraphError
        ``type_of`` of another kind, an empty mapping, a pattern that does not compile (naming
        it) or a type that is not a non-empty string.
    """
    try:
        return _perception_type_rule(type_of)
    except PerceptionError as exc:
        raise WorldGraphError(str(exc)) from exc


# ----------------------------------------------------------------------------------------------
# up axis
# ----------------------------------------------------------------------------------------------
def _check_up_axis(up_axis: object) -> str:
    """``up_axis`` as one of :data:`UP_AXES` (``"y"`` and ``"Y"`` read as ``"+y"``)."""
    if isinstance(up_axis, str):
        text = up_axis.strip().lower()
        text = "+" + text if text in ("x", "y", "z") else text
        if text in UP_AXES:
            return text
    raise WorldGraphError(f"up_axis must be None (the format's convention) or one of {UP_AXES} (the file "
                          f"axis that points up), got {_checks._short(up_axis)}")


def z_up_from(up_axis: str) -> NDArray[np.float64]:
    """The (4, 4) rotation taking a file whose up axis is ``up_axis`` to the library's z-up frame.

    Parameters
    ----------
    up_axis : {"+x", "-x", "+y", "-y", "+z", "-z"}
        The file axis that points up (against gravity).

    Returns
    -------
    (4, 4) float
        ``world_from_file``: a proper rotation with ``R @ axis = (0, 0, 1)``; for ``"+y"`` (glTF)
        ``(x, y, z) -> (x, -z, y)``.  Its transpose writes a z-up scene the other way, e.g. a
        glTF file that other tools read upright:
        ``scene.apply_transform(z_up_from("+y").T); scene.export("room.glb")``.

    Raises
    ------
    WorldGraphError
        Any other value, named.

    Examples
    --------
    >>> z_up_from("+y")[:3, :3] @ [0.0, 1.0, 0.0]
    array([0., 0., 1.])
    """
    out = np.eye(4)
    out[:3, :3] = _UP_ROTATIONS[_check_up_axis(up_axis)]
    return out


def _collada_up_axis(path: str) -> str:
    """The ``<asset><up_axis>`` of a COLLADA file as one of :data:`UP_AXES` (``"+y"``, the
    COLLADA default, when absent or unreadable: trimesh reads the file anyway or says why not)."""
    import xml.etree.ElementTree as ET

    try:
        for _, elem in ET.iterparse(path, events=("end",)):
            tag = elem.tag.rsplit("}", 1)[-1]
            if tag == "up_axis":
                return _COLLADA_UP.get((elem.text or "").strip().upper(), "+y")
            if tag == "asset":
                break
    except (ET.ParseError, OSError):
        pass
    return "+y"


def default_up_axis(path: str | os.PathLike[str], file_format: str | None = None) -> str:
    """The up axis a scene file is read with when ``up_axis`` is not given.

    Parameters
    ----------
    path : str or os.PathLike
        The scene file.
    file_format : str, optional
        A suffix to use instead of the path's.

    Returns
    -------
    str
        ``"+y"`` for glTF/GLB (the glTF 2.0 specification: +Y up, +Z front, as Blender writes
        it); for COLLADA (``.dae``) the file's ``<asset><up_axis>`` (``X_UP``, ``Y_UP``,
        ``Z_UP``; ``Y_UP`` when absent, the COLLADA default; trimesh itself ignores the
        element); ``"+z"`` for MJCF (MuJoCo's gravity is -z) and for OBJ, PLY, STL and OFF,
        which carry no up axis (read as written: the z-up convention of CAD, ROS and robot
        meshes; files written +Y up, as many OBJ exporters do on request, need ``up_axis="+y"``).

    Raises
    ------
    MalformedFileError
        An unknown suffix.
    """
    text = _checks.file_path("path", path)
    kind = _file_kind(text, file_format)
    suffix = (file_format or pathlib.Path(text).suffix).lower().lstrip(".")
    if kind == "mjcf":
        return "+z"
    if suffix == "dae":
        return _collada_up_axis(text)
    return _FORMAT_UP.get(suffix, "+z")


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------
def _file_kind(path: str, file_format: str | None) -> str:
    """``"trimesh"``, ``"obj"`` or ``"mjcf"`` from the suffix (or ``file_format``)."""
    if file_format is None:
        suffix = pathlib.Path(path).suffix.lower()
        what = f"{path}: file suffix {suffix!r}"
    else:
        if not isinstance(file_format, str):
            raise WorldGraphError(f"file_format must be None or a suffix such as '.obj', got "
                                  f"{_checks._short(file_format)}")
        suffix = file_format.lower() if file_format.startswith(".") else "." + file_format.lower()
        what = f"file_format = {file_format!r}"
    if suffix in OBJ_SUFFIXES:
        return "obj"
    if suffix in TRIMESH_SUFFIXES:
        return "trimesh"
    if suffix in MJCF_SUFFIXES:
        return "mjcf"
    known = ", ".join(OBJ_SUFFIXES + TRIMESH_SUFFIXES + MJCF_SUFFIXES)
    raise MalformedFileError(f"{what} is not a known scene format; known: {known} (pass file_format= "
                             "to read a file with another suffix)")


def scene_from_file(path: str | os.PathLike[str], *, file_format: str | None = None,
                    mjcf_objects: str = "bodies", up_axis: str | None = None) -> trimesh.Scene:
    """Read a scene file into a :class:`trimesh.Scene` of named candidate nodes, z up.

    Parameters
    ----------
    path : str or os.PathLike
        The file (see the module docstring for the formats).
    file_format : str, optional
        A suffix (``".obj"``, ``"glb"``, ``".xml"``, ...) to use instead of the path's.
    mjcf_objects : {"bodies", "geoms"}
        For MJCF: one node per named body or per geom.
    up_axis : {"+x", "-x", "+y", "-y", "+z", "-z"}, optional
        The file axis that points up; default the format's convention
        (:func:`default_up_axis`: glTF/GLB +Y, COLLADA its ``<up_axis>``, the others +Z).  The
        scene is turned by :func:`z_up_from` (its base frame's children), so that z is up.

    Returns
    -------
    trimesh.Scene
        z up; ``metadata["up_axis"]`` is the up axis it was read with.  For MJCF with
        ``metadata["mujoco_model"]`` and ``metadata["mujoco_data"]`` (in the file's frame).

    Raises
    ------
    MalformedFileError
        Missing or unreadable file, unknown suffix, a file its reader rejects.
    ImporterError
        ``mujoco`` (MJCF) or ``pycollada`` (``.dae``) not installed.
    WorldGraphError
        ``up_axis`` not one of :data:`UP_AXES`.
    """
    return _read_scene(_checks.file_path("path", path), file_format, mjcf_objects, up_axis, None)


def _read_scene(text: str, file_format: str | None, mjcf_objects: str, up_axis: str | None,
                rule: Callable[[str], str | None] | None) -> trimesh.Scene:
    """:func:`scene_from_file` of a checked path; ``rule`` types MJCF bodies as they are read."""
    if not isinstance(mjcf_objects, str) or mjcf_objects not in MJCF_OBJECTS:
        raise WorldGraphError(f"mjcf_objects must be one of {MJCF_OBJECTS}, got "
                              f"{_checks._short(mjcf_objects)}")
    kind = _file_kind(text, file_format)
    up = None if up_axis is None else _check_up_axis(up_axis)
    if not os.path.isfile(text):
        raise MalformedFileError(f"{text}: no such file" if not os.path.exists(text)
                                 else f"{text}: not a regular file")
    if kind == "obj":
        scene = _obj_scene(text)
    elif kind == "mjcf":
        scene = _mjcf_scene(text, mjcf_objects, rule)
    else:
        scene = _trimesh_scene(text, file_format)
    if up is None:
        up = default_up_axis(text, file_format)
    if up != "+z":
        _turn_up(scene, z_up_from(up))
    scene.metadata["up_axis"] = up
    return scene


def turn_scene(scene: trimesh.Scene, transform: ArrayLike) -> trimesh.Scene:
    """Move every node of a scene by a rigid transform, keeping the nodes' metadata.

    Parameters
    ----------
    scene : trimesh.Scene
        Changed in place: each child of the base frame gets ``transform @ matrix``.
    transform : (4, 4) float
        A rigid transform, e.g. :func:`z_up_from` or its transpose.

    Returns
    -------
    trimesh.Scene
        ``scene``.

    Notes
    -----
    :meth:`trimesh.Scene.apply_transform` does the same but drops each moved node's ``metadata``
    and ``geometry`` edge attributes (trimesh 5.2), and so the types written in glTF extras.
    """
    m = _checks.real_array("transform", transform, (4, 4))
    graph = scene.graph
    base = graph.base_frame
    for child in list(graph.transforms.children.get(base, [])):
        data = dict(graph.transforms.edge_data[(base, child)])
        kept = {k: data[k] for k in ("geometry", "metadata") if k in data}
        graph.update(frame_to=child, frame_from=base, matrix=m @ data.get("matrix", np.eye(4)), **kept)
    return scene


def write_scene(scene: trimesh.Scene, path: str | os.PathLike[str], *, up_axis: str | None = None) -> None:
    """Write a z-up scene to a file in the format's up-axis convention (a copy is turned).

    Parameters
    ----------
    scene : trimesh.Scene
        A scene in the library's frame (z up), e.g. of :mod:`worldgraph.scenes`.
    path : str or os.PathLike
        The file; its suffix selects the format (:meth:`trimesh.Scene.export`).
    up_axis : {"+x", "-x", "+y", "-y", "+z", "-z"}, optional
        The file axis that is to point up; default the format's convention
        (:func:`default_up_axis`: +Y for glTF/GLB and COLLADA, whose ``<up_axis>`` trimesh
        writes as ``Y_UP``; +Z for the others), so that :meth:`WorldModel.from_file
        <worldgraph.WorldModel.from_file>` reads the same world back.

    Raises
    ------
    WorldGraphError
        A bad ``up_axis``.
    MalformedFileError
        A suffix trimesh cannot write.
    """
    text = os.fspath(path)
    suffix = pathlib.Path(text).suffix.lower().lstrip(".")
    up = _FORMAT_UP.get(suffix, "+z") if up_axis is None else _check_up_axis(up_axis)
    out = scene.copy()
    if up != "+z":
        turn_scene(out, z_up_from(up).T)
    try:
        out.export(text)
    except (ValueError, KeyError, NotImplementedError) as exc:
        raise MalformedFileError(f"{text}: trimesh cannot write a scene as {suffix!r}: {exc}") from exc


def _turn_up(scene: trimesh.Scene, world_from_file: NDArray[np.float64]) -> None:
    """Turn ``scene`` (the base frame's children) and a ``metadata["room"]`` box by ``world_from_file``."""
    turn_scene(scene, world_from_file)
    room = scene.metadata.get("room")
    if room is not None:
        try:
            corners = np.array(room, dtype=np.float64).reshape(2, 3)
        except (ValueError, TypeError):
            return  # left for from_trimesh to refuse, naming it
        turned = corners @ world_from_file[:3, :3].T
        scene.metadata["room"] = (turned.min(axis=0), turned.max(axis=0))


def _trimesh_scene(path: str, file_format: str | None) -> trimesh.Scene:
    import trimesh

    suffix = (file_format or pathlib.Path(path).suffix).lower().lstrip(".")
    if suffix == "dae" and importlib.util.find_spec("collada") is None:
        raise ImporterError(f"{path}: reading COLLADA (.dae) needs pycollada: pip install pycollada")
    try:
        scene = trimesh.load_scene(path, file_type=suffix)
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, OSError, EOFError) as exc:
        raise MalformedFileError(f"{path}: trimesh cannot read it as {suffix}: "
                                 f"{type(exc).__name__}: {exc}") from exc
    return scene


# -- OBJ ---------------------------------------------------------------------------------------
def _obj_scene(path: str) -> trimesh.Scene:
    """One node per ``o``/``g`` part of an OBJ file, identity transforms.

    Not ``trimesh.exchange.obj.load_obj``: in trimesh 5.2 no option set gives these parts (names
    ``<o>_<g>``, parts of a repeated name merged, negative indices counted from the end of the
    file, malformed lines unnamed or read silently); tests/worldgraph/test_obj_trimesh_parity.py
    pins the differences.
    """
    import trimesh

    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError as exc:
        raise MalformedFileError(f"{path}: cannot read: {exc}") from exc
    vertices: list[tuple[float, float, float]] = []
    parts: list[tuple[str, list[list[int]]]] = []
    current: list[list[int]] | None = None
    for lineno, raw in enumerate(lines, start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        head, _, rest = line.partition(" ")
        fields = rest.split()
        if head == "v":
            if len(fields) < 3:
                raise MalformedFileError(f"{path}:{lineno}: a vertex needs 3 coordinates, got {raw!r}")
            try:
                xyz = (float(fields[0]), float(fields[1]), float(fields[2]))
            except ValueError as exc:
                raise MalformedFileError(f"{path}:{lineno}: cannot read the vertex {raw!r}") from exc
            if not all(np.isfinite(xyz)):
                raise MalformedFileError(f"{path}:{lineno}: vertex coordinates must be finite, got {raw!r}")
            vertices.append(xyz)
        elif head in ("o", "g"):
            name = fields[0] if fields else ""
            current = []
            parts.append((name, current))
        elif head == "f":
            if len(fields) < 3:
                raise MalformedFileError(f"{path}:{lineno}: a face needs at least 3 vertices, got {raw!r}")
            face = []
            for ref in fields:
                try:
                    k = int(ref.split("/", 1)[0])
                except ValueError as exc:
                    raise MalformedFileError(f"{path}:{lineno}: cannot read the face {raw!r}") from exc
                index = k - 1 if k > 0 else len(vertices) + k  # negative: relative to the end
                if k == 0 or not 0 <= index < len(vertices):
                    raise MalformedFileError(f"{path}:{lineno}: face refers to vertex {k}, but "
                                             f"{len(vertices)} vertices are defined so far")
                face.append(index)
            if current is None:
                current = []
                parts.append((pathlib.Path(path).name, current))
            current.append(face)
    verts = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    scene = trimesh.Scene()
    used_names: set[str] = set()
    for name, faces in parts:
        if not faces or not name:
            continue
        tris = np.array([[f[0], f[k], f[k + 1]] for f in faces for k in range(1, len(f) - 1)], dtype=np.int64)
        keep, inverse = np.unique(tris, return_inverse=True)
        mesh = trimesh.Trimesh(vertices=verts[keep], faces=inverse.reshape(-1, 3), process=False)
        node = _unique(name, used_names)
        scene.add_geometry(mesh, node_name=node, geom_name=node)
    return scene


def _unique(name: str, used: set[str]) -> str:
    """``name``, or ``name.1``, ``name.2``, ... if taken; recorded in ``used``."""
    out, k = name, 0
    while out in used:
        k += 1
        out = f"{name}.{k}"
    used.add(out)
    return out


# -- MJCF --------------------------------------------------------------------------------------
def _import_mujoco() -> Any:
    """``mujoco`` (headless: with ``MUJOCO_GL=egl`` unless set, as :mod:`perception.mujoco`)."""
    try:
        return import_mujoco()
    except ImportError as exc:
        raise ImporterError(f"reading MJCF needs the mujoco package: {_MJCF_PIP}") from exc


def _pose(position: NDArray[np.float64], xmat: NDArray[np.float64]) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, :3] = np.asarray(xmat, dtype=np.float64).reshape(3, 3)
    m[:3, 3] = position
    return m


def _mjcf_scene(path: str, mjcf_objects: str, rule: Callable[[str], str | None] | None = None
                ) -> trimesh.Scene:
    """The MJCF scene; with ``rule`` (bodies mode) a typed body's node also holds the visual
    geoms of its untyped descendants (:func:`perception.mujoco.object_geoms`)."""
    import trimesh

    mujoco = _import_mujoco()
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except ValueError as exc:
        raise MalformedFileError(f"{path}: MuJoCo cannot compile it: {exc}") from exc
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = trimesh.Scene()
    scene.metadata["mujoco_model"] = model
    scene.metadata["mujoco_data"] = data
    used: set[str] = set()

    def body_name(b: int) -> str:
        return model.body(b).name or f"body{b}"

    if mjcf_objects == "geoms":
        for g in range(model.ngeom):
            b = int(model.geom_bodyid[g])
            name = model.geom(g).name or f"{body_name(b)}:{g - int(model.body_geomadr[b])}"
            shape = geom_mesh(model, g)
            if shape is None:
                continue
            mesh, geom_from_mesh = shape
            node = _unique(name, used)
            world = _pose(data.geom_xpos[g], data.geom_xmat[g]) @ geom_from_mesh
            scene.add_geometry(mesh, node_name=node, geom_name=node, transform=world)
        return scene
    first = int(model.body_geomadr[0])  # named geoms of the world body: their own nodes
    for g in range(first, first + int(model.body_geomnum[0])):
        shape = geom_mesh(model, g)
        if model.geom(g).name and shape is not None:
            node = _unique(model.geom(g).name, used)
            world = _pose(data.geom_xpos[g], data.geom_xmat[g]) @ shape[1]
            scene.add_geometry(shape[0], node_name=node, geom_name=node, transform=world)
    geoms_of = object_geoms(model, rule)
    for b in range(1, model.nbody):
        name = model.body(b).name
        if not name:
            continue
        world_from_body = _pose(data.xpos[b], data.xmat[b])
        pieces = body_meshes(model, data, b, geoms_of[b])
        geometry: Any
        if pieces:
            geometry = trimesh.util.concatenate(pieces) if len(pieces) > 1 else pieces[0]
        else:
            geometry = trimesh.PointCloud(np.zeros((1, 3)))
        node = _unique(name, used)
        scene.add_geometry(geometry, node_name=node, geom_name=node, transform=world_from_body)
    return scene


# ----------------------------------------------------------------------------------------------
# world
# ----------------------------------------------------------------------------------------------
def _node_metadata_type(scene: trimesh.Scene, node: str) -> tuple[bool, Any]:
    """``(True, type)`` when the node carries ``metadata["type"]``, else ``(False, None)``."""
    parent = scene.graph.transforms.parents.get(node)
    if parent is None:
        return False, None
    meta = scene.graph.transforms.edge_data.get((parent, node), {}).get("metadata")
    if isinstance(meta, dict) and "type" in meta:
        return True, meta["type"]
    return False, None


def typed_scene(path: str | os.PathLike[str], type_of: Any = None, *, mjcf_objects: str = "bodies",
                file_format: str | None = None, up_axis: str | None = None
                ) -> tuple[trimesh.Scene, dict[str, Any]]:
    """The scene of a file (:func:`scene_from_file`) and the type of each typed node name (the
    type rules of :func:`worldgraph.importers.world_from_file`); :class:`WorldGraphError` when
    no node gets a type.  For MJCF bodies the rule is applied as the file is read, so that a
    typed body's node also holds the visual geoms of its untyped descendants (module docstring
    of :mod:`worldgraph.importers`)."""
    rule = type_rule(type_of)
    text = _checks.file_path("path", path)

    def checked_rule(node: str) -> Any:
        try:
            return rule(node)
        except Exception as exc:
            raise WorldGraphError(f"type_of({node!r}) raised {type(exc).__name__}: {exc}") from exc

    scene = _read_scene(text, file_format, mjcf_objects, up_axis, checked_rule)
    names = [str(n) for n in scene.graph.nodes_geometry]
    types: dict[str, Any] = {}
    for node in names:
        if type_of is None:
            has_meta, typ = _node_metadata_type(scene, node)
            if not has_meta:
                typ = rule(node)
        else:
            typ = checked_rule(node)
        if typ is not None:
            types[node] = typ
    if not types:
        shown = sorted(names)[:20]
        more = f" and {len(names) - 20} more" if len(names) > 20 else ""
        how = ("the leading word of a name must be one of worldgraph.importers.KNOWN_TYPES"
               if type_of is None else "type_of gave None for every name")
        raise WorldGraphError(f"{text}: no object recognised among the {len(names)} names {shown}{more} "
                              f"({how}; pass type_of= to type them)")
    return scene, types
