"""``solve_from_pddl``: a plain PDDL domain and problem (texts) planned by llmpas, as
PDDLStream's ``pddlstream.algorithms.search`` does with Fast Downward."""

from __future__ import annotations

from typing import Any

from llmpas.language.domain import parse_domain
from llmpas.language.problem import parse_problem_text
from llmpas.pddlstream.expressions import INF, PDDLProblem
from llmpas.pddlstream.solving import SolveContext, solve
from llmpas.pddlstream.translate import pddl_text


def solve_from_pddl(
    domain_pddl: Any, problem_pddl: Any, context: SolveContext | None = None, **kwargs: Any
) -> tuple[Any, float]:
    """(plan, cost) of a PDDL problem text; (None, INF) when none is found. Objects are the
    ones the init mentions (untyped)."""
    domain = parse_domain(*pddl_text(domain_pddl, "domain"))
    text, filename = pddl_text(problem_pddl, "problem")
    pf = parse_problem_text(text, domain, filename)
    init: list[Any] = [(a.predicate, *a.args) for a in pf.init]
    init += [("=", (t.name, *t.args), v) for t, v in pf.costs.items()]
    problem = PDDLProblem(domain_pddl, {}, None, {}, init, pf.goal)
    plan, cost, _ = solve(problem, context=context, **kwargs)
    return plan, (cost if plan is not None else INF)


class ABSTRIPSLayer:
    """PDDLStream's planning-hierarchy layer: accepted; llmpas plans without a hierarchy."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args = args
        self.kwargs = kwargs
