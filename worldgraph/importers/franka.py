"""The Franka kitchen of gymnasium-robotics as a world model (a real kitchen CAD model on PyPI).

``gymnasium-robotics`` ships the MuJoCo (MJCF) model of the D4RL/relay-policy-learning Franka
kitchen in ``gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/``.  Its runtime
dependencies (mujoco, gymnasium) are not needed here: install it with
``pip install --no-deps gymnasium-robotics``; this module only reads its XML and STL files.

:func:`load_franka_kitchen` parses ``kitchen_env_model.xml`` with :mod:`xml.etree.ElementTree`, expands
``<include file=...>`` (paths relative to the main file, as MuJoCo does), merges ``<compiler>``
settings (``angle`` radian/degree, ``eulerseq``, ``meshdir``), resolves ``<default>`` classes
(``class`` / ``childclass``), accumulates ``pos`` and ``quat`` / ``euler`` / ``axisangle`` /
``zaxis`` / ``xyaxes`` down the body tree, and builds a :class:`trimesh.Scene` with one node per
visual geom (box, cylinder, capsule, sphere, ellipsoid, plane as a thin box, mesh from the STL
files placed with their raw vertex coordinates in the geom frame).  Collision geoms (group 3
or 4, or a class whose name contains ``collision``) and the robot (includes from
``franka_assets``) are left out.

Type mapping (body name, geom -> type); every other geom stays in the scene untyped and is not
a world-model object:

=====================================  ============================================  ==========
body                                   geom                                          type
=====================================  ============================================  ==========
``hingeleftdoor``, ``hingerightdoor``  box (the door leaf)                           door
``hingeleftdoor``, ``hingerightdoor``  upright cylinder (no rotation)                handle
``slidelink``                          box (the sliding door)                        door
``slidelink``                          upright cylinder                              handle
``microdoorroot``                      mesh ``microdoor``                            door
``microdoorroot``                      upright capsule                               handle
``microroot``                          mesh ``micro``                                microwave
``ovenroot``, ``counters``             cylinder of radius 0.022 (horizontal bars)    handle
``knob 1`` ... ``knob 4``              cylinder of radius >= 0.04 (the dial)         knob
``Burner 1`` ... ``Burner 4``          cylinder                                      burner
``lightswitchroot``                    capsule                                       switch
``hoodroot``                           mesh ``hood``                                 hood
``kettleroot``                         mesh ``kettle``                               kettle
``counters``                           mesh ``faucet`` / ``countertop`` /            faucet /
                                       ``cabinetbase``                               countertop /
                                                                                     cabinet
``hingecab`` / ``slide``               the first / second box (the cabinet body)     cabinet
``ovenroot``                           the largest box (the oven body)               oven
``wallroot``, ``wall2``                the first box                                 wall
=====================================  ============================================  ==========

The scene is in the MJCF world frame (z up, metres).  The kettle is a free body; it is placed
at its ``<body pos>`` (not the keyframe).  The world model's ``room`` is the box over the MJCF
floor plane (x, y: the plane's extent; z: from the floor up 3 m).
"""

from __future__ import annotations

import importlib.util
import math
import pathlib
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from .. import _checks
from ..errors import ImporterError, MalformedFileError, WorldGraphError
from ..model import WorldModel
from ..tolerances import NORM_FLOOR, SIZE_MATCH, UPRIGHT_TOL

__all__ = ["FRANKA_BODY_TYPES", "FRANKA_TYPE_RULES", "ROOM_HEIGHT", "franka_kitchen_path",
           "franka_kitchen_scene", "load_franka_kitchen"]

_PIP = "pip install --no-deps gymnasium-robotics"
_MAIN_FILE = "kitchen_env_model.xml"
#: Height (metres) of the room box over the MJCF floor.
ROOM_HEIGHT = 3.0


