"""The three private validation modules agree.

``perception._checks``, ``worldgraph._checks`` and ``radialopt._checks`` each hold their own
``real_array``, ``real_scalar`` and ``integer`` (the packages do not import each other's private
modules).  Here one table of bad inputs goes through all three: each raises its package's base
error, the three messages are identical, and the message names the argument and the bad index
or value.  A second table of good inputs is accepted by all three with equal results, and the
shared functions have the same signatures.
"""

from __future__ import annotations

import inspect
from fractions import Fraction
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from perception import _checks as pchecks
from perception.errors import PerceptionError
from radialopt import _checks as rchecks
from radialopt.errors import RadialArgumentError
from worldgraph import _checks as wchecks
from worldgraph.errors import WorldGraphError

#: (module, the base error class its checks raise)
MODULES: list[tuple[ModuleType, type[Exception]]] = [
    (pchecks, PerceptionError),
    (wchecks, WorldGraphError),
    (rchecks, RadialArgumentError),
]
#: The functions every module has, with the same rules and messages.
SHARED = ("real_array", "real_scalar", "integer", "_short")
#: Functions perception and worldgraph share (radialopt draws no random numbers).
SHARED_TWO = ("generator",)

NAN, INF = float("nan"), float("inf")
HUGE_INT = 10**400  # beyond float64

#: (function, value, keywords, fragments the message must contain).  The argument is always
#: called ``x``; the fragments name it with the index and the value where there is one.
BAD: list[tuple[str, Any, dict[str, Any], tuple[str, ...]]] = [
    # real_array: type
    ("real_array", None, {}, ("x must be an array of real numbers, got None",)),
    ("real_array", "1.0", {}, ("x must be an array of real numbers, got '1.0'",)),
    ("real_array", b"12", {}, ("x must be an array of real numbers", "b'12'")),
    ("real_array", True, {}, ("x must hold real numbers, not booleans, got True",)),
    ("real_array", [True, False], {}, ("x must hold real numbers, not booleans, got [True, False]",)),
    ("real_array", np.array([1.0, True], dtype=object), {}, ("x[1] must be a real number, got True",)),
    ("real_array", np.array([False, True]), {}, ("x must hold real numbers, not booleans",)),
    ("real_array", [1.0, 2 + 1j], {}, ("x[1] must be real, got complex values",)),
    ("real_array", np.zeros(2, dtype=complex), {}, ("x must be real, got complex values",)),
    ("real_array", [[1.0, 2.0], [3.0]], {}, ("x must be a rectangular array of real numbers",)),
    ("real_array", [1.0, "a"], {}, ("x must be an array of real numbers, got dtype <U",)),
    ("real_array", np.array([1.0, None], dtype=object), {}, ("x[1] must be a real number, got None",)),
    ("real_array", np.array([[1.0, 2.0], [1j, 0.0]], dtype=object), {},
     ("x[1, 0] must be a real number, got 1j",)),
    ("real_array", [1, HUGE_INT], {}, ("x[1] = 1000", "does not fit a float64")),
    ("real_array", {1, 2}, {}, ("x must be a real number, got {1, 2}",)),
    # real_array: shape
    ("real_array", [1.0, 2.0], {"shape": (3,)}, ("x must have shape (3,), got shape (2,)",)),
    ("real_array", [[1.0, 2.0]], {"shape": (None, 3)}, ("x must have shape (n, 3), got shape (1, 2)",)),
    ("real_array", [1.0, 2.0, 3.0], {"shape": (None, 3)}, ("x must have shape (n, 3), got shape (3,)",)),
    ("real_array", np.zeros((2, 3)), {"shape": ("k", 2)}, ("x must have shape (k, 2), got shape (2, 3)",)),
    ("real_array", [1.0, 2.0], {"shape": (3,), "like": "y"},
     ("x must have shape (3,) like y, got shape (2,)",)),
    ("real_array", 1.0, {"ndim": (1, 2)}, ("x must have 1 or 2 dimension(s), got shape ()",)),
    ("real_array", [], {"min_size": 1}, ("x must hold at least 1 element(s), got shape (0,)",)),
    # real_array: values
    ("real_array", [1.0, 2.0, NAN], {}, ("x[2] must be finite, got nan",)),
    ("real_array", [[0.0, 1.0], [2.0, -INF]], {}, ("x[1, 1] must be finite, got -inf",)),
    ("real_array", NAN, {}, ("x must be finite, got nan",)),
    ("real_array", [0.5, -2.0], {"max_abs": 1.0}, ("x[1] must be <= 1 in magnitude, got -2.0",)),
    # real_scalar: type
    ("real_scalar", None, {}, ("x must be a real number, got None (NoneType)",)),
    ("real_scalar", "1.5", {}, ("x must be a real number, got '1.5' (str)",)),
    ("real_scalar", True, {}, ("x must be a real number, got True (bool)",)),
    ("real_scalar", np.bool_(False), {}, ("x must be a real number, got", "(bool")),
    ("real_scalar", 1 + 0j, {}, ("x must be a real number, got (1+0j) (complex)",)),
    ("real_scalar", [1.0], {}, ("x must be a real number, got [1.0] (list)",)),
    ("real_scalar", np.array([1.0]), {}, ("x must be a real number, got array([1.]) (ndarray)",)),
    ("real_scalar", np.array(True), {}, ("x must be a real number, got array(True) (ndarray)",)),
    ("real_scalar", HUGE_INT, {}, ("x = 1000", "does not fit a float64")),
    # real_scalar: values
    ("real_scalar", NAN, {}, ("x must be finite, got nan",)),
    ("real_scalar", -INF, {}, ("x must be finite, got -inf",)),
    ("real_scalar", np.float64(INF), {"maximum": 1.0}, ("x must be finite, got inf",)),
    ("real_scalar", 0.0, {"positive": True}, ("x must be > 0, got 0.0",)),
    ("real_scalar", -1, {"positive": True}, ("x must be > 0, got -1.0",)),
    ("real_scalar", 0.5, {"minimum": 1.0}, ("x must be >= 1, got 0.5",)),
    ("real_scalar", -0.25, {"minimum": 0.0}, ("x must be >= 0, got -0.25",)),
    ("real_scalar", 2.0, {"maximum": 1.5}, ("x must be <= 1.5, got 2.0",)),
    ("real_scalar", 2.0, {"minimum": 0.0, "maximum": 1.0}, ("x must be <= 1, got 2.0",)),
    ("real_scalar", -3.0, {"max_abs": 2.0}, ("x must be <= 2 in magnitude, got -3.0",)),
    ("real_scalar", 0.0, {"positive": True, "minimum": 0.0}, ("x must be > 0, got 0.0",)),
    # integer
    ("integer", True, {}, ("x must be an integer, got True (bool)",)),
    ("integer", np.bool_(True), {}, ("x must be an integer, got", "(bool")),
    ("integer", 2.0, {}, ("x must be an integer, got 2.0 (float)",)),
    ("integer", np.float64(2.5), {}, ("x must be an integer, got", "2.5", "(float64)")),
    ("integer", NAN, {}, ("x must be an integer, got nan (float)",)),
    ("integer", None, {}, ("x must be an integer, got None (NoneType)",)),
    ("integer", "3", {}, ("x must be an integer, got '3' (str)",)),
    ("integer", Fraction(3, 1), {}, ("x must be an integer, got Fraction(3, 1) (Fraction)",)),
    ("integer", np.array(3), {}, ("x must be an integer, got array(3) (ndarray)",)),
    ("integer", 0, {"minimum": 1}, ("x must be >= 1, got 0",)),
    ("integer", np.int64(6), {"maximum": 5}, ("x must be <= 5, got 6",)),
    ("integer", -(10**30), {"minimum": 0, "maximum": 10}, ("x must be >= 0, got -1" + "0" * 30,)),
    # generator (perception and worldgraph)
    ("generator", 3, {}, ("x must be a numpy.random.Generator, got 3 (int)",)),
    ("generator", None, {}, ("x must be a numpy.random.Generator, got None (NoneType)",)),
    ("generator", np.random.RandomState(0), {}, ("x must be a numpy.random.Generator", "(RandomState)")),
]

