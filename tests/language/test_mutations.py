"""Readers of mutated files fail only with a LanguageError (one line naming the place).

Each mutation deletes, inserts, replaces or swaps a few tokens of the planner tests' domain,
problem and stream files, drawing from PDDL keywords, connectives and odd numbers."""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest

from llmpas.language.bindings import bind
from llmpas.language.domain import parse_domain
from llmpas.language.language_errors import LanguageError
from llmpas.language.problem import Problem, parse_problem_text
from llmpas.language.streams import parse_streams

DATA = Path(__file__).parents[1] / "planning" / "data"
TEXTS = {k: (DATA / f"{k}.pddl").read_text() for k in ("domain", "problem", "stream")}
TOKEN = re.compile(r"\(|\)|[^\s()]+")
POOL = re.findall(
    r"\S+",
    "( ) () and not or forall exists imply when - ?x ?b = :parameters :effect :precondition "
    "increase (total-cost) 1 -1 nan inf 1e999 either :types :constants :objects object b0 "
    ":derived :stream :inputs :outputs :domain :certified :function :action define",
)


def mutate(text: str, rng: random.Random) -> str:
    toks = TOKEN.findall(text)
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(toks))
        op = rng.random()
        if op < 0.3:
            del toks[i]
        elif op < 0.6:
            toks.insert(i, rng.choice(POOL))
        elif op < 0.8:
            toks[i] = rng.choice(POOL)
        else:
            j = rng.randrange(len(toks))
            toks[i], toks[j] = toks[j], toks[i]
    return " ".join(toks)


def _problem(domain_text: str, problem_text: str, stream_text: str) -> Problem:
    domain = parse_domain(domain_text, "domain.pddl")
    spec = parse_streams(stream_text, "stream.pddl")
    pf = parse_problem_text(problem_text, domain, "problem.pddl")
    names = [s.name for s in spec.streams] + [f.name for f in spec.functions]
    impls = dict.fromkeys(names, print)
    bs, bf = bind(spec, impls)
    return Problem(domain, spec, {o: o for o in pf.objects}, frozenset(pf.init), pf.goal, bs, bf)


@pytest.mark.parametrize("which", ["domain", "problem", "stream"])
def test_mutated_files_raise_only_language_errors(which: str) -> None:
    rng = random.Random(f"{which}-0")
    failures = 0
    for _ in range(400):
        texts = dict(TEXTS)
        texts[which] = mutate(texts[which], rng)
        try:
            _problem(texts["domain"], texts["problem"], texts["stream"])
        except LanguageError as e:
            failures += 1
            assert "\n" not in str(e)
    assert failures > 100  # the mutations do break the files
