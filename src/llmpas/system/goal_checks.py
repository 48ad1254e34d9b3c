"""The checks of the LLM's goals (:class:`GoalChecker`): a function from a goal parse to a goal
parse, which is reasoning's :data:`~llmpas.reasoning.methods.Check`. Reasoning calls it on
every answer inside its repair loop; the feedback it writes is what a repair answers.

In order: a search the robot already made in vain is rejected (a repeat); goals that the
domain's invariants say cannot hold together are rejected before any planner call
(:mod:`llmpas.planning.invariants`: one object in two places); goals the robot
believes true are dropped (all of them: rejected); goals no plan reaches are dropped (all of
them: rejected, naming lost objects); goals that cannot be reached together are rejected; goals
tried before that did not help are rejected. Validating one answer costs 1 + n + 1 planner
calls at most (all goals, each goal, the reachable ones together).

The checker knows no world: it is given the search memory, a planner and the facts the planner
plans from, so a test can run it with a few facts and a planner that answers from a table.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence, Set
from dataclasses import dataclass, field, replace

from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.semantics import Semantics
from llmpas.planning import PlanResult, PlanStatus
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal
from llmpas.reasoning.methods import rejected
from llmpas.system.records import DECIDED_BY, CheckRecord
from llmpas.system.search_memory import SearchMemory

UNJUDGED = (PlanStatus.TIMEOUT, PlanStatus.CRASHED, PlanStatus.ERROR)  # no verdict


@dataclass(frozen=True)
class GoalChecker:
    """Reasoning's ``Check`` for one run.

    ``memory``: what was searched; ``plan``: a plan for a goal from the current belief (the
    loop memoises it per round); ``facts``: the facts the planner would plan a goal from (so
    that a check and the planner never disagree); ``sem``: the domain's semantics; ``task``: the
    task goal (its own literals are never read as searches); ``tried``: the goal sets achieved
    before that did not help; ``assists``: which checks run (``validation``) and whether
    ``(on X P)`` for a lost X is read as a search (``search_rewrite``)."""

    memory: SearchMemory
    plan: Callable[[Formula], PlanResult]
    facts: Callable[[Formula], Set[Atom]]
    sem: Semantics
    task: Formula
    tried: Callable[[], Sequence[frozenset[str]]] = tuple
    assists: Assists = field(default_factory=Assists)
    # whether some action can make a literal true (None: every literal may be); a literal no
    # action makes true is unreachable without asking the planner
    makeable: Callable[[Literal], bool] | None = None
    # the feedback for goals that restate the goal that just failed, when planning them would
    # repeat the failure ("" otherwise; None: no such check)
    restated: Callable[[Sequence[Literal]], str] | None = None
    # why goals cannot hold together by the domain's invariants ("" when they may; None: no
    # such check): a contradiction never reaches the planner
    contradiction: Callable[[Sequence[Literal]], str] | None = None
    # how many plans the planner has made so far (the calls a check makes are logged)
    calls: Callable[[], int] = lambda: 0
    log: list[CheckRecord] = field(default_factory=list, compare=False)  # every check, in order

    def __call__(self, parse: GoalParse) -> GoalParse:
        """Already-true goals are dropped; repeats of exhausted searches and of attempts that
        did not help, contradictions and unreachable goals are rejected with feedback. Each
        call is logged (:attr:`log`): the goals, the verdict, how it was decided, its time and
        the planner calls it made."""
        started, calls = time.perf_counter(), self.calls()
        out, by = self.decide(parse)
        verdict = "accepted" if out.ok else out.status.value
        seconds = time.perf_counter() - started
        text = " ".join(map(str, parse.goals))
        self.log.append(CheckRecord(text, verdict, by, seconds, self.calls() - calls))
        return out

    def decide(self, parse: GoalParse) -> tuple[GoalParse, str]:
        """The checked parse and how it was decided (:data:`DECIDED_BY`)."""
        raw = parse.goals
        rewrite = self.assists.search_rewrite
        if rewrite:
            parse = self.as_searches(parse)
        if not self.assists.validation:
            return parse, "unchecked"
        errors = []
        bad = []
        searching = self.memory.searching()
        for g in parse.goals:
            if isinstance(g, Atom) and self.memory.is_look(g):
                for obj, regions in searching.items():
                    if g.args[0] in regions:
                        bad.append(g)
                        errors.append(
                            f"{g}: {g.args[0]} was already searched for {obj} from "
                            "several positions without finding it; look elsewhere"
                            + self.memory.not_searched(regions)
                        )
        if errors:
            culprits = [r for r in raw if (self.as_goal(r) if rewrite else r) in bad]
            return rejected(parse, GoalStatus.REPEATED, errors, culprits), "repeat"
        why = self.contradiction(parse.goals) if self.contradiction is not None else ""
        if why:
            return rejected(parse, GoalStatus.UNREACHABLE, [why]), "invariant"
        parse = self.drop_true(parse)
        if not parse.ok:
            return replace(parse, rejected=raw), "already true"
        calls, goals = self.calls(), parse.goals
        parse, by = self.reachable(parse), "search"
        if not parse.ok:
            by = self.rejected_by(goals, self.calls() - calls)
            culprits = [r for r in raw if (self.as_goal(r) if rewrite else r) in parse.rejected]
            return replace(parse, rejected=tuple(culprits)), by
        why = self.restated(parse.goals) if self.restated is not None else ""
        if why:
            return rejected(parse, GoalStatus.REPEATED, [why], raw if len(raw) == 1 else ()), by
        key = frozenset(map(str, parse.goals))
        if key in self.tried():
            errors = [f"{' '.join(sorted(key))} was already tried and did not help"]
            return rejected(parse, GoalStatus.REPEATED, errors, raw if len(raw) == 1 else ()), by
        return parse, by

    def rejected_by(self, goals: Sequence[Literal], calls: int) -> str:
        """How :meth:`reachable` rejected ``goals``, having made ``calls`` planner calls: a
        literal no action makes true (no call), a limit of the planner, or its search."""
        if not calls and self.makeable is not None and not all(map(self.makeable, goals)):
            return "no action makes it"
        limits = (*UNJUDGED, PlanStatus.LIMIT)
        if any(self.plan(And((g,))).status in limits for g in goals):
            return "limit"
        return "search"

    def as_searches(self, parse: GoalParse) -> GoalParse:
        """``(on X P)`` for a lost object X and a place P the robot can search is read as the
        hypothesis it states: look at P, ``(scanned P)`` (no plan can put X anywhere before it
        is found). Only a recovery goal is read so: the task's own literal stays what it is."""
        goals: list[Literal] = []
        notes = list(parse.notes)
        for g in parse.goals:
            search = self.as_goal(g)
            if search != g and isinstance(g, Atom):
                notes.append(f"read {g} as {search}: where {g.args[0]} is, is unknown")
            if search not in goals:
                goals.append(search)
        if goals == list(parse.goals):
            return parse
        return GoalParse(parse.status, tuple(goals), parse.errors, parse.source, tuple(notes))

    def as_goal(self, g: Literal) -> Literal:
        """How the loop reads an answer's literal: a search for a lost object's place
        (:meth:`SearchMemory.as_search`), except the task's own literals."""
        return g if g in set(atoms_of(self.task)) else self.memory.as_search(g)

    def drop_true(self, parse: GoalParse) -> GoalParse:
        """Goals the robot believes already hold are dropped (all of them: rejected); read in
        the facts the planner plans from."""
        facts = self.facts(And(parse.goals))
        true = [g for g in parse.goals if self.sem.holds(g, facts)]
        if not true:
            return parse
        if len(true) == len(parse.goals):
            shown = ", ".join(map(str, true))
            msg = f"every goal already holds: {shown}; propose goals that are not yet true"
            return rejected(parse, GoalStatus.ALREADY_TRUE, [msg])
        kept = tuple(g for g in parse.goals if g not in true)
        notes = (*parse.notes, *(f"dropped {g}: it already holds" for g in true))
        return GoalParse(GoalStatus.OK, kept, (), parse.source, notes)

    def reachable(self, parse: GoalParse) -> GoalParse:
        """Goals no plan reaches from the believed state are dropped (when others are
        reachable) or rejected with feedback (when none is)."""
        goals = parse.goals
        never = [g for g in goals if self.makeable is not None and not self.makeable(g)]
        if not never and self.plan(And(goals)).solved:
            return parse
        ok = [g for g in goals if g not in never and self.plan(And((g,))).solved]
        bad = [g for g in goals if g not in ok]
        unjudged = [g for g in bad if g not in never and self.plan(And((g,))).status in UNJUDGED]
        if unjudged:  # a safety net fired: no verdict, and not "unreachable"
            why = [f"{g}: not judged: {self.plan(And((g,))).message}" for g in unjudged]
            return rejected(parse, GoalStatus.UNREACHABLE, why, unjudged)
        if not ok:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [self.why_unreachable(g) for g in bad],
                bad,
            )
        if len(ok) > 1 and not self.plan(And(tuple(ok))).solved:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [f"{' '.join(map(str, goals))}: cannot be achieved together"],
            )
        notes = (*parse.notes, *(f"dropped {g}: unreachable" for g in bad))
        return GoalParse(GoalStatus.OK, tuple(ok), (), parse.source, notes)

    def why_unreachable(self, goal: Literal) -> str:
        """The feedback for a goal no plan reaches, naming objects the robot has lost."""
        text = f"{goal}: no sequence of the robot's actions can achieve it from the current state"
        atom = goal.arg if isinstance(goal, Not) else goal
        model = self.memory.model
        lost = [a for a in getattr(atom, "args", ()) if model.lost(a)]
        if lost:
            text += (
                f" ({', '.join(lost)}: location unknown; find it first with a goal "
                f"({model.predicate} PLACE) for a place not searched yet)"
            )
        return text


__all__ = ["DECIDED_BY", "UNJUDGED", "CheckRecord", "GoalChecker"]
