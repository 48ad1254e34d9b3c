"""Problems built from Python values and read from problem.pddl files, and their checks."""

from __future__ import annotations

import numpy as np
import pytest

from llmpas.language.domain import parse_domain
from llmpas.language.language_errors import BindingError, ModelError, PddlSyntaxError
from llmpas.language.logic import And, Atom, FuncTerm, Not
from llmpas.language.problem import (
    Problem,
    ValueNamer,
    known_predicates,
    parse_formula,
    parse_problem_text,
    read_problem,
)
from llmpas.language.streams import parse_streams

from .texts import WILD_PROBLEM

BLOCKS = parse_domain(
    """(define (domain blocks)
  (:types block table)
  (:constants Table)
  (:predicates (Block ?b) (On ?b ?x) (Clear ?x) (AtPose ?b ?p))
  (:functions (Dist ?a ?b))
  (:derived (Above ?a ?b) (On ?a ?b))
  (:action stack :parameters (?b ?x)
    :precondition (and (Block ?b) (Clear ?b) (Clear ?x))
    :effect (and (On ?b ?x) (not (Clear ?x)) (increase (total-cost) (Dist ?b ?x)))))""",
    "blocks.pddl",
)


def where(text: str, needle: str) -> tuple[int, int]:
    offset = text.index(needle)
    before = text[:offset]
    return before.count("\n") + 1, offset - before.rfind("\n")


def problem_text(init: str, goal: str = "(Clear a)", objects: str = "a b") -> str:
    return (
        f"(define (problem p) (:domain blocks)\n  (:objects {objects})\n"
        f"  (:init {init})\n  (:goal {goal}))"
    )


def read_text(tmp_path, text: str, domain=BLOCKS, **kw) -> Problem:
    path = tmp_path / "problem.pddl"
    path.write_text(text, encoding="utf-8")
    return read_problem(domain, path, **kw)


# ------------------------------------------------------------------------ value naming


def test_value_namer():
    namer = ValueNamer(taken=["v0", "v2"])
    a, b = np.zeros(2), np.zeros(2)
    assert namer.name("MixedCase") == "mixedcase"
    na, nb = namer.name(a), namer.name(b)
    assert na == nb  # equal arrays are one object: bytes, shape and dtype decide
    assert na not in {"v0", "v2"}
    assert namer.values[na] is a
    # the same bytes under another shape or dtype are other values
    assert namer.name(np.zeros((2, 1))) != na
    assert namer.name(np.zeros(2, dtype=np.float32)) != na
    assert namer.name(np.array([0.0, 1e-12])) != na
    unhashable = [{"k": 1}, {"k": 1}]  # neither hashable nor arrays: identity decides
    assert namer.name(unhashable[0]) != namer.name(unhashable[1])
    assert namer.name((1.0, 2.0)) == namer.name((1.0, 2.0))  # equal hashable values share
    assert namer.name(7) != namer.name(8)


def test_create_with_numpy_arrays():
    p1, p2, p3 = np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([5.0, 5.0])
    prob = Problem.create(
        BLOCKS,
        init=[
            ("Block", "A"),
            ("AtPose", "A", p1),
            ("AtPose", "b", p2),
            ("AtPose", "a", p1),  # the same array again
            ("Block", "b"),
            ("AtPose", "b", p3),
        ],
        goal=[("AtPose", "a", p3)],
    )
    poses = {a.args[1] for a in prob.init if a.predicate == "atpose"}
    assert len(poses) == 2  # p1 and p2 are equal arrays: one object
    by_value = {id(prob.value(n)): n for n in poses}
    assert set(by_value) == {id(p1), id(p3)}
    assert prob.value(by_value[id(p1)]) is p1
    assert Atom("atpose", ("a", by_value[id(p1)])) in prob.init
    assert Atom("atpose", ("b", by_value[id(p1)])) in prob.init
    assert prob.goal == And((Atom("atpose", ("a", by_value[id(p3)])),))
    assert prob.value("a") == "A"  # symbolic objects stand for themselves, as first written
    assert prob.value("b") == "b" and prob.written("a") == "A"
    assert {"a", "b"} <= set(prob.objects)
    assert "table" not in prob.objects  # a constant, not an object
    assert "table" in prob.all_objects


