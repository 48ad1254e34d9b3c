"""Domains: the lax reader, the model, the writer, and the round trip through ``pddl``."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from pddl import parse_domain as pddl_parse_domain
from pddl.parser.domain import DomainParser

from llmpas.language.domain import (
    Action,
    Derived,
    Domain,
    Signature,
    parse_domain,
    read_domain,
)
from llmpas.language.language_errors import ModelError, PddlSyntaxError
from llmpas.language.logic import (
    TRUE,
    Atom,
    Exists,
    Forall,
    ForallEffect,
    FuncTerm,
    Imply,
    Increase,
    Not,
    Or,
    Param,
    When,
)
from llmpas.language.sexpr import Pos

from .strategies import formulas
from .texts import WILD_DOMAIN


def where(text: str, needle: str, after: str = "") -> tuple[int, int]:
    """1-based (line, column) of the first ``needle`` in ``text`` (after ``after``)."""
    offset = text.index(needle, text.index(after) if after else 0)
    before = text[:offset]
    return before.count("\n") + 1, offset - before.rfind("\n")


def syntax_error(text: str, filename: str = "d.pddl") -> PddlSyntaxError:
    with pytest.raises(PddlSyntaxError) as info:
        parse_domain(text, filename)
    assert "\n" not in str(info.value)
    return info.value


def domain_with(body: str, predicates: str = "(p ?x) (q ?x ?y) (r)") -> str:
    return f"(define (domain t)\n  (:predicates {predicates})\n  {body})"


PDDL_PARSER = DomainParser()  # building the parser is slow; reading with it is fast


def pddl_accepts(domain: Domain):
    """The domain as the ``pddl`` package reads ``domain.to_pddl()``."""
    return PDDL_PARSER(domain.to_pddl(numeric_fluents=True))


def assert_same_model(d1: Domain, d2: Domain) -> None:
    """``d2`` (read back from ``d1.to_pddl()``) has the same actions, derived and predicates."""
    assert d2.name == d1.name
    assert d2.actions == d1.actions
    assert d2.derived == d1.derived
    arities = {n: s.arity for n, s in d1.predicates.items()}
    arities |= {n: arity for n, (arity, _) in d1.undeclared.items()}
    assert {n: s.arity for n, s in d2.predicates.items()} == arities
    assert dict(d2.undeclared) == {}  # the writer declares everything
    assert d2.types == d1.types
    assert d2.constants == d1.constants


# ------------------------------------------------------------------------ the wild domain


def test_wild_domain_reads(wild_domain):
    d = wild_domain
    assert d.name == "pick-and-place"
    assert d.requirements == (":strips", ":equality")  # kept as written, not an error
    assert d.filename == "wild/domain.pddl"
    assert [a.name for a in d.actions] == ["move_base", "pick", "place"]
    assert d.derived_names == {"blocked"}
    assert d.predicates["atpose"] == Signature("atpose", (Param("?o"), Param("?p")))
    assert "blocked" in d.predicates  # derived heads count as declared predicates
    assert set(d.functions) == {"cost", "dist", "travelcost"}
    assert d.functions["dist"].arity == 2
    assert d.functions["cost"].arity == 0
    assert d.uses_costs()


def test_wild_domain_records_undeclared_predicates_with_first_use(wild_domain):
    und = dict(wild_domain.undeclared)
    assert {n: arity for n, (arity, _) in und.items()} == {
        "apart": 4,
        "base": 1,
        "reach": 6,
    }
    # first uses: Apart in the derived predicate, Base in move_base
    assert und["apart"][1] == Pos("wild/domain.pddl", *where(WILD_DOMAIN, "(Apart ?obj"))
    assert und["base"][1] == Pos("wild/domain.pddl", *where(WILD_DOMAIN, "(Base ?b1)"))
    assert und["reach"][1] == Pos("wild/domain.pddl", *where(WILD_DOMAIN, "(Reach ?arm"))


def test_wild_domain_mixed_case_names_are_one_predicate(wild_domain):
    pick = wild_domain.action("PICK")
    assert Atom("atpose", ("?obj", "?spot")) in pick.precondition.parts
    blocked = wild_domain.derived[0]
    assert isinstance(blocked.body, Exists)
    assert Atom("atpose", ("?o2", "?s2")) in blocked.body.body.parts


def test_wild_domain_formulas(wild_domain):
    place = wild_domain.action("place")
    assert place.params == tuple(
        Param(v) for v in ("?arm", "?obj", "?spot", "?hold", "?base", "?path")
    )
    parts = place.precondition.parts
    assert Or((Atom("block", ("?obj",)), Atom("surface", ("?obj",)))) in parts
    assert Not(Atom("blocked", ("?obj", "?spot"))) in parts
    (forall,) = [p for p in parts if isinstance(p, Forall)]
    assert forall.params == (Param("?o2"), Param("?s2"))
    assert isinstance(forall.body, Imply)
    assert forall.body.then == Or(
        (Atom("=", ("?o2", "?obj")), Atom("apart", ("?obj", "?spot", "?o2", "?s2")))
    )
    assert Increase(FuncTerm("cost", ())) in place.effects
    move = wild_domain.action("move_base")
    assert Not(Atom("=", ("?b1", "?b2"))) in move.precondition.parts
    assert move.effects == (
        Atom("atbase", ("?b2",)),
        Not(Atom("atbase", ("?b1",))),
        Increase(FuncTerm("dist", ("?b1", "?b2"))),
    )
    pick = wild_domain.action("pick")
    assert Increase(FuncTerm("travelcost", ("?path",))) in pick.effects


def test_read_domain_from_file(tmp_path):
    path = tmp_path / "domain.pddl"
    path.write_text(WILD_DOMAIN, encoding="utf-8")
    d = read_domain(path)
    assert d.filename == str(path)
    assert d.undeclared["reach"][1].filename == str(path)
    assert d.actions == parse_domain(WILD_DOMAIN).actions


def test_wild_domain_round_trip(wild_domain):
    text = wild_domain.to_pddl()
    again = parse_domain(text, "again.pddl")
    assert_same_model(wild_domain, again)
    assert set(again.functions) == {"cost", "dist", "travelcost", "total-cost"}
    # and the written text is a fixpoint of read/write
    assert again.to_pddl() == text


def test_writer_declares_every_requirement_it_uses(wild_domain):
    (line,) = [x for x in wild_domain.to_pddl().splitlines() if ":requirements" in x]
    reqs = line.replace("(", " ").replace(")", " ").split()
    for r in (
        ":strips",
        ":negative-preconditions",
        ":disjunctive-preconditions",
        ":equality",
        ":existential-preconditions",
        ":universal-preconditions",
        ":derived-predicates",
        ":action-costs",
    ):
        assert r in reqs


WILD_WITHOUT_FUNCTIONS = (
    WILD_DOMAIN.replace("(:functions (Cost) (Dist ?q1 ?q2))", "")
    .replace("(Dist ?b1 ?b2)", "1")
    .replace("(TravelCost ?path)", "2.5")
    .replace("(increase (total-cost) (Cost))", "(increase (total-cost) 3)")
)


def test_pddl_package_accepts_the_written_wild_domain_without_functions(tmp_path):
    d = parse_domain(WILD_WITHOUT_FUNCTIONS)
    assert d.functions == {}
    path = tmp_path / "written.pddl"
    path.write_text(d.to_pddl(), encoding="utf-8")
    parsed = pddl_parse_domain(str(path))  # the package's file API
    assert parsed.name == "pick-and-place"
    assert {a.name for a in parsed.actions} == {"move_base", "pick", "place"}
    assert {p.predicate.name for p in parsed.derived_predicates} == {"blocked"}
    assert {p.name for p in parsed.predicates} >= {"atpose", "reach", "apart", "base"}


def test_pddl_package_accepts_the_written_wild_domain(wild_domain):
    parsed = pddl_accepts(wild_domain)
    assert {a.name for a in parsed.actions} == {"move_base", "pick", "place"}


TYPED = """\
(define (domain Typed)
  (:requirements :strips :typing)
  (:types block table - object heavy - block room)
  (:constants T1 - table Red)
  (:predicates (on ?b - block ?t - table) (painted ?x) (in ?b - block ?r - room))
  (:derived (onheavy ?t - table) (exists (?b - heavy) (on ?b ?t)))
  (:derived (onheavy ?t - table) (painted ?t))
  (:action sweep
    :parameters (?b - heavy ?t - table)
    :precondition (and (not (onheavy ?t)) (imply (painted ?b) (painted Red)))
    :effect (and (on ?b ?t)
                 (forall (?x - block) (when (painted ?x) (not (painted ?x))))
                 (when (painted t1) (and (painted red) (increase (total-cost) 2.5)))))
  (:action noop :parameters () :precondition () :effect (and)))
