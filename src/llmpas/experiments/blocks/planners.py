"""LLMs as blocks-world planners: ``llm-ic``, ``copal`` and ``flp``; and the ``oracle`` bound.

- ``llm-ic`` — the LLM is the planner, shown the action library and one in-context example
  (a solved 3-block problem), then the problem; one answer.
- ``copal`` — the same first prompt; the whole plan is executed in the simulated domain and the
  failure (first inapplicable step with the false precondition, the unmet goal facts, or the
  syntax errors) is sent back, asking for a corrected plan, for at most ``rounds`` answers.
- ``flp`` — First Look Prompting as planner, the task description taken as the anomaly: step 1
  sees only the task in words and gives a reasoned approach (the *first look*); step 2 gets the
  action library, the state, the goal, the first look and the output format, and gives the plan.
- ``oracle`` — no LLM: Fast Downward's optimal plan through the same simulator. An upper bound.

:class:`ReferenceOracle` is an LLM stand-in that answers every plan request with Fast Downward's
plan (and a fixed first look): an explicitly labelled upper bound for the LLM methods. Prompts
are the templates ``reasoning/templates/bw_*.txt``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from llmpas.experiments.blocks.blocks_tasks import (
    Task,
    actions_text,
    facts_text,
    goal_text,
    state_words,
    task_words,
)
from llmpas.experiments.blocks.plans import (
    Outcome,
    Step,
    Verdict,
    judge,
    parse_plan,
    plan_gbnf,
    plan_text,
)
from llmpas.experiments.blocks.roles import BlocksRoles, detect_roles
from llmpas.language.problem import Problem
from llmpas.reasoning.llm import LLM, Message, Request, Response
from llmpas.reasoning.methods import template

METHODS = ("oracle", "llm-ic", "copal", "flp")
LLM_METHODS = ("llm-ic", "copal", "flp")
DECODINGS = ("grammar", "none")
TEMPLATES = ("bw_system", "bw_llm_ic", "bw_copal_feedback", "bw_flp_step1", "bw_flp_step2")
PROMPT_VERSION = 1  # bump when the code rendering prompts changes (it keys cached results)

# The in-context example of llm-ic (and copal's first prompt); tests check its plan is valid.
EXAMPLE = Task(
    "example",
    3,
    "in-context example",
    """(define (problem example) (:domain blocksworld) (:objects b1 b2 b3)
  (:init (handempty) (ontable b1) (on b2 b1) (clear b2) (ontable b3) (clear b3))
  (:goal (and (on b1 b2) (on b2 b3) (ontable b3))))""",
)
EXAMPLE_PLAN = (
    Step("unstack", ("b2", "b1")),
    Step("stack", ("b2", "b3")),
    Step("pickup", ("b1",)),
    Step("stack", ("b1", "b2")),
)


def example_for(
    roles: BlocksRoles, domain_name: str, domain_pddl: str
) -> tuple[Task, tuple[Step, ...]]:
    """The in-context example (and its plan) in the words of a domain with these roles."""
    r = roles
    text = (
        f"(define (problem example) (:domain {domain_name}) (:objects b1 b2 b3)\n"
        f"  (:init ({r.handempty}) ({r.ontable} b1) ({r.on} b2 b1) ({r.clear} b2)"
        f" ({r.ontable} b3) ({r.clear} b3))\n"
        f"  (:goal (and ({r.on} b1 b2) ({r.on} b2 b3) ({r.ontable} b3))))"
    )
    names = {"unstack": r.unstack, "stack": r.stack, "pickup": r.pickup, "putdown": r.putdown}
    plan = tuple(Step(names[s.action], s.args) for s in EXAMPLE_PLAN)
    task = Task("example", 3, "in-context example", text, None, domain_pddl)
    return task, plan


@dataclass(frozen=True)
class Settings:
    """How the LLM methods ask: COPAL's bound on answers, decoding, sampling, token budgets."""

    rounds: int = 3  # copal: answers at most (the first plan + rounds - 1 corrections)
    decoding: str = "grammar"  # grammar: a GBNF admitting only plans (llama.cpp)
    temperature: float = 0.0
    seed: int = 0
    correction_temperature: float = 0.7  # copal's corrections sample: greedy repeats the plan
    look_tokens: int = 100  # flp step 1
    tokens_per_step: int = 12  # plan answers get max_steps * this many tokens

    def __post_init__(self) -> None:
        if self.rounds < 1:
            raise ValueError(f"rounds must be >= 1, got {self.rounds}")
        if self.decoding not in DECODINGS:
            raise ValueError(
                f"decoding must be one of {', '.join(DECODINGS)}, got {self.decoding!r}"
            )
        for name in ("temperature", "correction_temperature"):
            if not 0.0 <= getattr(self, name) <= 2.0:
                raise ValueError(f"{name} must be in [0, 2], got {getattr(self, name)}")
        if self.look_tokens < 1 or self.tokens_per_step < 1:
            raise ValueError("look_tokens and tokens_per_step must be >= 1")


def max_steps(size: int) -> int:
    """The longest plan a grammar admits: clearing every block and rebuilding takes <= 4n."""
    return 4 * size + 4


@dataclass(frozen=True)
class Turn:
    """One request/response of a method, as recorded in the results."""

    tag: str
    prompt: str  # the last user message
    answer: str
    tokens: int
    latency: float


@dataclass(frozen=True)
class Attempt:
    """What a method did on one task."""

    method: str
    verdict: Verdict
    steps: tuple[Step, ...]
    rounds: int  # plan answers asked for (0 for the oracle method)
    syntax_errors: int  # plan answers rejected by the parser
    turns: tuple[Turn, ...] = ()
    first_look: str = ""

    @property
    def tokens(self) -> int:
        return sum(t.tokens for t in self.turns)

    @property
    def latency(self) -> float:
        return sum(t.latency for t in self.turns)