def test_create_equal_hashable_values_share_a_name():
    prob = Problem.create(
        BLOCKS,
        init=[("AtPose", "a", (1.0, 2.0)), ("AtPose", "b", (1.0, 2.0)), ("AtPose", "c", (3, 4))],
        goal=[],
    )
    names = {a.args[0]: a.args[1] for a in prob.init}
    assert names["a"] == names["b"] != names["c"]
    assert prob.value(names["a"]) == (1.0, 2.0)


def test_create_user_object_names_do_not_collide_with_generated_names():
    arrays = [np.full(2, i) for i in range(3)]
    prob = Problem.create(
        BLOCKS,
        objects=["v0", "V1"],
        init=[("Block", "v0"), ("Block", "v1")] + [("AtPose", "v0", x) for x in arrays],
        goal=[],
    )
    generated = {a.args[1] for a in prob.init if a.predicate == "atpose"}
    assert len(generated) == 3
    assert generated.isdisjoint({"v0", "v1"})
    assert prob.value("v0") == "v0"
    assert {id(prob.value(n)) for n in generated} == {id(x) for x in arrays}


@pytest.mark.parametrize("array_first", [False, True])
def test_create_names_in_init_do_not_collide_with_generated_names(array_first):
    pose = np.zeros(3)
    atoms = [("Block", "v0"), ("AtPose", "v0", pose)]
    prob = Problem.create(BLOCKS, init=atoms[::-1] if array_first else atoms, goal=[])
    (at,) = [a for a in prob.init if a.predicate == "atpose"]
    assert at.args[1] != "v0"
    assert prob.value("v0") == "v0"


def test_create_with_costs_goal_text_and_atoms():
    prob = Problem.create(
        BLOCKS,
        init=[Atom("block", ("a",)), ("Clear", "a"), ("Clear", "Table"), ("AtPose", "a", (0, 0))],
        goal="(and (On a Table) (not (Clear a)))",
        costs={("Dist", "a", "Table"): 2, ("DIST", "a", (0, 0)): 1.5},
        name="mine",
    )
    assert prob.name == "mine"
    assert prob.goal == And((Atom("on", ("a", "table")), Not(Atom("clear", ("a",)))))
    (pose,) = [a.args[1] for a in prob.init if a.predicate == "atpose"]  # shared with costs
    assert prob.costs == {
        FuncTerm("dist", ("a", "table")): 2.0,
        FuncTerm("dist", ("a", pose)): 1.5,
    }


def test_create_binds_streams():
    spec = parse_streams(
        "(define (stream s) (:stream grasp :inputs (?b) :domain (Block ?b) :outputs (?g) "
        ":certified (Grasp ?b ?g)))"
    )
    with pytest.raises(BindingError, match="stream 'grasp' is declared but has no Python"):
        Problem.create(BLOCKS, spec, init=[("Block", "a")], goal=[])
    prob = Problem.create(
        BLOCKS,
        spec,
        init=[("Block", "a"), ("Grasp", "a", np.eye(2))],  # a certified predicate in init
        goal=[("Block", "a")],
        implementations={"grasp": lambda b: (np.eye(2),)},
    )
    assert set(prob.bound_streams) == {"grasp"}


