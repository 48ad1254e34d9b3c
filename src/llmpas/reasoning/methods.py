"""Prompting methods: from an anomaly to validated PDDL goal literals.

- ``flp`` — First Look Prompting: step 1 shows the LLM only the anomaly and asks for a reasoned
  fix (the *first look*); step 2 gives the action library, the logical state predicates, the
  environment status and anomaly, the first look, and the output format, and asks for goals.
- ``flp-refer`` — the same two steps, but step 2 presents the first look as a suggestion to check.
- ``one-step`` — step 2's context without a first look.
- ``progprompt`` — ProgPrompt-style: the LLM writes a Python program of robot calls, which is
  parsed (never run) and mapped to goals.
- ``inner-monologue`` — Inner-Monologue-style: a textual dialogue (scene, human instruction,
  success feedback, earlier attempts) in which the LLM picks the robot's next skill; the skill's
  effect is the goal, and the closed loop feeds its outcome back in the next round.

- ``flp-multi`` — FLP whose step 2 asks for every open possibility in one answer (all the places a
  lost object could be, as one conjunction of search goals): one consultation instead of one per
  place (the paper's ASPL argument).
- ``flp-hypotheses`` — FLP with a structured first look: step 1 lists hypotheses about the cause,
  each with the fact that would confirm or fix it; step 2 turns them into goals.

- ``flp-choose`` — the model chooses instead of writing: the loop enumerates candidate goal sets
  (:mod:`llmpas.system.candidates`) and, after the first look, the model ranks them by their
  likelihood as its answer (:mod:`llmpas.reasoning.choose`); controls that carry no knowledge
  of the anomaly: ``candidates-shuffled`` (a seeded random order per task), ``prior`` (the
  model's score without the evidence), ``candidates-random`` (a uniform order seeded by the run
  only) and ``candidates-first`` (the enumeration's, by predicate name: for reference).

``MethodConfig.votes`` > 1 adds self-consistency to any method: that many sampled answers, each
checked by the validator (the loop's planner-backed check), the goal set most valid answers agree
on kept.

A method is a :class:`Method` in :data:`REGISTRY` (its step-2 template, its first-look template if
any, how its answers are read): a new method is one template file and one registry line, and
:func:`method_names` (the choices of ``--method`` and ``--methods``) lists it. Templates live in
``llmpas/reasoning/templates/*.txt`` (``string.Template`` placeholders) and can be edited without
touching code; a method may also name a template file elsewhere by its absolute path. Every
answer is parsed and validated against the goal vocabulary (:mod:`llmpas.reasoning.goal_reading`); a
rejected answer is sent back with the errors, at most ``repairs`` times.
LLM output is only ever parsed.
"""

from __future__ import annotations

import re
import time
from collections import Counter
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass, field, replace
from functools import cache
from importlib import resources
from pathlib import Path
from string import Template
from types import MappingProxyType
from typing import Any

from llmpas.language.logic import Formula
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal, parse_goals
from llmpas.reasoning.grammar import gbnf, json_schema, skill_gbnf
from llmpas.reasoning.llm import LLM, Message, Request, Response
from llmpas.reasoning.program import parse_program
from llmpas.reasoning.replan import REPLAN
from llmpas.reasoning.tables import Call, Vocabulary

DECODINGS = ("grammar", "schema", "none")
CHOOSERS = ("model", "prior", "shuffled", "random", "first")  # see llmpas.reasoning.choose
SCORINGS = tuple(f"{h}{r}" for h in ("mean", "diff", "pmi") for r in ("", "-words"))
READERS = ("goals", "program", "skill")


@dataclass(frozen=True)
class Method:
    """A prompting method: the template of its goal prompt, the template of its first look
    (empty: none), and how its answers are read (``goals``: PDDL literals; ``program``: a
    ProgPrompt program of robot calls; ``skill``: one Inner-Monologue skill call)."""

    name: str
    template: str
    first_look: str = ""
    reader: str = "goals"
    # how candidate goal sets the loop enumerates are ranked ("": the method writes goals;
    # model | prior | shuffled | random | first: :mod:`llmpas.reasoning.choose`)
    chooser: str = ""

    def __post_init__(self) -> None:
        if self.chooser not in ("", *CHOOSERS):
            raise ValueError(f"method {self.name!r}: chooser must be one of {', '.join(CHOOSERS)}")
        if not re.fullmatch(r"[a-z][a-z0-9-]*", self.name):
            raise ValueError(f"method name {self.name!r}: lower-case letters, digits and '-'")
        if self.reader not in READERS:
            raise ValueError(f"method {self.name!r}: reader must be one of {', '.join(READERS)}")
        if not self.template:
            raise ValueError(f"method {self.name!r} needs a template")

    @property
    def program(self) -> bool:
        """Whether its answers are programs of skill calls (not goal literals)."""
        return self.reader != "goals"


