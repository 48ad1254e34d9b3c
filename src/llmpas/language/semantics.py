"""The meaning of a domain: formulas evaluated in a state, derived predicates, action effects.

This is an independent reading of PDDL semantics (it shares nothing with Fast Downward), used to
replay plans, to keep the executor's believed state, and to check goals.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field

from llmpas.language.domain import Action, Derived, Domain
from llmpas.language.errors import ModelError
from llmpas.language.logic import (
    And,
    Atom,
    EffectItem,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    FuncTerm,
    Imply,
    Increase,
    Not,
    Or,
    Param,
    Substitution,
    When,
    atoms_of,
    is_var,
)

Env = dict[str, str]


def nnf(f: Formula, neg: bool = False) -> Formula:
    """Negation normal form: ``not`` only in front of atoms."""
    match f:
        case Atom():
            return Not(f) if neg else f
        case Not(arg):
            return nnf(arg, not neg)
        case And(parts):
            sub = tuple(nnf(p, neg) for p in parts)
            return Or(sub) if neg else And(sub)
        case Or(parts):
            sub = tuple(nnf(p, neg) for p in parts)
            return And(sub) if neg else Or(sub)
        case Imply(c, t):
            return nnf(Or((Not(c), t)), neg)
        case Exists(ps, body):
            return Forall(ps, nnf(body, True)) if neg else Exists(ps, nnf(body))
        case Forall(ps, body):
            return Exists(ps, nnf(body, True)) if neg else Forall(ps, nnf(body))
    raise TypeError(f"not a formula: {f!r}")


@dataclass
class Universe:
    """Objects by type, for quantifiers and unbound variables under negation."""

    domain: Domain
    object_types: Mapping[str, str]

    def __post_init__(self) -> None:
        self._by_type: dict[str, list[str]] = defaultdict(list)
        for o, t in self.object_types.items():
            for st in self.domain.supertypes(t):
                self._by_type[st].append(o)
        for ls in self._by_type.values():
            ls.sort()

    def of_type(self, t: str) -> list[str]:
        return self._by_type.get(t, [])


class State:
    """A set of atoms with a per-predicate index; derived atoms are computed on demand."""

    def __init__(self, facts: Iterable[Atom]) -> None:
        self.facts = frozenset(facts)
        self.index: dict[str, list[Atom]] = defaultdict(list)
        for a in self.facts:
            self.index[a.predicate].append(a)

    def __contains__(self, a: Atom) -> bool:
        return a in self.facts


class Evaluator:
    """Finds the bindings that make a formula true in a state (a small join engine)."""

    def __init__(self, universe: Universe, state: State) -> None:
        self.u = universe
        self.s = state

    def holds(self, f: Formula, env: Env | None = None) -> bool:
        return next(self.solve(nnf(f), dict(env or {}), {}), None) is not None

    def solve(self, f: Formula, env: Env, types: dict[str, str]) -> Iterator[Env]:
        match f:
            case Atom():
                yield from self._atom(f, env, types)
            case Not(Atom() as a):
                for e in self._bind_all(a.args, env, types):
                    if not self._atom_true(a, e):
                        yield e
            case And(parts):
                yield from self._conj(_order(parts), env, types)
            case Or(parts):
                for p in parts:
                    yield from self.solve(p, env, types)
            case Exists(ps, body):
                bound = {p.name for p in ps}
                inner = {k: v for k, v in env.items() if k not in bound}
                seen: set[tuple[tuple[str, str], ...]] = set()
                qtypes = {**types, **{p.name: p.type for p in ps}}
                for solved in self.solve(body, inner, qtypes):
                    # a quantified variable the body left unbound still ranges over its type:
                    # over an empty type there is no witness
                    e = next(self._bind_all(tuple(bound), solved, qtypes), None)
                    if e is None:
                        continue
                    out = {k: v for k, v in e.items() if k not in bound}
                    out.update({k: v for k, v in env.items() if k in bound})
                    key = tuple(sorted(out.items()))
                    if key not in seen:
                        seen.add(key)
                        yield out
            case Forall(ps, body):
                free = _free_vars(f) - env.keys()
                for e in self._bind_all(tuple(free), env, types):
                    neg = Exists(ps, nnf(body, True))
                    if next(self.solve(neg, e, types), None) is None:
                        yield e
            case _:
                raise TypeError(f"formula not in negation normal form: {f}")

    def _conj(self, parts: tuple[Formula, ...], env: Env, types: dict[str, str]) -> Iterator[Env]:
        if not parts:
            yield env
            return
        for e in self.solve(parts[0], env, types):
            yield from self._conj(parts[1:], e, types)

    def _atom_true(self, a: Atom, env: Env) -> bool:
        args = tuple(env.get(t, t) for t in a.args)
        if a.predicate == "=":
            return args[0] == args[1]
        return Atom(a.predicate, args) in self.s

    def _atom(self, a: Atom, env: Env, types: dict[str, str]) -> Iterator[Env]:
        if a.predicate == "=":
            for e in self._bind_all(a.args, env, types):
                if self._atom_true(a, e):
                    yield e
            return
        for fact in self.s.index.get(a.predicate, ()):
            m = _match(a.args, fact.args, env)
            if m is not None and self._typed_ok(m, a.args, types):
                yield m

    def _typed_ok(self, env: Env, terms: tuple[str, ...], types: dict[str, str]) -> bool:
        for t in terms:
            ty = types.get(t)
            if ty and ty != "object" and env[t] not in self.u.of_type(ty):
                return False
        return True

    def _bind_all(self, terms: tuple[str, ...], env: Env, types: dict[str, str]) -> Iterator[Env]:
        unbound = sorted({t for t in terms if is_var(t) and t not in env})
        if not unbound:
            yield env
            return
        v, rest = unbound[0], unbound[1:]
        for o in self.u.of_type(types.get(v, "object")):
            yield from self._bind_all(tuple(rest), {**env, v: o}, types)


def _match(pattern: tuple[str, ...], values: tuple[str, ...], env: Env) -> Env | None:
    if len(pattern) != len(values):
        return None
    out = dict(env)
    for p, v in zip(pattern, values, strict=True):
        if is_var(p):
            if out.setdefault(p, v) != v:
                return None
        elif p != v:
            return None
    return out


def _order(parts: tuple[Formula, ...]) -> tuple[Formula, ...]:
    """Positive atoms first so they bind variables before negations and quantifiers."""

    def rank(p: Formula) -> int:
        if isinstance(p, Atom) and p.predicate != "=":
            return 0
        if isinstance(p, And | Or | Exists):
            return 1
        return 2

    return tuple(sorted(parts, key=rank))


def _free_vars(f: Formula) -> set[str]:
    match f:
        case Atom(_, args):
            return {t for t in args if is_var(t)}
        case Not(arg):
            return _free_vars(arg)
        case And(parts) | Or(parts):
            return set().union(*(_free_vars(p) for p in parts)) if parts else set()
        case Imply(c, t):
            return _free_vars(c) | _free_vars(t)
        case Exists(ps, body) | Forall(ps, body):
            return _free_vars(body) - {p.name for p in ps}
    return set()


# ------------------------------------------------------------------------- derived predicates


def _strata(derived: tuple[Derived, ...]) -> list[list[Derived]]:
    names = {d.head.name for d in derived}
    level = dict.fromkeys(names, 0)
    for _ in range(len(names) + 1):
        changed = False
        for d in derived:
            for neg, a in _polarity_atoms(nnf(d.body)):
                if a.predicate in names:
                    need = level[a.predicate] + (1 if neg else 0)
                    if level[d.head.name] < need:
                        level[d.head.name] = need
                        changed = True
        if not changed:
            break
    else:
        raise ModelError("derived predicates depend on their own negation (not stratifiable)")
    out: list[list[Derived]] = [[] for _ in range(max(level.values(), default=0) + 1)]
    for d in derived:
        out[level[d.head.name]].append(d)
    return out


def _polarity_atoms(f: Formula) -> Iterator[tuple[bool, Atom]]:
    match f:
        case Atom():
            yield False, f
        case Not(Atom() as a):
            yield True, a
        case And(parts) | Or(parts):
            for p in parts:
                yield from _polarity_atoms(p)
        case Exists(_, b) | Forall(_, b):
            yield from _polarity_atoms(b)
            if isinstance(f, Forall):  # forall = not exists not: its atoms count as negative too
                for _, a in _polarity_atoms(b):
                    yield True, a


@dataclass
class Semantics:
    """Evaluates a domain over a fixed universe of objects."""

    domain: Domain
    object_types: Mapping[str, str]
    costs: Mapping[FuncTerm, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        types = dict(self.object_types)
        for c in self.domain.constants:
            types.setdefault(c.name, c.type)
        self.universe = Universe(self.domain, types)
        self._strata = _strata(self.domain.derived)

    def closure(self, facts: Iterable[Atom]) -> State:
        """The state with every derived atom added (stratified fixpoint)."""
        derived_names = self.domain.derived_names
        base = {a for a in facts if a.predicate not in derived_names}
        for stratum in self._strata:
            while True:
                state = State(base)
                ev = Evaluator(self.universe, state)
                new = set()
                for d in stratum:
                    head_vars = tuple(p.name for p in d.head.params)
                    types = {p.name: p.type for p in d.head.params}
                    for e in ev.solve(And((nnf(d.body),)), {}, types):
                        for full in ev._bind_all(head_vars, e, types):
                            new.add(Atom(d.head.name, tuple(full[v] for v in head_vars)))
                if new <= base:
                    break
                base |= new
        return State(base)

    def holds(self, f: Formula, facts: Iterable[Atom] | State) -> bool:
        state = facts if isinstance(facts, State) else self.closure(facts)
        return Evaluator(self.universe, state).holds(f)

    def applicable(self, action: Action, args: tuple[str, ...], state: State) -> bool:
        env = self._env(action, args)
        return Evaluator(self.universe, state).holds(action.precondition, env)

    def _env(self, action: Action, args: tuple[str, ...]) -> Env:
        if len(args) != len(action.params):
            raise ModelError(
                f"action {action.name!r} takes {len(action.params)} arguments, given {len(args)}"
            )
        for p, a in zip(action.params, args, strict=True):
            if p.type != "object" and a not in self.universe.of_type(p.type):
                raise ModelError(f"action {action.name!r}: {a!r} is not of type {p.type!r}")
        return {p.name: a for p, a in zip(action.params, args, strict=True)}

    def apply(self, action: Action, args: tuple[str, ...], state: State) -> tuple[set[Atom], float]:
        """Successor base facts (derived atoms dropped) and the cost of the step."""
        env = self._env(action, args)
        adds: set[Atom] = set()
        dels: set[Atom] = set()
        cost = self._effects(action.effects, env, state, adds, dels)
        derived = self.domain.derived_names
        base = {a for a in state.facts if a.predicate not in derived}
        return (base - dels) | adds, (cost if self.domain.uses_costs() else 1.0)

    def _effects(
        self,
        effects: tuple[EffectItem, ...],
        env: Env,
        state: State,
        adds: set[Atom],
        dels: set[Atom],
    ) -> float:
        sub = Substitution(env)
        cost = 0.0
        ev = Evaluator(self.universe, state)
        for e in effects:
            match e:
                case Atom():
                    adds.add(sub.atom(e))
                case Not(Atom() as a):
                    dels.add(sub.atom(a))
                case When(cond, effs):
                    if ev.holds(cond, env):
                        cost += self._effects(effs, env, state, adds, dels)
                case ForallEffect(ps, effs):
                    for full in ev._bind_all(
                        tuple(p.name for p in ps), env, {p.name: p.type for p in ps}
                    ):
                        cost += self._effects(effs, full, state, adds, dels)
                case Increase(amount):
                    cost += self._amount(amount, sub)
        return cost

    def _amount(self, amount: float | FuncTerm, sub: Substitution) -> float:
        if not isinstance(amount, FuncTerm):
            return float(amount)
        term = FuncTerm(amount.name, tuple(sub.term(t) for t in amount.args))
        if term not in self.costs:
            raise ModelError(f"no value for cost function {term}")
        return self.costs[term]


@dataclass(frozen=True)
class Replay:
    """The outcome of replaying a plan step by step against the domain semantics."""

    valid: bool
    message: str
    cost: float
    states: tuple[frozenset[Atom], ...]
    failed_step: int | None = None


def replay(
    sem: Semantics,
    init: Iterable[Atom],
    steps: Iterable[tuple[str, tuple[str, ...]]],
    goal: Formula | None = None,
) -> Replay:
    """Check every precondition, apply every effect, and (optionally) check the goal at the end."""
    facts = set(init)
    states = [frozenset(facts)]
    total = 0.0
    for i, (name, args) in enumerate(steps):
        state = sem.closure(facts)
        try:
            action = sem.domain.action(name)
            ok = sem.applicable(action, args, state)
        except ModelError as e:
            return Replay(False, f"step {i + 1}: {e}", total, tuple(states), i)
        if not ok:
            msg = f"step {i + 1}: precondition of ({name} {' '.join(args)}) does not hold"
            return Replay(False, msg, total, tuple(states), i)
        facts, c = sem.apply(action, args, state)
        total += c
        states.append(frozenset(facts))
    if goal is not None and not sem.holds(goal, facts):
        return Replay(False, "the goal does not hold after the last step", total, tuple(states))
    return Replay(True, "ok", total, tuple(states))


def ground_atoms(f: Formula) -> Iterator[Atom]:
    """Atoms of ``f`` that mention no variable."""
    return (a for a in atoms_of(f) if not any(is_var(t) for t in a.args))


__all__ = ["Evaluator", "Param", "Replay", "Semantics", "State", "nnf", "replay"]
