"""Declarations given twice: read with a warning when both say the same (as Fast Downward reads
them, and as PDDLStream's continuous_tamp/idtmp domain needs), one error line when they differ."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from llmpas.cli import main
from llmpas.language.domain import parse_domain, read_domain
from llmpas.language.language_errors import PddlSyntaxError

TWICE = Path(__file__).parent / "data" / "twice"


def test_a_predicate_declared_twice_identically_loads_with_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with caplog.at_level(logging.WARNING, logger="llmpas.language.domain"):
        domain = read_domain(TWICE / "domain.pddl")
    assert domain.predicates["holding"].arity == 2
    assert len([n for n in domain.predicates if n == "holding"]) == 1
    (warning,) = [r.getMessage() for r in caplog.records]
    assert warning.endswith(
        "domain.pddl:9:5: predicate 'holding' is declared twice (identically); the repeat "
        "is ignored"
    )


def test_the_domain_with_the_repeated_predicate_plans(capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(TWICE / "domain.pddl"), str(TWICE / "problem.pddl")]
    assert main(["plan", *files, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["status"] == "solved"
    assert [s["action"] for s in data["plan"]["steps"]] == ["pick", "move", "place"]


HEAD = "(define (domain d) (:requirements :strips :typing)\n"


@pytest.mark.parametrize(
    "body",
    [
        "(:types a b - object a) (:predicates (p ?x - a)))",
        "(:types a) (:constants c - a) (:constants c - a) (:predicates (p)))",
        "(:types a) (:predicates (p ?x - a)) (:predicates (p ?y - a)))",
        "(:types a) (:predicates (p)) (:functions (f ?x - a) (f ?y - a)))",
    ],
    ids=["type", "constant", "predicate", "function"],
)
def test_every_kind_of_identical_repeat_is_a_warning(
    body: str, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="llmpas.language.domain"):
        domain = parse_domain(HEAD + body, "d.pddl")
    assert domain.types.get("a") == "object"
    (warning,) = [r.getMessage() for r in caplog.records]
    assert warning.startswith("d.pddl:2:") and "declared twice (identically)" in warning


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            "(:types b a - object a - b) (:predicates (p)))",
            "type 'a' is declared twice, differently: a - object and a - b",
        ),
        (
            "(:types a) (:constants c) (:constants c - a) (:predicates (p)))",
            "constant 'c' is declared twice, differently: object and a",
        ),
        (
            "(:types a) (:predicates (p ?x - a) (p ?x)))",
            "predicate 'p' is declared twice, differently: (p ?x - a) and (p ?x)",
        ),
        (
            "(:predicates (p)) (:functions (f ?x) (f ?x ?y)))",
            "function 'f' is declared twice, differently: (f ?x) and (f ?x ?y)",
        ),
    ],
    ids=["type", "constant", "predicate", "function"],
)
def test_a_conflicting_repeat_is_one_error_naming_the_place(body: str, message: str) -> None:
    with pytest.raises(PddlSyntaxError) as caught:
        parse_domain(HEAD + body, "d.pddl")
    assert caught.value.message == message
    assert str(caught.value).startswith("d.pddl:2:")
