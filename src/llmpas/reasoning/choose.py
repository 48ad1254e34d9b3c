"""Choosing among candidate recovery goals (``flp-choose``, its controls and its scorings).

A small model is better at choosing among options than at writing them (SayCan scores a robot's
skills by the model's likelihood). The closed loop enumerates candidate goal sets the validator
accepts (:mod:`llmpas.system.candidates`); here they are ranked by the method's chooser:

- ``model`` (``flp-choose``): after the first look, each candidate is scored by the model's
  likelihood of writing it as its answer, with token log-probabilities where the backend has
  them (:class:`~llmpas.reasoning.llm.Scorer`), else by a numbered choice (the model names one
  number; that one first, the rest in the enumeration's order);
- ``prior`` (``prior``): the same score from the same prompt with the evidence removed (the
  anomaly and the first look): what the model prefers whatever happened. A control that knows
  no more than the candidates and the task;
- ``shuffled`` (``candidates-shuffled``): the enumeration in a seeded random order per task
  (seeded by the task's name, the run's seed and the consultation: the same order in every
  process, whatever ``PYTHONHASHSEED``), the first the checks accept proposed;
- ``random`` (``candidates-random``): a uniform order seeded by the run's seed only;
- ``first`` (``candidates-first``): the enumeration's own order (which is by predicate name:
  not neutral, kept for reference).

The controls other than ``prior`` ask no model: a lift of ``flp-choose`` over
``candidates-shuffled`` is the model's, and over ``prior`` the evidence's; a lift of the shuffled
order over the replan row is the enumeration's.

**Scorings** (:class:`Scoring`, ``MethodConfig.scoring``, written ``HOW[-words]``): ``mean`` —
the mean log-probability of the candidate's tokens (length-normalised); ``diff`` — the sum over
the candidate's tokens after the text every candidate shares (``(and (`` and more: a mean over a
long shared string dilutes the few tokens that differ); ``pmi`` — the candidate's summed
log-probability less its summed log-probability after the prompt without the evidence (pointwise
mutual information with the evidence, Holtzman et al. 2021: a candidate's own prior — short,
frequent, first — stops deciding). ``-words``: candidates read as plain words (``scanned
table2 right``) after a plain-words prefix, instead of PDDL literals after ``Goals:``. Every
ranking is a :class:`Ranked` list: the best is proposed, the rest kept for later rounds. LLM
output is data: a numbered choice is parsed as a number, never run.
"""

from __future__ import annotations

import hashlib
import random
import re
from collections.abc import Sequence
from dataclasses import dataclass, replace

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal
from llmpas.reasoning.llm import (
    LLM,
    Message,
    Request,
    Response,
    ScoreRequest,
    Scores,
    ScoringUnsupported,
)
from llmpas.reasoning.methods import (
    CHOOSERS,
    SCORINGS,
    Exchange,
    MethodConfig,
    Proposal,
    Situation,
    _Conversation,
    _system,
    method,
    template,
)

PREFIX = "Goals: "
WORDS_PREFIX = "Next the robot should make this true: "
MAX_NUMBERED = 99
HOWS = ("mean", "diff", "pmi")
RENDERINGS = ("pddl", "words")


@dataclass(frozen=True)
class Scoring:
    """How candidates are scored: ``how`` (mean | diff | pmi, see the module's doc) and their
    ``rendering`` (pddl | words). Written ``HOW`` or ``HOW-words`` (:meth:`parse`)."""

    how: str = "mean"
    rendering: str = "pddl"

    def __post_init__(self) -> None:
        if self.how not in HOWS:
            raise ValueError(f"scoring must be one of {', '.join(SCORINGS)}; got {self.how!r}")
        if self.rendering not in RENDERINGS:
            raise ValueError(f"rendering must be one of {', '.join(RENDERINGS)}")

    @classmethod
    def parse(cls, text: str) -> Scoring:
        how, _, rendering = text.strip().partition("-")
        if text.strip() not in SCORINGS:
            raise ValueError(f"scoring must be one of {', '.join(SCORINGS)}; got {text!r}")
        return cls(how, rendering or "pddl")

    @property
    def name(self) -> str:
        return self.how if self.rendering == "pddl" else f"{self.how}-{self.rendering}"

    @property
    def prefix(self) -> str:
        return PREFIX if self.rendering == "pddl" else WORDS_PREFIX

    def render(self, goals: Sequence[Literal]) -> str:
        """A candidate as the model is asked to score it."""
        if self.rendering == "pddl":
            return Ranked(tuple(goals)).text
        return " and ".join(words(g) for g in goals)


def words(g: Literal) -> str:
    """A literal in plain words: ``(not (on mug sink))`` -> ``not on mug sink`` (names split at
    ``_`` and ``-``): the domain's own names, nothing a domain must supply."""
    atom = g.arg if isinstance(g, Not) else g
    assert isinstance(atom, Atom)
    text = " ".join((atom.predicate, *atom.args)).replace("_", " ").replace("-", " ")
    return f"not {text}" if isinstance(g, Not) else text


