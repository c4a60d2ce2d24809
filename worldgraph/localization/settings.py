"""The settings of one localisation, checked once: :class:`LocalizeSettings`.

:func:`~worldgraph.localize`, :func:`~worldgraph.tiles.localize_tiled`,
:meth:`ClusterTiles.localize <worldgraph.tiles.ClusterTiles.localize>` and
:func:`~worldgraph.active_localize` take these settings as keywords or as one object
(``settings=``), build the object once and hand it down to every tile, worker and look.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

import radialopt as ro

from .._checks import _short, real_array, real_scalar
from ..errors import WorldGraphError
from ..pose.gravity import Gravity, SearchPlan, TiltPrior, check_gravity, check_up_sigma
from ..tolerances import ASSOCIATION_TOLERANCES, AssociationTolerances, _resolved_tol

__all__ = [
    "LOCALIZE_METHODS",
    "MAX_POSITION_3SIGMA",
    "MAX_ROTATION_3SIGMA",
    "LocalizeSettings",
]

#: ``"ml"``: the maximum-likelihood 6D pose from the full 3D percepts (their covariances);
#: ``"spheres"``: the range-only maximum-likelihood position of the Gaussian spheres
#: (``radialopt`` method ``"ml"``), then the rotation; ``"paper"``: the paper's association and
#: its radial-projection position; ``"srls"``, ``"gradient"``: other range-only estimators.
LOCALIZE_METHODS = ("ml", "spheres", "paper", "srls", "gradient")
#: Default largest 3-sigma position bound (m, along the worst direction) of an "ok" pose, and ...
MAX_POSITION_3SIGMA = 0.25
#: ... of the rotation (rad, about the worst axis).  Chosen for a mobile manipulator's global
#: localisation: good enough to drive to a cabinet and turn the head to the handle it wants
#: (5 degrees move a handle 2 m away by 17 cm, which the head camera then finds and servoes on);
#: tighten both for grasping from the global pose alone.
MAX_ROTATION_3SIGMA = math.radians(5.0)


@dataclass(frozen=True)
class LocalizeSettings:
    """Every setting of a localisation but the world, the percepts and the random generator,
    checked when it is made.

    The fields are the keywords of :func:`~worldgraph.localize` (its docstring says what each
    does); a field left out takes the same default.  Make one for a robot and pass it to every
    call::

        settings = LocalizeSettings(method="ml", gravity=(0.0, 0.0, 1.0), max_rotation_3sigma=0.05)
        result = localize(world, percepts, settings=settings)
        batch = cluster_tiles.localize_many(queries, settings=settings)

    ``dataclasses.replace(settings, method="paper")`` gives a checked copy with one field
    changed.

    Parameters
    ----------
    method : {"ml", "spheres", "paper", "srls", "gradient"}
    tol : AssociationTolerances, optional
        None: :data:`~worldgraph.tolerances.ASSOCIATION_TOLERANCES`.
    region : radialopt.Region or (lower, upper), optional
        A pair of 3-vectors becomes a Region.  None: :func:`~worldgraph.localization.default_region` of each
        world (each tile's own).
    max_position_3sigma, max_rotation_3sigma : float
        Metres and radians (> 0; the rotation at most pi).
    solver : str
        ``"active_set"`` or an installed cvxpy solver's name (kept in upper case).
    check, certify : bool
    gravity : "auto", (3,) float or None
        A vector is kept as a tuple of floats (so that settings compare equal field by field).
    up_sigma : float, optional
        Radians; None: ``tol.tilt_allowance / TILT_PRIOR_SIGMAS``; ``math.inf``: no tilt prior.

    Attributes
    ----------
    plan : SearchPlan
        The search ``gravity`` asks for (its up vector, levelling rotation and whether ``"auto"``
        may fall back to the free search).
    tilt_sd : float
        The tilt prior's standard deviation (rad) that ``up_sigma`` resolves to.

    Raises
    ------
    WorldGraphError
        A field of the wrong kind or out of range, named with its value.
    """

    method: str = "ml"
    tol: AssociationTolerances = ASSOCIATION_TOLERANCES
    region: ro.Region | None = None
    max_position_3sigma: float = MAX_POSITION_3SIGMA
    max_rotation_3sigma: float = MAX_ROTATION_3SIGMA
    solver: str = "active_set"
    check: bool = False
    certify: bool = False
    gravity: Gravity = "auto"
    up_sigma: float | None = None
    plan: SearchPlan = field(init=False, repr=False, compare=False)
    tilt_sd: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        method = self.method
        if not isinstance(method, str) or method not in LOCALIZE_METHODS:
            raise WorldGraphError(f"method must be one of {LOCALIZE_METHODS}, got {method!r}")
        tol = _resolved_tol(self.tol)
        solver = self.solver
        if not isinstance(solver, str):
            raise WorldGraphError(f"solver must be 'active_set' or a cvxpy solver name, got {solver!r}")
        solver_name = solver if solver == "active_set" else solver.upper()
        if solver_name != "active_set" and solver_name not in ro.installed_cvxpy_solvers():
            raise WorldGraphError(f"solver {solver!r} is neither 'active_set' nor an installed cvxpy solver "
                                  f"({', '.join(ro.installed_cvxpy_solvers())})")
        for name in ("check", "certify"):
            value = getattr(self, name)
            if not isinstance(value, bool | np.bool_):
                raise WorldGraphError(f"{name} must be a bool, got {value!r}")
        pos_tol = real_scalar("max_position_3sigma", self.max_position_3sigma, positive=True)
        rot_tol = real_scalar("max_rotation_3sigma", self.max_rotation_3sigma, positive=True)
        if rot_tol > math.pi:
            raise WorldGraphError(f"max_rotation_3sigma = {rot_tol!r} is an angle in radians and must be "
                                  f"<= pi; did you mean degrees? np.radians({rot_tol:g}) = "
                                  f"{math.radians(rot_tol):.4g}")
        plan = check_gravity(self.gravity, tol)
        gravity = self.gravity
        if not (gravity is None or isinstance(gravity, str)):
            gravity = tuple(float(g) for g in real_array("gravity", gravity, (3,)))
        tilt_sd = check_up_sigma(self.up_sigma, tol)
        checked = {"tol": tol, "region": _check_region(self.region), "max_position_3sigma": pos_tol,
                   "max_rotation_3sigma": rot_tol, "solver": solver_name, "check": bool(self.check),
                   "certify": bool(self.certify), "gravity": gravity, "plan": plan, "tilt_sd": tilt_sd}
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @property
    def tilt_prior(self) -> TiltPrior | None:
        """Gravity as a prior of the ML pose: only when the gravity search answers (not the free
        search) and ``up_sigma`` is finite."""
        if self.plan.up is None or not math.isfinite(self.tilt_sd):
            return None
        return TiltPrior(self.plan.up, self.tilt_sd)

    def free_search(self) -> LocalizeSettings:
        """These settings for the free 3D search (``gravity=None``): the pass ``"auto"`` falls
        back to."""
        return replace(self, gravity=None)


def settings_of(settings: object, **keywords: Any) -> LocalizeSettings:
    """The settings of a call: ``settings`` (a :class:`LocalizeSettings`, or None for the
    defaults) with every keyword that differs from its default put in its field.

    ``keywords`` are the call's setting keywords by field name; ``tol=None`` and ``region=None``
    are their defaults."""
    if settings is not None and not isinstance(settings, LocalizeSettings):
        raise WorldGraphError(f"settings must be None or a worldgraph.LocalizeSettings, "
                              f"got {_short(settings)}")
    given = {name: value for name, value in keywords.items() if not _is_default(name, value)}
    if settings is None:
        return LocalizeSettings(**given)
    return replace(settings, **given) if given else settings


_DEFAULTS = {f.name: f.default for f in fields(LocalizeSettings) if f.init}


def _is_default(name: str, value: object) -> bool:
    if name not in _DEFAULTS:
        raise WorldGraphError(f"{name!r} is not a field of LocalizeSettings")  # a programming error here
    if value is None:
        return name in ("tol", "region", "up_sigma")
    default = _DEFAULTS[name]
    if isinstance(value, np.ndarray) or type(value) is not type(default):
        return False
    return bool(value == default)


def _check_region(region: object) -> ro.Region | None:
    """None, a radialopt.Region, or a ``(lower, upper)`` pair of 3-vectors (metres)."""
    if region is None or isinstance(region, ro.Region):
        return region
    if isinstance(region, tuple | list) and len(region) == 2:
        lo = real_array("region[0]", region[0], (3,))
        hi = real_array("region[1]", region[1], (3,))
        try:
            return ro.Region(lo, hi)
        except ro.RadialError as exc:
            raise WorldGraphError(f"region (lower, upper) is not a box: {exc}") from exc
    raise WorldGraphError(f"region must be None, a radialopt.Region or a (lower, upper) pair of 3-vectors, "
                          f"got {type(region).__name__}")
