"""Tile files and the cluster-resident map (worldgraph.tiles.files, worldgraph.tiles.cluster): the files
round-trip, ClusterTiles answers as localize_tiled and the whole-world localize do, on a LocalCluster of
worker processes and on a scheduler and a worker started as separate processes; faults."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import distributed
import numpy as np
import pytest

import worldgraph as wg
from perception import Percept
from tests.problems import robot_at_a_table
from worldgraph import scenes
from worldgraph.errors import MalformedFileError, WorldGraphError
from worldgraph.tiles import (
    ClusterTiles,
    append_tiles,
    load_tile,
    localize_tiled,
    read_index,
    save_tiles,
    split,
    summarize,
)


@pytest.fixture(scope="module")
def site() -> scenes.Site:
    return scenes.campus_site(buildings=3, storeys=2, n_objects=4500, seed=11)


@pytest.fixture(scope="module")
def tiles(site):
    return split(site.world, site.labels("building"))


@pytest.fixture(scope="module")
def folder(tiles, tmp_path_factory) -> str:
    out = str(tmp_path_factory.mktemp("tiles"))
    save_tiles(iter(tiles), out)  # a generator: one tile at a time
    return out


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  memory_limit="2GiB") as c, distributed.Client(c) as client:
        yield c, client


def _scan(site: scenes.Site, seed: int) -> tuple[np.ndarray, list[Percept]]:
    return robot_at_a_table(site, seed, 7)


def _same(a: wg.LocalizationResult, b: wg.LocalizationResult) -> None:
    assert a.status == b.status, (a.message, b.message)
    np.testing.assert_allclose(a.transformation, b.transformation, rtol=0, atol=1e-9)
    assert a.correspondences == b.correspondences


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------
def test_tile_files_round_trip(tiles, folder) -> None:
    index = read_index(folder)
    assert [e.label for e in index.tiles] == [t.label for t in tiles]
    for tile, entry in zip(tiles, index.tiles, strict=True):
        back = load_tile(entry.path)
        assert back.label == tile.label
        np.testing.assert_array_equal(back.index, tile.index)
        np.testing.assert_array_equal(back.own, tile.own)
        np.testing.assert_array_equal(back.world.positions, tile.world.positions)
        assert list(back.world.types) == list(tile.world.types)
        ref = summarize(tile)
        got = entry.summary
        assert (got.label, got.n_objects) == (ref.label, ref.n_objects)
        assert dict(got.type_counts) == dict(ref.type_counts)
        np.testing.assert_allclose(got.lower, ref.lower)
        np.testing.assert_allclose(got.upper, ref.upper)
        assert set(got.link_bins) == set(ref.link_bins)
        for key, bins in ref.link_bins.items():
            np.testing.assert_array_equal(got.link_bins[key], bins)


def test_append_and_bad_folders(tiles, tmp_path) -> None:
    out = str(tmp_path / "grow")
    save_tiles(tiles[:1], out)
    index = append_tiles(tiles[1:], out)
    assert [e.label for e in index.tiles] == [t.label for t in tiles]
    with pytest.raises(WorldGraphError, match="already in"):
        append_tiles(tiles[:1], out)
    with pytest.raises(MalformedFileError, match="no tile index"):
        read_index(str(tmp_path / "nothing"))
    with pytest.raises(WorldGraphError, match=r"tiles must be an iterable of Tile, got"):
        save_tiles(tiles[0], str(tmp_path / "x"))
    world_file = str(tmp_path / "world.npz")
    tiles[0].world.save(world_file)
    with pytest.raises(MalformedFileError, match="not a tile file"):
        load_tile(world_file)


# ----------------------------------------------------------------------------------------------
# the cluster
# ----------------------------------------------------------------------------------------------
def test_cluster_tiles_answer_as_localize_tiled_and_the_whole_world(site, tiles, folder, cluster) -> None:
    _, client = cluster
    scans = [_scan(site, s) for s in (1, 2, 3)]
    with ClusterTiles(folder, client) as remote:
        for _, percepts in scans:
            got = remote.localize(percepts)
            _same(got, localize_tiled(tiles, percepts, workers=1))
            whole = wg.localize(site.world, percepts)
            if whole.status == "ok":
                assert got.status == "ok"
                np.testing.assert_allclose(got.position, whole.position, atol=1e-6)
            assert "visited" in got.message
        many = remote.localize_many([p for _, p in scans])
        for (_, percepts), res in zip(scans, many, strict=True):
            _same(res, remote.localize(percepts))
        # a position prior far from the robot's building skips it
        pose, percepts = scans[0]
        visits = remote.plan(percepts, near=pose[:3, 3], radius=1.0)
        assert any(not v.visit and v.reason == "outside_prior" for v in visits)
        # one prior per query (a NaN row: none)
        near = np.array([scans[0][0][:3, 3], [np.nan] * 3])
        both = remote.localize_many([scans[0][1], scans[1][1]], near=near, radius=[1.0, 5.0])
        _same(both[0], remote.localize(scans[0][1], near=near[0], radius=1.0))
        _same(both[1], remote.localize(scans[1][1]))
        assert "outside_prior" in both[0].message and "outside_prior" not in both[1].message
        with pytest.raises(WorldGraphError, match="near"):
            remote.localize_many([scans[0][1]], near=np.zeros((2, 3)), radius=1.0)
    assert remote.closed
    with pytest.raises(WorldGraphError, match="closed"):
        remote.localize(scans[0][1])


def test_a_dead_worker_costs_time_not_answers(site, tiles, folder, cluster) -> None:
    _, client = cluster
    _, percepts = _scan(site, 4)
    with ClusterTiles(folder, client) as remote:
        before = remote.localize(percepts, timeout=120)
        own = before.correspondences[0][1]
        label = next(t.label for t in tiles if own in set(t.index[t.own].tolist()))
        worker = remote.homes[label]  # the home of the tile that answers
        assert worker is not None
        pid = client.run(os.getpid, workers=[worker])[worker]
        os.kill(pid, signal.SIGKILL)  # the worker holding a tile dies; its nanny starts a fresh one
        t0 = time.perf_counter()
        after = remote.localize(percepts, timeout=120)
        assert time.perf_counter() - t0 < 120
        _same(before, after)
        assert remote.homes[label] != worker  # the tile was read again on a live worker


def _transfers(client) -> int:
    """Transfers between workers so far (every worker's incoming log)."""
    return sum(client.run(lambda dask_worker: len(dask_worker.transfer_incoming_log)).values())


def test_a_global_query_runs_each_tile_task_at_home_and_moves_no_tile(site, tiles, folder, cluster) -> None:
    _, client = cluster
    scans = [_scan(site, s) for s in (9, 10, 11)]
    with ClusterTiles(folder, client) as remote:
        remote.wait(timeout=120)
        homes = remote.homes
        assert set(homes.values()) == set(client.scheduler_info()["workers"])  # tiles spread over both
        before = _transfers(client)
        with distributed.get_task_stream(client) as stream:
            got = remote.localize_many([p for _, p in scans])  # no prior: every tile is asked
        assert _transfers(client) == before  # nothing crossed between workers
        answered = [t["worker"] for t in stream.data if str(t["key"]).startswith("worldgraph-answers-")]
        # one task per query and worker that holds tiles, and it ran on that worker: each worker
        # answered every query once (the tile that answers a query is the one on its shelf)
        per_worker = {w: answered.count(w) for w in set(homes.values())}
        assert set(answered) == set(homes.values())
        assert all(n >= len(scans) for n in per_worker.values()), per_worker
        assert len(answered) <= 2 * len(scans) * len(per_worker)  # the free search, at most, again
        for (_, percepts), res in zip(scans, got, strict=True):
            assert "visited 3 of 3" in res.message
            _same(res, localize_tiled(tiles, percepts, workers=1))
            whole = wg.localize(site.world, percepts)
            assert res.status == whole.status
            if whole.status == "ok":
                np.testing.assert_allclose(res.transformation, whole.transformation, atol=1e-6)


def test_a_worker_that_lost_its_tiles_gets_them_again(site, tiles, folder, cluster) -> None:
    c, client = cluster
    _, percepts = _scan(site, 12)
    with ClusterTiles(folder, c.scheduler_address) as remote:  # an address: the client is its own
        before = remote.localize(percepts, timeout=120)
        from worldgraph.tiles import cluster as module

        assert sum(client.run(module._drop, remote._token).values()) == len(tiles)  # every shelf emptied
        _same(remote.localize(percepts, timeout=120), before)
        own = remote._client
    assert own is not client and own.status == "closed"


def _shelves(client) -> dict[str, list[str]]:
    """Each worker's held tile keys."""
    def held(dask_worker) -> list[str]:
        from worldgraph.tiles import cluster as module

        return sorted(k[1] for k in module._SHELF if k[0] == dask_worker.address)

    return client.run(held)


def test_a_worker_that_joins_takes_tiles_and_the_giver_lets_them_go(site, tiles, folder) -> None:
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                  memory_limit="2GiB") as c, distributed.Client(c) as client, \
            ClusterTiles(folder, client) as remote:
        _, percepts = _scan(site, 13)
        before = remote.localize(percepts, timeout=120)
        first = set(remote.homes.values())
        assert len(first) == 1
        c.scale(2)
        client.wait_for_workers(2, timeout=120)
        after = remote.localize(percepts, timeout=120)
        _same(before, after)
        homes = remote.homes
        assert len(set(homes.values())) == 2  # the newcomer holds tiles now
        for _ in range(100):  # the giver's copies are let go (a fire-and-forget task)
            shelves = _shelves(client)
            if sum(len(v) for v in shelves.values()) == len(tiles):
                break
            time.sleep(0.1)
        for w, keys in shelves.items():
            held = sorted(int(k.split("-")[0]) for k in keys)
            assert held == sorted(lb for lb, h in homes.items() if h == w)


