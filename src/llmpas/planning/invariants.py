"""What a domain says can never hold together, read from the domain itself: a goal whose
literals no reachable state satisfies together is refused before any planner call, in
microseconds, with the reason (:meth:`Invariants.contradiction`).

**Where the invariants come from.** Fast Downward's translator finds them from the action
schemas (its invariant synthesis, bounded by its candidate count): groups of atoms of which at
most one holds in any state, for each binding of the group's parameters. In the household
domain it finds that an object is at one pose or in one grasp: ``{AtPose(o, *), AtGrasp(o, *)}``
for each ``o``. The translator uses them for fluent atoms only; a goal on a *derived* predicate
(``On(o, r)`` is ``exists p: Supported(o, p, r) and AtPose(o, p)``) is an axiom to it, and two
``On`` atoms of one object are separate variables. So the check carries the groups through the
derived predicates' definitions: two ground literals conflict when their definitions need two
distinct atoms of one group with the same parameters.

**When two existential witnesses are distinct.** ``On(o, r1)`` and ``On(o, r2)`` need
``AtPose(o, p1)`` and ``AtPose(o, p2)``: distinct atoms unless ``p1 = p2``, which would need
``Supported(o, p, r1)`` and ``Supported(o, p, r2)``. A static predicate (no action changes it)
is *functional* in one position when no two of the planner's facts agree on every other
position and differ there, and every stream that certifies it has one of its outputs at another
position (each stream output is a new object, so a new fact never shares its key with
another). The same reasoning holds for any domain and stream file: nothing here names a
predicate.

**Open/closed pairs** are a literal and its negation (always refused), and capacities written
with counting (``Full``) are left to the planner.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence, Set
from dataclasses import dataclass, field
from pathlib import Path

from llmpas.language.domain import Domain
from llmpas.language.logic import And, Atom, Exists, Formula, Not, Substitution, effect_atoms
from llmpas.language.streams import StreamSpec

COUNTED = -1  # the counted position of an invariant part (any value there)
_MAX_DEPTH = 3  # derived predicates expanded through at most this many definitions
_CANDIDATES = 100_000  # the translator's own bound on invariant candidates (a count)

Literal = Atom | Not


@dataclass(frozen=True, order=True)
class Part:
    """One predicate of a group: ``args[i]`` is the group's parameter at position ``i``
    (:data:`COUNTED` at the position that may take any value)."""

    predicate: str
    args: tuple[int, ...]

    def binding(self, atom: Atom) -> tuple[str, ...] | None:
        """The group's parameters as ``atom`` binds them (None: not an atom of this part)."""
        if atom.predicate != self.predicate or len(atom.args) != len(self.args):
            return None
        bound: dict[int, str] = {}
        for value, param in zip(atom.args, self.args, strict=True):
            if param != COUNTED and bound.setdefault(param, value) != value:
                return None
        return tuple(bound[k] for k in sorted(bound))

    def render(self, key: tuple[str, ...] = ()) -> str:
        """The part with the parameters ``key`` gives (``?i`` where none), ``*`` counted."""
        names = ["*" if p == COUNTED else key[p] if p < len(key) else f"?{p}" for p in self.args]
        return "(" + " ".join((self.predicate, *names)) + ")"


@dataclass(frozen=True)
class Group:
    """At most one atom of these parts holds, for each binding of the parameters."""

    parts: tuple[Part, ...]

    def bindings(self, atom: Atom) -> Iterator[tuple[str, ...]]:
        for part in self.parts:
            got = part.binding(atom)
            if got is not None:
                yield got

    def render(self, key: tuple[str, ...] = ()) -> str:
        return ", ".join(p.render(key) for p in self.parts)


