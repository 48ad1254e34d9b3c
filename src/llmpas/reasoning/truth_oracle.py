"""``oracle``: the labelled oracle, a recovery method that asks no model (like ``replan``,
:mod:`llmpas.reasoning.replan`): goals computed from a world's TRUE state, used only as an upper
bound (never as a default). Each world's oracle lives in the world's folder (``oracle(session)``,
named by its :class:`~llmpas.worlds.api.WorldEntry`) and derives from :class:`TruthOracle`; it
implements the LLM protocol and reads the anomaly from the request
(``request.situation.constraint``) like every backend reads it from the prompt."""

from __future__ import annotations

import re

from llmpas.language.logic import Atom, Formula, Not
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.reasoning.goal_reading import parse_goals
from llmpas.reasoning.llm import Request, Response, ScoreRequest, Scores
from llmpas.reasoning.tables import Vocabulary

ORACLE = "oracle"
"""The oracle's name: its ``--llm`` kind in ``llmpas run`` and its row in ``bench prompting``."""
FIRST_LOOK = "Look where the truth says."
_LITERAL = re.compile(r"\(not \([^()]*\)\)|\([^()]*\)")


def failed_literal(request: Request) -> Formula | None:
    """The anomaly's failed literal carried by the request (None: not a goal request)."""
    situation = request.situation
    if request.tag == "first-look" or situation is None:
        return None
    constraint: Formula | None = getattr(situation, "constraint", None)
    return constraint


class TruthOracle:
    """The shape every world's oracle shares: a short first look, then goals for the failed
    literal the request carries (:meth:`goals_for` the literal's atom; ``negated``: it failed
    as ``(not atom)``), computed from the world's truth by the subclass.

    Its answers are legal: with a ``vocabulary`` (set by the world's factory), a goal the
    vocabulary rejects is left out. When the truth gives no goal and the task has an intent
    other than its goal (``[judge] success``: another object will do as well), the oracle
    answers the intent's first alternative that does not name the failed literal's objects.
    Its failures are its own: the loop calls it ``the oracle`` (:attr:`role`)."""

    name = ORACLE
    role = "the oracle (an upper bound)"
    vocabulary: Vocabulary | None = None

    def complete(self, request: Request) -> Response:
        c = failed_literal(request)
        if c is None:
            return first_look()
        goals = self.legal(self.goals(c))
        if not goals:
            intent = str(getattr(request.situation, "intent", "") or "")
            goals = self.legal(substitute(intent, c))
        return answer(goals)

    def score(self, request: ScoreRequest) -> Scores:
        """The oracle's ranking of candidate goal sets: a candidate scores one per goal of the
        oracle's own answer it contains, less a hundredth per other literal (the oracle's
        goals first, the fewest extra literals next)."""
        c = getattr(request.situation, "constraint", None)
        goals: list[Atom | Not] = []
        if c is not None:
            goals = self.legal(self.goals(c))
            if not goals:
                goals = self.legal(substitute(str(getattr(request.situation, "intent", "")), c))
        wanted = {str(g) for g in goals}
        out = []
        for choice in request.choices:
            have = set(_LITERAL.findall(choice))
            out.append((len(have & wanted) - 0.01 * len(have - wanted),))
        return Scores(tuple(out), model=ORACLE)

    def legal(self, goals: list[Atom | Not]) -> list[Atom | Not]:
        """The goals the vocabulary accepts (all of them without one)."""
        vocab = self.vocabulary
        if vocab is None:
            return goals
        return [g for g in goals if parse_goals(f"(and {g})", vocab).ok]

    def goals(self, c: Formula) -> list[Atom | Not]:
        atom = c.arg if isinstance(c, Not) else c
        return self.goals_for(atom, isinstance(c, Not)) if isinstance(atom, Atom) else []

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        raise NotImplementedError


def substitute(intent: str, failed: Formula) -> list[Atom | Not]:
    """The first alternative of ``intent`` (an ``or`` of conjunctions of literals) that names
    none of the objects of the ``failed`` literal ([] when there is none)."""
    if not intent.strip():
        return []
    try:
        exprs = parse_all(intent, "intent")
    except ValueError:
        return []
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        return []
    top = exprs[0]
    options = top.items[1:] if top.head() == "or" else [top]
    atom = failed.arg if isinstance(failed, Not) else failed
    names = set(getattr(atom, "args", ()))
    for option in options:
        literals = _literals(option)
        named = {
            a for g in literals for a in getattr(g.arg if isinstance(g, Not) else g, "args", ())
        }
        if literals and not names & named:
            return literals
    return []


def _literals(e: object) -> list[Atom | Not]:
    """A literal or a conjunction of literals as a list ([] for anything else)."""
    if isinstance(e, SList) and e.head() == "and":
        parts = [_literals(i) for i in e.items[1:]]
        return [g for p in parts for g in p] if all(len(p) == 1 for p in parts) else []
    if isinstance(e, SList) and e.head() == "not" and len(e.items) == 2:
        inner = _literals(e.items[1])
        return [Not(inner[0])] if len(inner) == 1 and isinstance(inner[0], Atom) else []
    if isinstance(e, SList) and e.items and all(isinstance(a, Sym) for a in e.items):
        name, *args = (str(getattr(a, "text", a)).lower() for a in e.items)
        return [Atom(name, tuple(args))]
    return []


def answer(goals: list[Atom | Not]) -> Response:
    return Response(f"(and {' '.join(map(str, goals))})", model=ORACLE)


def first_look() -> Response:
    return Response(FIRST_LOOK, model=ORACLE)


__all__ = [
    "FIRST_LOOK",
    "ORACLE",
    "TruthOracle",
    "answer",
    "failed_literal",
    "first_look",
    "substitute",
]