def test_an_unreachable_scheduler_and_an_empty_tile_list_are_named(folder, tmp_path) -> None:
    import socket

    with socket.socket() as sock:  # a port where nothing listens
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    t0 = time.perf_counter()
    with pytest.raises(WorldGraphError, match=rf"client = 'tcp://127.0.0.1:{port}': no Dask scheduler "
                       r"answered there within timeout = 2 s"):
        ClusterTiles(folder, f"tcp://127.0.0.1:{port}", timeout=2)
    assert time.perf_counter() - t0 < 10
    out = str(tmp_path / "empty")
    with pytest.raises(WorldGraphError, match="tiles is empty: no tile to write"):
        save_tiles([], out)
    assert not os.path.exists(os.path.join(out, "index.npz"))
    with pytest.raises(MalformedFileError, match="no tile index"):
        read_index(out)


def test_missing_and_corrupt_tile_files_are_named(site, tiles, tmp_path, cluster) -> None:
    _, client = cluster
    out = str(tmp_path / "broken")
    save_tiles(tiles, out)
    first = read_index(out).tiles[0].path
    os.remove(first)
    with pytest.raises(MalformedFileError, match=os.path.basename(first)):
        ClusterTiles(out, client)
    save_tiles(tiles, out)
    with open(first, "r+b") as fh:
        fh.truncate(100)
    name = os.path.basename(first)
    with ClusterTiles(out, client) as remote:
        with pytest.raises(MalformedFileError, match=name):
            remote.wait(timeout=60)
        # a query that visits the broken tile raises its error too
        _, percepts = _scan(site, 8)
        assert remote.plan(percepts)[0].visit
        with pytest.raises(MalformedFileError, match=name):
            remote.localize(percepts, timeout=60)