@pytest.mark.parametrize(
    ("init", "goal", "message"),
    [
        ([("Blok", "a")], [], "init: unknown predicate 'blok' in (blok a)"),
        ([("Block", "a", "b")], [], "init: 'block' takes 1 arguments, given 2 in (block a b)"),
        ([("Above", "a", "b")], [], "init: (above a b) is a derived predicate; it cannot be set"),
        ([("Block", "a")], [("Blocks", "a")], "goal: unknown predicate 'blocks' in (blocks a)"),
        ([("Block", "a")], [("On", "a")], "goal: 'on' takes 2 arguments, given 1 in (on a)"),
        ([(3, "a")], [], "an init atom must start with a predicate name"),
    ],
)
def test_create_rejects_bad_atoms(init, goal, message):
    with pytest.raises(ModelError) as info:
        Problem.create(BLOCKS, init=init, goal=goal)
    assert str(info.value).startswith(message)


def test_goal_may_use_derived_predicates_and_quantifiers():
    prob = Problem.create(
        BLOCKS,
        init=[("Block", "a"), ("Block", "b")],
        goal="(and (Above a b) (forall (?x) (imply (Block ?x) (not (On ?x ?x)))))",
    )
    assert isinstance(prob.goal, And)


def test_goal_text_with_unknown_predicate_or_two_formulas():
    with pytest.raises(ModelError, match="goal: unknown predicate 'flying'"):
        Problem.create(BLOCKS, init=[("Block", "a")], goal="(Flying a)")
    with pytest.raises(ModelError, match="expected exactly one formula, found 2"):
        parse_formula("(Block a) (Block b)", BLOCKS, "<goal>")
    with pytest.raises(PddlSyntaxError, match="predicate 'on' takes 2 arguments, given 3"):
        parse_formula("(On a b c)", BLOCKS)


def test_with_state_replaces_init_and_rechecks():
    prob = Problem.create(BLOCKS, init=[("Block", "a"), ("Clear", "a")], goal=[("Clear", "a")])
    later = prob.with_state([Atom("block", ("a",))])
    assert later.init == {Atom("block", ("a",))}
    assert later.goal == prob.goal
    assert prob.init == {Atom("block", ("a",)), Atom("clear", ("a",))}  # unchanged
    with pytest.raises(ModelError, match="unknown object 'zz'"):
        prob.with_state([Atom("block", ("zz",))])
    pose = np.ones(2)
    moved = prob.with_state([Atom("atpose", ("a", "p9"))], objects={"p9": pose})
    assert moved.value("p9") is pose


def test_problem_mappings_are_read_only():
    prob = Problem.create(BLOCKS, init=[("Block", "a")], goal=[])
    with pytest.raises(TypeError):
        prob.objects["b"] = "b"  # type: ignore[index]


# ------------------------------------------------------------------------ undeclared predicates


UNDECLARED = """(define (domain d)
  (:predicates (Block ?b))
  (:action pick :parameters (?b ?g)
    :precondition (and (Block ?b) (Grasp ?b ?g))
    :effect (Holding ?b)))"""


def test_undeclared_predicate_without_stream_names_its_first_use():
    d = parse_domain(UNDECLARED, "undeclared.pddl")
    with pytest.raises(PddlSyntaxError) as info:
        Problem.create(d, init=[("Block", "a")], goal=[])
    line, col = where(UNDECLARED, "(Grasp ?b ?g)")
    assert str(info.value) == (
        f"undeclared.pddl:{line}:{col}: predicate 'grasp' is neither declared nor certified "
        "by a stream"
    )


def test_undeclared_predicate_certified_with_another_arity():
    d = parse_domain(UNDECLARED, "undeclared.pddl")
    spec = parse_streams(
        "(define (stream s) (:stream g :inputs (?b) :domain (Block ?b) :outputs (?g) "
        ":certified (and (Grasp ?g) (Holding ?b))))"
    )
    with pytest.raises(PddlSyntaxError) as info:
        Problem.create(d, spec, init=[("Block", "a")], goal=[], implementations={"g": print})
    assert info.value.message == "'grasp' takes 2 arguments here but its stream certifies 1"
    assert (info.value.line, info.value.col) == where(UNDECLARED, "(Grasp ?b ?g)")


