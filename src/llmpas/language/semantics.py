"""The meaning of a domain: formulas evaluated in a state, derived predicates, action effects.

This is an independent reading of PDDL semantics (it shares nothing with Fast Downward), used to
replay plans, to keep the executor's believed state, and to check goals.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from operator import attrgetter

from llmpas.language.domain import Action, Derived, Domain
from llmpas.language.language_errors import ModelError
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


_args = attrgetter("args")


class State:
    """A set of atoms with a per-predicate index; derived atoms are computed on demand."""

    def __init__(self, facts: Iterable[Atom]) -> None:
        self._facts: frozenset[Atom] | None = frozenset(facts)
        self._groups: dict[str, list[Atom]] = defaultdict(list)
        for a in self._facts:
            self._groups[a.predicate].append(a)
        self._sorted: set[str] = set()
        self._by_arg: dict[tuple[str, int], dict[str, list[Atom]]] = {}
        self._sets: dict[str, frozenset[Atom]] = {}

    @property
    def facts(self) -> frozenset[Atom]:
        if self._facts is None:  # a successor's: gathered on first use
            self._facts = frozenset(a for group in self._groups.values() for a in group)
        return self._facts

    def successor(self, adds: set[Atom], dels: set[Atom]) -> State:
        """The state ``(self - dels) | adds``, sharing the atoms of the predicates neither
        touches (and their indexes) with this one: a step of a plan costs what it changes,
        not the size of the state."""
        touched = {a.predicate for a in adds} | {a.predicate for a in dels}
        child = State.__new__(State)
        child._facts = None
        child._groups = defaultdict(list, self._groups)
        for p in touched:
            old = self._groups.get(p, [])
            kept = [a for a in old if a not in dels or a in adds]
            have = self._members(p)
            kept += sorted((a for a in adds if a.predicate == p and a not in have), key=_args)
            if kept:
                child._groups[p] = kept
            else:
                child._groups.pop(p, None)
        child._sorted = self._sorted - touched
        child._by_arg = {k: v for k, v in self._by_arg.items() if k[0] not in touched}
        child._sets = {k: v for k, v in self._sets.items() if k not in touched}
        return child

    def _members(self, predicate: str) -> frozenset[Atom]:
        members = self._sets.get(predicate)
        if members is None:
            members = self._sets[predicate] = frozenset(self._groups.get(predicate, ()))
        return members

    def atoms(self, predicate: str) -> list[Atom]:
        """The state's atoms of ``predicate``, sorted by arguments (on first use: joins
        enumerate them, so the order of bindings, and so of optimistic instances, witnesses and
        plans, does not depend on the string hash seed). Do not modify the list."""
        group = self._groups.get(predicate)
        if group is None:
            return []
        if predicate not in self._sorted:
            group.sort(key=_args)
            self._sorted.add(predicate)
        return group

    def atoms_with(self, predicate: str, position: int, value: str) -> list[Atom]:
        """The state's atoms of ``predicate`` with ``value`` at ``position`` (sorted, as
        :meth:`atoms`); the index is built on first use."""
        key = (predicate, position)
        index = self._by_arg.get(key)
        if index is None:
            index = defaultdict(list)
            for a in self.atoms(predicate):
                if position < len(a.args):
                    index[a.args[position]].append(a)
            self._by_arg[key] = index
        return index.get(value, [])

    def count(self, predicate: str) -> int:
        group = self._groups.get(predicate)
        return 0 if group is None else len(group)

    def __contains__(self, a: Atom) -> bool:
        if self._facts is not None:
            return a in self._facts
        return a in self._members(a.predicate)


class Evaluator:
    """Finds the bindings that make a formula true in a state (a small join engine).

    With ``rules`` (non-recursive derived predicates), derived atoms are evaluated top-down on
    demand and memoised, instead of computing every derived atom of the state first.
    """

    def __init__(
        self,
        universe: Universe,
        state: State,
        rules: Mapping[str, list[Derived]] | None = None,
    ) -> None:
        self.u = universe
        self.s = state
        self.rules = rules or {}
        self._memo: dict[Atom, bool] = {}
        self._fv: dict[int, tuple[Formula, frozenset[str]]] = {}

    def _free(self, f: Formula) -> frozenset[str]:
        """Free variables of ``f``, cached by identity (the formula is kept alive with it)."""
        hit = self._fv.get(id(f))
        if hit is None or hit[0] is not f:
            hit = (f, frozenset(_free_vars(f)))
            self._fv[id(f)] = hit
        return hit[1]

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
                yield from self._conj(parts, env, types)
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
                    witness = next(iter(self._bind_all(tuple(bound), solved, qtypes)), None)
                    if witness is None:
                        continue
                    out = {k: v for k, v in witness.items() if k not in bound}
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
        """Join the conjuncts, always taking next the one that is cheapest given ``env``."""
        if not parts:
            yield env
            return
        k = min(range(len(parts)), key=lambda i: self._cost(parts[i], env))
        rest = parts[:k] + parts[k + 1 :]
        for e in self.solve(parts[k], env, types):
            yield from self._conj(rest, e, types)

    def _cost(self, f: Formula, env: Env) -> float:
        unbound = sum(1 for v in self._free(f) if v not in env)
        if isinstance(f, Atom) and f.predicate != "=" and f.predicate not in self.rules:
            n = self.s.count(f.predicate)
            return n / (8.0 ** (len(f.args) - unbound)) if unbound else 0.0
        if not unbound:
            return 0.5  # a test of bound values
        if isinstance(f, Atom):
            return 1e6 if f.predicate in self.rules else 1e9  # derived, or '=' needing a binding
        return 1e9 if isinstance(f, Not | Forall) else 1e7

    def _atom_true(self, a: Atom, env: Env) -> bool:
        args = tuple(env.get(t, t) for t in a.args)
        if a.predicate == "=":
            return args[0] == args[1]
        ground = Atom(a.predicate, args)
        if a.predicate in self.rules:
            return self._derived_true(ground)
        return ground in self.s

    def _derived_true(self, ground: Atom) -> bool:
        if ground not in self._memo:
            self._memo[ground] = False  # guards recursion (the caller excludes recursive rules)
            self._memo[ground] = next(self._derived(ground, {}, {}), None) is not None
        return self._memo[ground]

    def _derived(self, a: Atom, env: Env, types: dict[str, str]) -> Iterator[Env]:
        """Bindings of ``a``'s variables that make the derived atom true, from its rules."""
        seen: set[tuple[tuple[str, str], ...]] = set()
        for rule in self.rules[a.predicate]:
            heads = tuple(p.name for p in rule.head.params)
            htypes = {p.name: p.type for p in rule.head.params}
            inner = {
                h: env.get(t, t)
                for h, t in zip(heads, a.args, strict=True)
                if not is_var(env.get(t, t))
            }
            for e in self.solve(rule.body, inner, htypes):  # rules come in NNF
                for full in self._bind_all(heads, e, htypes):
                    out = _match(a.args, tuple(full[h] for h in heads), env)
                    if out is None:
                        continue
                    key = tuple(sorted(out.items()))
                    if key not in seen:
                        seen.add(key)
                        yield out

    def _atom(self, a: Atom, env: Env, types: dict[str, str]) -> Iterator[Env]:
        if a.predicate == "=":
            for e in self._bind_all(a.args, env, types):
                if self._atom_true(a, e):
                    yield e
            return
        if a.predicate in self.rules:
            for m in self._derived(a, env, types):
                if self._typed_ok(m, a.args, types):
                    yield m
            return
        bound = [(k, env.get(t, t)) for k, t in enumerate(a.args)]
        bound = [(k, v) for k, v in bound if not is_var(v)]
        if len(bound) == len(a.args):  # ground: a lookup
            ground = Atom(a.predicate, tuple(v for _, v in bound))
            if ground in self.s and self._typed_ok(env, a.args, types):
                yield dict(env)
            return
        candidates = (
            self.s.atoms_with(a.predicate, *bound[0]) if bound else self.s.atoms(a.predicate)
        )
        for fact in candidates:
            found = _match(a.args, fact.args, env)
            if found is not None and self._typed_ok(found, a.args, types):
                yield found

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


