"""Shared test worlds and small geometry helpers of the worldgraph and perception tests.

Each builder here was written out identically in several test files; the tests import it from
here (``from tests.worlds import ...``).  Builders that differ, even by one number, are not
merged: a test keeps its own world.
"""

from __future__ import annotations

import numpy as np

import perception as pc
import worldgraph as wg


def four_type_world() -> wg.WorldModel:
    """20 objects of 4 types (t0-t3, in turn) uniform in a 6 x 6 x 2 m box, seed 0."""
    rng = np.random.default_rng(0)
    types = [f"t{i % 4}" for i in range(20)]
    return wg.WorldModel.from_arrays(types, rng.uniform([0, 0, 0], [6, 6, 2], (20, 3)))


def four_type_world_and_percepts() -> tuple[wg.WorldModel, list[pc.Percept]]:
    """The world of ``four_type_world`` and 10 exact percepts of its first 10 objects, seen from
    (2, 3, 0.5) unrotated, sigma 2 cm."""
    pos = np.random.default_rng(0).uniform([0, 0, 0], [6, 6, 2], (20, 3))
    world = wg.WorldModel.from_arrays([f"t{i % 4}" for i in range(20)], pos)
    return world, [pc.Percept(f"t{i % 4}", pos[i] - [2, 3, 0.5], 0.02) for i in range(10)]


def yaw_pose(yaw: float, t: tuple[float, float, float]) -> np.ndarray:
    """The 4x4 pose of a rotation by ``yaw`` about z and the translation ``t``."""
    c, s = np.cos(yaw), np.sin(yaw)
    M = np.eye(4)
    M[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    M[:3, 3] = t
    return M


def skew(v: np.ndarray) -> np.ndarray:
    """The cross-product matrix of ``v``: ``skew(v) @ w == np.cross(v, w)``."""
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def two_copied_rooms() -> tuple[wg.WorldModel, list[pc.Percept]]:
    """A room of 30 doors, knobs and handles (seed 2) and its copy 20 m along x; 6 exact percepts
    of the first room seen from (2.5, 2, 1), sigma 1 cm."""
    rng = np.random.default_rng(2)
    room = rng.uniform([0, 0, 0], [5, 4, 2], (30, 3))
    types = [("door", "knob", "handle")[i % 3] for i in range(30)]
    world = wg.WorldModel.from_arrays(types * 2, np.vstack([room, room + [20.0, 0.0, 0.0]]))
    percepts = [pc.Percept(types[i], room[i] - [2.5, 2.0, 1.0], 0.01) for i in range(6)]
    return world, percepts
