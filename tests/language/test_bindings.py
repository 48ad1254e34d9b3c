"""Binding Python implementations to stream declarations, and normalising what they return."""

from __future__ import annotations

import math

import numpy as np
import pytest

from llmpas.language import bindings
from llmpas.language.bindings import (
    BoundFunction,
    BoundStream,
    Kind,
    StreamInfo,
    bind,
    cost,
    function,
    sampler,
)
from llmpas.language.language_errors import BindingError, LanguageError
from llmpas.language.streams import parse_streams

SPEC = parse_streams(
    """(define (stream s)
  (:stream one :inputs (?x) :domain (P ?x) :outputs (?y) :certified (Q ?x ?y))
  (:stream two :inputs (?x) :domain (P ?x) :outputs (?a ?b) :certified (R ?x ?a ?b))
  (:stream check :inputs (?x ?y) :domain (and (P ?x) (P ?y)) :certified (Ok ?x ?y))
  (:stream watch :inputs (?x) :domain (P ?x) :fluents (AtPose Holding) :outputs (?t)
     :certified (T ?x ?t))
  (:function (Dist ?x ?y) (and (P ?x) (P ?y))))""",
    "s.pddl",
)


def bound(stream: str, impl) -> BoundStream:
    """``stream`` bound to ``impl`` (the other declarations get dummies)."""
    streams, _ = bind(SPEC, all_impls(**{stream: impl}))
    return streams[stream]


def bound_fn(fn) -> BoundFunction:
    _, functions = bind(SPEC, all_impls(dist=fn))
    return functions["dist"]


def all_impls(**over):
    impls = {
        "one": lambda x: (x + 1,),
        "two": lambda x: [(x, x), (x, -x)],
        "check": lambda x, y: x < y,
        "watch": lambda x, fluents: (len(fluents),),
        "dist": lambda x, y: abs(x - y),
    }
    impls.update(over)
    return impls


# ------------------------------------------------------------------------ bind


def test_bind_matches_every_declaration():
    streams, functions = bind(SPEC, all_impls())
    assert set(streams) == {"one", "two", "check", "watch"}
    assert set(functions) == {"dist"}
    assert streams["one"].schema is SPEC.stream("one")
    assert list(streams["one"].outputs((1,))) == [(2,)]
    assert functions["dist"].value((1, 4)) == 3.0
    assert streams["one"].info == StreamInfo()


def test_bind_is_case_insensitive_on_names():
    impls = all_impls()
    impls["DIST"] = impls.pop("dist")
    impls["One"] = impls.pop("one")
    streams, functions = bind(SPEC, impls)
    assert "one" in streams and "dist" in functions


def test_declared_stream_without_implementation():
    impls = all_impls()
    del impls["two"]
    with pytest.raises(BindingError) as info:
        bind(SPEC, impls)
    assert str(info.value) == "s.pddl: stream 'two' is declared but has no Python implementation"
    assert isinstance(info.value, LanguageError)


def test_declared_function_without_implementation():
    impls = all_impls()
    del impls["dist"]
    with pytest.raises(BindingError, match="stream 'dist' is declared but has no Python"):
        bind(SPEC, impls)


def test_implementation_without_declaration():
    with pytest.raises(BindingError) as info:
        bind(SPEC, all_impls(tree=lambda x: (x,)))
    assert str(info.value) == "implementation 'tree' is given but s.pddl declares no such stream"


def test_info_for_an_undeclared_stream():
    with pytest.raises(BindingError, match=r"stream info for 'nope': s\.pddl declares no such"):
        bind(SPEC, all_impls(), {"nope": StreamInfo()})


def test_info_overrides_by_name():
    streams, _ = bind(SPEC, all_impls(), {"ONE": StreamInfo(deferred=True, overhead=5)})
    assert streams["one"].info == StreamInfo(deferred=True, overhead=5.0)
    assert streams["two"].info == StreamInfo()


def test_info_given_with_the_wrapper():
    streams, _ = bind(SPEC, all_impls(one=sampler(lambda x: [(x,)], deferred=True, max_outputs=3)))
    assert streams["one"].info.deferred
    assert streams["one"].info.max_outputs == 3


def test_not_callable_and_cost_for_a_stream():
    with pytest.raises(BindingError, match="implementation of 'one' is int, not callable"):
        bind(SPEC, all_impls(one=3))
    with pytest.raises(BindingError, match="stream 'one' is bound to a cost function"):
        bind(SPEC, all_impls(one=cost(lambda x: 1.0)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"p_success": -0.1}, "p_success must be in"),
        ({"p_success": 0.0, "deferred": True}, "p_success must be > 0"),
        ({"opt_fn": 1.0}, "opt_fn must be callable"),
        ({"p_success": 1.5}, "p_success must be in"),
        ({"overhead": -1}, "overhead must be >= 0"),
        ({"max_outputs": 0}, "max_outputs must be >= 1"),
    ],
)
def test_stream_info_validation(kwargs, message):
    with pytest.raises(ValueError, match=message):
        StreamInfo(**kwargs)


def test_pytest_does_not_collect_the_test_wrapper():
    assert bindings.test.__test__ is False
    assert bindings.test(lambda: True).kind is Kind.TEST


# ------------------------------------------------------------------------ samplers and functions


def test_generator_function_is_a_sampler():
    def gen(x):
        yield (x,)
        yield None  # "no output this time" is skipped
        yield [x * 2]  # a list works as a tuple

    assert bound("one", gen).impl.kind is Kind.SAMPLER
    assert list(bound("one", gen).outputs((3,))) == [(3,), (6,)]


def test_multi_output_function_returning_one_tuple():
    assert list(bound("two", lambda x: (x, x + 1)).outputs((1,))) == [(1, 2)]