def _recursive(derived: tuple[Derived, ...]) -> bool:
    """Whether some derived predicate depends on itself (then the closure is computed)."""
    names = {d.head.name for d in derived}
    deps: dict[str, set[str]] = defaultdict(set)
    for d in derived:
        deps[d.head.name] |= {a.predicate for a in atoms_of(d.body)} & names
    for start in names:
        stack, seen = list(deps[start]), set()
        while stack:
            n = stack.pop()
            if n == start:
                return True
            if n not in seen:
                seen.add(n)
                stack.extend(deps[n])
    return False


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
    strict_costs: bool = True  # False: a cost term without a value counts 0 (for belief updates)

    def __post_init__(self) -> None:
        types = dict(self.object_types)
        for c in self.domain.constants:
            types.setdefault(c.name, c.type)
        self.universe = Universe(self.domain, types)
        self._strata = _strata(self.domain.derived)
        self._rules: dict[str, list[Derived]] = {}
        if not _recursive(self.domain.derived):
            for d in self.domain.derived:
                self._rules.setdefault(d.head.name, []).append(Derived(d.head, nnf(d.body)))

    def state(self, facts: Iterable[Atom]) -> State:
        """A state to evaluate formulas in: derived atoms on demand when the derived predicates
        are not recursive, else the full closure."""
        if self._rules or not self.domain.derived:
            derived = self.domain.derived_names
            return State(a for a in facts if a.predicate not in derived)
        return self.closure(facts)

    def evaluator(self, state: State) -> Evaluator:
        return Evaluator(self.universe, state, self._rules)

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
        state = facts if isinstance(facts, State) else self.state(facts)
        return self.evaluator(state).holds(f)

    def applicable(self, action: Action, args: tuple[str, ...], state: State) -> bool:
        env = self._env(action, args)
        return self.evaluator(state).holds(action.precondition, env)

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

    def successor(self, action: Action, args: tuple[str, ...], state: State) -> State:
        """The state after the step (as :meth:`apply`), built from ``state`` by what the step
        adds and deletes when derived atoms are computed on demand."""
        if not (self._rules or not self.domain.derived):  # a full closure: computed again
            return self.state(self.apply(action, args, state)[0])
        adds: set[Atom] = set()
        dels: set[Atom] = set()
        self._effects(action.effects, self._env(action, args), state, adds, dels)
        return state.successor(adds, dels)

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
        ev = self.evaluator(state)
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
            if not self.strict_costs:
                return 0.0
            raise ModelError(f"no value for cost function {term}")
        return self.costs[term]