@dataclass(frozen=True)
class Invariants:
    """The groups of a domain (:meth:`of`) and what the conflict check reads from the domain:
    the derived predicates' definitions, the static predicates and the streams' outputs."""

    groups: tuple[Group, ...]
    domain: Domain
    streams: StreamSpec | None = None
    derived: Mapping[str, tuple[tuple[str, ...], Formula]] = field(init=False)
    static: frozenset[str] = field(init=False)

    def __post_init__(self) -> None:
        derived = {d.head.name.lower(): (tuple(p.name for p in d.head.params), d.body)
                   for d in self.domain.derived}  # fmt: skip
        changed = {a.predicate.lower() for act in self.domain.actions
                   for _, a in effect_atoms(act.effects)}  # fmt: skip
        static = {p.lower() for p in self.domain.predicates} - changed - set(derived)
        if self.streams is not None:
            static |= {a.predicate.lower() for s in self.streams.streams for a in s.certified}
        object.__setattr__(self, "derived", derived)
        object.__setattr__(self, "static", frozenset(static - changed - set(derived)))

    @classmethod
    def of(cls, domain: Domain, streams: StreamSpec | None = None) -> Invariants:
        """The translator's invariants of ``domain`` (no problem needed: they are lifted)."""
        return cls(tuple(_translator_groups(domain)), domain, streams)

    def contradiction(self, goals: Sequence[Literal], facts: Set[Atom]) -> str:
        """Why ``goals`` cannot hold together ("" when no invariant says so); ``facts``: the
        facts the planner plans from (they say which static relations are functional)."""
        funcs = _Functional(self, facts)
        for a, b in itertools.combinations(dict.fromkeys(goals), 2):
            why = self._conflict(a, b, funcs)
            if why:
                return f"{a} {b}: cannot be achieved together ({why})"
        return ""

    def conflicts(self, facts: Set[Atom]) -> Callable[[Formula, Formula], bool]:
        """A test of two literals against each other, for the facts given (False for a
        formula that is no literal)."""
        funcs = _Functional(self, facts)

        def test(a: Formula, b: Formula) -> bool:
            if not (_is_literal(a) and _is_literal(b)):
                return False
            return bool(self._conflict(a, b, funcs))  # type: ignore[arg-type]

        return test

    def _conflict(self, a: Literal, b: Literal, funcs: _Functional) -> str:
        if a == _negation(b):
            return "one is the other's negation"
        if not (isinstance(a, Atom) and isinstance(b, Atom)) or a == b:
            return ""
        for x in self._anchors(a, "#1", 0):
            for y in self._anchors(b, "#2", 0):
                why = self._exclusive(x, y, funcs)
                if why:
                    return why
        return ""

    def _anchors(self, atom: Atom, tag: str, depth: int) -> Iterator[tuple[Atom, tuple[Atom, ...]]]:
        """The atoms ``atom`` needs true, each with the static atoms beside it (variables of an
        ``exists`` renamed with ``tag``): itself, or its definition's conjuncts."""
        lowered = Atom(atom.predicate.lower(), atom.args)
        if lowered.predicate not in self.derived:
            yield lowered, ()
            return
        if depth >= _MAX_DEPTH:
            return
        params, body = self.derived[lowered.predicate]
        if len(params) != len(atom.args):
            return
        parts = _conjunction(Substitution(dict(zip(params, atom.args, strict=True))).formula(body),
                             tag)  # fmt: skip
        if parts is None:
            return
        statics = tuple(p for p in parts if p.predicate.lower() in self.static)
        for p in parts:
            if p.predicate.lower() not in self.static:
                for inner, beside in self._anchors(p, tag, depth + 1):
                    yield inner, (*statics, *beside)

    def _exclusive(
        self, x: tuple[Atom, tuple[Atom, ...]], y: tuple[Atom, tuple[Atom, ...]], f: _Functional
    ) -> str:
        (a, sa), (b, sb) = x, y
        for g in self.groups:
            keys = set(g.bindings(a)) & set(g.bindings(b))
            ground = [k for k in keys if not any(map(_is_var, k)) and f.at_most_one(g, k)]
            if ground and _distinct(a, b, sa, sb, f):
                return f"at most one of {g.render(ground[0])} holds at a time"
        return ""


def _is_literal(f: Formula) -> bool:
    return isinstance(f, Atom) or (isinstance(f, Not) and isinstance(f.arg, Atom))


def _is_var(term: str) -> bool:
    return term.startswith("?")


def _negation(g: Literal) -> Formula:
    return g.arg if isinstance(g, Not) else Not(g)


def _conjunction(f: Formula, tag: str) -> tuple[Atom, ...] | None:
    """The positive atoms of a conjunction under ``exists`` (bound variables renamed with
    ``tag``); None when ``f`` is not of that shape (a disjunction, say)."""
    match f:
        case Atom():
            return (f,)
        case Exists(params, body):
            renamed = Substitution({p.name: p.name + tag for p in params}).formula(body)
            return _conjunction(renamed, tag)
        case And(parts):
            out: list[Atom] = []
            for p in parts:
                if isinstance(p, Not):
                    continue  # a negative conjunct needs nothing true
                got = _conjunction(p, tag)
                if got is None:
                    return None
                out += got
            return tuple(out)
    return None