def test_localize_tiled_keeps_its_tiles_on_the_cluster(site, tiles, cluster, monkeypatch) -> None:
    _, client = cluster
    _, percepts = _scan(site, 5)
    calls = []
    scatter = client.scatter

    def counting(data, *args, **kwargs):
        calls.append(len(data))
        return scatter(data, *args, **kwargs)

    monkeypatch.setattr(client, "scatter", counting)
    a = localize_tiled(tiles, percepts, scheduler=client)
    b = localize_tiled(tiles, percepts, scheduler=client)
    _same(a, b)
    assert calls == [len(tiles)]  # the second call sent only the percepts


def test_a_scheduler_and_a_worker_started_as_processes(site, tiles, folder, tmp_path) -> None:
    dask = shutil.which("dask") or os.path.join(os.path.dirname(sys.executable), "dask")
    sched_file = str(tmp_path / "scheduler.json")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd(), os.environ.get("PYTHONPATH", "")]))
    procs = [subprocess.Popen([dask, "scheduler", "--scheduler-file", sched_file, "--port", "0",
                               "--dashboard-address", ":0", "--no-show"], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(300):
            if os.path.exists(sched_file):
                break
            time.sleep(0.1)
        procs.append(subprocess.Popen([dask, "worker", "--scheduler-file", sched_file, "--nworkers", "1",
                                       "--nthreads", "1", "--no-dashboard"], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with distributed.Client(scheduler_file=sched_file, timeout=60) as client:
            client.wait_for_workers(1, timeout=60)
            _, percepts = _scan(site, 6)
            with ClusterTiles(folder, client) as remote:
                _same(remote.localize(percepts, timeout=120), localize_tiled(tiles, percepts, workers=1))
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