def franka_kitchen_path() -> pathlib.Path:
    """Directory ``.../gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/``.

    Found with :func:`importlib.util.find_spec` without importing gymnasium_robotics (whose
    runtime dependencies need not be installed).  Raises :class:`ImporterError` naming the pip
    command when the package or the directory is absent.
    """
    try:
        spec = importlib.util.find_spec("gymnasium_robotics")
    except (ImportError, ValueError) as exc:  # pragma: no cover - broken installs
        raise ImporterError(f"gymnasium_robotics cannot be located ({exc}); install it with: {_PIP}") from exc
    if spec is None or not spec.submodule_search_locations:
        raise ImporterError(f"the Franka kitchen needs gymnasium-robotics; install it with: {_PIP}")
    for root in spec.submodule_search_locations:
        path = pathlib.Path(root) / "envs" / "assets" / "kitchen_franka" / "kitchen_assets"
        if (path / _MAIN_FILE).is_file():
            return path
    raise ImporterError("gymnasium_robotics is installed but has no "
                        f"kitchen_franka/kitchen_assets/{_MAIN_FILE}; reinstall it with: {_PIP}")


# ----------------------------------------------------------------------------------------------
# rotations (MuJoCo conventions)
# ----------------------------------------------------------------------------------------------
def _quat_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix of a quaternion ``(w, x, y, z)``, normalised; a zero one is a ValueError."""
    return Rotation.from_quat(q, scalar_first=True).as_matrix()


def _euler_matrix(seq: str, angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix of MuJoCo's ``euler`` with ``compiler eulerseq = seq``.

    A lower-case sequence turns about the moving axes (intrinsic), any other about the fixed axes
    of the parent (extrinsic, its letters read as lower case); a sequence that is not three of
    x, y, z with no axis twice in a row is a ValueError.
    """
    return Rotation.from_euler(seq.upper() if seq.islower() else seq.lower(), angles).as_matrix()