def _distinct(a: Atom, b: Atom, sa: tuple[Atom, ...], sb: tuple[Atom, ...], f: _Functional) -> bool:
    """Whether ``a`` and ``b`` are two atoms in every state that satisfies both sides."""
    if a.predicate != b.predicate:
        return True
    for u, v in zip(a.args, b.args, strict=True):
        if u == v:
            continue
        if not _is_var(u) and not _is_var(v):
            return True
        if _is_var(u) and _is_var(v) and f.apart(u, v, sa, sb):
            return True
    return False


@dataclass
class _Functional:
    """What one set of facts says: which static relations are functional in which position,
    and which groups the facts satisfy (at most one atom true: a group holds in every state
    reached from facts that satisfy it)."""

    inv: Invariants
    facts: Set[Atom]
    memo: dict[tuple[str, int], bool] = field(default_factory=dict)

    crowded: dict[tuple[Group, tuple[str, ...]], bool] = field(default_factory=dict)

    def at_most_one(self, group: Group, key: tuple[str, ...]) -> bool:
        if (group, key) not in self.crowded:
            true = [a for a in self.facts if key in set(group.bindings(a))]
            self.crowded[group, key] = len(true) > 1
        return not self.crowded[group, key]

    def apart(self, u: str, v: str, sa: tuple[Atom, ...], sb: tuple[Atom, ...]) -> bool:
        """``u = v`` would need two static facts that differ only where their relation is
        functional."""
        for s in sa:
            for t in sb:
                if s.predicate.lower() != t.predicate.lower() or len(s.args) != len(t.args):
                    continue
                same = [x == y or (x, y) == (u, v) for x, y in zip(s.args, t.args, strict=True)]
                if not any((x, y) == (u, v) for x, y in zip(s.args, t.args, strict=True)):
                    continue
                differ = [i for i, ok in enumerate(same) if not ok]
                if len(differ) != 1:
                    continue
                k = differ[0]
                if not (_is_var(s.args[k]) or _is_var(t.args[k])) and self.functional(
                    s.predicate.lower(), k
                ):
                    return True
        return False

    def functional(self, predicate: str, k: int) -> bool:
        key = (predicate, k)
        if key not in self.memo:
            self.memo[key] = self._functional(predicate, k)
        return self.memo[key]

    def _functional(self, predicate: str, k: int) -> bool:
        seen: dict[tuple[str, ...], str] = {}
        for fact in self.facts:
            if fact.predicate.lower() != predicate or len(fact.args) <= k:
                continue
            rest = fact.args[:k] + fact.args[k + 1 :]
            if seen.setdefault(rest, fact.args[k]) != fact.args[k]:
                return False
        streams = self.inv.streams.streams if self.inv.streams is not None else ()
        for s in streams:
            for c in s.certified:
                if c.predicate.lower() != predicate:
                    continue
                fresh = set(s.outputs)
                if not any(x in fresh for i, x in enumerate(c.args) if i != k):
                    return False
        return True


def _translator_groups(domain: Domain) -> Iterator[Group]:
    """Fast Downward's invariant synthesis on ``domain`` (its output silenced)."""
    from fast_downward.translate import invariant_finder, normalize, options, pddl_parser

    with tempfile.TemporaryDirectory(prefix="llmpas-inv-") as tmp:
        domain_file, problem_file = Path(tmp) / "domain.pddl", Path(tmp) / "problem.pddl"
        domain_file.write_text(domain.to_pddl())
        problem_file.write_text(
            f"(define (problem invariants) (:domain {domain.name}) (:init) (:goal (and)))"
        )
        arguments = [str(domain_file), str(problem_file),
                     "--invariant-generation-max-candidates", str(_CANDIDATES),
                     "--invariant-generation-max-time", "1000000000"]  # fmt: skip
        with contextlib.redirect_stdout(io.StringIO()):
            options.set_options(arguments)
            task = pddl_parser.open(
                domain_filename=str(domain_file), problem_filename=str(problem_file)
            )
            normalize.normalize(task)
            found = list(invariant_finder.find_invariants(task, None))
    for inv in found:
        parts = tuple(sorted(Part(p.predicate, tuple(p.args)) for p in inv.parts))
        if len(parts) > 1 or any(COUNTED in p.args for p in parts):
            yield Group(parts)


__all__ = ["COUNTED", "Group", "Invariants", "Part"]