def shuffle_seed(task: str, seed: int | None, consultation: int) -> int:
    """The shuffled control's seed: from the task's name, the run's seed and the consultation,
    through SHA-256 (the same in every process; ``hash()`` is salted per process)."""
    text = f"{task}|{0 if seed is None else seed}|{consultation}"
    return int.from_bytes(hashlib.sha256(text.encode("utf-8")).digest()[:8], "big")


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
    if chooser in ("random", "shuffled"):
        order = list(range(len(cands)))
        if chooser == "random":
            seed = 0 if config.seed is None else config.seed
            random.Random(seed * 1000 + consultation).shuffle(order)
        else:
            random.Random(shuffle_seed(config.task, config.seed, consultation)).shuffle(order)
        return [Ranked(cands[i]) for i in order], (), ""
    scoring = Scoring.parse(config.scoring)
    talk = _Conversation(llm, config, situation)
    first_look = ""
    if made.first_look and chooser == "model":
        step1 = template(made.first_look).substitute(situation.fields())
        first_look = talk.ask("first-look", [_system(), Message("user", step1)], {}).strip()
    with_evidence = _messages(made.template, situation, first_look)
    blind = _messages(made.template, without_evidence(situation), "")
    messages = blind if chooser == "prior" else with_evidence
    scorer = getattr(llm, "score", None)
    if callable(scorer):
        try:
            values, scores = _score(
                scorer, scoring, chooser, cands, with_evidence, blind, situation
            )
        except ScoringUnsupported:
            pass
        else:
            order = sorted(range(len(cands)), key=lambda i: (-values[i], i))
            ranked = [Ranked(cands[i], values[i]) for i in order]
            shown = Request((*messages, Message("assistant", scoring.prefix)), tag="goals")
            answer = Response(
                PREFIX + ranked[0].text,
                scores[0].model,
                sum(s.prompt_tokens for s in scores),
                sum(len(lp) for s in scores for lp in s.logprobs),
                sum(s.latency for s in scores),
                {"scored": len(cands), "scoring": scoring.name, "requests": len(scores)},
            )
            return ranked, (*talk.exchanges, Exchange("goals", shown, answer)), first_look
    prompt = messages[-1].content
    return _numbered(talk, messages, cands, prompt), tuple(talk.exchanges), first_look


def _messages(name: str, situation: Situation, first_look: str) -> tuple[Message, ...]:
    return (_system(), Message("user", template(name).substitute(situation.fields(first_look))))


def without_evidence(situation: Situation) -> Situation:
    """The situation with its evidence removed: no anomaly (the first look, which reads it, is
    left out by the caller); the task, actions, predicates, environment and history stay."""
    return replace(situation, anomaly="")


def _score(
    scorer: object,
    scoring: Scoring,
    chooser: str,
    cands: list[tuple[Literal, ...]],
    with_evidence: tuple[Message, ...],
    blind: tuple[Message, ...],
    situation: Situation,
) -> tuple[list[float], list[Scores]]:
    """Each candidate's value under ``scoring`` (higher is better) and the scores read."""
    texts = [scoring.render(c) for c in cands]
    prefix = scoring.prefix
    if scoring.how == "diff":
        shared = _shared_prefix(texts)
        prefix, texts = prefix + shared, [t[len(shared) :] for t in texts]
    score = scorer  # a Scorer's bound ``score``

    def read(messages: tuple[Message, ...]) -> Scores:
        request = ScoreRequest(messages, tuple(texts), prefix, tag="goals", situation=situation)
        result: Scores = score(request)  # type: ignore[operator]
        if len(result.logprobs) != len(texts):
            raise ScoringUnsupported("the scorer gave another number of scores than choices")
        return result

    if chooser == "prior":
        prior = read(blind)
        return _aggregate(prior, scoring.how), [prior]
    given = read(with_evidence)
    if scoring.how != "pmi":
        return _aggregate(given, scoring.how), [given]
    prior = read(blind)
    pmi = [a - b for a, b in zip(_sums(given), _sums(prior), strict=True)]
    return pmi, [given, prior]


def _aggregate(scores: Scores, how: str) -> list[float]:
    """``mean``: the mean over each choice's tokens; ``diff`` and ``pmi`` (its prior part):
    the sum."""
    return list(scores.mean()) if how == "mean" else _sums(scores)


def _sums(scores: Scores) -> list[float]:
    return [sum(lp) if lp else float("-inf") for lp in scores.logprobs]


def _shared_prefix(texts: Sequence[str]) -> str:
    """The text every candidate starts with, cut so that each keeps at least one character."""
    shared = texts[0]
    for t in texts[1:]:
        n = 0
        while n < min(len(shared), len(t)) and shared[n] == t[n]:
            n += 1
        shared = shared[:n]
    shortest = min(len(t) for t in texts)
    return shared[: max(0, min(len(shared), shortest - 1))]


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


__all__ = [
    "CHOOSERS",
    "PREFIX",
    "SCORINGS",
    "Ranked",
    "Scoring",
    "chosen",
    "nothing",
    "rank",
    "shuffle_seed",
    "without_evidence",
    "words",
]