def test_known_predicates(wild_domain, wild_streams):
    known = known_predicates(wild_domain, wild_streams)
    assert known["reach"] == 6 and known["apart"] == 4
    assert known["canrest"] == 2  # from a stream's :domain
    assert known["blocked"] == 2  # derived
    assert known["="] == 2


def test_stream_certifying_a_declared_predicate_with_another_arity():
    spec = parse_streams(
        "(define (stream s) (:stream g :inputs (?b) :domain (Block ?b) :outputs (?x) "
        ":certified (On ?x)))"
    )
    with pytest.raises(ModelError):
        Problem.create(BLOCKS, spec, init=[("Block", "a")], goal=[], implementations={"g": print})


# ------------------------------------------------------------------------ problem files


def test_read_wild_problem(wild_files, wild_impls):
    prob = read_problem(
        wild_files["domain"], wild_files["problem"], wild_files["stream"], wild_impls
    )
    assert prob.name == "two-blocks"
    assert prob.domain.name == "pick-and-place"
    assert set(prob.objects) == {
        "left", "a", "b", "table", "s-a", "s-b", "s-c", "h-a", "base0", "base1", "path0"
    }  # fmt: skip
    assert prob.objects["s-a"] == "s-a"
    assert prob.object_types["a"] == "object"
    assert Atom("atpose", ("a", "s-a")) in prob.init
    assert Atom("reach", ("left", "a", "s-c", "h-a", "base1", "path0")) in prob.init
    assert prob.costs == {
        FuncTerm("cost", ()): 1.0,
        FuncTerm("dist", ("base0", "base1")): 3.0,
        FuncTerm("travelcost", ("path0",)): 2.5,
    }
    assert prob.goal == And((Atom("atpose", ("a", "s-c")), Atom("handempty", ("left",))))
    assert set(prob.bound_streams) == {"find-spot", "reach", "spots-apart"}
    assert set(prob.bound_functions) == {"travelcost"}


def test_read_problem_needs_the_streams_of_an_undeclared_predicate(wild_files):
    with pytest.raises(PddlSyntaxError) as info:
        read_problem(wild_files["domain"], wild_files["problem"])
    err = info.value
    assert err.filename == str(wild_files["domain"])
    assert "is neither declared nor certified by a stream" in err.message


def test_read_problem_with_parsed_domain_and_streams(wild_domain, wild_streams, wild_files):
    impls = {"find-spot": print, "reach": print, "spots-apart": print, "travelcost": print}
    prob = read_problem(wild_domain, wild_files["problem"], wild_streams, impls)
    assert prob.domain is wild_domain
    assert prob.streams is wild_streams


def test_read_typed_objects(tmp_path):
    prob = read_text(
        tmp_path,
        "(define (problem p) (:domain blocks) (:requirements :typing)\n"
        " (:objects a b - block t - table c)\n"
        " (:init (Block a) (= (Dist a b) 3) (= (Dist b a) 0.5)) (:goal (On a t)))",
    )
    assert dict(prob.object_types) == {"a": "block", "b": "block", "t": "table", "c": "object"}
    assert prob.costs == {FuncTerm("dist", ("a", "b")): 3.0, FuncTerm("dist", ("b", "a")): 0.5}


@pytest.mark.parametrize(
    ("init", "goal", "message"),
    [
        ("(Blok a)", "(Clear a)", "init: unknown predicate 'blok' in (blok a)"),
        ("(On a)", "(Clear a)", "init: 'on' takes 2 arguments, given 1 in (on a)"),
        ("(On a zz)", "(Clear a)", "init: unknown object 'zz' in (on a zz)"),
        ("(Above a b)", "(Clear a)", "init: (above a b) is a derived predicate"),
        ("(Block a)", "(Clearr a)", "goal: unknown predicate 'clearr' in (clearr a)"),
        ("(Block a)", "(and (Block a) (On a zz))", "goal: unknown object 'zz' in (on a zz)"),
    ],
)
def test_read_problem_rejects_bad_atoms(tmp_path, init, goal, message):
    with pytest.raises(ModelError) as info:
        read_text(tmp_path, problem_text(init, goal))
    # the message names the problem file first
    assert str(info.value).startswith(f"{tmp_path / 'problem.pddl'}: {message}")