def _axis_angle_matrix(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    """Rotation matrix of the turn by ``angle`` (radians) about ``axis`` (normalised here)."""
    return Rotation.from_rotvec(angle * (axis / np.linalg.norm(axis))).as_matrix()


@dataclass
class _Compiler:
    degrees: bool = True  # MuJoCo's default angle unit is degrees
    eulerseq: str = "xyz"
    meshdir: pathlib.Path | None = None


def _floats(text: str | None, n: int | None, what: str) -> NDArray[np.float64]:
    try:
        vals = np.array([float(v) for v in (text or "").split()], dtype=np.float64)
    except ValueError as exc:
        raise MalformedFileError(f"{what}: cannot parse numbers from {text!r}") from exc
    if n is not None and vals.size != n:
        raise MalformedFileError(f"{what} must have {n} numbers, got {text!r}")
    if not np.all(np.isfinite(vals)):
        raise MalformedFileError(f"{what} must be finite, got {text!r}")
    return vals


def _local_transform(el: ET.Element, comp: _Compiler, what: str) -> NDArray[np.float64]:
    """``parent_from_element`` from pos and one orientation attribute."""
    m = np.eye(4)
    if el.get("pos") is not None:
        m[:3, 3] = _floats(el.get("pos"), 3, f"{what} pos")
    unit = math.pi / 180.0 if comp.degrees else 1.0
    if el.get("quat") is not None:
        m[:3, :3] = _quat_matrix(_floats(el.get("quat"), 4, f"{what} quat"))
    elif el.get("euler") is not None:
        m[:3, :3] = _euler_matrix(comp.eulerseq, _floats(el.get("euler"), 3, f"{what} euler") * unit)
    elif el.get("axisangle") is not None:
        v = _floats(el.get("axisangle"), 4, f"{what} axisangle")
        m[:3, :3] = _axis_angle_matrix(v[:3], v[3] * unit)
    elif el.get("zaxis") is not None:
        z = _floats(el.get("zaxis"), 3, f"{what} zaxis")
        z = z / np.linalg.norm(z)
        ez = np.array([0.0, 0.0, 1.0])
        axis = np.cross(ez, z)
        if np.linalg.norm(axis) < NORM_FLOOR:
            m[:3, :3] = np.eye(3) if z[2] > 0 else np.diag([1.0, -1.0, -1.0])
        else:
            m[:3, :3] = _axis_angle_matrix(axis, math.acos(float(np.clip(z[2], -1.0, 1.0))))
    elif el.get("xyaxes") is not None:
        v = _floats(el.get("xyaxes"), 6, f"{what} xyaxes")
        x = v[:3] / np.linalg.norm(v[:3])
        y = v[3:] - x * (x @ v[3:])
        y /= np.linalg.norm(y)
        m[:3, :3] = np.column_stack([x, y, np.cross(x, y)])
    return m


# ----------------------------------------------------------------------------------------------
# MJCF parsing
# ----------------------------------------------------------------------------------------------
@dataclass
class _Geom:
    body: str
    index: int  # index of the geom within its body
    kind: str
    size: NDArray[np.float64]
    mesh: str | None
    rotated: bool  # has an orientation attribute of its own
    world_from_geom: NDArray[np.float64]
    name: str | None = None  # the geom's own name attribute


@dataclass
class _Model:
    compiler: _Compiler = field(default_factory=_Compiler)
    defaults: dict[str, dict[str, str]] = field(default_factory=dict)
    meshes: dict[str, tuple[pathlib.Path, NDArray[np.float64]]] = field(default_factory=dict)
    geoms: list[_Geom] = field(default_factory=list)


def _expand_includes(el: ET.Element, base: pathlib.Path, here: pathlib.Path, depth: int = 0) -> None:
    """Replace ``<include file=...>`` children (recursively) by the included file's children."""
    if depth > 20:
        raise MalformedFileError("MJCF includes nest deeper than 20 levels (a cycle?)")
    k = 0
    while k < len(el):
        child = el[k]
        if child.tag == "include":
            name = child.get("file")
            if not name:
                raise MalformedFileError(f"<include> without a file attribute in {here}")
            el.remove(child)
            if "franka_assets" in name:  # the robot arm is not part of the kitchen
                continue
            path = (base / name) if (base / name).is_file() else (here.parent / name)
            if not path.is_file():
                raise MalformedFileError(f"included MJCF file {name!r} not found next to {base} "
                                         f"or {here.parent}")
            try:
                root = ET.parse(path).getroot()
            except ET.ParseError as exc:
                raise MalformedFileError(f"{path}: not valid XML: {exc}") from exc
            _expand_includes(root, base, path, depth + 1)
            for j, sub in enumerate(list(root)):
                el.insert(k + j, sub)
            k += len(root)
        else:
            _expand_includes(child, base, here, depth)
            k += 1


def _read_defaults(el: ET.Element, parent: dict[str, str], out: dict[str, dict[str, str]]) -> None:
    name = el.get("class", "main")
    attrs = dict(parent)
    geom = el.find("geom")
    if geom is not None:
        attrs.update(geom.attrib)
    out[name] = attrs
    for sub in el.findall("default"):
        _read_defaults(sub, attrs, out)


def _parse(path: pathlib.Path) -> _Model:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise MalformedFileError(f"{path}: not valid XML: {exc}") from exc
    base = path.parent
    _expand_includes(root, base, path)
    model = _Model()
    for comp in root.iter("compiler"):
        if comp.get("angle") is not None:
            model.compiler.degrees = comp.get("angle") != "radian"
        if comp.get("eulerseq") is not None:
            model.compiler.eulerseq = comp.get("eulerseq", "xyz")
        if comp.get("meshdir") is not None:
            model.compiler.meshdir = base / comp.get("meshdir", ".")
    main_defaults: dict[str, str] = {}
    for top in root.findall("default"):
        geom = top.find("geom")
        if geom is not None:
            main_defaults.update(geom.attrib)
    model.defaults["main"] = main_defaults
    for top in root.findall("default"):
        for d in top.findall("default"):
            _read_defaults(d, main_defaults, model.defaults)
    meshdir = model.compiler.meshdir or base
    for mesh in root.iter("mesh"):
        file = mesh.get("file")
        if file is None:
            continue
        name = mesh.get("name") or pathlib.Path(file).stem
        scale = _floats(mesh.get("scale"), 3, f"mesh {name} scale") if mesh.get("scale") else np.ones(3)
        model.meshes[name] = ((meshdir / file).resolve(), scale)
    for world in root.findall("worldbody"):
        _walk(world, np.eye(4), "world", "main", model)
    return model


def _walk(body: ET.Element, world_from_body: NDArray[np.float64], name: str, childclass: str,
          model: _Model) -> None:
    k = 0
    for geom in body.findall("geom"):
        cls = geom.get("class", childclass)
        attrs = dict(model.defaults.get(cls, model.defaults.get("main", {})))
        attrs.update(geom.attrib)
        k += 1
        if "collision" in cls or attrs.get("group") in ("3", "4"):
            continue
        if geom.get("type") is not None:
            kind = geom.get("type", "sphere")
        elif "mesh" in attrs:
            kind = "mesh"
        else:
            kind = attrs.get("type", "sphere")
        if kind == "mesh" and "mesh" not in attrs:
            raise MalformedFileError(f"body {name!r}: mesh geom without a mesh attribute")
        what = f"body {name!r} geom {k - 1}"
        local = _local_transform(geom, model.compiler, what)
        size = _floats(attrs.get("size", "0"), None, f"{what} size")
        if attrs.get("fromto") is not None:
            ft = _floats(attrs.get("fromto"), 6, f"{what} fromto")
            a, b = ft[:3], ft[3:]
            axis = b - a
            length = float(np.linalg.norm(axis))
            local = np.eye(4)
            local[:3, 3] = 0.5 * (a + b)
            ez = np.array([0.0, 0.0, 1.0])
            rot_axis = np.cross(ez, axis)
            if np.linalg.norm(rot_axis) > NORM_FLOOR:
                turn = math.acos(float(np.clip(axis[2] / length, -1, 1)))
                local[:3, :3] = _axis_angle_matrix(rot_axis, turn)
            size = np.array([size[0], length / 2])
        rotated = any(geom.get(a) is not None for a in ("quat", "euler", "axisangle", "zaxis", "xyaxes"))
        world_from_geom = world_from_body @ local
        model.geoms.append(_Geom(name, k - 1, kind, size, attrs.get("mesh"), rotated, world_from_geom,
                                 geom.get("name")))
    for n, child in enumerate(body.findall("body")):
        child_name = child.get("name") or f"{name}/body{n}"
        m = world_from_body @ _local_transform(child, model.compiler, f"body {child_name!r}")
        _walk(child, m, child_name, child.get("childclass", childclass), model)


# ----------------------------------------------------------------------------------------------
# typing rules
# ----------------------------------------------------------------------------------------------
def _first_box(g: _Geom) -> bool:
    return g.kind == "box" and g.index == 0


#: The Franka kitchen's bodies as typed objects, a ``type_of`` mapping (regex on the body name ->
#: type) for :meth:`WorldModel.from_file <worldgraph.WorldModel.from_file>` and
#: :class:`perception.mujoco.MujocoScene` on ``kitchen_env_model.xml`` itself (MuJoCo compiles the
#: file; the robot's bodies stay untyped).  One object per body, so a door's handle is part of its
#: door (its geoms sit in the door's body); :data:`FRANKA_TYPE_RULES` types geoms instead.  The
#: landmarks a robot recognises: doors, knobs, burners, the light switch and the kettle; the
#: cabinet, oven, hood and microwave bodies stay untyped (measured on renders, their centres lie
#: 20-70 cm from what a view of them shows, half hidden behind their own doors).
FRANKA_BODY_TYPES: dict[str, str] = {
    r"^hinge(left|right)door$": "door",
    r"^slidelink$": "door",
    r"^microdoorroot$": "door",
    r"^knob \d+$": "knob",
    r"^Burner \d+$": "burner",
    r"^lightswitchroot$": "switch",
    r"^kettle$": "kettle",
}

#: (body-name regex, geom predicate, type): the first matching rule types a geom.
FRANKA_TYPE_RULES: tuple[tuple[str, Callable[[_Geom], bool], str], ...] = (
    (r"hinge(left|right)door|slidelink", lambda g: g.kind == "box", "door"),
    (r"hinge(left|right)door|slidelink", lambda g: g.kind == "cylinder" and not g.rotated, "handle"),
    (r"microdoorroot", lambda g: g.mesh == "microdoor", "door"),
    (r"microdoorroot", lambda g: g.kind == "capsule" and not g.rotated, "handle"),
    (r"microroot", lambda g: g.mesh == "micro", "microwave"),
    (r"ovenroot|counters", lambda g: g.kind == "cylinder" and abs(g.size[0] - 0.022) < SIZE_MATCH, "handle"),
    (r"knob \d+", lambda g: g.kind == "cylinder" and g.size[0] >= 0.04, "knob"),
    (r"Burner \d+", lambda g: g.kind == "cylinder", "burner"),
    (r"lightswitchroot", lambda g: g.kind == "capsule", "switch"),
    (r"hoodroot", lambda g: g.mesh == "hood", "hood"),
    (r"kettleroot", lambda g: g.mesh == "kettle", "kettle"),
    (r"counters", lambda g: g.mesh == "faucet", "faucet"),
    (r"counters", lambda g: g.mesh == "countertop", "countertop"),
    (r"counters", lambda g: g.mesh == "cabinetbase", "cabinet"),
    (r"hingecab", _first_box, "cabinet"),
    (r"slide", lambda g: g.kind == "box" and g.index == 1, "cabinet"),
    (r"ovenroot", lambda g: g.kind == "box" and float(np.prod(g.size)) > 0.1, "oven"),
    (r"wallroot|wall2", _first_box, "wall"),
)


def _type_of(g: _Geom) -> str | None:
    for pattern, pred, typ in FRANKA_TYPE_RULES:
        if re.fullmatch(pattern, g.body) and pred(g):
            return typ
    return None


def _geometry(g: _Geom, model: _Model, cache: dict[str, trimesh.Trimesh]) -> tuple[str, trimesh.Trimesh]:
    s = g.size
    if g.kind == "mesh":
        key = f"mesh_{g.mesh}"
        if key not in cache:
            if g.mesh not in model.meshes:
                raise MalformedFileError(f"geom of body {g.body!r} refers to unknown mesh {g.mesh!r}")
            file, scale = model.meshes[g.mesh]
            if not file.is_file():
                raise MalformedFileError(f"mesh file {file} of mesh {g.mesh!r} is missing")
            mesh = trimesh.load_mesh(file)
            if not np.allclose(scale, 1.0):
                mesh.apply_scale(scale)
            cache[key] = mesh
        return key, cache[key]
    key = f"{g.kind}_" + "_".join(f"{v:g}" for v in s)
    if key in cache:
        return key, cache[key]
    if g.kind == "box":
        mesh = trimesh.creation.box(extents=2 * s[:3])
    elif g.kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=s[0], height=2 * s[1], sections=24)
    elif g.kind == "capsule":
        mesh = trimesh.creation.capsule(height=2 * s[1], radius=s[0], count=[12, 12])
    elif g.kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=s[0])
    elif g.kind == "ellipsoid":
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        mesh.apply_scale(s[:3])
    elif g.kind == "plane":
        mesh = trimesh.creation.box(extents=(2 * s[0], 2 * s[1], 1e-3))
    else:
        raise MalformedFileError(f"geom type {g.kind!r} of body {g.body!r} is not supported")
    cache[key] = mesh
    return key, mesh