"""


def test_typed_domain_reads():
    d = parse_domain(TYPED)
    assert dict(d.types) == {
        "block": "object",
        "table": "object",
        "heavy": "block",
        "room": "object",
    }
    assert d.constants == (Param("t1", "table"), Param("red"))
    assert d.supertypes("heavy") == ("heavy", "block", "object")
    assert d.supertypes("room") == ("room", "object")
    assert d.supertypes("unknown") == ("unknown", "object")
    assert len(d.derived) == 2  # two rules for one derived predicate
    assert d.derived[0].head == Signature("onheavy", (Param("?t", "table"),))
    sweep = d.action("sweep")
    assert sweep.params == (Param("?b", "heavy"), Param("?t", "table"))
    fe = sweep.effects[1]
    assert fe == ForallEffect(
        (Param("?x", "block"),),
        (When(Atom("painted", ("?x",)), (Not(Atom("painted", ("?x",))),)),),
    )
    assert sweep.effects[2] == When(
        Atom("painted", ("t1",)), (Atom("painted", ("red",)), Increase(2.5))
    )
    noop = d.action("noop")
    assert noop.precondition == TRUE
    assert noop.effects == ()


def test_typed_domain_round_trip_and_pddl_package():
    d = parse_domain(TYPED)
    assert_same_model(d, parse_domain(d.to_pddl()))
    parsed = pddl_accepts(d)
    assert {a.name for a in parsed.actions} == {"sweep", "noop"}
    assert {t for t in parsed.types} >= {"block", "table", "heavy", "room"}
    assert {c.name for c in parsed.constants} == {"t1", "red"}


def test_functions_section_with_number_types():
    d = parse_domain(
        "(define (domain f) (:predicates (p)) "
        "(:functions (total-cost) - number (Dist ?a ?b) - number (Cost)) "
        "(:action a :parameters (?x ?y) :effect (increase (total-cost) (dist ?x ?y))))"
    )
    assert set(d.functions) == {"total-cost", "dist", "cost"}
    assert d.to_pddl().count("(total-cost)") == 2  # declared once + used once


def test_domain_without_costs_has_no_functions_section():
    d = parse_domain(domain_with("(:action a :parameters (?x) :effect (p ?x))"))
    assert not d.uses_costs()
    assert ":functions" not in d.to_pddl()


def test_nested_increase_counts_as_using_costs():
    d = parse_domain(
        domain_with("(:action a :parameters (?x) :effect (when (p ?x) (increase (total-cost) 1)))")
    )
    assert d.uses_costs()
    assert "(:functions (total-cost) - number)" in d.to_pddl()


def test_action_lookup_and_duplicates():
    d = parse_domain(domain_with("(:action Go :parameters (?x) :effect (p ?x))"))
    assert d.action("GO").name == "go"
    with pytest.raises(ModelError, match="unknown action 'fly'"):
        d.action("fly")
    with pytest.raises(PddlSyntaxError, match=r"^d\.pddl:\d+:\d+: action 'go' is defined twice$"):
        parse_domain(domain_with("(:action go :effect (r)) (:action GO :effect (r))"), "d.pddl")


def test_arity_of_declared_undeclared_and_equality(wild_domain):
    assert wild_domain.arity("atpose") == 2
    assert wild_domain.arity("reach") == 6
    assert wild_domain.arity("=") == 2
    assert wild_domain.arity("nothing") is None


def test_with_additions_keeps_existing_and_adds_new():
    d = parse_domain(domain_with("(:action a :parameters (?x) :effect (p ?x))"))
    extra = Action("b", (), TRUE, (Atom("z"),))
    d2 = d.with_additions(
        predicates=[Signature("z"), Signature("p", (Param("?a"), Param("?b")))],
        actions=[extra],
        derived=[Derived(Signature("w"), Atom("z"))],
    )
    assert d2.predicates["p"].arity == 1  # an existing declaration is not replaced
    assert "z" in d2.predicates
    assert d2.action("b") == extra
    assert d2.derived_names == {"w"}
    assert "(w)" in d2.to_pddl()
    assert d.actions == (d.action("a"),)  # the original is unchanged


def test_domain_mappings_are_read_only(wild_domain):
    with pytest.raises(TypeError):
        wild_domain.predicates["new"] = Signature("new")  # type: ignore[index]


# ------------------------------------------------------------------------ bad input


def test_wrong_arity_of_a_declared_predicate_points_at_the_atom():
    text = (
        "(define (domain d)\n"
        "  (:predicates (AtPose ?o ?p))\n"
        "  (:action a :parameters (?o)\n"
        "     :precondition (and (atpose ?o)) :effect (and)))"
    )
    err = syntax_error(text)
    assert str(err) == "d.pddl:4:25: predicate 'atpose' takes 2 arguments, given 1"


def test_wrong_arity_in_an_effect():
    text = domain_with("(:action a :parameters (?x) :effect (and (r ?x)))")
    err = syntax_error(text)
    assert (err.line, err.col) == where(text, "(r ?x)")
    assert err.message == "predicate 'r' takes 0 arguments, given 1"


def test_inconsistent_arity_of_an_undeclared_predicate():
    text = domain_with(
        "(:action a :parameters (?x ?y)\n   :precondition (and (Near ?x ?y))\n"
        "   :effect (not (NEAR ?x)))"
    )
    err = syntax_error(text)
    assert (err.line, err.col) == where(text, "(NEAR ?x)")
    assert err.message == "'near' used with 1 arguments here, 2 elsewhere"


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("(:action a :parameters (?x)\n :effect (and (p ?x) (not (p ?z))))", "?z"),
        ("(:action a :parameters (?x) :effect (increase (total-cost) (f ?x ?w)))", "(f ?x ?w)"),
        ("(:action a :parameters (?x) :effect (forall (?y) (q ?y ?v)))", "?v"),
        ("(:action a :parameters (?x) :effect (when (p ?x) (p ?u)))", "?u"),
    ],
)
def test_unbound_variable_in_an_effect_or_a_cost_is_refused(body, needle):
    text = domain_with(body)
    err = syntax_error(text)
    assert (err.line, err.col) == where(text, needle, after=body)
    assert err.message.startswith("variable '?")
    assert err.message.endswith("' is not bound here")


@pytest.mark.parametrize(
    ("body", "needle", "read"),
    [
        (
            "(:action a :parameters (?x) :precondition (q ?x ?y) :effect (p ?x))",
            "?y",
            lambda d: d.actions[0].precondition,
        ),
        (
            "(:derived (d ?x) (and (p ?x) (q ?x ?y)))",
            "?y",
            lambda d: d.derived[0].body.parts[1],
        ),
        (
            "(:action a :precondition (exists (?y) (q ?y ?x)) :effect (r))",
            "?x",
            lambda d: d.actions[0].precondition.body,
        ),
        (
            "(:action a :parameters (?x) :effect (when (p ?u) (p ?x)))",
            "?u",
            lambda d: d.actions[0].effects[0].cond,
        ),
        (
            "(:action a :parameters (?x) :precondition (not (= ?x ?u)) :effect (r))",
            "?u",
            lambda d: d.actions[0].precondition.arg,
        ),
    ],
)
def test_unbound_variable_in_a_condition_names_no_object(body, needle, read, caplog):
    """As the Fast Downward translator PDDLStream ships (its ffrob example has one): the atom
    is false, so its negation holds; said once, where it is."""
    text = domain_with(body)
    domain = parse_domain(text, "d.pddl")
    assert read(domain) == Or(())
    line, col = where(text, needle, after=body)
    (warning,) = [r.getMessage() for r in caplog.records]
    assert warning.startswith(f"d.pddl:{line}:{col}: variable '{needle}' is not bound here")
    assert "is false" in warning


def test_quantified_variables_are_bound_only_inside():
    body = (
        "(:action a :parameters (?x)"
        " :precondition (and (exists (?y) (q ?x ?y)) (p ?y)) :effect (r))"
    )
    pre = parse_domain(domain_with(body), "d.pddl").actions[0].precondition
    assert pre.parts == (Exists((Param("?y"),), Atom("q", ("?x", "?y"))), Or(()))


def test_unbound_variable_in_a_condition_still_checks_arity():
    err = syntax_error(domain_with("(:derived (d ?x) (and (p ?x) (q ?y)))"))
    assert err.message == "predicate 'q' takes 2 arguments, given 1"


def test_unknown_domain_section():
    err = syntax_error("(define (domain d)\n  (:predicates (p))\n  (:actions a))")
    assert str(err) == "d.pddl:3:3: unknown domain section ':actions'"


def test_unknown_action_keyword():
    err = syntax_error(domain_with("(:action a :parameters (?x)\n :pre (p ?x) :effect (p ?x))"))
    assert str(err) == "d.pddl:4:2: unknown action keyword ':pre' in action 'a'"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("(domain d)", "expected '(define (domain NAME) ...)'"),
        ("(define (problem d))", "expected '(domain NAME)'"),
        ("(define d)", "expected '(domain NAME)' in parentheses, found 'd'"),
        ("(define (domain d) (:constraints (and)))", "':constraints' is not supported"),
        (
            "(define (domain d) (:types a - (either b c)))",
            "'(either ...)' types are not supported in :types",
        ),
        ("(define (domain d) (:types a -))", "'-' without a type in :types"),
        ("(define (domain d) (:derived (x)))", "expected '(:derived (NAME ?x ...) FORMULA)'"),
        ("(define (domain d) (:predicates ()))", "empty declaration '()'"),
        ("(define (domain d) (:predicates p))", "expected a predicate declaration in parentheses"),
        (
            "(define (domain d) (:predicates (p)) (:action a :effect (decrease (total-cost) 1)))",
            "numeric effect 'decrease' is not supported (only total-cost)",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :effect (increase (fuel) 1)))",
            "only '(total-cost)' can be increased",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :effect (increase (total-cost) x)))",
            "expected a number or a function term, found 'x'",
        ),
        (
            "(define (domain d) (:functions (f ?a))"
            " (:action a :effect (increase (total-cost) (f))))",
            "function 'f' takes 1 arguments, given 0",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :effect (p) (p)))",
            "':effect' takes exactly one value",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :effect (p) :effect (p)))",
            "':effect' given twice in action 'a'",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :precondition (not (p) (p))))",
            "'not' takes one formula",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :precondition (imply (p))))",
            "'imply' takes two formulas",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :precondition (exists (?x))))",
            "'exists' takes a variable list and a formula",
        ),
        (
            "(define (domain d) (:predicates (p)) (:action a :precondition ((p))))",
            "bad formula",
        ),
        ("(define (domain d) (:predicates (p)) (:action))", "expected '(:action NAME"),
    ],
)
def test_malformed_domains(text, message):
    err = syntax_error(text)
    assert err.message.startswith(message)
    assert str(err).startswith(f"d.pddl:{err.line}:{err.col}: ")


# ------------------------------------------------------------------------ known defects


def test_empty_effect_is_allowed():
    d = parse_domain(domain_with("(:action a :parameters (?x) :precondition (p ?x) :effect ())"))
    assert d.action("a").effects == ()


@pytest.mark.parametrize("effect", ["(not)", "(when (p ?x))", "(forall (?y))", "(and (p ?x) ())"])
def test_malformed_effect_is_a_syntax_error(effect):
    syntax_error(domain_with(f"(:action a :parameters (?x) :effect {effect})"))


def test_derived_predicate_in_an_effect_is_rejected():
    syntax_error(
        domain_with("(:derived (d ?x) (p ?x)) (:action a :parameters (?x) :effect (d ?x))")
    )


def test_derived_head_must_match_its_declaration():
    syntax_error(domain_with("(:derived (p ?x ?y) (q ?x ?y))"))


def test_negative_constant_cost_is_rejected():
    syntax_error(domain_with("(:action a :parameters (?x) :effect (increase (total-cost) -3))"))


def test_writer_output_for_a_domain_without_predicates():
    d = parse_domain("(define (domain empty) (:action a :parameters () :effect (and)))")
    pddl_accepts(d)


def test_untyped_before_typed_parameter_keeps_its_type():
    d = parse_domain(
        "(define (domain t) (:requirements :typing) (:types room)\n"
        " (:constants c1 - object t1 - room)\n"
        " (:predicates (at ?x - object ?r - room))\n"
        " (:action go :parameters (?x - object ?r - room) :precondition (at ?x ?r) :effect (and)))"
    )
    again = parse_domain(d.to_pddl())
    assert again.action("go").params == (Param("?x"), Param("?r", "room"))
    assert again.predicates["at"] == d.predicates["at"]
    assert again.constants == (Param("c1"), Param("t1", "room"))


# ------------------------------------------------------------------------ round-trip property

PROPERTY_DOMAIN = """\
(define (domain prop)
  (:requirements :strips :typing)
  (:types block room - object)
  (:constants a c)
  (:predicates (p ?x) (q ?x ?y) (r))
  (:action act :parameters (?v - block) :precondition (and) :effect (and)))
