"""The meaning of a domain: formulas in states, derived predicates, effects, plan replay, costs."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from llmpas.language.domain import parse_domain
from llmpas.language.language_errors import ModelError
from llmpas.language.logic import And, Atom, Exists, Forall, FuncTerm, Imply, Not, Or, Param
from llmpas.language.problem import parse_formula, read_problem
from llmpas.language.semantics import Semantics, State, ground_atoms, nnf, replay

from .strategies import formulas


def A(pred: str, *args: str) -> Atom:
    return Atom.of(pred, *args)


BLOCKS = parse_domain(
    """(define (domain blocks)
  (:requirements :strips :typing)
  (:types block room - object)
  (:constants Floor - block)
  (:predicates (on ?x ?y) (red ?x) (in ?b - block ?r - room) (lit) (mark ?x))
  ; declared before the predicate it negates: strata do not follow file order
  (:derived (free ?x) (not (covered ?x)))
  (:derived (covered ?x) (exists (?y) (on ?y ?x)))
  (:derived (above ?x ?y) (on ?x ?y))
  (:derived (above ?x ?y) (exists (?z) (and (on ?x ?z) (above ?z ?y))))
  (:derived (topfree ?x) (and (red ?x) (not (free ?x))))
  (:derived (allred ?r - room) (forall (?b - block) (imply (in ?b ?r) (red ?b))))
  (:action paint :parameters (?x)
    :precondition (and (free ?x) (not (red ?x)))
    :effect (and (red ?x) (increase (total-cost) 2)))
  (:action put :parameters (?x ?y)
    :precondition (and (free ?x) (free ?y) (not (= ?x ?y)))
    :effect (and (on ?x ?y) (increase (total-cost) (Dist ?x ?y))))
  (:action clean :parameters (?r - room)
    :precondition (forall (?b - block) (imply (in ?b ?r) (not (red ?b))))
    :effect (and (mark ?r)))
  (:action toggle :parameters ()
    :precondition (and)
    :effect (and (when (lit) (not (lit))) (when (not (lit)) (lit))))
  (:action sweep :parameters (?r - room)
    :precondition (and)
    :effect (forall (?b - block) (when (in ?b ?r) (and (not (in ?b ?r)) (mark ?b)))))
  (:action refresh :parameters (?x)
    :precondition (red ?x)
    :effect (and (not (red ?x)) (red ?x)))
  (:action same :parameters (?x ?y)
    :precondition (= ?x ?y)
    :effect (mark ?x)))