def _floor_room(model: _Model) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """``(lower, upper)`` of the room over the MJCF floor: the first upright plane geom of finite
    size (one named ``floor`` first), its x, y extent, from its height up :data:`ROOM_HEIGHT`."""
    planes = [g for g in model.geoms if g.kind == "plane" and g.size.size >= 2 and np.all(g.size[:2] > 0)
              and g.world_from_geom[2, 2] > 1.0 - UPRIGHT_TOL]
    planes.sort(key=lambda g: g.name != "floor")
    if not planes:
        return None
    g = planes[0]
    sx, sy = g.size[:2]
    corners = np.array([[x, y, 0.0, 1.0] for x in (-sx, sx) for y in (-sy, sy)]) @ g.world_from_geom.T
    z = float(g.world_from_geom[2, 3])
    lower = np.array([*corners[:, :2].min(axis=0), z])
    return lower, np.array([*corners[:, :2].max(axis=0), z + ROOM_HEIGHT])


def franka_kitchen_scene(path: str | pathlib.Path | None = None) -> tuple[trimesh.Scene, dict[str, str]]:
    """The Franka kitchen as a scene, and the type of each typed node (``node name -> type``).

    Node names are ``f"{body}:{geom index}"``; node metadata holds ``{"type": ...}`` (``None``
    for untyped geoms).  ``scene.metadata["room"]`` is ``(lower, upper)`` of the room over the
    MJCF floor plane (``basic_scene.xml``'s ``floor``, 10 x 10 m about the origin): its x, y
    extent, from the floor up :data:`ROOM_HEIGHT` metres; absent when the model has no finite
    upright plane.

    Every problem with the file (bad XML, missing includes or meshes, bad numbers, nesting too
    deep) is a :class:`MalformedFileError` naming the file; a ``path`` that is not ``None``, a
    ``str`` or an ``os.PathLike`` (or holds a NUL character) is an :class:`WorldGraphError`.
    """
    directory = franka_kitchen_path() if path is None else \
        pathlib.Path(_checks.file_path("path", path, "None, a str or an os.PathLike"))
    try:
        main = directory / _MAIN_FILE if directory.is_dir() else directory
        found = main.is_file()
    except OSError as exc:
        raise ImporterError(f"Franka kitchen model at {_checks._short(str(directory))} cannot be read: "
                            f"{exc}") from exc
    if not found:
        raise ImporterError(f"Franka kitchen model {main} not found; install it with: {_PIP}")
    try:
        return _build_scene(main)
    except WorldGraphError:
        raise
    except RecursionError as exc:
        raise MalformedFileError(f"{main}: MJCF nested too deeply to read") from exc
    except (OSError, ValueError, TypeError, KeyError, IndexError, AttributeError, ArithmeticError,
            np.linalg.LinAlgError) as exc:
        raise MalformedFileError(f"{main}: cannot build the kitchen: {type(exc).__name__}: {exc}") from exc


