"""A :class:`~perception.KinematicChain` from a URDF file (through the optional yourdfpy).

The URDF's joint tree is walked from the camera link up to the base link; the joints on that
path, from the base down, become the chain. Revolute and continuous joints become
:class:`~perception.Joint` s, fixed joints are folded into the next transform
(``perception._urdf`` reads the file; :meth:`perception.KinematicChain.from_urdf` builds the
chain).
"""

from __future__ import annotations

import os

from numpy.typing import ArrayLike

from .chain import KinematicChain


def chain_from_urdf(
    path: str | os.PathLike[str],
    base_link: str,
    camera_link: str,
    link_from_camera: ArrayLike,
) -> KinematicChain:
    """The chain of a URDF robot from ``base_link`` down to ``camera_link``.

    See :meth:`perception.KinematicChain.from_urdf` (the public entry point) for the parameters,
    the result and the errors.
    """
    return KinematicChain.from_urdf(path, base_link, camera_link, link_from_camera)


__all__ = ["chain_from_urdf"]
