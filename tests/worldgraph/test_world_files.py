"""The binary world file (``.npz``) of WorldModel.save/load against the JSON file and the original."""

from __future__ import annotations

import io
import os
import shutil
import zipfile

import numpy as np
import pytest
from scipy.spatial.distance import cdist
from scipy.spatial.transform import Rotation

from worldgraph.errors import MalformedFileError
from worldgraph.model import ObjectModel, WorldModel

TYPES = ("door", "handle", "knob")


def _rotated_world(seed: int = 0, n: int = 60) -> WorldModel:
    """Objects with random rotations, sizes, ids and geometry keys that are not their types, a
    room, a link margin, a non-default link length and the gravity flag."""
    rng = np.random.default_rng(seed)
    rotations = Rotation.random(n, random_state=seed).as_matrix()
    objs = []
    for k in range(n):
        pose = np.eye(4)
        pose[:3, :3] = rotations[k]
        pose[:3, 3] = rng.uniform([0, 0, 0], [12, 8, 3])
        objs.append(ObjectModel(f"obj-{k:03d}-é", TYPES[k % 3], pose, rng.uniform(0.01, 1.0, 3),
                                f"shape_{k % 4}"))
    cv = {f"shape_{g}": rng.normal(size=(3 + g, 3)) for g in range(4)}
    cv["unused"] = rng.normal(size=(1, 3))
    return WorldModel(objs, max_link_length=3.5, class_vertices=cv, link_margin=0.4,
                      room=(np.array([-1.0, -1.0, 0.0]), np.array([13.0, 9.0, 3.2])), gravity_aligned=True)


def _table_world(seed: int = 1, ids: bool = True) -> WorldModel:
    rng = np.random.default_rng(seed)
    n = 300
    types = rng.choice(["chair", "lamp", "sign"], n)
    positions = rng.uniform(0, 20, (n, 3))
    sizes = rng.uniform(0.05, 0.5, (n, 3))
    names = [f"item #{k}" for k in rng.permutation(n)] if ids else None
    return WorldModel.from_arrays(types, positions, max_link_length=4.0, ids=names, sizes=sizes,
                                  link_margin=0.25)


def _both(world: WorldModel, folder) -> tuple[WorldModel, WorldModel]:
    world.save(folder / "w.json")
    world.save(folder / "w.npz")
    assert (folder / "w.json").read_bytes()[:1] == b"{"  # JSON stays JSON
    assert (folder / "w.npz").read_bytes()[:4] == b"PK\x03\x04"
    return WorldModel.load(folder / "w.npz"), WorldModel.load(folder / "w.json")


def _fields(world: WorldModel) -> dict:
    objs = list(world.objects)
    return {
        "ids": [o.id for o in objs], "types": [o.type for o in objs], "geometry": [o.geometry for o in objs],
        "poses": np.array([o.pose for o in objs]), "sizes": np.array([o.size for o in objs]),
        "positions": np.array(world.positions), "max_link_length": world.max_link_length,
        "link_margin": world.link_margin, "gravity_aligned": world.gravity_aligned,
        "room": None if world.room is None else (world.room.lower.tolist(), world.room.upper.tolist()),
        "class_vertices": {k: v.tolist() for k, v in world.class_vertices.items()},
        "links": {pair: tuple(a.tolist() for a in world.link_lengths(*pair)) for pair in world.links},
    }


def _assert_same(a: WorldModel, b: WorldModel) -> None:
    fa, fb = _fields(a), _fields(b)
    assert fa.keys() == fb.keys()
    for key in fa:
        if isinstance(fa[key], np.ndarray):
            assert np.array_equal(fa[key], fb[key]), key
        else:
            assert fa[key] == fb[key], key
    assert a == b