#: (function, value, keywords, the result every module returns)
GOOD: list[tuple[str, Any, dict[str, Any], Any]] = [
    ("real_array", [1, 2, 3], {"shape": (3,)}, np.array([1.0, 2.0, 3.0])),
    ("real_array", [[1, 2, 3], [4, 5, 6]], {"shape": (None, 3)}, np.arange(1.0, 7.0).reshape(2, 3)),
    ("real_array", np.zeros((0, 3)), {"shape": (None, 3)}, np.zeros((0, 3))),
    ("real_array", np.arange(6, dtype=np.int32).reshape(2, 3), {"shape": ("k", 3)},
     np.arange(6.0).reshape(2, 3)),
    ("real_array", [], {}, np.zeros(0)),
    ("real_array", 2.5, {}, np.array(2.5)),
    ("real_array", np.array([Fraction(1, 2), 3], dtype=object), {"shape": (2,)}, np.array([0.5, 3.0])),
    ("real_array", [np.float32(0.5), np.uint8(200)], {"ndim": (1,)}, np.array([0.5, 200.0])),
    ("real_array", [-1.0, 1.0], {"max_abs": 1.0, "min_size": 2}, np.array([-1.0, 1.0])),
    ("real_array", [1.0, 2.0], {"shape": (2,), "like": "y"}, np.array([1.0, 2.0])),
    ("real_scalar", 3, {}, 3.0),
    ("real_scalar", np.float32(0.5), {}, 0.5),
    ("real_scalar", np.int64(-2), {}, -2.0),
    ("real_scalar", np.array(2.0), {}, 2.0),
    ("real_scalar", Fraction(1, 4), {"positive": True}, 0.25),
    ("real_scalar", 1.0, {"minimum": 1.0, "maximum": 1.0}, 1.0),
    ("real_scalar", 0.0, {"minimum": 0.0}, 0.0),
    ("real_scalar", -2.0, {"max_abs": 2.0}, -2.0),
    ("real_scalar", 10**300, {}, 1e300),
    ("integer", 3, {}, 3),
    ("integer", np.int64(3), {"minimum": 3, "maximum": 3}, 3),
    ("integer", np.uint8(255), {"maximum": 255}, 255),
    ("integer", -(10**30), {}, -(10**30)),
    ("_short", "x" * 300, {}, repr("x" * 300)[:197] + "..."),
    ("_short", [1, 2], {}, "[1, 2]"),
]


