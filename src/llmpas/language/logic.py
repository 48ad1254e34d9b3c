"""Immutable first-order formulas and effects of PDDL, with rendering and substitution."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field


def is_var(term: str) -> bool:
    return term.startswith("?")


@dataclass(frozen=True, order=True)
class Atom:
    """``(predicate arg...)``; arguments are object names or ``?variables``; ``=`` is equality."""

    predicate: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.predicate:
            raise ValueError("an atom needs a predicate name")
        if not isinstance(self.args, tuple):
            object.__setattr__(self, "args", tuple(self.args))

    def __hash__(self) -> int:
        """The dataclass hash, computed once: atoms are hashed millions of times in joins."""
        cached: int | None = self.__dict__.get("_hash")
        if cached is None:
            cached = hash((self.predicate, self.args))
            object.__setattr__(self, "_hash", cached)
        return cached

    def __reduce__(self) -> tuple[type[Atom], tuple[str, tuple[str, ...]]]:
        # the cached hash is not pickled: string hashes differ between processes
        return (Atom, (self.predicate, self.args))

    def __str__(self) -> str:
        return "(" + " ".join((self.predicate, *self.args)) + ")"

    @classmethod
    def of(cls, predicate: str, *args: str) -> Atom:
        return cls(predicate.lower(), tuple(a.lower() for a in args))


@dataclass(frozen=True)
class Not:
    arg: Formula

    def __str__(self) -> str:
        return f"(not {self.arg})"


@dataclass(frozen=True)
class And:
    parts: tuple[Formula, ...]

    def __str__(self) -> str:
        return "(and " + " ".join(map(str, self.parts)) + ")" if self.parts else "(and)"


@dataclass(frozen=True)
class Or:
    parts: tuple[Formula, ...]

    def __str__(self) -> str:
        return "(or " + " ".join(map(str, self.parts)) + ")"


@dataclass(frozen=True)
class Imply:
    cond: Formula
    then: Formula

    def __str__(self) -> str:
        return f"(imply {self.cond} {self.then})"


@dataclass(frozen=True)
class Param:
    name: str
    type: str = "object"

    def __str__(self) -> str:
        return self.name if self.type == "object" else f"{self.name} - {self.type}"


def typed_list(params: Iterable[Param]) -> str:
    """``?a ?b - t ?c``. Items of one type share one ``- type``; an untyped run gets an explicit
    ``- object`` only when typed items follow it (else it would take their type)."""
    groups: list[tuple[str, list[str]]] = []
    for p in params:
        if groups and groups[-1][0] == p.type:
            groups[-1][1].append(p.name)
        else:
            groups.append((p.type, [p.name]))
    parts = []
    for i, (t, names) in enumerate(groups):
        last = i == len(groups) - 1
        parts.append(" ".join(names) if t == "object" and last else f"{' '.join(names)} - {t}")
    return " ".join(parts)


def params_text(params: Iterable[Param]) -> str:
    return "(" + typed_list(params) + ")"


@dataclass(frozen=True)
class Exists:
    params: tuple[Param, ...]
    body: Formula

    def __str__(self) -> str:
        return f"(exists {params_text(self.params)} {self.body})"


@dataclass(frozen=True)
class Forall:
    params: tuple[Param, ...]
    body: Formula

    def __str__(self) -> str:
        return f"(forall {params_text(self.params)} {self.body})"


Formula = Atom | Not | And | Or | Imply | Exists | Forall
TRUE: Formula = And(())
FALSE: Formula = Or(())


@dataclass(frozen=True)
class FuncTerm:
    """A numeric function application such as ``(Dist ?q1 ?q2)``."""

    name: str
    args: tuple[str, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join((self.name, *self.args)) + ")"


NumExpr = float | FuncTerm


@dataclass(frozen=True)
class Increase:
    """``(increase (total-cost) amount)``."""

    amount: NumExpr

    def __str__(self) -> str:
        amount = self.amount if isinstance(self.amount, FuncTerm) else _num(self.amount)
        return f"(increase (total-cost) {amount})"


def _num(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else repr(float(x))


@dataclass(frozen=True)
class When:
    cond: Formula
    effects: tuple[EffectItem, ...]

    def __str__(self) -> str:
        return f"(when {self.cond} {render_effects(self.effects)})"


@dataclass(frozen=True)
class ForallEffect:
    params: tuple[Param, ...]
    effects: tuple[EffectItem, ...]

    def __str__(self) -> str:
        return f"(forall {params_text(self.params)} {render_effects(self.effects)})"


EffectItem = Atom | Not | When | ForallEffect | Increase


def render_effects(effects: tuple[EffectItem, ...]) -> str:
    if len(effects) == 1:
        return str(effects[0])
    return "(and " + " ".join(map(str, effects)) + ")"


@dataclass(frozen=True)
class Substitution:
    """A variable -> term mapping applied to formulas and effects."""

    mapping: Mapping[str, str] = field(default_factory=dict)

    def term(self, t: str) -> str:
        return self.mapping.get(t, t)

    def atom(self, a: Atom) -> Atom:
        return Atom(a.predicate, tuple(self.term(t) for t in a.args))

    def without(self, params: Iterable[Param]) -> Substitution:
        names = {p.name for p in params}
        return Substitution({k: v for k, v in self.mapping.items() if k not in names})

    def formula(self, f: Formula) -> Formula:
        match f:
            case Atom():
                return self.atom(f)
            case Not(arg):
                return Not(self.formula(arg))
            case And(parts):
                return And(tuple(self.formula(p) for p in parts))
            case Or(parts):
                return Or(tuple(self.formula(p) for p in parts))
            case Imply(c, t):
                return Imply(self.formula(c), self.formula(t))
            case Exists(ps, body):
                return Exists(ps, self.without(ps).formula(body))
            case Forall(ps, body):
                return Forall(ps, self.without(ps).formula(body))
        raise TypeError(f"not a formula: {f!r}")

    def effect(self, e: EffectItem) -> EffectItem:
        match e:
            case Atom():
                return self.atom(e)
            case Not(arg):
                return Not(self.formula(arg))
            case When(c, effs):
                return When(self.formula(c), tuple(self.effect(x) for x in effs))
            case ForallEffect(ps, effs):
                inner = self.without(ps)
                return ForallEffect(ps, tuple(inner.effect(x) for x in effs))
            case Increase(FuncTerm(name, args)):
                return Increase(FuncTerm(name, tuple(self.term(t) for t in args)))
            case Increase():
                return e
        raise TypeError(f"not an effect: {e!r}")


def atoms_of(f: Formula) -> Iterator[Atom]:
    """Every atom occurring in ``f`` (under any polarity)."""
    match f:
        case Atom():
            yield f
        case Not(arg):
            yield from atoms_of(arg)
        case And(parts) | Or(parts):
            for p in parts:
                yield from atoms_of(p)
        case Imply(c, t):
            yield from atoms_of(c)
            yield from atoms_of(t)
        case Exists(_, body) | Forall(_, body):
            yield from atoms_of(body)


def conjuncts(f: Formula) -> tuple[Formula, ...]:
    """The top-level conjuncts of ``f``."""
    if isinstance(f, And):
        return tuple(c for p in f.parts for c in conjuncts(p))
    return (f,)


def effect_atoms(effects: Iterable[EffectItem]) -> Iterator[tuple[bool, Atom]]:
    """(is_add, atom) for every literal effect, nested ones included."""
    for e in effects:
        match e:
            case Atom():
                yield True, e
            case Not(Atom() as a):
                yield False, a
            case When(_, effs) | ForallEffect(_, effs):
                yield from effect_atoms(effs)