REGISTRY: Mapping[str, Method] = MappingProxyType(
    {
        m.name: m
        for m in (
            Method("flp", "flp_step2", first_look="flp_step1"),
            Method("flp-refer", "flp_refer_step2", first_look="flp_step1"),
            Method("one-step", "one_step"),
            Method("progprompt", "progprompt", reader="program"),
            Method("inner-monologue", "inner_monologue", reader="skill"),
            Method("flp-multi", "flp_multi_step2", first_look="flp_step1"),
            Method("flp-hypotheses", "flp_step2", first_look="flp_hypotheses_step1"),
            Method("flp-choose", "choose_step2", first_look="flp_step1", chooser="model"),
            Method("candidates-shuffled", "choose_step2", chooser="shuffled"),
            Method("prior", "choose_step2", chooser="prior"),
            Method("candidates-random", "choose_step2", chooser="random"),
            Method("candidates-first", "choose_step2", chooser="first"),
        )
    }
)
METHODS = tuple(REGISTRY)  # the shipped methods (for the registered ones: method_names())
PAPER_METHODS = ("flp", "flp-refer", "one-step", "progprompt", "inner-monologue")


def method_names() -> tuple[str, ...]:
    """The registered methods: the choices of the command line's ``--method``/``--methods``."""
    return tuple(REGISTRY)


def controls(name: str) -> tuple[str, ...]:
    """The rows a method's row is compared with (the first: its main control): a method that
    chooses by the model against the knowledge-free orders of the same candidates
    (``candidates-shuffled``) and the model without the evidence (``prior``); every other
    method, a control included, against ``replan`` (no reasoning)."""
    if method(name).chooser == "model":
        return ("candidates-shuffled", "prior", REPLAN)
    return (REPLAN,)


