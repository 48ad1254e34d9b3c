"""``solve`` and its variants: plan a :class:`PDDLProblem` with llmpas's planner and answer as
PDDLStream does, ``Solution(plan, cost, certificate)`` with the user's values in the plan.

PDDLStream's algorithms map onto llmpas's: ``adaptive``, ``binding`` and ``focused`` plan with
llmpas's adaptive focused planner, ``incremental`` with its incremental one. A generator that
yields ``None`` has nothing this call, as there: the call ends without an output. Nothing is
deferred to execution: every stream a plan needs is evaluated before it is returned
(PDDLStream's ``defer_fn`` only orders those evaluations). Options that mean nothing here are
accepted and said to be ignored, once per run.
"""

from __future__ import annotations

import argparse
import logging
import math
import resource
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from llmpas.errors import PlannerError
from llmpas.language.logic import Atom
from llmpas.pddlstream.expressions import INF, Action, Certificate, PDDLProblem, Solution
from llmpas.pddlstream.translate import Translation, Unsupported, translate
from llmpas.pddlstream.wrappers import SHARED_DEBUG, Notes
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus
from llmpas.planning import solve as plan
from llmpas.planning.fluents import unsupported_fluents
from llmpas.planning.instances import negative_test_predicates

log = logging.getLogger(__name__)

FOCUSED_ALGORITHMS = ("focused", "binding", "adaptive")
ALGORITHMS = ("incremental", *FOCUSED_ALGORITHMS)
DEFAULT_ALGORITHM = "adaptive"
#: llmpas's algorithm per PDDLStream name: its adaptive algorithm keeps a skeleton queue, its
#: focused and binding ones do not
_ALGORITHM = {"incremental": "incremental", "adaptive": "skeletons"}
DEFAULT_MAX_TIME = 300.0  # seconds, when a script says max_time=INF: a safety net

# A generator's ``None`` ends the call without an output, as in PDDLStream (one call is one
# ``next``: ``None`` is an empty list of outputs); the instance may be called again later. Not
# llmpas's default (a call goes on until ``max_time``), which lets one hopeless instance (an
# inverse-visibility sampler that never finds a view) take the whole time.
GENERATOR_NONE_ENDS_CALL = 1

# PDDLStream's planner names -> Fast Downward searches (every heuristic with the axiom option
# llmpas requires); other names: llmpas's default search
_AX = "axioms=approximate_negative"
PLANNERS = {
    "dijkstra": "astar(blind())",
    "max-astar": f"astar(hmax({_AX}))",
    "lmcut-astar": f"astar(hmax({_AX}))",  # LM-cut has no axiom option: another admissible one
    "ff-astar": f"astar(ff({_AX}))",
    "ff-eager": f"eager_greedy([ff({_AX})])",
    "ff-lazy": f"lazy_greedy([ff({_AX})])",
    "add-lazy": f"lazy_greedy([add({_AX})])",
    "goal-lazy": "lazy_greedy([goalcount()])",
    **{f"ff-wastar{w}": f"eager_wastar([ff({_AX})], w={w})" for w in (1, 2, 3, 5)},
    **{f"max-wastar{w}": f"eager_wastar([hmax({_AX})], w={w})" for w in (1, 2, 3, 5)},
}

# solve's options with no meaning here that are never worth a word
_QUIET = frozenset({"verbose", "debug", "visualize", "max_planner_time", "clean", "temp_dir"})


@dataclass(frozen=True)
class Attempt:
    """One call of ``solve``: the translated problem, llmpas's result, the solution returned
    and the CPU seconds it took (this process and the planner's child processes)."""

    translation: Translation
    result: PlanResult
    solution: Solution
    cpu_seconds: float
    unit_costs: bool = False


@dataclass
class SolveContext:
    """What the calls of one run share: the notes already said, and who hears of attempts."""

    notes: Notes = field(default_factory=Notes)
    on_attempt: Callable[[Attempt], None] | None = None


def solve(
    problem: PDDLProblem,
    algorithm: str = DEFAULT_ALGORITHM,
    constraints: Any = None,
    stream_info: Mapping[str, Any] | None = None,
    replan_actions: Iterable[str] = (),
    unit_costs: bool = False,
    success_cost: float = INF,
    max_time: float = INF,
    max_iterations: float = INF,
    max_memory: float = INF,
    context: SolveContext | None = None,
    **options: Any,
) -> Solution:
    """Plan ``problem``; a Solution with plan None and cost INF when no plan was found."""
    ctx = context or SolveContext()
    if algorithm not in ALGORITHMS:
        raise Unsupported(
            f"solve: algorithm {algorithm!r} does not exist (known: {', '.join(ALGORITHMS)})"
        )
    _check_constraints(constraints, ctx.notes)
    if list(replan_actions or ()):
        ctx.notes.ignored("solve(replan_actions=...)", "nothing is deferred to execution")
    if success_cost < INF:
        ctx.notes.ignored("solve(success_cost=...)", "the first plan found is returned")
    search = _search(options.pop("planner", None), ctx.notes)
    for key in sorted(options):
        if key not in _QUIET and options[key] not in (None, False, (), []):
            ctx.notes.ignored(f"solve({key}=...)", "no meaning for llmpas's planner")
    config = PlannerConfig(
        algorithm=_ALGORITHM.get(algorithm, "focused"),
        defer=False,
        max_time=DEFAULT_MAX_TIME if math.isinf(max_time) else float(max_time),
        search_time=DEFAULT_MAX_TIME if math.isinf(max_time) else float(max_time),
        max_iterations=200 if math.isinf(max_iterations) else max(1, int(max_iterations)),
        memory_mb=4096 if math.isinf(max_memory) else max(64, int(max_memory)),
        search=search,
        max_empty_samples=GENERATOR_NONE_ENDS_CALL,
        init_identity=True,  # as in PDDLStream
        lazy_tests=True,  # as PDDLStream's focused algorithm: tests for a plan's bindings
        share_placeholders=_shared_values(problem),
    )
    started = _cpu()
    tr = translate(problem, stream_info, unit_costs=unit_costs, notes=ctx.notes)
    refused = unsupported_fluents(
        tr.problem, config.algorithm, negated=negative_test_predicates(tr.problem)
    )
    if refused is not None:
        raise Unsupported(refused)
    result = plan(tr.problem, config)
    solution = solution_of(tr, result, unit_costs, problem.init)
    attempt = Attempt(tr, result, solution, _cpu() - started, unit_costs)
    if ctx.on_attempt is not None:
        ctx.on_attempt(attempt)
    if result.status is PlanStatus.ERROR:
        raise PlannerError(f"planner: {result.message}")
    if not result.solved:
        log.warning("pddlstream: no plan (%s): %s", result.status.value, result.message)
    return solution