class ReferenceOracle:
    """UPPER BOUND, not a language model: answers plan requests with Fast Downward's optimal
    plan for the task, and the first-look request with a fixed sentence."""

    FIRST_LOOK = "Upper-bound oracle: the plan below is Fast Downward's optimal plan."

    def __init__(self, steps: Sequence[Step]) -> None:
        self.steps = tuple(steps)
        self.name = "oracle (Fast Downward plan; upper bound)"

    def complete(self, request: Request) -> Response:
        text = self.FIRST_LOOK if request.tag == "first-look" else plan_text(self.steps)
        return Response(text, model=self.name)


@dataclass
class _Talk:
    llm: LLM
    settings: Settings
    turns: list[Turn] = field(default_factory=list)

    def ask(
        self,
        tag: str,
        messages: Sequence[Message],
        max_tokens: int,
        grammar: str | None,
        correction: int = 0,
    ) -> str:
        """Corrections (``correction > 0``) sample at the correction temperature with their own
        seed: under greedy decoding a small model answers feedback with the same plan."""
        settings = self.settings
        request = Request(
            tuple(messages),
            temperature=settings.correction_temperature if correction else settings.temperature,
            max_tokens=max_tokens,
            seed=settings.seed + correction,
            grammar=grammar,
            tag=tag,
        )
        start = time.perf_counter()
        response = self.llm.complete(request)
        latency = response.latency or time.perf_counter() - start
        tokens = response.prompt_tokens + response.completion_tokens
        self.turns.append(Turn(tag, messages[-1].content, response.text, tokens, latency))
        return response.text


def _system() -> Message:
    return Message("system", template("bw_system").substitute().strip())


def _ic_prompt(problem: Problem, domain_pddl: str) -> str:
    roles = detect_roles(problem.domain)
    if domain_pddl:
        task, plan = example_for(roles, problem.domain.name, domain_pddl)
    else:
        task, plan = EXAMPLE, EXAMPLE_PLAN
    example = task.problem()
    return template("bw_llm_ic").substitute(
        actions=actions_text(problem.domain),
        example_state=_state(example),
        example_goal=goal_text(example),
        example_plan=plan_text(plan),
        state=_state(problem),
        goal=goal_text(problem),
    )


def _state(problem: Problem) -> str:
    words = state_words(problem.init, detect_roles(problem.domain))
    return f"{facts_text(problem.init)} (in words: {words})"


def _feedback(verdict: Verdict) -> str:
    if verdict.outcome in (Outcome.SYNTAX_ERROR, Outcome.NO_PLAN):
        failure = f"Your plan could not be read: {verdict.message}."
    else:
        failure = f"Your plan was executed and failed: {verdict.message}."
    return template("bw_copal_feedback").substitute(failure=failure)


def run_method(
    method: str, problem: Problem, llm: LLM | None, settings: Settings, domain_pddl: str = ""
) -> Attempt:
    """Run ``method`` on ``problem`` with ``llm`` (unused by ``oracle``, which needs it to be a
    :class:`ReferenceOracle` carrying the reference plan). ``domain_pddl``: the text of the
    problem's domain when it is not the shipped one (the in-context example is rewritten in
    its words)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    if llm is None:
        raise ValueError(f"method {method!r} needs an LLM (or the reference oracle)")
    objects = tuple(sorted(problem.objects))
    if method == "oracle":
        if not isinstance(llm, ReferenceOracle):
            raise ValueError("the oracle method runs the reference plan: pass a ReferenceOracle")
        parse = parse_plan(plan_text(llm.steps), problem.domain, objects)
        return Attempt(method, judge(problem, parse), parse.steps, 0, 0)
    talk = _Talk(llm, settings)
    steps_cap = max_steps(len(objects))
    grammar = (
        plan_gbnf(problem.domain, objects, steps_cap) if settings.decoding == "grammar" else None
    )
    budget = steps_cap * settings.tokens_per_step
    first_look = ""
    if method == "flp":
        step1 = template("bw_flp_step1").substitute(task=task_words(problem))
        first_look = talk.ask(
            "first-look", [_system(), Message("user", step1)], settings.look_tokens, None
        ).strip()
        prompt = template("bw_flp_step2").substitute(
            actions=actions_text(problem.domain),
            state=_state(problem),
            goal=goal_text(problem),
            first_look=first_look,
        )
    else:
        prompt = _ic_prompt(problem, domain_pddl)
    messages = [_system(), Message("user", prompt)]
    limit = settings.rounds if method == "copal" else 1
    syntax_errors = 0
    rounds = 0
    while True:
        rounds += 1
        tag = "plan" if rounds == 1 else f"correction-{rounds - 1}"
        answer = talk.ask(tag, messages, budget, grammar, rounds - 1)
        parse = parse_plan(answer, problem.domain, objects)
        verdict = judge(problem, parse)
        # no steps where the goal already holds is the right answer, not a syntax error
        syntax_errors += not parse.ok and not verdict.success
        if verdict.success or rounds >= limit:
            break
        messages += [Message("assistant", answer), Message("user", _feedback(verdict))]
    steps = parse.steps if parse.ok else ()
    return Attempt(method, verdict, steps, rounds, syntax_errors, tuple(talk.turns), first_look)


__all__ = [
    "EXAMPLE",
    "EXAMPLE_PLAN",
    "LLM_METHODS",
    "METHODS",
    "Attempt",
    "ReferenceOracle",
    "Settings",
    "Turn",
    "example_for",
    "max_steps",
    "run_method",
]
