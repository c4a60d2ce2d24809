"""Figures of a localisation: a top view of the world, the percepts, the hypotheses and the
estimate with its 3-sigma ellipse; camera images with their detections.

matplotlib is an optional dependency (``pip install gaussian-spheres[plots]``, also in the
``examples`` extra); it is imported inside the functions, so ``import worldgraph.figures.plots`` costs
nothing without it, and a call raises :class:`~worldgraph.errors.ImporterError` naming the
extra when it is missing.  Nothing here picks a backend: scripts that write files call
``matplotlib.use("Agg")`` first.

Every type has one colour (:func:`type_colours`): the model objects of a type and the percepts
of that type are drawn in it, in every panel of a figure.  Legends go outside the axes, to the
right, so they never hide data.  Lengths are metres.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TypeGuard

import numpy as np
from numpy.typing import NDArray

from .._checks import _short, as_list, integer, real_array, real_scalar
from .._rigid import rigid_transform
from ..errors import ImporterError, WorldGraphError
from ..localization import LocalizationResult
from ..model import WorldModel
from ..tolerances import PSD_RTOL, SAME_POSITION, SYMMETRY_RTOL, TINY

__all__ = [
    "TYPE_COLOURS",
    "covariance_ellipse",
    "image_view",
    "legend_outside",
    "top_view",
    "type_colours",
]

#: Fixed colours of the types the examples recognise, so that a door is brown in every figure.
TYPE_COLOURS: Mapping[str, str] = {
    "door": "#8c564b",      # brown
    "handle": "#1f77b4",    # blue
    "drawer": "#2ca02c",    # green
    "knob": "#9467bd",      # purple
    "switch": "#e377c2",    # pink
    "lamp": "#bcbd22",      # olive
    "cabinet": "#17becf",   # cyan
    "window": "#ff7f0e",    # orange
}

#: Colours given, in order, to types without a fixed colour (tab20 without greys, and without
#: the red, orange and black used for the estimate, the hypotheses and the truth).
_SPARE_COLOURS = (
    "#aec7e8", "#98df8a", "#c5b0d5", "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5", "#ffbb78",
    "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd", "#31a354", "#756bb1",
)
_OTHER_COLOUR = "0.78"          # objects of types not drawn in colour
_ESTIMATE_COLOUR = "#d62728"    # red: the estimate and its ellipse
_HYPOTHESIS_COLOUR = "#ff7f0e"  # orange: the near-best alternatives
_TRUTH_COLOUR = "black"


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImporterError(
            "worldgraph.figures.plots needs matplotlib: pip install gaussian-spheres[plots] "
            "(the examples extra brings it too)") from exc
    return plt


def type_colours(types: Iterable[str]) -> dict[str, str]:
    """One matplotlib colour per type.

    Types of :data:`TYPE_COLOURS` get their fixed colour; the others, in sorted order, the next
    unused colour of a fixed list (cycling when there are more than 16 of them).

    Parameters
    ----------
    types : iterable of str
        Type names; repeats are allowed.

    Returns
    -------
    dict str -> str
        Colour (a hex string) of each distinct type.

    Raises
    ------
    WorldGraphError
        ``types`` is a string, or holds something other than non-empty strings.
    """
    names = as_list("types", types, "type names")
    for i, t in enumerate(names):
        if not isinstance(t, str | np.str_) or not t:
            raise WorldGraphError(f"types[{i}] must be a non-empty string, got {_short(t)}")
    out = {str(t): TYPE_COLOURS[str(t)] for t in names if str(t) in TYPE_COLOURS}
    spare = [c for c in _SPARE_COLOURS if c not in out.values()]
    for k, t in enumerate(sorted({str(t) for t in names} - out.keys())):
        out[t] = spare[k % len(spare)]
    return out


def covariance_ellipse(center: Any, covariance: Any, *, n_sigma: float = 3.0, **style: Any) -> Any:
    """The ``n_sigma`` ellipse of a 2-D Gaussian as a matplotlib patch (not yet added to axes).

    Its semi-axes are ``n_sigma * sqrt(eigenvalue)`` along the covariance's eigenvectors.

    Parameters
    ----------
    center : (2,) float
        Mean, metres.
    covariance : (2, 2) float
        Symmetric positive semi-definite covariance, m^2.
    n_sigma : float
        Scale of the ellipse, ``> 0``.
    **style
        Passed to :class:`matplotlib.patches.Ellipse` (default: unfilled).

    Returns
    -------
    matplotlib.patches.Ellipse

    Raises
    ------
    WorldGraphError
        - ``center`` or ``covariance`` of the wrong shape, or not finite.
        - ``covariance`` not symmetric or with a negative eigenvalue (beyond rounding).
    """
    _pyplot()
    from matplotlib.patches import Ellipse

    c = real_array("center", center, (2,))
    cov = real_array("covariance", covariance, (2, 2))
    n_sigma = real_scalar("n_sigma", n_sigma, positive=True)
    scale = max(float(np.abs(cov).max()), TINY)
    if abs(cov[0, 1] - cov[1, 0]) > SYMMETRY_RTOL * scale:
        raise WorldGraphError(f"covariance must be symmetric, got {cov.tolist()}")
    eig, vec = np.linalg.eigh(cov)
    if eig[0] < -PSD_RTOL * scale:
        raise WorldGraphError(
            f"covariance must be positive semi-definite, got eigenvalues {eig.tolist()}")
    semi = n_sigma * np.sqrt(np.maximum(eig, 0.0))
    angle = math.degrees(math.atan2(vec[1, 1], vec[0, 1]))  # direction of the major axis
    style = {"fill": False, **style}
    return Ellipse(tuple(c), 2.0 * semi[1], 2.0 * semi[0], angle=angle, **style)


def legend_outside(ax: Any, **kwargs: Any) -> Any:
    """A legend of ``ax`` to the right of its axes box, one entry per label.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    **kwargs
        Passed to :meth:`matplotlib.axes.Axes.legend` (e.g. ``fontsize``).

    Returns
    -------
    matplotlib.legend.Legend or None
        None when nothing in ``ax`` has a label.
    """
    handles, labels = [], []
    for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
        if lab not in labels:
            handles.append(h)
            labels.append(lab)
    if not handles:
        return None
    opts = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0,
            "fontsize": 8, "frameon": False}
    opts.update(kwargs)
    return ax.legend(handles, labels, **opts)


def _percept_list(percepts: Any) -> list[Any]:
    items = as_list("percepts", percepts, "perception.Percept")
    for i, p in enumerate(items):
        if not (isinstance(getattr(p, "type", None), str) and hasattr(p, "position")):
            raise WorldGraphError(f"percepts[{i}] must be a perception.Percept, got {_short(p)}")
    return items


def _finite_pose(value: Any) -> TypeGuard[NDArray[np.float64]]:
    return value is not None and bool(np.all(np.isfinite(value)))


def _heading_arrow(ax: Any, pose: NDArray[np.float64], length: float, **style: Any) -> None:
    """An arrow along the ego x axis (forward) of ``pose`` from its origin."""
    x, y = pose[0, 3], pose[1, 3]
    dx, dy = length * pose[0, 0], length * pose[1, 0]
    ax.annotate("", xy=(x + dx, y + dy), xytext=(x, y),
                arrowprops={"arrowstyle": "-|>", "lw": 1.5, "shrinkA": 0, "shrinkB": 0, **style})


def top_view(
    world: WorldModel,
    *,
    percepts: Sequence[Any] | None = None,
    result: LocalizationResult | None = None,
    ax: Any = None,
    types: Iterable[str] | None = None,
    truth: Any = None,
    pose: Any = None,
    n_hypotheses: int = 5,
    n_sigma: float = 3.0,
    legend: bool = True,
    title: str | None = None,
) -> Any:
    """Top view (x-y plane) of a world, the percepts, the hypotheses and the estimate.

    Draws, each labelled for the legend:

    * the world's bounding box and its objects, those of ``types`` in their type's colour
      (:func:`type_colours`), the rest as small grey dots;
    * the percepts placed in the world by ``pose`` (default: the result's
      ``transformation``), as open circles in their type's colour;
    * the near-best alternative poses (``result.alternatives``) as orange crosses and the
      positions of up to ``n_hypotheses`` further association hypotheses as small orange plus
      signs, each with the hypotheses' heading;
    * the estimate (``result.position``) with its heading and the ``n_sigma`` ellipse of the x-y
      block of ``result.pose_covariance``, whose semi-axes the legend gives in centimetres;
    * the true pose ``truth``, when given, as a black star with its heading.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept, optional
        Percepts in the ego frame (those passed to :func:`~worldgraph.localize`).
    result : LocalizationResult, optional
        What :func:`~worldgraph.localize` returned for ``percepts``.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default a new figure (10 x 7 inches, constrained layout).
    types : iterable of str, optional
        Types drawn in colour; default the percepts' types, or every type of the world when
        there are no percepts.
    truth : (4, 4) float, optional
        True ``world_from_ego``.
    pose : (4, 4) float, optional
        ``world_from_ego`` that places the percepts; default ``result.transformation`` (the
        percepts are not drawn when neither is a finite pose).
    n_hypotheses : int
        Further hypotheses drawn, ``>= 0``.
    n_sigma : float
        Size of the uncertainty ellipse, ``> 0``.
    legend : bool
        Put a legend to the right of the axes (:func:`legend_outside`).
    title : str, optional

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into: equal aspect, axes labelled in metres.

    Raises
    ------
    ImporterError
        matplotlib is not installed.
    WorldGraphError
        - ``world`` not a WorldModel, ``result`` not a LocalizationResult, a percept that is not
          a Percept, a bad ``n_hypotheses``.
        - ``truth`` or ``pose`` not a finite rigid (4, 4) transform.
    """
    plt = _pyplot()
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {_short(world)}")
    if result is not None and not isinstance(result, LocalizationResult):
        raise WorldGraphError(f"result must be a LocalizationResult or None, got {_short(result)}")
    plist = [] if percepts is None else _percept_list(percepts)
    n_hypotheses = integer("n_hypotheses", n_hypotheses, minimum=0)
    n_sigma = real_scalar("n_sigma", n_sigma, positive=True)
    if not isinstance(legend, bool):
        raise WorldGraphError(f"legend must be a bool, got {_short(legend)}")
    truth_t = None if truth is None else rigid_transform("truth", truth)
    if pose is not None:
        place = rigid_transform("pose", pose)
    elif result is not None and _finite_pose(result.transformation):
        place = np.asarray(result.transformation, dtype=np.float64)
    else:
        place = None
    if types is None:
        shown = sorted({p.type for p in plist}) if plist else list(world.type_names)
    else:
        shown = [str(t) for t in as_list("types", types, "type names")]
    colours = type_colours(shown + [p.type for p in plist])

    if ax is None:
        _, ax = plt.subplots(figsize=(10, 7), constrained_layout=True)
    lower, upper = np.asarray(world.bounds)[:, :2]
    ax.plot([lower[0], upper[0], upper[0], lower[0], lower[0]],
            [lower[1], lower[1], upper[1], upper[1], lower[1]], color="0.5", lw=0.8,
            label="world bounds")
    xy = world.positions[:, :2]
    is_shown = np.isin(world.types, shown)
    if np.any(~is_shown):
        ax.scatter(*xy[~is_shown].T, s=3, color=_OTHER_COLOUR, linewidths=0, zorder=1,
                   label=f"other objects ({int(np.sum(~is_shown))})")
    for t in shown:
        idx = world.indices_of(t) if t in world.type_names else np.zeros(0, dtype=np.intp)
        ax.scatter(*xy[idx].T.reshape(2, -1), s=14, color=colours[t], linewidths=0, zorder=2,
                   label=f"{t} ({len(idx)})", gid=f"objects:{t}")

    if plist and place is not None:
        world_xy = np.array([place[:3, :3] @ np.asarray(p.position, dtype=np.float64) + place[:3, 3]
                             for p in plist])[:, :2]
        ptypes = np.array([p.type for p in plist])
        for t in sorted(set(ptypes.tolist())):
            sel = ptypes == t
            ax.scatter(*world_xy[sel].T, s=60, facecolors="none", edgecolors=colours[t],
                       linewidths=1.4, zorder=4, label=f"{t} percepts ({int(sel.sum())})",
                       gid=f"percepts:{t}")

    if result is not None:
        _draw_result(ax, result, n_hypotheses, n_sigma)
    if truth_t is not None:
        ax.plot(*truth_t[:2, 3], "*", color=_TRUTH_COLOUR, ms=13, zorder=6, label="true pose",
                ls="none")
        _heading_arrow(ax, truth_t, 0.6, color=_TRUTH_COLOUR)

    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title is not None:
        ax.set_title(title)
    if legend:
        legend_outside(ax)
    return ax


def _draw_result(ax: Any, result: LocalizationResult, n_hypotheses: int, n_sigma: float) -> None:
    """The alternatives, further hypotheses, the estimate and its ellipse."""
    est = np.asarray(result.transformation, dtype=np.float64)
    have_pose = _finite_pose(est)
    drawn: list[NDArray[np.float64]] = [est[:3, 3]] if have_pose else []
    alts = [np.asarray(a, dtype=np.float64) for a in result.alternatives if _finite_pose(a)]
    if alts:
        pts = np.array([a[:2, 3] for a in alts])
        ax.plot(*pts.T, "x", color=_HYPOTHESIS_COLOUR, ms=10, mew=2, ls="none", zorder=5,
                label=f"near-best alternatives ({len(alts)})")
        for a in alts:
            _heading_arrow(ax, a, 0.4, color=_HYPOTHESIS_COLOUR)
            drawn.append(a[:3, 3])
    others: list[NDArray[np.float64]] = []
    for h in result.hypotheses:
        if len(others) == n_hypotheses:
            break
        T = getattr(h, "world_from_ego", None)
        if not _finite_pose(T) or np.allclose(T, np.eye(4)):
            continue
        if any(np.linalg.norm(T[:3, 3] - d) < SAME_POSITION for d in drawn):
            continue
        others.append(T[:2, 3])
        drawn.append(T[:3, 3])
    if others:
        ax.plot(*np.array(others).T, "+", color=_HYPOTHESIS_COLOUR, ms=8, mew=1.2, ls="none",
                zorder=5, label=f"other hypotheses ({len(others)})")
    if not have_pose:
        return
    ax.plot(*est[:2, 3], "o", mfc="none", mec=_ESTIMATE_COLOUR, mew=2, ms=11, ls="none", zorder=6,
            label=f"estimate ({result.status})")
    _heading_arrow(ax, est, 0.6, color=_ESTIMATE_COLOUR)
    cov = np.asarray(result.pose_covariance, dtype=np.float64)[:2, :2]
    if cov.shape == (2, 2) and np.all(np.isfinite(cov)):
        patch = covariance_ellipse(est[:2, 3], cov, n_sigma=n_sigma, color=_ESTIMATE_COLOUR,
                                   lw=1.5, zorder=6)
        semi = 0.5 * np.array([patch.width, patch.height])
        patch.set_label(f"{n_sigma:g}σ ellipse (semi-axes {100 * semi.max():.1f}, "
                        f"{100 * semi.min():.1f} cm)")
        patch.set_gid("ellipse")
        ax.add_patch(patch)


def image_view(image: Any, detections: Sequence[Any] = (), *, ax: Any = None, bgr: bool = True,
               title: str | None = None, colours: Mapping[str, str] | None = None) -> Any:
    """A camera image with its detections marked at their centroids, coloured by type.

    Parameters
    ----------
    image : (height, width, 3) uint8
        The image, BGR (OpenCV) unless ``bgr=False``.
    detections : sequence of perception.Detection
        Each with ``type`` and ``centroid_uv`` (pixels).
    ax : matplotlib.axes.Axes, optional
        Default: a new figure.
    bgr : bool
        The channels are in OpenCV's BGR order (flipped for display).
    title : str, optional
    colours : mapping str -> colour, optional
        Colour of each type; default :func:`type_colours` of the detections' types.

    Returns
    -------
    matplotlib.axes.Axes
        Pixel axes (u right, v down), labelled in pixels, with a legend below the image.

    Raises
    ------
    ImporterError
        matplotlib is not installed.
    WorldGraphError
        - ``image`` is not an (height, width, 3) array.
        - A detection without ``type`` or ``centroid_uv``.
    """
    plt = _pyplot()
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] == 0 or img.shape[1] == 0:
        raise WorldGraphError(f"image must be an (height, width, 3) array, got shape {img.shape}")
    dets = as_list("detections", detections, "perception.Detection")
    for i, d in enumerate(dets):
        if not (isinstance(getattr(d, "type", None), str) and hasattr(d, "centroid_uv")):
            raise WorldGraphError(f"detections[{i}] must be a perception.Detection, got {_short(d)}")
    if colours is None:
        colours = type_colours([d.type for d in dets])
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5), constrained_layout=True)
    ax.imshow(img[:, :, ::-1] if bgr else img)
    for t in sorted({d.type for d in dets}):
        uv = np.array([d.centroid_uv for d in dets if d.type == t])
        # a white halo under the coloured ring keeps it visible on a same-coloured region
        ax.scatter(*uv.T, s=90, facecolors="none", edgecolors="white", linewidths=4.0)
        ax.scatter(*uv.T, s=90, facecolors="none", edgecolors=colours[t], linewidths=2.0,
                   label=f"{t} detections ({len(uv)})", gid=f"detections:{t}")
    ax.set_xlim(-0.5, img.shape[1] - 0.5)
    ax.set_ylim(img.shape[0] - 0.5, -0.5)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    if title is not None:
        ax.set_title(title)
    if dets:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3, fontsize=8, frameon=False)
    return ax