def _shared_values(problem: PDDLProblem) -> bool:
    """Whether every stream gives one value per stream and output whatever its inputs
    (``stream_map=SHARED_DEBUG``): then one placeholder per stream output (and level) stands
    for what evaluation will give, as PDDLStream's shared optimistic objects do, where one per
    instance only multiplies the objects the translator grounds (kitchen/run.py: 66 s of CPU
    in the translator with one per instance, under the script's limit on a loaded machine
    not even one search; 0.3 s shared). A task unsolvable so is planned again with one per
    instance (``share_placeholders``)."""
    m = problem.stream_map
    return isinstance(m, str) and m.lower() == SHARED_DEBUG


def _cpu() -> float:
    """CPU seconds of this process and its finished children (Fast Downward runs in them)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def solution_of(
    tr: Translation, result: PlanResult, unit_costs: bool, init: Iterable[Any]
) -> Solution:
    """llmpas's result as PDDLStream's Solution: actions and facts hold the user's values."""
    p = result.plan

    def value(name: str) -> Any:
        if p is not None and name in p.objects and name not in tr.values:
            return p.objects[name]
        return tr.value(name)

    def fact(a: Atom) -> tuple[Any, ...]:
        return (a.predicate, *(value(x) for x in a.args))

    certified = [] if p is None else [fact(a) for a in sorted(p.certified)]
    certificate = Certificate([*list(init), *certified], certified)
    if p is None:
        return Solution(None, INF, certificate)
    actions = [Action(s.action, tuple(value(a) for a in s.args)) for s in p.steps]
    cost = float(len(actions)) if unit_costs else p.cost
    return Solution(actions, cost, certificate)


def _check_constraints(constraints: Any, notes: Notes) -> None:
    if constraints is None:
        return
    if getattr(constraints, "skeletons", None) is not None:
        raise Unsupported(
            "solve: PlanConstraints(skeletons=...) (plan skeletons) are not supported"
        )
    if getattr(constraints, "max_cost", INF) < INF:
        notes.ignored("PlanConstraints(max_cost=...)", "no bound on the plan's cost")


def _search(planner: Any, notes: Notes) -> str | None:
    if planner is None:
        return None
    if isinstance(planner, str) and planner in PLANNERS:
        return PLANNERS[planner]
    notes.ignored(f"solve(planner={planner!r})", "unknown here: llmpas's default search")
    return None


def solve_focused(problem: PDDLProblem, **kwargs: Any) -> Solution:
    return solve(problem, algorithm="focused", **kwargs)


def solve_binding(problem: PDDLProblem, **kwargs: Any) -> Solution:
    return solve(problem, algorithm="binding", **kwargs)


def solve_adaptive(problem: PDDLProblem, **kwargs: Any) -> Solution:
    return solve(problem, algorithm="adaptive", **kwargs)


def solve_incremental(problem: PDDLProblem, **kwargs: Any) -> Solution:
    return solve(problem, algorithm="incremental", **kwargs)


def solve_serialized(problem: PDDLProblem, **kwargs: Any) -> Solution:
    return solve(problem, **kwargs)


def create_parser(default_algorithm: str = DEFAULT_ALGORITHM) -> argparse.ArgumentParser:
    """The parser PDDLStream's example scripts extend: ``-a/--algorithm`` and ``-u/--unit``."""
    parser = argparse.ArgumentParser()
    parser.add_argument(
        "-a",
        "--algorithm",
        default=default_algorithm,
        choices=ALGORITHMS,
        help="the PDDLStream algorithm (adaptive, binding, focused: llmpas's focused planner)",
    )
    parser.add_argument("-u", "--unit", action="store_true", help="uses unit costs")
    return parser


__all__ = [
    "ALGORITHMS",
    "Attempt",
    "SolveContext",
    "create_parser",
    "solution_of",
    "solve",
    "solve_adaptive",
    "solve_binding",
    "solve_focused",
    "solve_incremental",
    "solve_serialized",
]