def test_auto_function_returning_none_gives_nothing():
    assert list(bound("one", lambda x: None).outputs((1,))) == []


def test_auto_function_returning_a_list_of_tuples():
    assert list(bound("two", lambda x: [(1, 2), (3, 4)]).outputs((0,))) == [(1, 2), (3, 4)]


def test_function_wrapper_takes_a_list_as_one_output_tuple():
    assert list(bound("two", function(lambda x: [x, x])).outputs((7,))) == [(7, 7)]


def test_outputs_are_opaque_python_values():
    arr = np.arange(3)
    (out,) = list(bound("one", lambda x: (arr,)).outputs((0,)))
    assert out[0] is arr


def test_sampler_yielding_wrong_arity_names_the_stream():
    def gen(x):
        yield (1,)
        yield (1, 2)

    outs = bound("one", gen).outputs((0,))
    assert next(outs) == (1,)
    with pytest.raises(BindingError) as info:
        next(outs)
    assert str(info.value).startswith("stream 'one' produced (1, 2); expected a tuple of 1 output")


def test_two_output_stream_given_one_value():
    with pytest.raises(BindingError, match=r"^stream 'two' produced \(5,\); expected a tuple of 2"):
        list(bound("two", lambda x: (5,)).outputs((0,)))


def test_sampler_yielding_a_bare_value_names_the_stream():
    with pytest.raises(BindingError, match="stream 'one' produced 5"):
        list(bound("one", sampler(lambda x: iter([5]))).outputs((0,)))


@pytest.mark.parametrize("value", [5, 2.0, "xy", b"xy"])
def test_function_returning_a_non_iterable(value):
    with pytest.raises(BindingError, match="stream 'one' returned"):
        list(bound("one", lambda x: value).outputs((0,)))


def test_fluents_are_passed_only_to_streams_that_declare_them():
    seen = {}

    def watch(x, fluents):
        seen["fluents"] = fluents
        return (x,)

    state = [("atpose", "a", "p"), ("holding", "b")]
    assert list(bound("watch", watch).outputs((1,), state)) == [(1,)]
    assert seen["fluents"] == state
    # a stream without ':fluents' is called without the keyword
    assert list(bound("one", lambda x: (x,)).outputs((1,), state)) == [(1,)]


# ------------------------------------------------------------------------ tests


@pytest.mark.parametrize(("result", "expected"), [(True, [()]), (False, [])])
def test_test_streams(result, expected):
    assert list(bound("check", lambda x, y: result).outputs((1, 2))) == expected


@pytest.mark.parametrize("result", ["yes", [True], 1.0, ()])
def test_test_returning_a_non_bool_names_the_stream(result):
    with pytest.raises(BindingError) as info:
        list(bound("check", bindings.test(lambda x, y: result)).outputs((1, 2)))
    msg = str(info.value)
    assert msg.startswith("test stream 'check' returned ")
    assert msg.endswith("not bool")


def test_generator_bound_to_a_test_is_an_error():
    def gen(x, y):
        yield ()

    with pytest.raises(BindingError, match="test stream 'check' returned generator"):
        list(bound("check", gen).outputs((1, 2)))


def test_test_may_return_a_numpy_bool():
    assert list(bound("check", lambda x, y: np.float64(x) < y).outputs((1, 2))) == [()]


# ------------------------------------------------------------------------ cost functions


def test_cost_function_values():
    assert bound_fn(lambda x, y: 3).value((0, 0)) == 3.0
    assert isinstance(bound_fn(lambda x, y: 3).value((0, 0)), float)
    assert bound_fn(lambda x, y: 0.0).value((0, 0)) == 0.0
    assert bound_fn(lambda x, y: np.float64(2.5)).value((0, 0)) == 2.5


def test_cost_function_returning_a_negative_number():
    with pytest.raises(BindingError) as info:
        bound_fn(lambda x, y: -0.5).value((0, 0))
    assert str(info.value) == "function 'dist' returned -0.5, costs must be finite and >= 0"


@pytest.mark.parametrize("value", [None, "1", True, (1,)])
def test_cost_function_returning_a_non_number(value):
    with pytest.raises(BindingError, match=r"function 'dist' returned .*, not a number"):
        bound_fn(lambda x, y: value).value((0, 0))


def test_cost_function_returning_nan():
    with pytest.raises(BindingError):
        bound_fn(lambda x, y: math.nan).value((0, 0))


@pytest.mark.parametrize("value", [np.float32(1.5), np.int64(2)])
def test_cost_function_returning_a_numpy_scalar(value):
    assert bound_fn(lambda x, y: value).value((0, 0)) == float(value)


@pytest.mark.parametrize(
    ("impl", "expected"),
    [
        (bindings.function(lambda x, y: ()), [()]),
        (bindings.function(lambda x, y: None), []),
        (bindings.sampler(lambda x, y: iter([None, ()])), [()]),
        (bindings.sampler(lambda x, y: iter([])), []),
    ],
)
def test_a_test_given_as_a_function_or_a_sampler_answers_with_outputs(impl, expected):
    """As PDDLStream's ``from_fn``/``from_list_fn`` on a stream without outputs."""
    assert list(bound("check", impl).outputs((1, 2))) == expected


def test_reported_facts_are_items_not_outputs():
    facts = bindings.Facts([("near", 1, 2)])
    check = bound("check", bindings.sampler(lambda x, y: iter([facts])))
    assert list(check.items((1, 2))) == [facts]
    assert list(check.outputs((1, 2))) == []
    one = bound("one", bindings.sampler(lambda x: iter([facts, (3,)])))
    assert list(one.items((1,))) == [facts, (3,)]
    assert list(one.outputs((1,))) == [(3,)]
