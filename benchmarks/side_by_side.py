"""Same outputs before and after a change that should not alter them (a restructuring).

Writes, as sorted JSON, the ``to_dict()`` output of ``localize`` (methods "ml" and "paper"),
the direction of ``plan_view`` and every result of ``active_localize`` (two looks of at most 4
percepts, each object seen with probability 0.6, as in ``benchmarks/active_validation.py``) on
seeded views of the paper's kitchen (15) and a galley layout (6), the digests of both worlds'
``to_dict()``, of a kitchen read back by ``WorldModel.from_file`` and the result of
``localize_tiled``; timings are dropped and floats kept to 10 significant digits. Run it in two
checkouts and compare the files:

    python benchmarks/side_by_side.py before.json     # in the checkout before the change
    python benchmarks/side_by_side.py after.json      # after it
    cmp before.json after.json                        # silent when the outputs are the same
"""

from __future__ import annotations

import argparse
import hashlib
import json
import tempfile
from pathlib import Path

import numpy as np
from active_validation import MAX_RANGE, PERCEPT_TYPES, _looker, _pose  # benchmarks/active_validation.py

import worldgraph as wg
from perception.simulation.simulate import simulate_percepts

DEPTH_FACTOR = 500.0


def _plain(value):
    """``value`` without timings, floats to 10 significant digits."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items() if "time" not in k and "timing" not in k}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, float):
        return float(f"{value:.10g}")
    return value


def _digest(value) -> str:
    return hashlib.sha256(json.dumps(_plain(value), sort_keys=True).encode()).hexdigest()


def outputs() -> dict:
    out: dict = {}
    worlds = {"kitchen0": wg.scenes.kitchen(seed=0), "galley1": wg.scenes.kitchen_layout("galley", seed=1)}
    percepts: list = []
    for name, world in worlds.items():
        out[f"{name}/world"] = _digest(world.to_dict())
        mask = np.isin(world.types, PERCEPT_TYPES)
        types, positions = list(world.types[mask]), world.positions[mask]
        lo, hi = world.bounds
        rng = np.random.default_rng(7)
        for view in range(15 if name == "kitchen0" else 6):
            pose = _pose(rng, lo, hi)
            percepts, _ = simulate_percepts(types, positions, pose, rng, depth_factor=DEPTH_FACTOR,
                                            max_range=MAX_RANGE, n_false=1, false_types=sorted(set(types)))
            percepts = percepts[:9]
            if len(percepts) < 3:
                continue
            for method in ("ml", "paper"):
                try:
                    result = wg.localize(world, percepts, method=method)
                    out[f"{name}/{view}/{method}"] = _plain(result.to_dict())
                except wg.WorldGraphError as exc:
                    out[f"{name}/{view}/{method}"] = repr(exc)
            plan = wg.plan_view(world, wg.localize(world, percepts))
            out[f"{name}/{view}/plan"] = _plain([float(x) for x in plan.direction])
            look = _looker(types, positions, pose, np.random.default_rng(view), DEPTH_FACTOR,
                           detection=0.6, cap=4)
            active = wg.active_localize(world, percepts, look, max_looks=2, types=PERCEPT_TYPES)
            out[f"{name}/{view}/active"] = _plain([r.to_dict() for r in active.results])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "kitchen.glb"
        write = getattr(getattr(wg, "importers", None), "write_scene", None)
        if write is not None:  # +Y up, as glTF is and from_file reads it
            write(wg.scenes.kitchen_scene(seed=2), path)
        else:  # an older checkout, before GLB files were Y-up: z-up GLB files, read as they are
            wg.scenes.kitchen_scene(seed=2).export(path)
        out["from_file"] = _digest(wg.WorldModel.from_file(path).to_dict())
    kitchen = worlds["kitchen0"]
    halves = (kitchen.positions[:, 0] > np.median(kitchen.positions[:, 0])).astype(int)
    out["tiles"] = _plain(wg.localize_tiled(wg.tiles.split(kitchen, halves, halo=2.0), percepts).to_dict())
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path, help="the JSON file to write")
    args = ap.parse_args(argv)
    found = outputs()
    args.out.write_text(json.dumps(found, sort_keys=True, indent=0))
    print(f"{len(found)} outputs written to {args.out}")


if __name__ == "__main__":
    main()
