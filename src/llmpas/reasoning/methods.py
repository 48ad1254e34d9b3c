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

Templates live in ``llmpas/reasoning/templates/*.txt`` (``string.Template`` placeholders) and can
be edited without touching code. Every answer is parsed and validated against the goal vocabulary
(:mod:`llmpas.reasoning.goals`); a rejected answer is sent back with the errors, at most
``repairs`` times. LLM output is only ever parsed.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from string import Template

from llmpas.language.logic import Formula
from llmpas.reasoning.goals import GoalParse, GoalStatus, Literal, parse_goals
from llmpas.reasoning.grammar import gbnf, json_schema, skill_gbnf
from llmpas.reasoning.llm import LLM, Message, Request, Response
from llmpas.reasoning.program import parse_program
from llmpas.reasoning.tables import Call, Vocabulary

METHODS = ("flp", "flp-refer", "one-step", "progprompt", "inner-monologue")
DECODINGS = ("grammar", "schema", "none")


@cache
def template(name: str) -> Template:
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

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {self.method!r}")
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


_TEMPLATES = {
    "flp": "flp_step2",
    "flp-refer": "flp_refer_step2",
    "one-step": "one_step",
    "progprompt": "progprompt",
    "inner-monologue": "inner_monologue",
}
_ACTION = re.compile(r"Robot action:\s*(.*)")


def _reader(
    situation: Situation, vocab: Vocabulary, config: MethodConfig, exclude: Collection[Literal] = ()
) -> tuple[Callable[[str], GoalParse], dict[str, object]]:
    """How the method's answers are read, and how decoding is constrained."""
    if config.method == "progprompt":  # free text: a program cannot be grammar-bound here
        return (lambda text: parse_program(text, situation.calls, vocab)), {}
    if config.method == "inner-monologue":
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
) -> Proposal:
    """Ask ``llm`` for goals with the configured method; parse, validate and repair.

    With grammar decoding, the literals in ``exclude`` and every literal a validation rejected
    in an earlier answer are left out of the grammar: a small model cannot repeat them."""
    config = config or MethodConfig()
    talk = _Conversation(llm, config, situation)
    first_look = ""
    if config.method in ("flp", "flp-refer"):
        step1 = template("flp_step1").substitute(situation.fields())
        first_look = talk.ask("first-look", [_system(), Message("user", step1)], {}).strip()
    prompt = template(_TEMPLATES[config.method]).substitute(situation.fields(first_look))
    messages = [_system(), Message("user", prompt)]
    banned = set(exclude)
    read, constrain = _reader(situation, vocab, config, _sorted(banned))
    parse = _parse(talk.ask("goals", messages, constrain), read, check)
    repairs = 0
    while not parse.ok and repairs < config.repairs:
        if not banned.issuperset(parse.rejected):
            banned.update(parse.rejected)
            try:
                constrain = _reader(situation, vocab, config, _sorted(banned))[1]
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