def _modules(func: str) -> list[tuple[ModuleType, type[Exception]]]:
    return [(m, err) for m, err in MODULES if hasattr(m, func)]


def _call(module: ModuleType, func: str, value: Any, kw: dict[str, Any]) -> Any:
    if func == "_short":
        return module._short(value, **kw)
    return getattr(module, func)("x", value, **kw)


def _messages(func: str, value: Any, kw: dict[str, Any]) -> list[tuple[str, type[Exception], str]]:
    """``(module name, class raised, message)`` of each module that has ``func``."""
    out = []
    for module, _ in _modules(func):
        with pytest.raises(Exception) as info:
            _call(module, func, value, kw)
        out.append((module.__name__, type(info.value), str(info.value)))
    return out


@pytest.mark.parametrize(("func", "value", "kw", "fragments"), BAD,
                         ids=[f"{i}-{row[0]}" for i, row in enumerate(BAD)])
def test_bad_input_raises_the_same_message_in_every_package(func: str, value: Any, kw: dict[str, Any],
                                                            fragments: tuple[str, ...]) -> None:
    expected = len(MODULES) if func in SHARED else 2
    outcomes = _messages(func, value, kw)
    assert len(outcomes) == expected
    for (name, raised, _), (_, err) in zip(outcomes, _modules(func), strict=True):
        assert raised is err, f"{name}.{func} raised {raised.__name__}, not {err.__name__}"
    texts = {name: text for name, _, text in outcomes}
    assert len(set(texts.values())) == 1, f"{func}({value!r}, {kw}) disagrees: {texts}"
    text = next(iter(texts.values()))
    assert text.startswith("x"), text
    for fragment in fragments:
        assert fragment in text, f"{fragment!r} not in {text!r}"


@pytest.mark.parametrize(("func", "value", "kw", "want"), GOOD,
                         ids=[f"{i}-{row[0]}" for i, row in enumerate(GOOD)])
def test_good_input_gives_the_same_value_in_every_package(func: str, value: Any, kw: dict[str, Any],
                                                          want: Any) -> None:
    for module, _ in _modules(func):
        got = _call(module, func, value, kw)
        if isinstance(want, np.ndarray):
            assert isinstance(got, np.ndarray) and got.dtype == np.float64, module.__name__
            assert got.shape == want.shape and np.array_equal(got, want), module.__name__
            assert got is not value, module.__name__  # a new array, never the caller's
        else:
            assert type(got) is type(want) and got == want, (module.__name__, got)


def test_generator_is_returned_as_is() -> None:
    rng = np.random.default_rng(0)
    for module, _ in _modules("generator"):
        assert module.generator("x", rng) is rng


def test_an_array_that_owns_its_data_is_copied() -> None:
    value = np.array([1.0, 2.0])
    for module, _ in MODULES:
        got = module.real_array("x", value)
        got[0] = 5.0
        assert value[0] == 1.0, module.__name__


@pytest.mark.parametrize("func", SHARED + SHARED_TWO)
def test_shared_functions_have_the_same_signature(func: str) -> None:
    signatures = {m.__name__: inspect.signature(getattr(m, func)) for m, _ in _modules(func)}
    params = {name: [(p.name, p.kind) for p in s.parameters.values()] for name, s in signatures.items()}
    assert len({tuple(p) for p in params.values()}) == 1, params
    # radialopt's real_array bounds magnitudes by default (the test below)
    defaults = {name: [(p.name, repr(p.default)) for p in s.parameters.values()
                       if not (func == "real_array" and p.name == "max_abs")]
                for name, s in signatures.items()}
    assert len({tuple(d) for d in defaults.values()}) == 1, defaults


def test_radialopt_bounds_array_magnitudes_by_its_length_limit() -> None:
    """The one documented difference: radialopt's ``real_array`` defaults ``max_abs`` to
    ``MAX_LENGTH``; the others leave magnitudes unbounded unless told."""
    big = [0.0, 10 * rchecks.MAX_LENGTH]
    with pytest.raises(RadialArgumentError,
                       match=r"x\[1\] must be <= 1e\+09 in magnitude, got 10000000000\.0"):
        rchecks.real_array("x", big)
    assert rchecks.real_array("x", big, max_abs=None)[1] == big[1]
    for module in (pchecks, wchecks):
        assert module.real_array("x", big)[1] == big[1]