"""


@settings(max_examples=60, deadline=None, database=None)
@given(
    formulas(mixed_types=False),
    formulas(frozenset({"?v"}), mixed_types=False),
)
def test_written_formulas_read_back_identically(derived_body, precondition):
    base = parse_domain(PROPERTY_DOMAIN)
    act = Action(
        "act",
        (Param("?v", "block"),),
        precondition,
        (Atom("r"), When(derived_body, (Not(Atom("p", ("?v",))),))),
    )
    d = Domain(
        name=base.name,
        types=base.types,
        constants=base.constants,
        predicates=base.predicates,
        derived=(Derived(Signature("dd"), derived_body),),
        actions=(act,),
    )
    text = d.to_pddl()
    again = parse_domain(text)
    assert again.actions == (act,)
    assert again.derived == d.derived
    parsed = PDDL_PARSER(text)  # standard PDDL: the pddl package reads it too
    assert {a.name for a in parsed.actions} == {"act"}


TEMPORAL = """(define (domain temporal)
  (:requirements :strips {req})
  (:predicates (at ?x))
  (:durative-action go
    :parameters (?x) :duration (= ?duration 1)
    :condition (at start (at ?x)) :effect (at end (not (at ?x)))))"""


@pytest.mark.parametrize(
    ("req", "needle", "message"),
    [
        ("", "(:durative-action", "':durative-action' is not supported (temporal planning)"),
        (":durative-actions", ":durative-actions", "requirement ':durative-actions' is not"),
        (":timed-initial-literals", ":timed-initial", "requirement ':timed-initial-literals'"),
    ],
)
def test_temporal_domains_get_one_line_naming_the_construct(req, needle, message):
    text = TEMPORAL.format(req=req)
    err = syntax_error(text)
    assert (err.line, err.col) == where(text, needle)
    assert err.message.startswith(message)
