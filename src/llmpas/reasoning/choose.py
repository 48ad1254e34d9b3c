"""Choosing among candidate recovery goals (``flp-choose`` and its controls).

A small model is better at choosing among options than at writing them (SayCan scores a robot's
skills by the model's likelihood). The closed loop enumerates candidate goal sets the validator
accepts (:mod:`llmpas.system.candidates`); here they are ranked:

- ``model`` (``flp-choose``): after the first look, each candidate is scored by the model's
  likelihood of writing it as its answer (``Goals: (and ...)``): with token log-probabilities
  where the backend has them (:class:`~llmpas.reasoning.llm.Scorer`; the mean log-probability
  of the candidate's tokens), else by a numbered choice (the model names one number; that one
  first, the rest in the enumeration's order);
- ``random`` (``candidates-random``): a uniform order, seeded by the method's seed;
- ``first`` (``candidates-first``): the enumeration's own order.

The two controls ask no model: a lift of ``flp-choose`` over them is the model's, a lift of
theirs over the replan row is the enumeration's. Every ranking is a :class:`Ranked` list: the
best is proposed, the rest kept for later rounds. LLM output is data: a numbered choice is
parsed as a number, never run.
"""

from __future__ import annotations

import random
import re
from collections.abc import Sequence
from dataclasses import dataclass

from llmpas.reasoning.goals import GoalParse, GoalStatus, Literal
from llmpas.reasoning.llm import LLM, Message, Request, Response, ScoreRequest, ScoringUnsupported
from llmpas.reasoning.methods import (
    Exchange,
    MethodConfig,
    Proposal,
    Situation,
    _Conversation,
    _system,
    method,
    template,
)

CHOOSERS = ("model", "random", "first")
PREFIX = "Goals: "
MAX_NUMBERED = 99


@dataclass(frozen=True)
class Ranked:
    """A candidate goal set with its score (None: ranked without one) and its place."""

    goals: tuple[Literal, ...]
    score: float | None = None

    @property
    def text(self) -> str:
        return f"(and {' '.join(map(str, self.goals))})"


def rank(
    situation: Situation,
    llm: LLM,
    candidates: Sequence[tuple[Literal, ...]],
    config: MethodConfig,
    consultation: int = 0,
) -> tuple[list[Ranked], tuple[Exchange, ...], str]:
    """The candidates ranked by the method's chooser (best first), the exchanges that ranked
    them, and the first look (model only)."""
    made = method(config.method)
    chooser = made.chooser
    cands = [tuple(c) for c in candidates]
    if chooser == "first":
        return [Ranked(c) for c in cands], (), ""
    if chooser == "random":
        order = list(range(len(cands)))
        seed = 0 if config.seed is None else config.seed
        random.Random(seed * 1000 + consultation).shuffle(order)
        return [Ranked(cands[i]) for i in order], (), ""
    talk = _Conversation(llm, config, situation)
    first_look = ""
    if made.first_look:
        step1 = template(made.first_look).substitute(situation.fields())
        first_look = talk.ask("first-look", [_system(), Message("user", step1)], {}).strip()
    prompt = template(made.template).substitute(situation.fields(first_look))
    messages = (_system(), Message("user", prompt))
    texts = tuple(Ranked(c).text for c in cands)
    scorer = getattr(llm, "score", None)
    if callable(scorer):
        request = ScoreRequest(messages, texts, PREFIX, tag="goals", situation=situation)
        try:
            scores = scorer(request)
        except ScoringUnsupported:
            pass
        else:
            means = scores.mean()
            order = sorted(range(len(cands)), key=lambda i: (-means[i], i))
            ranked = [Ranked(cands[i], means[i]) for i in order]
            shown = Request((*messages, Message("assistant", PREFIX)), tag="goals")
            answer = Response(
                PREFIX + ranked[0].text,
                scores.model,
                scores.prompt_tokens,
                sum(len(lp) for lp in scores.logprobs),
                scores.latency,
                {"scored": len(cands)},
            )
            return ranked, (*talk.exchanges, Exchange("goals", shown, answer)), first_look
    return _numbered(talk, messages, cands, prompt), tuple(talk.exchanges), first_look


def _numbered(
    talk: _Conversation,
    messages: tuple[Message, ...],
    cands: list[tuple[Literal, ...]],
    prompt: str,
) -> list[Ranked]:
    """A numbered choice: the model names one candidate (grammar-bound where the backend
    supports it); that one first, the rest in the enumeration's order."""
    shown = cands[:MAX_NUMBERED]
    listing = "\n".join(f"{i}. {Ranked(c).text}" for i, c in enumerate(shown, 1))
    ask = prompt + template("choose_numbered").substitute(candidates=listing)
    grammar = "root ::= " + " | ".join(f'"{i}"' for i in range(1, len(shown) + 1)) + "\n"
    text = talk.ask("choice", [messages[0], Message("user", ask)], {"grammar": grammar})
    found = re.search(r"\d+", text)
    pick = int(found.group()) - 1 if found else -1
    if not 0 <= pick < len(shown):
        return [Ranked(c) for c in cands]
    rest = [c for i, c in enumerate(cands) if i != pick]
    return [Ranked(cands[pick], 0.0), *(Ranked(c) for c in rest)]


def chosen(
    method: str,
    ranked: Ranked,
    exchanges: Sequence[Exchange],
    first_look: str,
    ranking: Sequence[Ranked],
    notes: Sequence[str] = (),
) -> Proposal:
    """The proposal of a ranking's best candidate (``ranking``: every candidate ranked, shown
    on the run's page)."""
    exchanges = tuple(exchanges)
    if not any(e.tag == "goals" for e in exchanges):  # a control: its pick, as the answer read
        shown = Request((Message("user", "(the candidates, ranked without a model)"),), tag="goals")
        exchanges += (Exchange("goals", shown, Response(PREFIX + ranked.text, method)),)
    parse = GoalParse(GoalStatus.OK, ranked.goals, (), ranked.text, tuple(notes))
    return Proposal(method, parse, exchanges, 0, first_look, tuple(ranking), ranked)


def nothing(
    method: str,
    why: str,
    ranking: Sequence[Ranked] = (),
    exchanges: Sequence[Exchange] = (),
    first_look: str = "",
) -> Proposal:
    """No candidate is left to propose (``ranking``: those ranked, all rejected)."""
    parse = GoalParse(GoalStatus.EMPTY, (), (why,))
    return Proposal(method, parse, tuple(exchanges), 0, first_look, tuple(ranking))


__all__ = ["CHOOSERS", "PREFIX", "Ranked", "chosen", "nothing", "rank"]