def method(name: str) -> Method:
    """The registered method ``name``; ``ValueError`` naming the choices otherwise."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise ValueError(f"method must be one of {', '.join(REGISTRY)}; got {name!r}") from None


@cache
def template(name: str) -> Template:
    """The template ``name``: ``templates/NAME.txt`` of this package, or the file ``name`` when
    it is an absolute path ending in ``.txt``."""
    if name.endswith(".txt") and Path(name).is_absolute():
        return Template(Path(name).read_text(encoding="utf-8"))
    text = resources.files("llmpas.reasoning").joinpath("templates", f"{name}.txt")
    return Template(text.read_text(encoding="utf-8"))


@dataclass(frozen=True)
class Situation:
    """Everything a prompt may show, already rendered as text."""

    anomaly: str
    actions: str
    predicates: str
    environment: str
    task: str
    example: str = "(and (inspected door1))"  # format only: from another domain
    example_call: str = 'inspect("door1")'  # the same, as an Inner-Monologue skill call
    history: str = ""  # earlier attempts that failed (for the deadlock guard's feedback)
    calls: Mapping[str, Call] = field(default_factory=dict)  # ProgPrompt: actions as functions
    objects: tuple[str, ...] = ()
    constraint: Formula | None = None  # the anomaly's failed literal, as data (never shown)
    intent: str = ""  # the task's intent (PDDL, "": the task goal), as data (never shown)

    def fields(self, first_look: str = "") -> dict[str, str]:
        history = f"\n## Already tried without success\n{self.history}\n" if self.history else ""
        return {
            "anomaly": self.anomaly,
            "actions": self.actions,
            "predicates": self.predicates,
            "environment": self.environment,
            "task": self.task,
            "example": self.example,
            "history": history,
            "first_look": first_look,
            "program_api": "\n".join(
                f"# {c.signature(n)}  -> ({c.predicate} ...)" for n, c in self.calls.items()
            ),
            "skills": "\n".join(f"- {_skill(n, c)}" for n, c in self.calls.items()),
            "dialogue": f"Earlier attempts:\n{self.history}\n" if self.history else "",
            "example_call": self.example_call,
            "objects": ", ".join(repr(o) for o in self.objects),
            "environment_comment": _comment(self.environment),
            "anomaly_comment": _comment(self.anomaly),
            "history_comment": _comment(self.history) if self.history else "",
        }


def _skill(name: str, call: Call) -> str:
    fact = f"({call.predicate} {' '.join(call.params[i] for i in call.positions)})"
    return f"{name}({', '.join(call.params)}) -> {'not ' if call.negated else ''}{fact}"


def _comment(text: str) -> str:
    return "\n".join(f"# {line}" for line in text.splitlines())


@dataclass(frozen=True)
class Exchange:
    """One request/response pair, as the episode records it."""

    tag: str
    request: Request
    response: Response


@dataclass(frozen=True)
class Proposal:
    """The outcome of one prompting method on one anomaly."""

    method: str
    parse: GoalParse
    exchanges: tuple[Exchange, ...]
    repairs: int
    first_look: str = ""
    candidates: tuple[Any, ...] = ()  # choosing methods: every candidate ranked (``Ranked``)
    chosen: Any = None  # the candidate proposed

    @property
    def ok(self) -> bool:
        return self.parse.ok

    @property
    def goals(self) -> tuple[Literal, ...]:
        return self.parse.goals

    @property
    def tokens(self) -> int:
        return sum(e.response.prompt_tokens + e.response.completion_tokens for e in self.exchanges)

    @property
    def latency(self) -> float:
        return sum(e.response.latency for e in self.exchanges)


Check = Callable[[GoalParse], GoalParse]  # extra validation (already true, deadlock guard)


@dataclass(frozen=True)
class MethodConfig:
    method: str = "flp"
    decoding: str = "grammar"
    repairs: int = 2
    temperature: float = 0.0
    seed: int | None = 0
    max_tokens: int = 256
    reasoning: int = 200  # characters of one reasoning line before the goals (0: goals only)
    repair_temperature: float = 0.7  # repairs sample: a greedy model would repeat its answer
    votes: int = 1  # self-consistency: sampled answers per consultation, each checked (1: off)
    vote_temperature: float = 0.7  # the temperature of the sampled answers (when votes > 1)
    # how a choosing method scores its candidates (llmpas.reasoning.choose.Scoring)
    scoring: str = "mean"
    task: str = ""  # the task's name: seeds candidates-shuffled's order (never shown)

    def __post_init__(self) -> None:
        if self.scoring not in SCORINGS:
            raise ValueError(f"scoring must be one of {', '.join(SCORINGS)}; got {self.scoring!r}")
        if not 1 <= self.votes <= 16:
            raise ValueError(f"votes must be in [1, 16], got {self.votes}")
        if not 0 <= self.vote_temperature <= 2:
            raise ValueError(f"vote_temperature must be in [0, 2], got {self.vote_temperature}")
        method(self.method)  # ValueError naming the registered methods
        if self.decoding not in DECODINGS:
            raise ValueError(f"decoding must be one of {', '.join(DECODINGS)}")
        if self.repairs < 0:
            raise ValueError(f"repairs must be >= 0, got {self.repairs}")
        if not 0 <= self.repair_temperature <= 2:
            raise ValueError(f"repair_temperature must be in [0, 2], got {self.repair_temperature}")
        if self.reasoning < 0:
            raise ValueError(f"reasoning must be >= 0, got {self.reasoning}")


@dataclass
class _Conversation:
    llm: LLM
    config: MethodConfig
    situation: Situation | None = None
    exchanges: list[Exchange] = field(default_factory=list)

    def ask(
        self, tag: str, messages: list[Message], constrain: Mapping[str, object], repair: int = 0
    ) -> str:
        seed = self.config.seed
        request = Request(
            tuple(messages),
            temperature=self.config.repair_temperature if repair else self.config.temperature,
            max_tokens=self.config.max_tokens,
            seed=seed + repair if seed is not None and repair else seed,
            tag=tag,
            situation=self.situation,
            **constrain,  # type: ignore[arg-type]
        )
        start = time.perf_counter()
        response = self.llm.complete(request)
        if not response.latency:
            response = Response(
                response.text,
                response.model,
                response.prompt_tokens,
                response.completion_tokens,
                time.perf_counter() - start,
                response.meta,
            )
        self.exchanges.append(Exchange(tag, request, response))
        return response.text


def _system() -> Message:
    return Message("system", template("system").substitute().strip())


def _constraints(
    vocab: Vocabulary, config: MethodConfig, exclude: Collection[Literal] = ()
) -> dict[str, object]:
    if config.decoding == "grammar":
        return {"grammar": gbnf(vocab, reasoning=config.reasoning, exclude=exclude)}
    if config.decoding == "schema":
        return {"json_schema": json_schema(vocab)}
    return {}


_ACTION = re.compile(r"Robot action:\s*(.*)")


def answer_reader(
    situation: Situation, vocab: Vocabulary, config: MethodConfig, exclude: Collection[Literal] = ()
) -> tuple[Callable[[str], GoalParse], dict[str, object]]:
    """How the method's answers are read (its :attr:`Method.reader`), and how decoding is
    constrained."""
    reader = REGISTRY[config.method].reader
    if reader == "program":  # free text: a program cannot be grammar-bound here
        return (lambda text: parse_program(text, situation.calls, vocab)), {}
    if reader == "skill":
        grammar = config.decoding == "grammar" and situation.calls
        constrain: dict[str, object] = (
            {"grammar": skill_gbnf(situation.calls, vocab, max(config.reasoning, 1))}
            if grammar
            else {}
        )
        return (lambda text: parse_program(_action(text), situation.calls, vocab)), constrain
    return (lambda text: parse_goals(text, vocab)), _constraints(vocab, config, exclude)


def _action(text: str) -> str:
    """The one skill call of an Inner-Monologue answer (the line after the last
    ``Robot action:``; the whole text when there is no such line)."""
    found = _ACTION.findall(text)
    return found[-1] if found else text


def propose(
    situation: Situation,
    llm: LLM,
    vocab: Vocabulary,
    config: MethodConfig | None = None,
    check: Check | None = None,
    exclude: Iterable[Literal] = (),
    prune: bool = True,
) -> Proposal:
    """Ask ``llm`` for goals with the configured method; parse, validate and repair.

    With grammar decoding, the literals in ``exclude`` and (with ``prune``) every literal a
    validation rejected in an earlier answer are left out of the grammar: a small model cannot
    repeat them. With ``config.votes`` > 1 the goal prompt is answered that many times and the
    answer most valid answers agree on is taken (:func:`_vote`)."""
    config = config or MethodConfig()
    method = REGISTRY[config.method]
    talk = _Conversation(llm, config, situation)
    first_look = ""
    if method.first_look:
        step1 = template(method.first_look).substitute(situation.fields())
        first_look = talk.ask("first-look", [_system(), Message("user", step1)], {}).strip()
    prompt = template(method.template).substitute(situation.fields(first_look))
    messages = [_system(), Message("user", prompt)]
    banned = set(exclude)
    read, constrain = answer_reader(situation, vocab, config, _sorted(banned))
    parse = _parse(talk.ask("goals", messages, constrain), read, check)
    if config.votes > 1:
        parse = _vote(talk, messages, constrain, read, check, parse)
    repairs = 0
    while not parse.ok and repairs < config.repairs:
        if prune and not banned.issuperset(parse.rejected):
            banned.update(parse.rejected)
            try:
                constrain = answer_reader(situation, vocab, config, _sorted(banned))[1]
            except ValueError:  # every literal is excluded: nothing left to ask for
                break
        repairs += 1
        messages += [
            Message("assistant", talk.exchanges[-1].response.text),
            Message(
                "user",
                template("repair").substitute(errors="\n".join(f"- {e}" for e in parse.errors)),
            ),
        ]
        parse = _parse(talk.ask(f"repair-{repairs}", messages, constrain, repairs), read, check)
    return Proposal(config.method, parse, tuple(talk.exchanges), repairs, first_look)


def _vote(
    talk: _Conversation,
    messages: list[Message],
    constrain: Mapping[str, object],
    read: Callable[[str], GoalParse],
    check: Check | None,
    first: GoalParse,
) -> GoalParse:
    """Self-consistency with the validator as verifier: ``votes - 1`` more answers sampled at
    ``vote_temperature`` (seeds after the first answer's), each parsed and checked; the goal set
    given by most valid answers wins (ties: the one given first). None valid: the last
    answer's rejection (its errors drive the repairs)."""
    config = talk.config
    sampled = replace(config, temperature=config.vote_temperature)
    voter = _Conversation(talk.llm, sampled, talk.situation, talk.exchanges)
    parses = [first]
    for k in range(1, config.votes):
        seed = None if config.seed is None else config.seed + 1000 + k
        voter.config = replace(sampled, seed=seed)
        parses.append(_parse(voter.ask(f"vote-{k}", messages, constrain), read, check))
    valid = [p for p in parses if p.ok]
    if not valid:
        return parses[-1]  # the last answer's errors: the repair follows that answer
    counts = Counter(frozenset(map(str, p.goals)) for p in valid)
    best = max(counts.values())
    chosen = next(p for p in valid if counts[frozenset(map(str, p.goals))] == best)
    note = f"self-consistency: {len(valid)} of {len(parses)} answers valid; chosen by {best}"
    return replace(chosen, notes=(*chosen.notes, note))


def _sorted(literals: Iterable[Literal]) -> tuple[Literal, ...]:
    return tuple(sorted(literals, key=str))


def _parse(text: str, read: Callable[[str], GoalParse], check: Check | None) -> GoalParse:
    parse = read(text)
    if parse.ok and check is not None:
        parse = check(parse)
    return parse


def rejected(
    parse: GoalParse, status: GoalStatus, errors: list[str], literals: Iterable[Literal] = ()
) -> GoalParse:
    """A copy of ``parse`` turned into a rejection (for extra checks such as the deadlock
    guard); ``literals`` are the goals at fault, left out of the repairs' decoding."""
    return GoalParse(status, (), tuple(errors), parse.source, rejected=tuple(literals))