def _build_scene(main: pathlib.Path) -> tuple[trimesh.Scene, dict[str, str]]:
    model = _parse(main)
    scene = trimesh.Scene()
    cache: dict[str, trimesh.Trimesh] = {}
    types: dict[str, str] = {}
    for g in model.geoms:
        key, mesh = _geometry(g, model, cache)
        if key not in scene.geometry:
            scene.geometry.update({key: mesh})
        node = f"{g.body}:{g.index}"
        typ = _type_of(g)
        scene.graph.update(frame_to=node, frame_from=scene.graph.base_frame, matrix=g.world_from_geom,
                           geometry=key, metadata={"type": typ})
        if typ is not None:
            types[node] = typ
    room = _floor_room(model)
    if room is not None:
        scene.metadata["room"] = room
    return scene, types


def load_franka_kitchen(path: str | pathlib.Path | None = None, max_link_length: float = 5.0,
                        link_margin: float = 0.0) -> WorldModel:
    """The Franka kitchen of gymnasium-robotics as a :class:`WorldModel` (typed geoms only).

    Parameters
    ----------
    path : path, optional
        The ``kitchen_assets`` directory or its ``kitchen_env_model.xml``; default
        :func:`franka_kitchen_path`.

    The model's :attr:`~WorldModel.room` is the box over the MJCF floor plane (see
    :func:`franka_kitchen_scene`), ``None`` if the file has none.
    """
    _checks.real_scalar("max_link_length", max_link_length, positive=True)
    _checks.real_scalar("link_margin", link_margin, minimum=0.0)
    scene, types = franka_kitchen_scene(path)
    return WorldModel.from_trimesh(scene, type_of=lambda node, _geom: types.get(node),
                                   max_link_length=max_link_length, link_margin=link_margin)
