"""The next goal the loop plans: the task with the recovery goals reached kept true
(:meth:`NextGoal.task`), or an answer's goals joined to it, staged in the order written, or
alone (:meth:`NextGoal.answer`); and the check that sends back an answer restating the goal that
just failed (:meth:`NextGoal.restates`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import Problem, parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning import PlanResult
from llmpas.planning.invariants import Invariants
from llmpas.reasoning.goal_reading import Literal
from llmpas.system.acting import Acting
from llmpas.system.anomaly_memory import Anomaly
from llmpas.system.records import Round
from llmpas.system.recovery import Conflicts, Stages, conjuncts, kept_goal, out_of_order
from llmpas.system.search_memory import SearchMemory
from llmpas.system.substitution import Causes, Substitution, substituted, substitution
from llmpas.system.sweep import Sweep


@dataclass
class NextGoal:
    """What to plan next, for one run. ``task``: the task goal; ``success``: its intent (None:
    the task goal); ``stages``: recovery goals reached and still to reach."""

    acting: Acting
    sem: Semantics
    task_text: str
    memory: SearchMemory
    success: str | None = None
    stages: Stages = field(default_factory=Stages)
    invariants: Invariants | None = None  # the domain's: which literals exclude each other

    def __post_init__(self) -> None:
        self.goal = parse_formula(self.task_text, self.sem.domain)
        self.causes = Causes.of(self.sem.domain)
        self.substitutions: list[Substitution] = []  # in the order they were made

    def substitute(self, goals: Sequence[Literal]) -> Substitution | None:
        """Carry a substitute into the task (:mod:`llmpas.system.substitution`): the task's
        literal that a known cause forbids is replaced by the goal that does the same
        elsewhere; every other part stays. None: no substitute, or no known cause."""
        found = substitution(self.goal, goals, self.acting.facts(self.goal), self.causes)
        if found is not None:
            self.goal = substituted(self.goal, found)
            self.task_text = str(self.goal)
            self.substitutions.append(found)
        return found

    def conflicts(self) -> Conflicts | None:
        """Whether two literals cannot hold together, by the domain's invariants read in the
        facts the planner plans from now (None: no invariants)."""
        if self.invariants is None:
            return None
        return self.invariants.conflicts(self.acting.facts(self.goal))

    def holds(self) -> bool:
        """Whether the robot believes the task done: its intent (``success``) where the run
        has one, else its goal; read in the facts the planner plans from."""
        intent = parse_formula(self.success or self.task_text, self.sem.domain)
        return self.sem.holds(intent, self.acting.facts(intent))

    def verdict(self) -> tuple[bool, str]:
        """The run's verdict once the task's plan succeeded, and words that say which task was
        done: the task as given, or as substituted (what replaced what), judged by its intent
        (:meth:`holds`)."""
        done = self.holds()
        if not self.substitutions:
            return done, "the task is done" if done else "the task's plan ran, but it does not hold"
        what = "; ".join(s.describe() for s in self.substitutions)
        text = f"the substituted task {self.task_text} is done ({what})"
        if done:
            return True, text
        intent = self.success or self.task_text
        return False, f"{text}, but the task's intent {intent} does not hold"

    def task(self) -> tuple[Formula, str]:
        """The task with the recovery goals reached so far kept true
        (:mod:`llmpas.system.recovery`), when that can be planned; else the task alone."""
        task = parse_formula(self.task_text, self.sem.domain)
        if self.stages.kept:
            both = kept_goal(task, self.stages.kept, (), self.conflicts())
            if self.acting.plan(both)[0].solved:
                return both, str(both)
        return task, self.task_text

    def recovery_goals(self, rnd: Round, pending: frozenset[str] | None) -> list[Literal]:
        """The LLM's goals a recovery round reached, to keep true: neither its task conjuncts
        nor its searches (a look stays done: nothing in the world undoes it)."""
        goal = parse_formula(rnd.goal, self.sem.domain)
        task = set(atoms_of(parse_formula(self.task_text, self.sem.domain)))
        wanted = {str(g) for g in self.stages.queue} | set(pending or ())
        return [
            g
            for g in conjuncts(goal)
            if isinstance(g, Atom | Not)
            and str(g) in wanted | {str(k) for k in self.stages.kept}
            and (g.arg if isinstance(g, Not) else g) not in task
            and not self.memory.is_look(g)
        ]

    def reached(self, rnd: Round, pending: frozenset[str] | None) -> None:
        """A recovery round succeeded: its goals are kept, its searches remembered."""
        self.stages.reached(self.recovery_goals(rnd, pending), self.conflicts())
        self.memory.searched_in(parse_formula(rnd.goal, self.sem.domain))

    def answer(self, goals: list[Literal], anomaly: Anomaly | None) -> tuple[Formula, str]:
        """The new goals with the task goals they do not contradict and the recovery goals
        reached before, when that can be planned, the plan does not repeat a step that failed
        for a reason the belief does not hold, and it reaches the goals in the order written;
        else the first goal (the others follow, one at a time) when the order was not kept;
        else the new goals alone, with those reached before when that can be planned (the task
        is planned again once they are achieved). A substitute for a part of the task that a
        known cause forbids is carried into the task first (:meth:`substitute`)."""
        self.stages.queue = []
        self.substitute(goals)
        task = parse_formula(self.task_text, self.sem.domain)
        conflicts = self.conflicts()
        both = kept_goal(task, self.stages.kept, goals, conflicts)
        result, problem = self.acting.plan(both)
        repeats = result.solved and self.repeats(anomaly, result, problem)
        if result.solved and not repeats and not self.reordered(result, problem, goals):
            return both, str(both)
        goal = kept_goal(And(()), self.stages.kept, goals, conflicts)
        result, problem = self.acting.plan(goal)
        if not result.solved:
            goal = And(tuple(goals))
            result, problem = self.acting.plan(goal)
        if result.solved and self.reordered(result, problem, goals):
            self.stages.queue = list(goals[1:])
            goal = kept_goal(And(()), self.stages.kept, goals[:1], conflicts)
            if not self.acting.plan(goal)[0].solved:
                goal = And(tuple(goals[:1]))
        return goal, str(goal)

    def look(self, sweep: Sweep, anomaly: Anomaly | None) -> tuple[Formula, str] | None:
        """The sweep's next place, planned (None: its budget is spent or no place left is
        reachable). Places searched in vain are passed over, and so are looks no plan
        reaches."""
        if sweep.over():
            return None
        for look in sweep.candidates(self.memory.exhausted()):
            goal, text = self.answer([look], anomaly)
            result = self.acting.plan(goal)[0]
            if result.solved and result.plan is not None:
                sweep.take(look, len(result.plan.steps))
                return goal, text
            sweep.passed.append(f"{look}: no plan reaches it")
            sweep.order.remove(look)
        return None

    def reordered(self, result: PlanResult, problem: Problem, goals: list[Literal]) -> bool:
        """The plan reaches the goals out of the order written. Searches are left out: a look
        changes nothing in the world, so the order of looks is the planner's to choose."""
        changes = [g for g in goals if not self.memory.is_look(g)]
        return result.plan is not None and out_of_order(self.sem, problem, result.plan, changes)

    def repeats(self, anomaly: Anomaly | None, result: PlanResult, problem: Problem) -> bool:
        """The plan contains the step whose failure is the anomaly, and nothing the robot
        believes says why it failed. Nothing tells the planner to achieve the new goals before
        it, so planned together with the task it would fail again."""
        return anomaly is not None and anomaly.repeated_by(self.sem, result.plan, problem)

    def restates(
        self, goals: Sequence[Literal], anomaly: Anomaly | None, just_failed: frozenset[str]
    ) -> str:
        """The feedback for an answer whose goals are all of the goal that just failed, when
        its plan repeats the step that failed and nothing the robot believes says why (the
        failure would repeat); "" otherwise (the belief now explains it: replanning may work)."""
        names = frozenset(map(str, goals))
        if anomaly is None or not names or not names <= just_failed:
            return ""
        both = kept_goal(self.goal, self.stages.kept, list(goals), self.conflicts())
        result, problem = self.acting.plan(both)
        if not (result.solved and self.repeats(anomaly, result, problem)):
            return ""
        return (
            f"{' '.join(sorted(names))} restates the goal that just failed ({anomaly.step}: "
            f"{anomaly.reason}); planned again, the same step would fail the same way, since "
            "nothing the robot believes has changed; propose what must become true first"
        )


__all__ = ["NextGoal"]