def test_goal_may_name_domain_constants(tmp_path):
    prob = read_text(tmp_path, problem_text("(Block a) (= (Dist a Table) 1)", "(On a Table)"))
    assert prob.goal == Atom("on", ("a", "table"))


@pytest.mark.parametrize(
    ("text", "needle", "message"),
    [
        (
            problem_text("(Block a)", "(On a b c)"),
            "(On a b c)",
            "predicate 'on' takes 2 arguments, given 3",
        ),
        (problem_text("(Block a)", "(On a ?x)"), "?x", "variable '?x' is not bound here"),
        (problem_text("(not (Block a))"), "(not", "init holds atoms only, found 'not'"),
        (problem_text("(Block (a))"), "(a)", "init atoms take object names as arguments"),
        (problem_text("(= (Dist a b) far)"), "far", "expected a number, found 'far'"),
        (
            "(define (problem p) (:domain other) (:goal (Block a)))",
            "(:domain",
            "problem is for domain 'other', not 'blocks'",
        ),
        ("(define (problem p) (:domain blocks) (:init))", "(define", "problem has no ':goal'"),
        (
            "(define (problem p) (:domain blocks) (:constraints) (:goal (Block a)))",
            "(:constraints",
            "unknown problem section ':constraints'",
        ),
        ("(define (domain p))", "(domain", "expected '(problem NAME)'"),
        ("(problem p)", "(problem", "expected '(define (problem NAME) ...)'"),
    ],
)
def test_malformed_problem_files(tmp_path, text, needle, message):
    with pytest.raises(PddlSyntaxError) as info:
        read_text(tmp_path, text)
    err = info.value
    path = str(tmp_path / "problem.pddl")
    assert str(err) == f"{path}:{err.line}:{err.col}: {message}"
    assert (err.line, err.col) == where(text, needle)


def test_problem_syntax_error_positions(tmp_path):
    text = "(define (problem p)\n  (:domain blocks)\n  (:init (Block a)\n  (:goal (Block a))"
    with pytest.raises(PddlSyntaxError) as info:
        read_text(tmp_path, text)
    assert (info.value.line, info.value.col) == (3, 3)
    assert info.value.message == "'(' is never closed"


def test_parse_problem_text_keeps_file_order():
    pf = parse_problem_text(problem_text("(Block b) (Block a) (= (Dist a b) 3)"), BLOCKS)
    assert pf.init == (Atom("block", ("b",)), Atom("block", ("a",)))
    assert pf.objects == {"a": "object", "b": "object"}
    assert pf.domain_name == "blocks"


@pytest.mark.parametrize(
    "text",
    [
        problem_text("()"),
        "(define (problem p) (:domain blocks) (:goal))",
        "(define (problem p) (:domain) (:goal (Block a)))",
        problem_text("(= (Dist a b))"),
    ],
)
def test_truncated_problem_sections_are_syntax_errors(text):
    with pytest.raises(PddlSyntaxError):
        parse_problem_text(text, BLOCKS)


@pytest.mark.parametrize(
    "fact", ["(= (Distt a b) 3)", "(= (Dist a zz) 3)", "(= (Dist a b) nan)", "(= (Dist a) 1)"]
)
def test_numeric_init_is_checked(tmp_path, fact):
    with pytest.raises((ModelError, PddlSyntaxError)):
        read_text(tmp_path, problem_text(f"(Block a) {fact}"))


def test_wild_problem_text_is_kept_as_written(wild_domain):
    pf = parse_problem_text(WILD_PROBLEM, wild_domain, "p.pddl")
    assert pf.name == "two-blocks"
    assert pf.domain_name == "pick-and-place"


