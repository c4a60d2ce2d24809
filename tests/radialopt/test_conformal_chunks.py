"""meet2_batch / meet3_batch / meet4_batch: chunked equals unchunked, bounded memory.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro


# ---------------------------------------------------------------- 3. bounded memory: chunked batches
def _batch_equal(a: object, b: object) -> None:
    from dataclasses import fields

    assert type(a) is type(b)
    for f in fields(a):
        np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)


@pytest.mark.parametrize("fn, m", [(ro.meet2_batch, 2), (ro.meet3_batch, 3), (ro.meet4_batch, 4)])
def test_meet_batches_chunked_equal_unchunked(monkeypatch: pytest.MonkeyPatch, fn: object, m: int) -> None:
    import radialopt.conformal as conformal

    rng = np.random.default_rng(3)
    k = 1003
    c = rng.uniform(0, 10, (k, m, 3))
    r2 = rng.uniform(1, 5, (k, m)) ** 2
    c[5, 1] = c[5, 0]  # a coincident instance (NaN rows) inside a later chunk too
    c[777, 1] = c[777, 0]
    whole = fn(c, r2)
    monkeypatch.setattr(conformal, "MEET_CHUNK", 64)
    chunked = fn(c, r2)
    _batch_equal(whole, chunked)
    # each row equals the meet of that instance alone (the obvious per-row reference)
    for i in (0, 5, 63, 64, 777, k - 1):
        _batch_equal(fn(c[i:i + 1], r2[i:i + 1]), type(whole)(
            **{f: getattr(whole, f)[i:i + 1] for f in whole.__dataclass_fields__}))


def test_meet4_batch_memory_stays_near_the_input_size(monkeypatch: pytest.MonkeyPatch) -> None:
    import tracemalloc

    import radialopt.conformal as conformal

    rng = np.random.default_rng(5)
    c = rng.uniform(0, 10, (200_000, 4, 3))
    r2 = rng.uniform(1, 5, (200_000, 4))
    monkeypatch.setattr(conformal, "MEET_CHUNK", 10_000)
    tracemalloc.start()
    try:
        ro.meet4_batch(c, r2)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # unchunked: about 6x the input (SVD, solve and distance temporaries of every row at once)
    assert peak < 2.5 * (c.nbytes + r2.nbytes)