"""
)

TYPES = {"a": "block", "b": "block", "c": "block", "r1": "room", "r2": "room"}
COSTS = {FuncTerm("dist", ("a", "b")): 4.0, FuncTerm("dist", ("b", "c")): 0.5}


@pytest.fixture
def sem() -> Semantics:
    return Semantics(BLOCKS, TYPES, COSTS)


def formula(text: str):
    return parse_formula(text, BLOCKS)


# ------------------------------------------------------------------------ formulas


def test_nnf_pushes_negation_to_atoms():
    f = Not(And((A("p"), Imply(A("q"), A("r")), Exists((Param("?x"),), A("s", "?x")))))
    assert nnf(f) == Or(
        (Not(A("p")), And((A("q"), Not(A("r")))), Forall((Param("?x"),), Not(A("s", "?x"))))
    )
    assert nnf(Not(Not(A("p")))) == A("p")


def test_universe_follows_types_and_constants(sem):
    assert sem.universe.of_type("block") == ["a", "b", "c", "floor"]
    assert sem.universe.of_type("room") == ["r1", "r2"]
    assert len(sem.universe.of_type("object")) == 6
    assert sem.universe.of_type("ghost") == []


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("(exists (?x) (on ?x b))", True),
        ("(exists (?x) (on ?x a))", False),
        ("(forall (?x - block) (imply (on ?x b) (red ?x)))", True),
        ("(forall (?x - block) (imply (not (red ?x)) (on ?x b)))", False),
        ("(forall (?x - room) (not (red ?x)))", True),
        ("(exists (?x - room) (red ?x))", False),  # 'a' is red, but a block
        ("(exists (?x - block) (red ?x))", True),
        ("(exists (?x ?y) (and (on ?x ?y) (red ?y)))", False),
        ("(or (lit) (red a))", True),
        ("(and (red a) (not (red b)))", True),
        ("(imply (red b) (lit))", True),
        ("(= a a)", True),
        ("(not (= a b))", True),
        ("(exists (?x - block) (and (not (red ?x)) (not (= ?x floor)) (not (on ?x b))))", True),
        ("(forall (?x - block) (exists (?y) (or (= ?x ?y) (on ?x ?y))))", True),
        ("(exists (?x) (forall (?y - block) (not (on ?y ?x))))", True),
        ("(forall (?x) (exists (?y - room) (= ?x ?y)))", False),
    ],
)
def test_formulas_in_a_state(sem, text, expected):
    state = [A("on", "a", "b"), A("red", "a")]
    assert sem.holds(formula(text), state) is expected


def test_holds_with_free_variables_bound_by_env(sem):
    from llmpas.language.semantics import Evaluator

    ev = Evaluator(sem.universe, State([A("on", "a", "b")]))
    f = Exists((Param("?z"),), A("on", "?x", "?z"))
    assert ev.holds(f, {"?x": "a"})
    assert not ev.holds(f, {"?x": "b"})
    # a quantifier shadows an outer binding of the same variable
    shadow = Exists((Param("?x"),), A("on", "?x", "b"))
    assert ev.holds(shadow, {"?x": "c"})


# ------------------------------------------------------------------------ derived predicates


def test_derived_with_exists_and_negation(sem):
    st_ = sem.closure([A("on", "a", "b"), A("on", "b", "c")])
    assert A("covered", "b") in st_ and A("covered", "c") in st_
    assert A("covered", "a") not in st_
    free = {a.args[0] for a in st_.facts if a.predicate == "free"}
    assert free == {"a", "floor", "r1", "r2"}  # not covered, over the whole universe


def test_recursive_derived_with_two_rules(sem):
    st_ = sem.closure([A("on", "a", "b"), A("on", "b", "c"), A("on", "c", "floor")])
    above = {a.args for a in st_.facts if a.predicate == "above"}
    assert above == {
        ("a", "b"), ("a", "c"), ("a", "floor"), ("b", "c"), ("b", "floor"), ("c", "floor")
    }  # fmt: skip


def test_stratification_derived_on_negation_of_derived(sem):
    # topfree x <- red x and not free x ; free x <- not covered x ; covered <- exists on
    st_ = sem.closure([A("on", "a", "b"), A("red", "b"), A("red", "a")])
    assert A("topfree", "b") in st_  # b is covered, so not free
    assert A("topfree", "a") not in st_


def test_derived_with_typed_head_and_forall(sem):
    st_ = sem.closure([A("in", "a", "r1"), A("red", "a"), A("in", "b", "r2")])
    rooms = {a.args[0] for a in st_.facts if a.predicate == "allred"}
    assert rooms == {"r1"}  # r2 holds b, which is not red; only rooms are considered


def test_closure_drops_stale_derived_atoms(sem):
    st_ = sem.closure([A("covered", "a"), A("on", "b", "c")])
    assert A("covered", "a") not in st_
    assert A("covered", "c") in st_


def test_not_stratifiable():
    d = parse_domain(
        "(define (domain s) (:predicates (p ?x))"
        " (:derived (q ?x) (and (p ?x) (not (r ?x)))) (:derived (r ?x) (not (q ?x))))"
    )
    with pytest.raises(ModelError, match="not stratifiable"):
        Semantics(d, {"a": "object"})


def test_forall_counts_as_negative_dependency():
    d = parse_domain(
        "(define (domain s) (:predicates (p ?x))"
        " (:derived (q ?x) (forall (?y) (r ?y))) (:derived (r ?x) (q ?x)))"
    )
    with pytest.raises(ModelError, match="not stratifiable"):
        Semantics(d, {"a": "object"})


def test_positive_recursion_is_stratifiable():
    d = parse_domain(
        "(define (domain s) (:predicates (e ?x ?y))"
        " (:derived (reach ?x ?y) (or (e ?x ?y) (exists (?z) (and (reach ?x ?z) (e ?z ?y)))))"
        " (:derived (unreach ?x ?y) (not (reach ?x ?y))))"
    )
    sem = Semantics(d, dict.fromkeys("abc", "object"))
    st_ = sem.closure([A("e", "a", "b"), A("e", "b", "c")])
    assert A("reach", "a", "c") in st_
    assert A("unreach", "c", "a") in st_
    assert A("unreach", "a", "c") not in st_


# ------------------------------------------------------------------------ actions


def test_negated_derived_precondition(sem):
    st_ = sem.closure([A("on", "a", "b")])
    paint = BLOCKS.action("paint")
    assert sem.applicable(paint, ("a",), st_)
    assert not sem.applicable(paint, ("b",), st_)  # b is covered


def test_forall_imply_precondition(sem):
    clean = BLOCKS.action("clean")
    st_ = sem.closure([A("in", "a", "r1"), A("red", "a"), A("in", "b", "r2")])
    assert not sem.applicable(clean, ("r1",), st_)
    assert sem.applicable(clean, ("r2",), st_)


def test_equality_precondition(sem):
    st_ = sem.closure([])
    same = BLOCKS.action("same")
    assert sem.applicable(same, ("a", "a"), st_)
    assert not sem.applicable(same, ("a", "b"), st_)
    put = BLOCKS.action("put")
    assert not sem.applicable(put, ("a", "a"), st_)
    assert sem.applicable(put, ("a", "b"), st_)


def test_conditional_effects_see_the_state_before_the_action(sem):
    toggle = BLOCKS.action("toggle")
    on, _ = sem.apply(toggle, (), sem.closure([A("lit")]))
    assert A("lit") not in on
    off, _ = sem.apply(toggle, (), sem.closure([]))
    assert A("lit") in off


def test_forall_effect_with_condition(sem):
    facts = [A("in", "a", "r1"), A("in", "b", "r1"), A("in", "c", "r2")]
    after, cost = sem.apply(BLOCKS.action("sweep"), ("r1",), sem.closure(facts))
    assert after == {A("in", "c", "r2"), A("mark", "a"), A("mark", "b")}
    assert cost == 0.0  # the domain uses costs; this action adds none


def test_add_wins_over_delete(sem):
    after, _ = sem.apply(BLOCKS.action("refresh"), ("a",), sem.closure([A("red", "a")]))
    assert A("red", "a") in after


def test_apply_drops_derived_atoms(sem):
    after, cost = sem.apply(BLOCKS.action("paint"), ("a",), sem.closure([A("on", "b", "c")]))
    assert after == {A("on", "b", "c"), A("red", "a")}
    assert cost == 2.0


def test_typed_parameters_are_checked(sem):
    with pytest.raises(ModelError, match="action 'clean': 'a' is not of type 'room'"):
        sem.applicable(BLOCKS.action("clean"), ("a",), sem.closure([]))
    with pytest.raises(ModelError, match="action 'paint' takes 1 arguments, given 2"):
        sem.applicable(BLOCKS.action("paint"), ("a", "b"), sem.closure([]))


# ------------------------------------------------------------------------ replay and costs


def test_replay_accepts_a_valid_plan(sem):
    plan = [("put", ("b", "c")), ("PUT", ("a", "b")), ("paint", ("a",))]
    r = replay(sem, [], plan, formula("(and (above a c) (red a))"))
    assert r.valid and r.message == "ok" and r.failed_step is None
    assert r.cost == 0.5 + 4.0 + 2.0
    assert len(r.states) == 4
    assert r.states[0] == frozenset()
    assert r.states[-1] == {A("on", "b", "c"), A("on", "a", "b"), A("red", "a")}


def test_replay_rejects_an_invalid_plan_naming_the_step(sem):
    plan = [("put", ("b", "c")), ("paint", ("c",)), ("paint", ("a",))]
    r = replay(sem, [], plan)
    assert not r.valid
    assert r.message == "step 2: precondition of (paint c) does not hold"
    assert r.failed_step == 1
    assert r.cost == 0.5
    assert len(r.states) == 2  # the initial state and the one after step 1


def test_replay_reports_an_unreached_goal(sem):
    r = replay(sem, [], [("paint", ("a",))], formula("(red b)"))
    assert not r.valid
    assert r.message == "the goal does not hold after the last step"
    assert r.failed_step is None
    assert r.cost == 2.0


def test_replay_errors(sem):
    bad = replay(sem, [], [("fly", ())])  # an unknown action is an invalid plan, not a crash
    assert not bad.valid and bad.failed_step == 0
    assert "step 1:" in bad.message and "unknown action 'fly'" in bad.message
    with pytest.raises(ModelError, match=r"no value for cost function \(dist a c\)"):
        replay(sem, [], [("put", ("a", "c"))])


def test_unit_costs_without_action_costs():
    d = parse_domain(
        "(define (domain u) (:predicates (p ?x)) (:action a :parameters (?x) :effect (p ?x)))"
    )
    sem = Semantics(d, {"x": "object"})
    r = replay(sem, [], [("a", ("x",)), ("a", ("x",))], A("p", "x"))
    assert r.valid and r.cost == 2.0


def test_wild_problem_replay(wild_files, wild_impls):
    prob = read_problem(
        wild_files["domain"], wild_files["problem"], wild_files["stream"], wild_impls
    )
    sem = Semantics(prob.domain, prob.object_types, prob.costs)
    plan = [
        ("move_base", ("base0", "base1")),
        ("pick", ("left", "a", "s-a", "h-a", "base1", "path0")),
        ("place", ("left", "a", "s-c", "h-a", "base1", "path0")),
    ]
    r = replay(sem, prob.init, plan, prob.goal)
    assert r.valid, r.message
    assert r.cost == 3.0 + 2.5 + 1.0  # Dist, TravelCost and Cost from the numeric init

    # s-b is where b stands and no test said it is apart: Blocked holds, place fails
    bad = [*plan[:2], ("place", ("left", "a", "s-b", "h-a", "base1", "path0"))]
    r = replay(sem, prob.init, bad, prob.goal)
    assert not r.valid and r.failed_step == 2
    assert r.message == "step 3: precondition of (place left a s-b h-a base1 path0) does not hold"
    state = sem.closure(r.states[-1])
    assert A("blocked", "a", "s-b") in state
    assert A("blocked", "a", "s-c") not in state

    r = replay(sem, prob.init, plan[1:], prob.goal)
    assert not r.valid and r.message.startswith("step 1: precondition of (pick left a s-a")


def test_ground_atoms():
    f = formula("(and (red a) (exists (?x) (on ?x b)) (not (lit)))")
    assert set(ground_atoms(f)) == {A("red", "a"), A("lit")}


# ------------------------------------------------------------------------ against a reference

PROP_DOMAIN = parse_domain(
    "(define (domain prop) (:types block room ghost - object) (:predicates (p ?x) (q ?x ?y) (r)))"
)
PROP_TYPES = {"a": "block", "b": "block", "c": "room", "d": "object"}


def reference(sem: Semantics, f, env, facts) -> bool:
    """Textbook semantics by enumeration."""
    match f:
        case Atom(pred, args):
            vals = tuple(env.get(t, t) for t in args)
            return vals[0] == vals[1] if pred == "=" else Atom(pred, vals) in facts
        case Not(x):
            return not reference(sem, x, env, facts)
        case And(parts):
            return all(reference(sem, x, env, facts) for x in parts)
        case Or(parts):
            return any(reference(sem, x, env, facts) for x in parts)
        case Imply(c, t):
            return not reference(sem, c, env, facts) or reference(sem, t, env, facts)
        case Exists(ps, body) | Forall(ps, body):
            values = itertools.product(*(sem.universe.of_type(p.type) for p in ps))
            results = (
                reference(
                    sem, body, {**env, **{p.name: v for p, v in zip(ps, vs, strict=True)}}, facts
                )
                for vs in values
            )
            return any(results) if isinstance(f, Exists) else all(results)
    raise TypeError(f)


ALL_FACTS = (
    [Atom("p", (o,)) for o in PROP_TYPES]
    + [Atom("q", (o1, o2)) for o1 in PROP_TYPES for o2 in PROP_TYPES]
    + [Atom("r")]
)


@settings(max_examples=150, deadline=None, database=None)
@given(
    formulas(depth=4, types=("object", "block", "room")),
    st.sets(st.sampled_from(ALL_FACTS), max_size=10),
)
def test_evaluator_agrees_with_reference_semantics(f, facts):
    sem = Semantics(PROP_DOMAIN, PROP_TYPES)
    assert sem.holds(f, facts) is reference(sem, f, {}, facts)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("(forall (?z - ghost) (not (r)))", True),
        ("(exists (?z - ghost) (r))", False),
        ("(exists (?z - ghost) (or (p ?z) (r)))", False),
    ],
)
def test_quantifier_over_an_empty_type(text, expected):
    sem = Semantics(PROP_DOMAIN, PROP_TYPES)
    assert sem.holds(parse_formula(text, PROP_DOMAIN), [Atom("r")]) is expected


def test_support_of_a_forall_takes_the_consequent_only_where_the_antecedent_holds() -> None:
    from llmpas.language.semantics import Support

    objects = {f"o{i}": "object" for i in range(60)}
    domain = parse_domain("(define (domain d) (:predicates (at ?x) (ok ?x)))")
    sem = Semantics(domain, objects)
    facts = [A("at", "o1"), A("at", "o2"), A("ok", "o1"), A("ok", "o2"), A("ok", "o3")]
    forall = parse_formula("(forall (?x) (imply (at ?x) (ok ?x)))", domain)
    support = Support(sem, sem.state(facts)).of(forall)
    assert support == {A("ok", "o1"), A("ok", "o2")}  # not (ok o3): o3 is nowhere
    assert Support(sem, sem.state(facts[:3])).of(forall) is None  # (ok o2) missing