def _brute_links(world: WorldModel) -> dict[tuple[str, str], int]:
    """Number of object pairs per sorted type pair closer than max_link_length + link_margin,
    by all pairwise distances."""
    pos = np.array([o.pose[:3, 3] for o in world.objects])
    types = np.array([o.type for o in world.objects])
    d = cdist(pos, pos)
    reach = world.max_link_length + world.link_margin
    out: dict[tuple[str, str], int] = {}
    for i, j in zip(*np.nonzero(np.triu(d < reach, k=1)), strict=True):
        pair = tuple(sorted((str(types[i]), str(types[j]))))
        out[pair] = out.get(pair, 0) + 1  # type: ignore[index]
    return out


@pytest.mark.parametrize("make", [_rotated_world, _table_world, lambda: _table_world(ids=False)],
                         ids=["rotated-objects", "table-with-ids", "table-default-ids"])
def test_binary_round_trip_equals_json_and_original(tmp_path, make):
    world = make()
    binary, text = _both(world, tmp_path)
    _assert_same(binary, world)
    _assert_same(binary, text)
    _assert_same(text, world)
    counts = {pair: len(binary.link_lengths(*pair)[0]) for pair in binary.links}
    assert counts == _brute_links(world)


def test_round_trip_keeps_rotations_room_and_settings(tmp_path):
    world = _rotated_world(seed=3)
    back, _ = _both(world, tmp_path)
    rot = np.array([o.pose[:3, :3] for o in back.objects])
    assert not np.allclose(rot, np.eye(3))  # the poses are not identities ...
    assert np.array_equal(rot, np.array([o.pose[:3, :3] for o in world.objects]))  # ... and kept bit for bit
    assert back.room is not None and back.room.upper.tolist() == [13.0, 9.0, 3.2]
    assert (back.max_link_length, back.link_margin, back.gravity_aligned) == (3.5, 0.4, True)
    assert sorted(back.class_vertices) == ["shape_0", "shape_1", "shape_2", "shape_3", "unused"]
    assert {o.geometry for o in back.objects} == {"shape_0", "shape_1", "shape_2", "shape_3"}
    assert back.objects[0].id == "obj-000-é"


def test_world_without_room_or_gravity(tmp_path):
    world = WorldModel.from_arrays(["a", "b", "a"], [[0, 0, 0], [1, 0, 0], [0, 2, 0]])
    back, text = _both(world, tmp_path)
    assert back.room is None and not back.gravity_aligned
    _assert_same(back, text)


def test_renamed_binary_file_loads(tmp_path):
    world = _rotated_world()
    world.save(tmp_path / "w.npz")
    for name in ("renamed.json", "no_suffix"):
        shutil.copy(tmp_path / "w.npz", tmp_path / name)
        _assert_same(WorldModel.load(tmp_path / name), world)
    world.save(tmp_path / "text.dat")  # not .npz: JSON
    assert (tmp_path / "text.dat").read_text(encoding="utf-8").startswith("{")
    _assert_same(WorldModel.load(str(tmp_path / "text.dat")), world)


def test_file_without_link_tables_builds_them(tmp_path):
    world = _table_world()
    world.save(tmp_path / "w.npz")
    _rewrite(tmp_path / "w.npz", tmp_path / "bare.npz", link_i=None, link_j=None, link_length=None)
    _assert_same(WorldModel.load(tmp_path / "bare.npz"), world)