class Support:
    """Which base facts make a formula true in a state: a witness, through derived predicates.

    For a plan, the union over its steps is the plan's *preimage*: the facts it relies on (what a
    stream-based planner must actually produce). Negative literals contribute no facts.
    """

    def __init__(self, sem: Semantics, state: State) -> None:
        self.sem = sem
        self.ev = sem.evaluator(state)
        self.rules: dict[str, list[Derived]] = defaultdict(list)
        for d in sem.domain.derived:
            self.rules[d.head.name].append(d)
        self._memo: dict[Atom, frozenset[Atom]] = {}

    def of(self, f: Formula, env: Env | None = None) -> frozenset[Atom] | None:
        """The supporting base facts, or None when ``f`` is false."""
        g = nnf(f)
        e = next(self.ev.solve(g, dict(env or {}), {}), None)
        return None if e is None else self._facts(g, e)

    def _facts(self, f: Formula, env: Env) -> frozenset[Atom]:
        match f:
            case Atom():
                if f.predicate == "=":
                    return frozenset()
                return self._atom(Substitution(env).atom(f))
            case Not():
                return frozenset()
            case And(parts):
                out: frozenset[Atom] = frozenset()
                for p in parts:
                    out |= self._facts(p, env)
                return out
            case Or(parts):
                for p in parts:
                    got = self.of(p, env)
                    if got is not None:
                        return got
            case Exists():
                got = self.of(f.body, {k: v for k, v in env.items() if k not in _names(f.params)})
                return got or frozenset()
            case Forall(ps, body):
                vs = tuple(p.name for p in ps)
                types = {p.name: p.type for p in ps}
                acc: frozenset[Atom] = frozenset()
                for full in self._relevant(
                    body, vs, {k: v for k, v in env.items() if k not in vs}, types
                ):
                    acc |= self.of(body, full) or frozenset()
                return acc
        return frozenset()

    def _relevant(
        self, body: Formula, vs: tuple[str, ...], env: Env, types: dict[str, str]
    ) -> Iterator[Env]:
        """Bindings of ``vs`` whose instance of ``body`` needs support: where one of its negated
        atom disjuncts holds (an implication's false antecedent), the empty witness will do; so
        only bindings that make every such atom true are enumerated, as a join, not over every
        tuple of objects."""
        guards = tuple(_negated_disjuncts(body))
        if not guards:
            yield from self.ev._bind_all(vs, env, types)
            return
        for e in self.ev.solve(And(guards), env, types):
            yield from self.ev._bind_all(vs, e, types)

    def _atom(self, a: Atom) -> frozenset[Atom]:
        if a.predicate not in self.rules:
            return frozenset((a,))
        if a in self._memo:
            return self._memo[a]
        self._memo[a] = frozenset()  # guards recursive rules
        for rule in self.rules[a.predicate]:
            env = dict(zip((p.name for p in rule.head.params), a.args, strict=True))
            got = self.of(rule.body, env)
            if got is not None:
                self._memo[a] = got
                break
        return self._memo[a]


