"""Logging a localisation to `rerun <https://rerun.io>`_: the world's objects, the percepts, the
estimated pose and its 3-sigma position ellipsoid, as 3D entities a rerun viewer shows.

rerun-sdk is an optional dependency (``pip install gaussian-spheres[rerun]``); it is imported
inside :func:`log_rerun`, so ``import worldgraph`` never loads it, and a call raises
:class:`~worldgraph.errors.ImporterError` naming the extra when it is missing.  Nothing here
spawns a viewer: the caller chooses the recording's sink (``RecordingStream.save(path)`` for an
``.rrd`` file, ``spawn()`` or ``connect_grpc()`` for a live viewer).

The entities, under ``prefix`` (default ``"world"``), in world coordinates (metres):

=================================  ========================================================
``/{prefix}/objects/{type}``       ``Points3D``: the objects of one type, labelled with their
                                   ids, in the type's colour of :mod:`worldgraph.figures.plots`
                                   (static: logged once for every timeline)
``/{prefix}/percepts/{type}``      ``Points3D``: the percepts of one type placed in the world
                                   by the estimated pose (a result with a pose given)
``/{prefix}/percepts_ego/{type}``  ``Points3D``: the same in the ego frame, when there is no
                                   pose to place them
``/{prefix}/estimate``             ``Transform3D`` (``world_from_ego``) with
                                   ``TransformAxes3D``: the estimated pose as three axes
``/{prefix}/estimate_3sigma``      ``Ellipsoids3D``: the ``n_sigma`` ellipsoid of the
                                   estimate's position covariance
``/{prefix}/truth``                ``Transform3D`` with ``TransformAxes3D``: the true pose,
                                   when given
=================================  ========================================================

Type names are escaped as entity-path parts (``rerun.escape_entity_path_part``).  rerun stores
positions as 32-bit floats (about 1e-6 relative precision).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from perception import Percept

from .._checks import _short, name_string, percept_list, real_scalar
from .._rigid import rigid_transform
from ..errors import ImporterError, WorldGraphError
from ..localization import LocalizationResult
from ..model import WorldModel
from .plots import type_colours

__all__ = ["log_rerun"]

#: Point radii (metres) of the world's objects and of the percepts in the viewer.
OBJECT_RADIUS = 0.03
PERCEPT_RADIUS = 0.05
#: Length (metres) of the axes drawn at the estimated pose.
AXIS_LENGTH = 0.5
_ESTIMATE_RGB = (214, 39, 40)  # the red of worldgraph.figures.plots' estimate and ellipse


#: Oldest rerun-sdk release :func:`log_rerun` is known to work with (pyproject's ``rerun`` extra).
MIN_RERUN_VERSION = (0, 41)


def _rerun() -> Any:
    need = ".".join(map(str, MIN_RERUN_VERSION))
    try:
        import rerun
    except ImportError as exc:
        raise ImporterError(
            "worldgraph.figures.rerun_log.log_rerun needs rerun-sdk: pip install gaussian-spheres[rerun] "
            f"(rerun-sdk >= {need}, which needs Python >= 3.11)") from exc
    version = str(getattr(rerun, "__version__", "0"))
    numbers = tuple(int(x) if x.isdigit() else 0 for x in version.split(".")[:2])
    if numbers < MIN_RERUN_VERSION:
        raise ImporterError(f"worldgraph.figures.rerun_log.log_rerun needs rerun-sdk >= {need}, "
                            f"found {version}: pip install -U gaussian-spheres[rerun]")
    return rerun


def _rgb(hex_colour: str) -> tuple[int, int, int]:
    """``"#rrggbb"`` as three 0-255 integers."""
    h = hex_colour.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)


def _prefix_path(prefix: Any) -> str:
    prefix = name_string("prefix", prefix)
    parts = prefix.strip("/").split("/")
    for i, part in enumerate(parts):
        if not part:
            raise WorldGraphError(
                f"prefix must be an entity path of non-empty parts separated by '/', got "
                f"{prefix!r} (part {i} is empty)")
    return "/" + "/".join(parts)


def _percepts(percepts: Any) -> list[Percept]:
    return percept_list("percepts", percepts)


def _ellipsoid(covariance: NDArray[np.float64], n_sigma: float) -> tuple[NDArray[np.float64],
                                                                           NDArray[np.float64]]:
    """Semi-axes ``(3,)`` and the ``(x, y, z, w)`` quaternion of the frame of the
    ``n_sigma`` ellipsoid of a 3x3 covariance (its eigenvectors, made right-handed)."""
    sym = 0.5 * (covariance + covariance.T)
    eig, vec = np.linalg.eigh(sym)
    if np.linalg.det(vec) < 0.0:
        vec[:, 0] = -vec[:, 0]
    semi = n_sigma * np.sqrt(np.maximum(eig, 0.0))
    return semi, Rotation.from_matrix(vec).as_quat()


def log_rerun(
    world: WorldModel,
    percepts: Sequence[Percept] | None = None,
    result: LocalizationResult | None = None,
    *,
    recording: Any = None,
    prefix: str = "world",
    n_sigma: float = 3.0,
    truth: Any = None,
) -> list[str]:
    """Log a world, its percepts and a pose estimate to a rerun recording.

    The world's objects become one ``Points3D`` entity per type (labels: the object ids;
    colours: :func:`worldgraph.figures.plots.type_colours`, as in the figures), logged static.  The
    percepts, the estimate (``Transform3D`` of ``result.transformation`` with axes) and its
    ``n_sigma`` position ellipsoid (``Ellipsoids3D`` of ``result.covariance``, whose label also
    gives ``result.rotation_3sigma``) are logged at the recording's current time, so that calls
    after ``recording.set_time(...)`` make a time series.  The module docstring lists the
    entity paths.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept, optional
        Percepts in the ego frame (those passed to :func:`~worldgraph.localize`).  They are
        placed in the world by ``result.transformation`` when the result has a pose, and
        logged in the ego frame under ``percepts_ego`` otherwise.
    result : LocalizationResult, optional
        What :func:`~worldgraph.localize` returned.  Without a pose (``result.has_pose``
        false) no estimate is logged.
    recording : rerun.RecordingStream, optional
        Where to log; default the active recording (``rerun.get_data_recording()``: the
        thread-local one, else the global one of ``rerun.init``).
    prefix : str
        Entity path the entities go under, parts separated by ``/``.
    n_sigma : float
        Size of the position ellipsoid, ``> 0``.
    truth : (4, 4) float, optional
        True ``world_from_ego`` (simulations), logged as axes beside the estimate's.

    Returns
    -------
    list of str
        The entity paths logged, in the order logged (``"/world/objects/door"``, ...).

    Raises
    ------
    ImporterError
        rerun-sdk is not installed (``pip install gaussian-spheres[rerun]``).
    WorldGraphError
        - ``world`` not a WorldModel, ``percepts`` not a sequence of Percept (naming the index),
          ``result`` not a LocalizationResult, ``recording`` not a ``rerun.RecordingStream``,
          ``recording`` omitted with no active recording, or a bad ``prefix``.
        - ``n_sigma`` not a positive finite number.
        - ``truth`` not a finite rigid (4, 4) transform.

    Examples
    --------
    >>> import rerun as rr                                          # doctest: +SKIP
    >>> rec = rr.RecordingStream("kitchen")                         # doctest: +SKIP
    >>> rec.save("out/kitchen.rrd")                                 # doctest: +SKIP
    >>> log_rerun(world, percepts, localize(world, percepts), recording=rec)  # doctest: +SKIP
    """
    rr = _rerun()
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {_short(world)}")
    plist = [] if percepts is None else _percepts(percepts)
    if result is not None and not isinstance(result, LocalizationResult):
        raise WorldGraphError(f"result must be a LocalizationResult or None, got {_short(result)}")
    if recording is not None and not isinstance(recording, rr.RecordingStream):
        raise WorldGraphError(f"recording must be a rerun.RecordingStream or None, got {_short(recording)}")
    root = _prefix_path(prefix)
    n_sigma = real_scalar("n_sigma", n_sigma, positive=True)
    truth_t = None if truth is None else rigid_transform("truth", truth)
    rec = rr.get_data_recording(recording)
    if rec is None:
        raise WorldGraphError(
            "recording is None and there is no active rerun recording: call rerun.init(...) first "
            "or pass recording=rerun.RecordingStream(...)")

    colours = {t: _rgb(c) for t, c in
               type_colours(list(world.type_names) + [p.type for p in plist]).items()}
    logged: list[str] = []

    def log(path: str, *archetypes: Any, static: bool = False) -> None:
        rec.log(path, *archetypes, static=static)
        logged.append(path)

    ids = np.array([o.id for o in world.objects], dtype=object)
    for t in world.type_names:
        idx = world.indices_of(t)
        log(f"{root}/objects/{rr.escape_entity_path_part(t)}",
            rr.Points3D(world.positions[idx], colors=[colours[t]] * len(idx),
                        labels=ids[idx].tolist(), radii=OBJECT_RADIUS),
            static=True)

    pose = None
    if result is not None and result.has_pose:
        pose = np.asarray(result.transformation, dtype=np.float64)

    if plist:
        ego = np.array([p.position for p in plist], dtype=np.float64).reshape(-1, 3)
        if pose is not None:
            where, pts = "percepts", ego @ pose[:3, :3].T + pose[:3, 3]
        else:
            where, pts = "percepts_ego", ego
        ptypes = np.array([p.type for p in plist])
        for t in sorted(set(ptypes.tolist())):
            sel = np.flatnonzero(ptypes == t)
            labels = [f"percept {i} ({t}, sigma {100 * plist[i].sigma:.1f} cm)" for i in sel.tolist()]
            log(f"{root}/{where}/{rr.escape_entity_path_part(t)}",
                rr.Points3D(pts[sel], colors=[colours[t]] * len(sel), labels=labels,
                            radii=PERCEPT_RADIUS))

    if pose is not None and result is not None:
        log(f"{root}/estimate",
            rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3]),
            rr.TransformAxes3D(AXIS_LENGTH))
        cov = np.asarray(result.covariance, dtype=np.float64)
        if cov.shape == (3, 3) and np.all(np.isfinite(cov)):
            semi, quat = _ellipsoid(cov, n_sigma)
            rot = result.rotation_3sigma
            rot_text = "" if math.isnan(rot) else f"; rotation 3σ {math.degrees(rot):.2f} deg"
            label = (f"{n_sigma:g}σ position ({result.status}): semi-axes "
                     + ", ".join(f"{100 * s:.1f}" for s in semi) + f" cm{rot_text}")
            log(f"{root}/estimate_3sigma",
                rr.Ellipsoids3D(centers=[pose[:3, 3]], half_sizes=[semi], quaternions=[quat],
                                colors=[_ESTIMATE_RGB], labels=[label]))
    if truth_t is not None:
        log(f"{root}/truth", rr.Transform3D(translation=truth_t[:3, 3], mat3x3=truth_t[:3, :3]),
            rr.TransformAxes3D(AXIS_LENGTH))
    return logged
