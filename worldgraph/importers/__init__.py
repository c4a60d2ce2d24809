"""World models from scene files: :meth:`WorldModel.from_file <worldgraph.WorldModel.from_file>`.

:func:`scene_from_file` reads a file into a :class:`trimesh.Scene` with one named geometry node
per candidate object, :func:`world_from_file` types the nodes by name and builds the world with
:meth:`WorldModel.from_trimesh <worldgraph.WorldModel.from_trimesh>` (so the object position is
the world position of the centre of the node geometry's bounding box, as there).  The scene is
kept as :attr:`WorldModel.scene <worldgraph.WorldModel.scene>`.

Formats, chosen by the file suffix (or ``file_format``):

* ``.glb``, ``.gltf``, ``.ply``, ``.stl``, ``.off``, ``.dae``: :func:`trimesh.load_scene`; the
  candidates are the scene's geometry nodes, named as in the file (a single-mesh file such as a
  PLY gives one node named after the file).  ``.dae`` needs ``pycollada``.
* ``.obj``: read here, not by trimesh's OBJ loader (whose grouping depends on the trimesh
  version and merges ``o`` and ``g`` names): every ``o NAME`` or ``g NAME`` line starts a new
  part named ``NAME`` (the first name of the line), the faces up to the next such line are
  its mesh (polygons as triangle fans, negative indices as in the OBJ format, ``v/vt/vn``
  references read for ``v``); faces before the first ``o``/``g`` line form a part named after
  the file.  Materials, textures and normals are not read.
* ``.xml``, ``.mjcf``: MJCF, compiled by MuJoCo (``mujoco.MjModel.from_xml_path``, then
  ``mujoco.MjData`` and ``mujoco.mj_forward`` at the model's reference configuration
  ``qpos0``), so any MJCF MuJoCo reads works.  Needs the ``mjcf`` extra
  (``pip install gaussian-spheres[mjcf]``).  ``mjcf_objects`` says what a candidate is:

  - ``"bodies"`` (default): every named body but the world body, its node holding the
    body's *visual* geoms in the body frame (``data.xpos``, ``data.xmat``), and every named
    geom of the world body (static geometry such as a ``floor`` plane, which gives the room)
    as its own node.  A body's visual geoms are those MuJoCo draws by default: geom group 0,
    1 or 2 (``mjvOption.geomgroup``) and a colour with alpha > 0 (the geom's ``rgba``, or its
    material's when the geom has a material and the default ``rgba``); when the body has
    visual geoms that do not collide (``contype == 0`` and ``conaffinity == 0``) besides
    colliding ones, only the non-colliding ones (the usual visual/collision split).  A body
    whose name the type rule types also holds the visual geoms of its *untyped descendants*
    (child bodies, recursively, stopping at typed descendants, which are their own objects):
    a typed ``microwave`` body takes the geoms of its untyped door body.  A body with no such
    geom keeps all its own geoms (so nothing disappears), and a body without geoms is a single
    point at its origin.  :func:`scene_from_file` has no type rule: there each body holds its
    own visual geoms only.  The rule is :func:`perception.mujoco.object_geoms`, which
    :class:`perception.mujoco.MujocoScene` shares, so a simulated scan and the world model
    read from one file agree on every object centre;
  - ``"geoms"``: every geom, its node in the geom frame (``data.geom_xpos``,
    ``data.geom_xmat``), named by the geom's name, or ``f"{body}:{k}"`` for an unnamed geom,
    the ``k``-th geom of its body in file order (the node names of
    :func:`worldgraph.importers.franka.franka_kitchen_scene`).

  Geom shapes: boxes, spheres, ellipsoids, cylinders and capsules as trimesh primitives of the
  geom's size; meshes with their vertices as written in the asset file (MuJoCo's re-centring
  on the mesh's inertia frame undone with ``mesh_pos`` / ``mesh_quat``, so the box centre is
  that of the authored mesh); finite planes as flat rectangles; infinite planes are left
  out; height fields and other types as their bounding box ``geom_aabb``.  The compiled
  ``MjModel`` and ``MjData`` are kept in ``scene.metadata["mujoco_model"]`` and
  ``scene.metadata["mujoco_data"]``.

Up axis (``up_axis``): the world is z up (against gravity, docs/conventions.md), and each
file is turned so from its own convention unless ``up_axis`` says otherwise (one of
:data:`UP_AXES`, the file axis that points up; :func:`default_up_axis` gives the default):

* glTF/GLB: +Y, as the glTF 2.0 specification fixes it (and Blender, three.js and most
  exporters write it); turned by ``(x, y, z) -> (x, -z, y)`` (:func:`z_up_from`).  trimesh
  itself reads glTF coordinates as they are, and ``trimesh.Scene.export`` writes a scene's
  coordinates as they are: :func:`write_scene` writes a z-up scene (e.g. of
  :mod:`worldgraph.scenes`) +Y up, so that others read it upright and ``from_file`` reads the
  same world back; a z-up GLB written by ``scene.export`` reads back with ``up_axis="+z"``;
* COLLADA (``.dae``): its ``<asset><up_axis>`` (``X_UP``, ``Y_UP``, ``Z_UP``; absent means
  ``Y_UP``, the COLLADA default).  trimesh ignores the element (checked with trimesh 5.2), so it
  is read here;
* MJCF: +Z (MuJoCo's default gravity is -z);
* OBJ, PLY, STL, OFF: the formats carry no up axis; read as written, +Z, the convention of CAD
  and robot meshes (ROS, URDF).  Files exported +Y up (a choice many OBJ exporters offer:
  Blender's asks for Forward/Up axes) need ``up_axis="+y"``.

A world that still looks like a room on its side (a flat floor whose thin axis is horizontal,
or objects spread along z far more than sideways) gets a :class:`UserWarning` naming the likely
``up_axis=`` to pass.

Types (``type_of``):

* ``None`` (default): :func:`default_type_of` -- a node's ``metadata["type"]`` when the file
  carries one (glTF node extras, as written by :mod:`worldgraph.scenes`; ``None`` there skips
  the node), else the leading word of its name (the letters before the first character that
  is not a letter, lower-cased: ``"door_1"``, ``"Door.001"``, ``"knob 3"``, ``"handle:0"``) when
  it is one of :data:`KNOWN_TYPES`;
* a callable ``name -> type or None`` (``None`` skips the node);
* a mapping ``regex pattern -> type``: the first pattern (in mapping order) that
  :func:`re.search` finds in the name gives the type; no match skips the node.  Anchor with
  ``^``/``$`` and add ``(?i)`` for case-insensitive matching as needed.

Errors (all :class:`~worldgraph.errors.WorldGraphError`): a missing file, an unknown suffix
and a file trimesh or MuJoCo cannot read are :class:`~worldgraph.errors.MalformedFileError`
naming the path; a file in which no candidate gets a type is an
:class:`~worldgraph.errors.WorldGraphError` naming the path and the names seen; a missing
optional package (``mujoco``, ``pycollada``) is an :class:`~worldgraph.errors.ImporterError`
naming what to install.

Where things live: :mod:`worldgraph.model.scene_files` reads the files into typed scenes
(the formats, :func:`scene_from_file`; the names are importable from here; the typing rules
:data:`KNOWN_TYPES`, :func:`default_type_of` and :func:`type_rule` are defined in
:mod:`perception.type_rules`, shared with :mod:`perception.mujoco`, and re-exported here),
below the world model, whose :meth:`~worldgraph.WorldModel.from_file` calls it;
:mod:`worldgraph.importers.franka` builds the Franka kitchen;
:func:`world_from_file` is defined here.
"""