def _negated_disjuncts(f: Formula) -> Iterator[Atom]:
    """Atoms ``a`` such that ``(not a)`` is a disjunct of ``f`` (in negation normal form)."""
    match f:
        case Not(Atom() as a):
            yield a
        case Or(parts):
            for p in parts:
                yield from _negated_disjuncts(p)


def _names(params: Iterable[Param]) -> set[str]:
    return {p.name for p in params}


def preimage(
    sem: Semantics,
    init: Iterable[Atom],
    steps: Iterable[tuple[str, tuple[str, ...]]],
    goal: Formula | None = None,
) -> list[frozenset[Atom]] | None:
    """For each step (and the goal, last), the facts it relies on; None if the plan is invalid."""
    state = sem.state(init)
    out: list[frozenset[Atom]] = []
    for name, args in steps:
        action = sem.domain.action(name)
        got = Support(sem, state).of(action.precondition, sem._env(action, args))
        if got is None:
            return None
        out.append(got)
        state = sem.successor(action, args, state)
    if goal is not None:
        got = Support(sem, state).of(goal)
        if got is None:
            return None
        out.append(got)
    return out


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
    implied: Callable[[set[Atom]], set[Atom]] | None = None,
) -> Replay:
    """Check every precondition, apply every effect, and (optionally) check the goal at the end.

    ``implied``: facts a state implies beyond its own (a stream's facts recomputed in each state,
    say): seen by preconditions and the goal, never kept in the states."""
    facts = set(init)
    states = [frozenset(facts)]
    total = 0.0
    for i, (name, args) in enumerate(steps):
        extra = implied(facts) - facts if implied else set()
        state = sem.state(facts | extra)
        try:
            action = sem.domain.action(name)
            ok = sem.applicable(action, args, state)
        except ModelError as e:
            return Replay(False, f"step {i + 1}: {e}", total, tuple(states), i)
        if not ok:
            msg = f"step {i + 1}: precondition of ({name} {' '.join(args)}) does not hold"
            return Replay(False, msg, total, tuple(states), i)
        new, c = sem.apply(action, args, state)
        facts = set(new) - extra
        total += c
        states.append(frozenset(facts))
    final = facts | implied(facts) if implied else facts
    if goal is not None and not sem.holds(goal, final):
        return Replay(False, "the goal does not hold after the last step", total, tuple(states))
    return Replay(True, "ok", total, tuple(states))


def ground_atoms(f: Formula) -> Iterator[Atom]:
    """Atoms of ``f`` that mention no variable."""
    return (a for a in atoms_of(f) if not any(is_var(t) for t in a.args))


__all__ = ["Evaluator", "Replay", "Semantics", "State", "Support", "nnf", "preimage", "replay"]
