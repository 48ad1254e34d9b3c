"""The consultation: an anomaly goes to the reasoning method, and its goals come back checked.
A goal-writing method is asked through :func:`~llmpas.reasoning.methods.propose` with the
:class:`~llmpas.system.goal_checks.GoalChecker` inside its repair loop; a choosing method gets the
candidates enumerated now (:mod:`llmpas.system.candidates`), ranks them, and the best one the
checks accept is proposed, the rest kept for the same anomaly again."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from llmpas.language.logic import And, Atom, Formula
from llmpas.language.semantics import Semantics
from llmpas.planning.invariants import Invariants
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.choose import Ranked, chosen, nothing, rank
from llmpas.reasoning.goal_reading import Literal
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import MethodConfig, Proposal, method, propose
from llmpas.reasoning.prompts import situation
from llmpas.reasoning.tables import Vocabulary
from llmpas.system.achievable import Makeable, certified
from llmpas.system.acting import Acting
from llmpas.system.anomaly_memory import Anomaly, Tried
from llmpas.system.candidates import enumerate_goals, first_accepted
from llmpas.system.goal_checks import GoalChecker
from llmpas.system.search_memory import SearchMemory
from llmpas.system.substitution import Causes, substitutes
from llmpas.system.sweep import Sweep, SweepBudget, ordered


@dataclass
class Consultation:
    """The reasoning of one run. ``tried``: what was tried (the checks reject it again, the
    prompt's history says it); ``restated``: the feedback for an answer restating the goal that
    just failed ("" when it may be planned)."""

    acting: Acting
    sem: Semantics
    task: Formula
    memory: SearchMemory
    tried: Tried
    restated: Callable[[Sequence[Literal]], str]
    method: MethodConfig = field(default_factory=MethodConfig)
    assists: Assists = field(default_factory=Assists)
    success: str | None = None
    ranked_for: str = ""  # choosing methods: the anomaly the ranking was made for
    ranked: list[Ranked] = field(default_factory=list)  # that ranking
    ranking: list[Ranked] = field(default_factory=list)  # its candidates not proposed yet
    invariants: Invariants | None = None  # the domain's: goals that cannot hold together

    def __post_init__(self) -> None:
        s = self.acting.session
        self.causes = Causes.of(s.domain)
        self.makeable = Makeable(
            s.domain,
            lambda literal: self.acting.facts(And((literal,))),
            certified(s.problem(self.task, 0)),
        )
        self.check = GoalChecker(
            self.memory,
            lambda goal: self.acting.plan(goal)[0],
            self.acting.facts,
            self.sem,
            self.task,
            self.tried.rejected,
            self.assists,
            self.makeable,
            self.restated,
            self.contradiction if self.invariants is not None else None,
            lambda: len(self.acting.plans),
        )

    def contradiction(self, goals: Sequence[Literal]) -> str:
        """Why ``goals`` cannot hold together, by the domain's invariants ("" if they may)."""
        assert self.invariants is not None
        return self.invariants.contradiction(goals, self.acting.facts(And(tuple(goals))))

    def ask(self, anomaly: Anomaly, backend: LLM, asked: int) -> Proposal:
        """The method's proposal for ``anomaly`` (``asked``: consultations before this one)."""
        a = self.assists
        if method(self.method.method).chooser:
            return self.choose(anomaly, backend, asked)
        return propose(
            self.situation(anomaly),
            backend,
            self.acting.session.vocabulary,
            self.method,
            self.check if a.validation or a.search_rewrite else None,
            self.memory.exhausted() if a.grammar_pruning else (),
            prune=a.grammar_pruning,
        )

    def sweep(self, anomaly: Anomaly, proposal: Proposal, budget: SweepBudget) -> Sweep | None:
        """The places an object-loss consultation yields, in its order: the proposal's looks
        as written, then, for a choosing method, the looks of the rest of its ranking in rank
        order (None: not an object loss, or the proposal is not all looks)."""
        search = self.acting.session.search
        obj = anomaly.detected(search.detection)
        goals = list(proposal.goals)
        if not obj or not search.lost(obj) or not goals:
            return None
        if not all(self.memory.is_look(g) for g in goals):
            return None
        rest: list[Literal] = []
        if method(self.method.method).chooser:
            singles = [r.goals[0] for r in self.ranking if len(r.goals) == 1]
            rest = [g for g in singles if self.memory.is_look(g)]
        return Sweep(obj, ordered(goals, rest), budget)

    def situation(self, anomaly: Anomaly) -> Any:
        """The prompt's text for an anomaly, with what was tried before."""
        s = self.acting.session
        return situation(
            s.prompts,
            anomaly.text,
            s.environment(),
            s.task,
            self.tried.history(self.memory.history()),
            anomaly.constraint,
            self.success or "",
        )

    def choose(self, anomaly: Anomaly, backend: LLM, asked: int) -> Proposal:
        """A choosing method's proposal: for an anomaly ranked before, the next candidate of
        that ranking the checks still accept (no model asked); else the candidates enumerated
        now, ranked by the method's chooser, the best one the validator accepts proposed and the
        rest kept."""
        name = self.method.method
        key = anomaly.key
        if self.ranked_for == key and self.ranking:
            found = first_accepted(self.check, [r.goals for r in self.ranking])
            if found is not None:
                i, _ = found
                pick, self.ranking = self.ranking[i], self.ranking[i + 1 :]
                note = "the next candidate of the ranking made for this anomaly before"
                return chosen(name, pick, (), "", self.ranked, [note])
        t = time.perf_counter()
        cands = self.candidates(anomaly)
        self.acting.count("candidates", time.perf_counter() - t)
        if not cands:
            return nothing(name, "no candidate goal set is left (each already true or tried)")
        ranking, exchanges, first_look = rank(
            self.situation(anomaly), backend, cands, self.method, asked
        )
        t = time.perf_counter()
        found = first_accepted(self.check, [r.goals for r in ranking])
        self.acting.count("candidates", time.perf_counter() - t)
        if found is None:
            why = "no candidate goal set passed the checks (unreachable, already true or tried)"
            return nothing(name, why, ranking, exchanges, first_look)
        i, _ = found
        skipped = [f"skipped {r.text}: the checks rejected it" for r in ranking[:i]]
        self.ranked_for, self.ranked, self.ranking = key, ranking, list(ranking[i + 1 :])
        return chosen(name, ranking[i], exchanges, first_look, ranking, skipped)

    def candidates(self, anomaly: Anomaly) -> list[tuple[Literal, ...]]:
        """The goal sets a choosing method ranks for ``anomaly``."""
        vocab = self.acting.session.vocabulary
        search = self.acting.session.search
        anchors = anomaly.objects(vocab.objects)
        looks = []
        if any(search.lost(o) for o in anchors):
            places = vocab.predicates.get(search.predicate, ((),))[0]
            looks = [self.memory.look(p) for p in sorted(places)]
        return enumerate_goals(
            vocab,
            anchors,
            looks,
            self.makeable,
            lambda g: self.sem.holds(g, self.acting.facts(And((g,)))),
            self.tried.just_failed,
            self.memory.exhausted(),
            self.check.as_goal if self.assists.search_rewrite else lambda g: g,
            search.lost,
            self.conflicts(),
            self.substitutes(vocab),
        )

    def substitutes(self, vocab: Vocabulary) -> list[Atom]:
        """Candidates for a task literal a known cause blocks
        (:func:`~llmpas.system.substitution.substitutes`), among the vocabulary's objects."""
        facts = self.acting.facts(self.task)
        return substitutes(self.task, facts, self.causes, vocab.objects)

    def conflicts(self) -> Callable[[Literal, Literal], bool] | None:
        """Whether two literals cannot hold together (None: no invariants)."""
        if self.invariants is None:
            return None
        return self.invariants.conflicts(self.acting.facts(And(())))


__all__ = ["Consultation"]
