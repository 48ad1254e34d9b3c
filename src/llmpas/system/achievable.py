"""Which goal literals some action of the domain can make true (:class:`Makeable`).

A vocabulary lists a predicate with the objects each argument may name, so it offers literals
no action ever makes true: ``(scanned sink)`` where every scanning action asks for a table, a
drawer, a cover or a container to look into. Such a goal costs an answer and a planner call to
reject. The test here reads only the domain's action schemas and the facts the planner would
plan the literal from:

- an atom of a basic predicate is makeable when some action adds it, with every *static*
  precondition of that action (a predicate no action changes, no rule derives and no stream
  certifies: a type such as ``(Surface ?r)``) that names only the literal's arguments true in
  those facts; a negated atom likewise when some action deletes it;
- a derived atom (or its negation) is makeable when some basic predicate of its rule can change
  (the rule is not read further: a conservative answer, never a wrong rejection);
- a literal already true is not judged here (the already-true check says so).

It knows no world: a domain, the stream predicates and a function from a literal to the facts
its problem starts from.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Set
from dataclasses import dataclass, field

from llmpas.language.domain import Action, Domain
from llmpas.language.logic import Atom, Not, atoms_of, conjuncts, effect_atoms, is_var
from llmpas.language.problem import Problem
from llmpas.reasoning.goal_reading import Literal


def changed(domain: Domain) -> frozenset[str]:
    """The predicates some action adds or deletes."""
    return frozenset(a.predicate for act in domain.actions for _, a in effect_atoms(act.effects))


@dataclass
class Makeable:
    """``makeable(literal)``: whether some action can make ``literal`` true (memoised: the
    domain's types do not change within a run).

    ``facts``: the facts a problem for that literal alone starts from (problem construction may
    add facts a goal asks for); ``certified``: the predicates streams certify (never static)."""

    domain: Domain
    facts: Callable[[Literal], Set[Atom]]
    certified: Iterable[str] = ()
    memo: dict[Literal, bool] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.fluent = changed(self.domain)
        self.derived = {d.head.name.lower(): d for d in self.domain.derived}
        self.static = (
            {p.lower() for p in self.domain.predicates}
            - self.fluent
            - set(self.derived)
            - {p.lower() for p in self.certified}
        )

    def __call__(self, literal: Literal) -> bool:
        if literal not in self.memo:
            self.memo[literal] = self.judge(literal)
        return self.memo[literal]

    def judge(self, literal: Literal) -> bool:
        positive = not isinstance(literal, Not)
        atom = literal.arg if isinstance(literal, Not) else literal
        if not isinstance(atom, Atom):
            return True
        if atom.predicate in self.derived:
            return self.derived_changes(atom.predicate, set())
        if atom.predicate not in self.fluent:
            return atom.predicate not in self.static  # a static literal never changes
        facts: Set[Atom] | None = None
        for action in self.domain.actions:
            for adds, effect in effect_atoms(action.effects):
                if adds != positive or effect.predicate != atom.predicate:
                    continue
                binding = bind(effect, atom)
                if binding is None:
                    continue
                if facts is None:
                    facts = self.facts(literal)
                if self.statics_hold(action, binding, facts):
                    return True
        return False

    def derived_changes(self, predicate: str, seen: set[str]) -> bool:
        """Some basic predicate of the rule (or of a rule it uses) can change."""
        if predicate in seen:
            return False
        seen.add(predicate)
        for a in atoms_of(self.derived[predicate].body):
            if a.predicate in self.fluent:
                return True
            if a.predicate in self.derived and self.derived_changes(a.predicate, seen):
                return True
        return False

    def statics_hold(self, action: Action, binding: dict[str, str], facts: Set[Atom]) -> bool:
        """Every positive static precondition atom whose arguments the binding names holds."""
        for c in conjuncts(action.precondition):
            if not isinstance(c, Atom) or c.predicate not in self.static:
                continue
            args = tuple(binding.get(t, "") if is_var(t) else t for t in c.args)
            if all(args) and Atom(c.predicate, args) not in facts:
                return False
        return True


def certified(problem: Problem) -> frozenset[str]:
    """The predicates the problem's streams certify."""
    return frozenset(a.predicate.lower() for st in problem.streams.streams for a in st.certified)


def bind(schema: Atom, ground: Atom) -> dict[str, str] | None:
    """The variables of ``schema`` bound to ``ground``'s arguments (None: they do not match)."""
    if len(schema.args) != len(ground.args):
        return None
    out: dict[str, str] = {}
    for t, value in zip(schema.args, ground.args, strict=True):
        if is_var(t):
            if out.setdefault(t, value) != value:
                return None
        elif t.lower() != value:
            return None
    return out


__all__ = ["Makeable", "bind", "certified", "changed"]