from __future__ import annotations

import os
from typing import Any

from ..model import WorldModel
from ..model.scene_files import (
    KNOWN_TYPES,
    MJCF_OBJECTS,
    MJCF_SUFFIXES,
    OBJ_SUFFIXES,
    TRIMESH_SUFFIXES,
    UP_AXES,
    default_type_of,
    default_up_axis,
    scene_from_file,
    turn_scene,
    type_rule,
    write_scene,
    z_up_from,
)

__all__ = [
    "KNOWN_TYPES",
    "MJCF_OBJECTS",
    "MJCF_SUFFIXES",
    "OBJ_SUFFIXES",
    "TRIMESH_SUFFIXES",
    "UP_AXES",
    "default_type_of",
    "default_up_axis",
    "scene_from_file",
    "turn_scene",
    "type_rule",
    "world_from_file",
    "write_scene",
    "z_up_from",
]


def world_from_file(path: str | os.PathLike[str], type_of: Any = None, *, max_link_length: float = 5.0,
                    link_margin: float = 0.0, room: Any = "auto", mjcf_objects: str = "bodies",
                    file_format: str | None = None, world_class: type[WorldModel] | None = None,
                    up_axis: str | None = None) -> WorldModel:
    """World model from a scene file (GLB/GLTF/OBJ/PLY/STL/OFF/DAE or MJCF).

    Parameters
    ----------
    path : str or os.PathLike
        The scene file; its suffix selects the reader (module docstring).
    type_of : None, callable or mapping
        How names become types: ``None`` for :func:`default_type_of` (node metadata first),
        a callable ``name -> type or None``, or a mapping ``regex pattern -> type`` (first
        pattern found in the name wins).  Nodes without a type are not objects.
    max_link_length, link_margin : float
        See :class:`~worldgraph.WorldModel`.
    room : "auto", radialopt.Region, (lower, upper) or None
        As in :meth:`~worldgraph.WorldModel.from_trimesh`.
    mjcf_objects : {"bodies", "geoms"}
        For MJCF: one candidate per named body or per geom (module docstring).
    file_format : str, optional
        Suffix to use instead of the path's.
    world_class : type, optional
        The :class:`~worldgraph.WorldModel` subclass to build (default ``WorldModel``).
    up_axis : {"+x", "-x", "+y", "-y", "+z", "-z"}, optional
        The file axis that points up; default the format's convention (module docstring:
        glTF/GLB +Y, COLLADA its ``<up_axis>``, MJCF/OBJ/PLY/STL/OFF +Z).

    Returns
    -------
    WorldModel
        One object per typed node, positioned at the world centre of the node geometry's
        bounding box; :attr:`~worldgraph.WorldModel.scene` is the scene read.

    Raises
    ------
    MalformedFileError
        Missing file, unknown suffix, unreadable file.
    WorldGraphError
        - No node got a type; the message names the path and the names seen.
        - A bad ``type_of``, ``mjcf_objects`` or ``file_format``.
        - A bad ``up_axis``, naming it.
    ImporterError
        A needed optional package is missing (``mujoco``: ``pip install gaussian-spheres[mjcf]``).

    Warns
    -----
    UserWarning
        The world looks like a room on its side; the message names the likely ``up_axis``.
    """
    cls = WorldModel if world_class is None else world_class
    return cls.from_file(path, type_of, max_link_length=max_link_length, link_margin=link_margin, room=room,
                         mjcf_objects=mjcf_objects, file_format=file_format, up_axis=up_axis)