# ----------------------------------------------------------------------------------------------
# bad files
# ----------------------------------------------------------------------------------------------
def _entries(path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def _rewrite(src, dst, **changes) -> None:
    """Copy the archive ``src`` to ``dst`` with entries replaced (None: removed)."""
    entries = _entries(src)
    for key, value in changes.items():
        if value is None:
            entries.pop(key)
        else:
            entries[key] = value
    with open(dst, "wb") as fh:
        np.savez(fh, **entries)


def _refused(path, *words: str) -> None:
    with pytest.raises(MalformedFileError) as info:
        WorldModel.load(path)
    text = str(info.value)
    assert str(path) in text
    for word in words:
        assert word in text, text


@pytest.fixture()
def saved(tmp_path):
    world = _rotated_world()
    world.save(tmp_path / "good.npz")
    return tmp_path / "good.npz"


def test_truncated_and_corrupt_files(saved, tmp_path):
    raw = saved.read_bytes()
    for cut in (10, len(raw) // 2, len(raw) - 30):
        (tmp_path / "cut.npz").write_bytes(raw[:cut])
        _refused(tmp_path / "cut.npz")
    # flip bytes inside the positions array: the archive's CRC fails
    with zipfile.ZipFile(saved) as z:
        info = z.getinfo("positions.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra) + 200
    broken = bytearray(raw)
    broken[start:start + 16] = bytes(16)
    (tmp_path / "flipped.npz").write_bytes(bytes(broken))
    _refused(tmp_path / "flipped.npz")
    (tmp_path / "magic_only.npz").write_bytes(b"PK\x03\x04garbage")
    _refused(tmp_path / "magic_only.npz", "npz")


def test_a_file_that_is_no_zip_archive_is_named_not_read_as_a_pickle(saved, tmp_path):
    from worldgraph.model.binary_files import read_entries

    (tmp_path / "text.npz").write_bytes(b"{}")
    with pytest.raises(MalformedFileError, match="zip") as info:
        read_entries(str(tmp_path / "text.npz"))
    assert str(tmp_path / "text.npz") in str(info.value) and "pickle" not in str(info.value)


def test_missing_entry(saved, tmp_path):
    for key in ("positions", "codes", "class_vertices", "version"):
        _rewrite(saved, tmp_path / "m.npz", **{key: None})
        _refused(tmp_path / "m.npz", "missing", key)


def test_wrong_format_and_version(saved, tmp_path):
    _rewrite(saved, tmp_path / "v.npz", version=np.array(2))
    _refused(tmp_path / "v.npz", "version")
    _rewrite(saved, tmp_path / "f.npz", format=np.array("something.else"))
    _refused(tmp_path / "f.npz", "format")
    _rewrite(saved, tmp_path / "t.npz", version=np.array(1.0))
    _refused(tmp_path / "t.npz", "version")


def test_bad_values(saved, tmp_path):
    e = _entries(saved)
    nan = e["positions"].copy()
    nan[5, 1] = np.nan
    _rewrite(saved, tmp_path / "nan.npz", positions=nan)
    _refused(tmp_path / "nan.npz", "positions", "non-finite")
    far = e["positions"].copy()
    far[3, 0] = 2e6
    _rewrite(saved, tmp_path / "far.npz", positions=far)
    _refused(tmp_path / "far.npz", "positions", "MAX_COORDINATE")
    scaled = e["rotations"].copy()
    scaled[7] *= 1.1
    _rewrite(saved, tmp_path / "scaled.npz", rotations=scaled)
    _refused(tmp_path / "scaled.npz", "rotations", "[7]")
    mirrored = e["rotations"].copy()
    mirrored[2, :, 0] *= -1
    _rewrite(saved, tmp_path / "mirror.npz", rotations=mirrored)
    _refused(tmp_path / "mirror.npz", "rotations", "[2]")
    codes = e["codes"].copy()
    codes[4] = 3
    _rewrite(saved, tmp_path / "codes.npz", codes=codes)
    _refused(tmp_path / "codes.npz", "codes")
    _rewrite(saved, tmp_path / "shape.npz", sizes=e["sizes"][:-1])
    _refused(tmp_path / "shape.npz", "sizes", "shape")
    _rewrite(saved, tmp_path / "dtype.npz", positions=e["positions"].astype(np.int64))
    _refused(tmp_path / "dtype.npz", "positions", "dtype")
    negative = e["sizes"].copy()
    negative[1, 2] = -0.5
    _rewrite(saved, tmp_path / "neg.npz", sizes=negative)
    _refused(tmp_path / "neg.npz", "sizes")


def test_bad_ids(saved, tmp_path):
    ids = _entries(saved)["ids"].tobytes().decode("utf-8").split("\x00")
    repeated = list(ids)
    repeated[9] = repeated[2]
    join = lambda names: np.frombuffer("\x00".join(names).encode("utf-8"), dtype=np.uint8)  # noqa: E731
    _rewrite(saved, tmp_path / "dup.npz", ids=join(repeated))
    _refused(tmp_path / "dup.npz", "unique", repeated[2])
    empty = list(ids)
    empty[4] = ""
    _rewrite(saved, tmp_path / "empty.npz", ids=join(empty))
    _refused(tmp_path / "empty.npz", "empty")
    _rewrite(saved, tmp_path / "short.npz", ids=join(ids[:-1]))
    _refused(tmp_path / "short.npz", "ids")
    _rewrite(saved, tmp_path / "utf.npz", ids=np.concatenate([join(ids), np.array([0xFF], np.uint8)]))
    _refused(tmp_path / "utf.npz", "UTF-8")


def test_pickled_object_array_is_refused(saved, tmp_path):
    entries = _entries(saved)
    entries["ids"] = np.array([object()] * 3, dtype=object)
    buffer = io.BytesIO()
    np.savez(buffer, **entries)  # allow_pickle: the object array is pickled into the archive
    (tmp_path / "pickle.npz").write_bytes(buffer.getvalue())
    _refused(tmp_path / "pickle.npz", "pickle")


def test_edited_link_tables_are_refused(tmp_path):
    world = _table_world()
    world.save(tmp_path / "w.npz")
    e = _entries(tmp_path / "w.npz")
    assert len(world) < 1000  # every object in the neighbour-count sample
    _rewrite(tmp_path / "w.npz", tmp_path / "drop.npz", link_i=e["link_i"][1:], link_j=e["link_j"][1:],
             link_length=e["link_length"][1:])
    _refused(tmp_path / "drop.npz", "link")
    length = e["link_length"].copy()
    length[len(length) // 2] += 1e-9
    _rewrite(tmp_path / "w.npz", tmp_path / "len.npz", link_length=length)
    _refused(tmp_path / "len.npz", "link")
    swapped = e["link_i"].copy(), e["link_j"].copy()
    _rewrite(tmp_path / "w.npz", tmp_path / "swap.npz", link_i=swapped[1], link_j=swapped[0])
    _refused(tmp_path / "swap.npz", "link")
    # links made for a shorter reach: the tree finds more neighbours than the file links
    _rewrite(tmp_path / "w.npz", tmp_path / "reach.npz", max_link_length=np.array(6.0))
    _refused(tmp_path / "reach.npz", "link")
    _rewrite(tmp_path / "w.npz", tmp_path / "shorter.npz", max_link_length=np.array(1.0))
    _refused(tmp_path / "shorter.npz", "link")


def test_coincident_objects_in_file(tmp_path):
    world = WorldModel.from_arrays(["a", "a", "b"], [[0, 0, 0], [1, 0, 0], [0, 2, 0]])
    world.save(tmp_path / "w.npz")
    e = _entries(tmp_path / "w.npz")
    pos = e["positions"].copy()
    pos[1] = pos[0]
    # the stored links no longer match, and without them the search finds the coincident pair
    _rewrite(tmp_path / "w.npz", tmp_path / "c.npz", positions=pos)
    _refused(tmp_path / "c.npz")
    _rewrite(tmp_path / "w.npz", tmp_path / "c2.npz", positions=pos, link_i=None, link_j=None,
             link_length=None)
    _refused(tmp_path / "c2.npz", "coincide")


def test_unreadable_paths(tmp_path):
    _refused(tmp_path / "missing.npz")
    os.mkdir(tmp_path / "folder.npz")
    with pytest.raises(MalformedFileError):
        WorldModel.load(tmp_path / "folder.npz")


def test_compressed_archive_loads(tmp_path):
    world = _rotated_world(seed=5)
    world.save(tmp_path / "w.npz")
    entries = _entries(tmp_path / "w.npz")
    with open(tmp_path / "small.npz", "wb") as fh:
        np.savez_compressed(fh, **entries)
    with zipfile.ZipFile(tmp_path / "small.npz") as z:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())
    _assert_same(WorldModel.load(tmp_path / "small.npz"), world)
