"""Nesting depth and declarations: deep text refused as it is read, declared types, duplicates."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.domain import parse_domain
from llmpas.language.language_errors import PddlSyntaxError
from llmpas.language.problem import read_problem
from llmpas.language.sexpr import MAX_DEPTH, parse_all
from llmpas.planning import PlannerConfig, solve


def _domain(precondition: str, head: str = "") -> str:
    return (
        f"(define (domain deep) {head} (:predicates (p ?x) (q ?x) (g ?x))\n"
        f" (:action a :parameters (?x) :precondition {precondition} :effect (g ?x)))"
    )


@pytest.mark.parametrize("opening", ["(and ", "(not ", "(or ", "("])
def test_deeper_than_the_limit_is_refused_as_it_is_read(opening: str) -> None:
    text = opening * 100_000 + ")" * 100_000
    with pytest.raises(PddlSyntaxError, match=f"nested deeper than {MAX_DEPTH} levels"):
        parse_all(text, "deep.pddl")


def test_formulas_at_the_limit_are_planned(tmp_path: Path) -> None:
    """Every walker (reader, checks, compilation, Fast Downward's translator) copes with the
    deepest text the reader accepts: define > action > and > 95 x not > atom."""
    nots = 95
    assert 3 + nots + 1 <= MAX_DEPTH
    pre = "(and (p ?x) " + "(not " * nots + "(q ?x)" + ")" * nots + ")"
    (tmp_path / "d.pddl").write_text(_domain(pre))
    (tmp_path / "p.pddl").write_text(
        "(define (problem d) (:domain deep) (:objects o) (:init (p o)) (:goal (g o)))"
    )
    result = solve(read_problem(tmp_path / "d.pddl", tmp_path / "p.pddl"), PlannerConfig())
    assert result.solved, result.message  # an odd number of 'not': (not (q o)) holds


@pytest.mark.parametrize(
    ("head", "params", "message"),
    [
        ("", "(?x - gizmo)", r"d\.pddl:2:31: type 'gizmo' in the parameters of action 'a'"),
        ("(:types a - b b - c c - a)", "(?x)", "type 'a' is its own ancestor|type 'c' is its"),
        ("(:types a b) (:types a - b)", "(?x)", "type 'a' is declared twice, differently"),
        ("(:constants k - gizmo)", "(?x)", "type 'gizmo' in :constants is not declared"),
        ("(:types t u) (:constants k - t m k - u)", "(?x)", "'k' is declared twice, differently"),
        ("", "(?x ?x)", "'\\?x' is named twice in the parameters of action 'a'"),
    ],
)
def test_declarations_are_checked_where_they_are_written(
    head: str, params: str, message: str
) -> None:
    text = _domain("(p ?x)", head).replace("(?x) :precondition", f"{params} :precondition")
    with pytest.raises(PddlSyntaxError, match=message):
        parse_domain(text, "d.pddl")


def test_types_may_be_declared_after_their_use() -> None:
    text = (
        "(define (domain t) (:predicates (on ?a - block ?b - block))\n"
        " (:types block - thing thing))"
    )
    assert parse_domain(text).predicates["on"].params[0].type == "block"


def test_objects_of_undeclared_types_in_a_problem_name_the_place(tmp_path: Path) -> None:
    (tmp_path / "d.pddl").write_text("(define (domain t) (:types block) (:predicates (p ?x)))")
    (tmp_path / "p.pddl").write_text(
        "(define (problem q) (:domain t)\n (:objects a - block b - gizmo) (:init) (:goal (p a)))"
    )
    with pytest.raises(PddlSyntaxError, match=r"p\.pddl:2:26: type 'gizmo' in :objects"):
        read_problem(tmp_path / "d.pddl", tmp_path / "p.pddl")