# ------------------------------------------------- values, spelling and cost idioms (issue #11)


def test_file_objects_keep_their_spelling_and_take_given_values(tmp_path):
    pose = np.array([0.5, 1.5])
    prob = read_text(
        tmp_path,
        problem_text("(Block pA0) (Block Q) (= (Dist pA0 Q) 1)", "(On pA0 Q)", "pA0 Q"),
        values={"PA0": pose},  # matched without regard to case
    )
    assert prob.value("pa0") is pose  # streams receive the value
    assert prob.value("q") == "Q"  # or the name as written
    assert prob.goal == Atom("on", ("pa0", "q"))  # matching stays case-insensitive


def test_values_for_unknown_objects_are_refused(tmp_path):
    with pytest.raises(ModelError, match="a value is given for 'pb', which is not an object"):
        read_text(tmp_path, problem_text("(Block a) (= (Dist a b) 1)"), values={"pB": 1.0})


def test_equal_values_from_init_and_from_streams_are_one_object():
    pose = np.array([1.0, 2.0])
    namer = ValueNamer(prefix="s", known={"pa0": pose, "a": "a"})
    assert namer.name(np.array([1.0, 2.0])) == "pa0"
    assert namer.name(np.array([2.0, 1.0])) not in {"pa0", "a"}


@pytest.mark.parametrize(
    "cost", ["(= (total-cost) 0) (= (Dist a b) 1)", "(= (Dist a b) 1) (= (total-cost) 3)"]
)
def test_total_cost_in_init_is_accepted_and_left_to_the_planner(tmp_path, cost):
    prob = read_text(tmp_path, problem_text(f"(Block a) {cost}"))
    assert prob.costs == {FuncTerm("dist", ("a", "b")): 1.0}


def test_python_equal_idiom_gives_function_values():
    prob = Problem.create(
        BLOCKS,
        init=[
            ("Block", "a"),
            ("Block", "b"),
            ("=", ("Dist", "a", "b"), 2),
            ("=", ("total-cost",), 0),
        ],
        goal=[("On", "a", "b")],
    )
    assert prob.costs == {FuncTerm("dist", ("a", "b")): 2.0}
    assert all(a.predicate != "=" for a in prob.init)


@pytest.mark.parametrize(
    ("item", "message"),
    [
        (("=", "Dist", 2), "expected \\('=', \\(FUNCTION, ARG, ...\\), NUMBER\\)"),
        (("=", ("Dist", "a", "b"), "far"), "the value of .* is not a number"),
        (("=", ("Dist", "a", "b"), -1), "must be a finite number >= 0"),
    ],
)
def test_python_equal_idiom_errors(item, message):
    with pytest.raises(ModelError, match=message):
        Problem.create(BLOCKS, init=[("Block", "a"), ("Block", "b"), item], goal=[("Block", "a")])


def test_a_missing_cost_value_is_named_at_load_time(tmp_path):
    with pytest.raises(ModelError) as info:
        read_text(tmp_path, problem_text("(Block a)"))
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'problem.pddl'}: action 'stack' adds (dist ?b ?x)")
    assert "no value of 'dist' is given" in message and "\n" not in message


@pytest.mark.parametrize(
    ("init", "needle", "message"),
    [
        ("(= (Cost) 1)", "(Cost)", "function 'cost' is not declared in the domain's ':functions'"),
        ("(= (Dist a) 1)", "(Dist a)", "function 'dist' takes 2 arguments, given 1"),
    ],
)
def test_function_values_in_init_are_checked_at_their_place(tmp_path, init, needle, message):
    text = problem_text(f"(Block a) {init}")
    path = tmp_path / "problem.pddl"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(PddlSyntaxError) as info:
        read_problem(BLOCKS, path)
    assert (info.value.line, info.value.col) == where(text, needle)
    assert info.value.message == message
