"""Problems: objects (names bound to Python values), init atoms, a goal, and bound streams."""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.language.bindings import BoundFunction, BoundStream, StreamInfo, bind
from llmpas.language.domain import Domain, read_domain, reader_for_formulas, typed_names
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
    When,
    atoms_of,
    is_var,
)
from llmpas.language.sexpr import (
    SExpr,
    SList,
    expect_list,
    expect_sym,
    parse_all,
    parse_definition,
)
from llmpas.language.streams import EMPTY_STREAMS, StreamSpec, read_streams


def value_key(value: Any) -> Any:
    """What makes two Python values the same object: equality for hashable values, the bytes,
    shape and dtype for numpy arrays, identity for anything else."""
    if isinstance(value, np.ndarray):
        return ("np", value.dtype.str, value.shape, value.tobytes())
    try:
        key: Any = ("h", type(value), value)
        hash(key)
    except TypeError:
        key = ("id", id(value))
    return key


class ValueNamer:
    """Gives Python values PDDL names: equal values share one (see :func:`value_key`).

    ``known`` (name -> value) seeds the namer, so a stream output equal to an init object's
    value is that object."""

    def __init__(
        self, taken: Iterable[str] = (), prefix: str = "v", known: Mapping[str, Any] | None = None
    ) -> None:
        self.taken = set(taken)
        self.prefix = prefix
        self.by_key: dict[Any, str] = {}
        self.values: dict[str, Any] = {}
        for n, v in sorted((known or {}).items()):
            if not isinstance(v, str):
                self.by_key.setdefault(value_key(v), n)
                self.taken.add(n)

    def name(self, value: Any) -> str:
        if isinstance(value, str):
            return value.lower()
        key = value_key(value)
        if key not in self.by_key:
            n = len(self.values)  # names generated so far (known values are not counted)
            while f"{self.prefix}{n}" in self.taken:
                n += 1
            nm = f"{self.prefix}{n}"
            self.taken.add(nm)
            self.by_key[key] = nm
            self.values[nm] = value
        return self.by_key[key]


@dataclass(frozen=True, eq=False)
class Problem:
    """A complete, checked planning problem. Build with :meth:`create` or :func:`read_problem`."""

    domain: Domain
    streams: StreamSpec
    objects: Mapping[str, Any]  # name -> Python value (the name itself for symbolic objects)
    init: frozenset[Atom]
    goal: Formula
    bound_streams: Mapping[str, BoundStream] = field(default_factory=dict)
    bound_functions: Mapping[str, BoundFunction] = field(default_factory=dict)
    costs: Mapping[FuncTerm, float] = field(default_factory=dict)
    object_types: Mapping[str, str] = field(default_factory=dict)
    name: str = "problem"
    spelling: Mapping[str, str] = field(default_factory=dict)  # name -> as the file writes it

    def __post_init__(self) -> None:
        attrs = ("objects", "bound_streams", "bound_functions", "costs", "object_types", "spelling")
        for attr in attrs:
            object.__setattr__(self, attr, MappingProxyType(dict(getattr(self, attr))))
        object.__setattr__(self, "init", frozenset(self.init))
        _check_problem(self)

    # ------------------------------------------------------------------ construction
    @classmethod
    def create(
        cls,
        domain: Domain,
        streams: StreamSpec = EMPTY_STREAMS,
        *,
        init: Iterable[Atom | tuple[Any, ...]],
        goal: Formula | str | Iterable[Atom | tuple[Any, ...]],
        implementations: Mapping[str, Any] | None = None,
        info: Mapping[str, StreamInfo] | None = None,
        objects: Iterable[str] | Mapping[str, Any] = (),
        costs: Mapping[tuple[Any, ...], float] | None = None,
        name: str = "problem",
    ) -> Problem:
        """Build a problem from Python: init atoms may hold arbitrary values (poses, arrays).

        ``objects`` names objects that no init atom mentions; as a mapping it also gives the
        Python value of named objects (e.g. ``{"p_cube": Placement(...)}``)."""
        init, equal = _split_costs(list(init))
        costs = {**equal, **(costs or {})}
        given = {k.lower(): v for k, v in objects.items()} if isinstance(objects, Mapping) else {}
        written = list(objects)
        objects = [o.lower() for o in objects]
        spelling = _spelling(init, written)
        names = _string_names(init, goal) | set(objects)
        namer = ValueNamer(taken=[c.name for c in domain.constants] + sorted(names), known=given)
        atoms = [_atom_from(x, namer) for x in init]
        goal_f = _goal_from(goal, domain, namer)
        cost_map = {
            FuncTerm(str(k[0]).lower(), tuple(namer.name(a) for a in k[1:])): float(v)
            for k, v in costs.items()
            if str(k[0]).lower() != TOTAL_COST
        }
        names = {o.lower() for o in objects} | {t for a in atoms for t in a.args}
        names -= {c.name for c in domain.constants}
        constants = {c.name for c in domain.constants}
        for a in atoms_of(goal_f):
            unknown = [t for t in a.args if not is_var(t) and t not in names | constants]
            if unknown:
                raise ModelError(
                    f"goal: unknown object {unknown[0]!r} in {a} (not in init or objects)"
                )
        # sorted: a set's order depends on the string hash seed, and this order is the objects'
        # a name stands for itself, spelled as first written
        values = {n: given.get(n, namer.values.get(n, spelling.get(n, n))) for n in sorted(names)}
        bs, bf = bind(streams, implementations or {}, info)
        types = dict.fromkeys(values, "object")  # objects from Python are untyped
        spelled = {n: spelling[n] for n in values if n in spelling}
        return cls(
            domain,
            streams,
            values,
            frozenset(atoms),
            goal_f,
            bs,
            bf,
            cost_map,
            types,
            name=name,
            spelling=spelled,
        )

    def with_state(
        self,
        init: Iterable[Atom],
        goal: Formula | None = None,
        objects: Mapping[str, Any] | None = None,
    ) -> Problem:
        """The same problem from another state (and goal): what replanning uses."""
        return replace(
            self,
            init=frozenset(init),
            goal=self.goal if goal is None else goal,
            objects={**self.objects, **(objects or {})},
        )

    def value(self, name: str) -> Any:
        return self.objects.get(name, name)

    def written(self, name: str) -> str:
        """An object's name as the problem file writes it (PDDL matches names in any case)."""
        return self.spelling.get(name, name)

    @property
    def all_objects(self) -> tuple[str, ...]:
        return tuple(sorted(set(self.objects) | {c.name for c in self.domain.constants}))


TOTAL_COST = "total-cost"  # the planner sets it to 0 itself: a given initial value is ignored


def _split_costs(
    init: list[Atom | tuple[Any, ...]],
) -> tuple[list[Atom | tuple[Any, ...]], dict[tuple[Any, ...], float]]:
    """PDDLStream's ``Equal(('Cost',), 1)`` init items, i.e. ``('=', ('Cost',), 1)``, are
    function values, not atoms."""
    atoms: list[Atom | tuple[Any, ...]] = []
    costs: dict[tuple[Any, ...], float] = {}
    for x in init:
        if not (isinstance(x, tuple) and x and isinstance(x[0], str) and x[0] == "="):
            atoms.append(x)
            continue
        if len(x) != 3 or not isinstance(x[1], tuple) or not x[1] or not isinstance(x[1][0], str):
            raise ModelError(f"init: {x!r}: expected ('=', (FUNCTION, ARG, ...), NUMBER)")
        if isinstance(x[2], bool) or not isinstance(x[2], numbers.Real):
            raise ModelError(f"init: {x!r}: the value of {x[1]!r} is not a number")
        costs[x[1]] = float(x[2])
    return atoms, costs


def _spelling(init: Iterable[Any], objects: Iterable[str]) -> dict[str, str]:
    """Object name (lower case) -> as first written, for names given as strings."""
    written = [a for x in init if isinstance(x, tuple) for a in x[1:] if isinstance(a, str)]
    out: dict[str, str] = {}
    for a in [*objects, *written]:
        out.setdefault(a.lower(), a)
    return out


def _string_names(init: Iterable[Any], goal: Any) -> set[str]:
    """Every object name written as a string, so generated value names never take one."""
    out: set[str] = set()
    items = list(init) + (
        [] if isinstance(goal, str) or not isinstance(goal, Iterable) else list(goal)
    )
    for x in items:
        if isinstance(x, Atom):
            out |= set(x.args)
        elif isinstance(x, tuple):
            out |= {a.lower() for a in x[1:] if isinstance(a, str)}
    return out


def _atom_from(x: Atom | tuple[Any, ...], namer: ValueNamer) -> Atom:
    if isinstance(x, Atom):
        return x
    if not x or not isinstance(x[0], str):
        raise ModelError(f"an init atom must start with a predicate name: {x!r}")
    return Atom(x[0].lower(), tuple(namer.name(a) for a in x[1:]))


def _goal_from(goal: Any, domain: Domain, namer: ValueNamer) -> Formula:
    if isinstance(goal, str):
        return parse_formula(goal, domain, "<goal>")
    if isinstance(goal, Atom | Not | And | Or | Imply | Exists | Forall):
        return goal
    return And(tuple(_atom_from(g, namer) for g in goal))


def parse_formula(text: str, domain: Domain, filename: str = "<formula>") -> Formula:
    """Read one formula (e.g. a goal) against ``domain``'s predicates."""
    exprs = parse_all(text, filename)
    if len(exprs) != 1:
        raise ModelError(f"{filename}: expected exactly one formula, found {len(exprs)}")
    return reader_for_formulas(domain).formula(exprs[0], set())


# ------------------------------------------------------------------------------ checking


def known_predicates(domain: Domain, streams: StreamSpec) -> dict[str, int]:
    """Predicate -> arity for everything a problem may mention."""
    out = {n: s.arity for n, s in domain.predicates.items()}
    for n, (arity, _) in domain.undeclared.items():
        out.setdefault(n, arity)
    for n, arity in streams.certified_predicates.items():
        out.setdefault(n, arity)
    for s in streams.streams:
        if s.is_predicate:  # an external predicate: its own name, the arity of its head
            out.setdefault(s.name, len(s.inputs))
        for a in s.domain:
            out.setdefault(a.predicate, len(a.args))
    out["="] = 2
    return out


def _check_problem(p: Problem) -> None:
    certified = p.streams.certified_predicates
    certified |= {s.name: len(s.inputs) for s in p.streams.streams if s.is_predicate}
    for pred, (arity, pos) in p.domain.undeclared.items():
        if pred not in certified:
            raise pos.error(f"predicate '{pred}' is neither declared nor certified by a stream")
        if certified[pred] != arity:
            raise pos.error(
                f"'{pred}' takes {arity} arguments here but its stream certifies {certified[pred]}"
            )
    for pred, arity in certified.items():
        declared = p.domain.predicates.get(pred)
        if declared is not None and declared.arity != arity:
            raise ModelError(
                f"{p.streams.filename}: a stream certifies '{pred}' with {arity} arguments but "
                f"{p.domain.filename} declares it with {declared.arity}"
            )
        if pred in p.domain.derived_names:
            raise ModelError(f"{p.streams.filename}: streams cannot certify derived '{pred}'")
    known = known_predicates(p.domain, p.streams)
    objs = set(p.objects) | {c.name for c in p.domain.constants}
    for a in sorted(p.init):
        _check_atom(a, known, objs, "init", p.domain)
    for a in atoms_of(p.goal):
        _check_atom(a, known, objs | {t for t in a.args if is_var(t)}, "goal", p.domain, init=False)
    for term, value in p.costs.items():
        _check_cost(term, value, p, objs)


def missing_function_value(p: Problem) -> str | None:
    """Says which function an action's cost reads that has no value at all (neither in init
    nor from a ``:function``), or None. Fast Downward would silently drop such actions."""
    given = {t.name for t in p.costs} | set(p.bound_functions)
    for act in p.domain.actions:
        for term in _cost_terms(act.effects):
            if term.name not in given:
                return (
                    f"action '{act.name}' adds {term} to total-cost, but no value of "
                    f"'{term.name}' is given: add '(= ({term.name} ...) NUMBER)' to :init or "
                    f"'(:function ({term.name} ...) ...)' to the stream file"
                )
    return None


def _cost_terms(effects: Iterable[EffectItem]) -> Iterator[FuncTerm]:
    for e in effects:
        if isinstance(e, Increase) and isinstance(e.amount, FuncTerm):
            yield e.amount
        elif isinstance(e, When | ForallEffect):
            yield from _cost_terms(e.effects)


def _check_cost(term: FuncTerm, value: float, p: Problem, objs: set[str]) -> None:
    sig = p.domain.functions.get(term.name)
    if sig is None:
        raise ModelError(f"init: unknown function {term.name!r} in (= {term} {value:g})")
    if sig.arity != len(term.args):
        raise ModelError(
            f"init: function {term.name!r} takes {sig.arity} arguments, given {len(term.args)}"
        )
    for t in term.args:
        if t not in objs:
            raise ModelError(f"init: unknown object {t!r} in (= {term} {value:g})")
    if not (value >= 0 and value != float("inf")):
        raise ModelError(f"init: (= {term} {value:g}) must be a finite number >= 0")


def _check_atom(
    a: Atom, known: dict[str, int], objs: set[str], where: str, domain: Domain, init: bool = True
) -> None:
    if a.predicate not in known:
        raise ModelError(f"{where}: unknown predicate {a.predicate!r} in {a}")
    if init and a.predicate in domain.derived_names:
        raise ModelError(f"{where}: {a} is a derived predicate; it cannot be set in init")
    if known[a.predicate] != len(a.args):
        raise ModelError(
            f"{where}: {a.predicate!r} takes {known[a.predicate]} arguments, "
            f"given {len(a.args)} in {a}"
        )
    for t in a.args:
        if t not in objs:
            raise ModelError(f"{where}: unknown object {t!r} in {a}")


# ------------------------------------------------------------------------------ problem files


@dataclass(frozen=True)
class ProblemFile:
    name: str
    domain_name: str
    objects: dict[str, str]
    init: tuple[Atom, ...]
    costs: dict[FuncTerm, float]
    goal: Formula
    spelling: dict[str, str] = field(default_factory=dict)  # object name -> as written


def parse_problem_text(text: str, domain: Domain, filename: str = "<problem>") -> ProblemFile:
    root, name, sections = parse_definition(text, "problem", filename)
    objects: dict[str, str] = {}
    spelling: dict[str, str] = {}
    init: list[Atom] = []
    costs: dict[FuncTerm, float] = {}
    goal: Formula | None = None
    dom_name = domain.name
    fr = reader_for_formulas(domain)
    for item in sections:
        s = expect_list(item, "a problem section")
        key = s.head()
        if key is None:
            raise s.pos.error("expected a problem section such as '(:init ...)', found '()'")
        if key in (":domain", ":goal") and len(s) != 2:
            raise s.pos.error(f"'{key}' takes exactly one value")
        if key == ":domain":
            dom_name = expect_sym(s[1], "a domain name").text
            if dom_name != domain.name:
                raise s.pos.error(f"problem is for domain '{dom_name}', not '{domain.name}'")
        elif key == ":objects":
            _read_objects(s, domain, objects, spelling)
        elif key == ":init":
            _read_init(s.items[1:], init, costs, domain)
        elif key == ":goal":
            goal = fr.formula(s[1], set())
        elif key in (":metric", ":requirements"):
            continue
        else:
            raise s.pos.error(f"unknown problem section '{key}'")
    if goal is None:
        raise root.pos.error("problem has no ':goal'")
    return ProblemFile(name, dom_name, objects, tuple(init), costs, goal, spelling)


def _read_objects(
    s: SList, domain: Domain, objects: dict[str, str], spelling: dict[str, str]
) -> None:
    """``(:objects a b - t ...)``: types declared in the domain, every name once; each
    name's spelling as first written."""
    types = frozenset(domain.types) | frozenset(domain.types.values()) | {"object"}
    constants = {c.name for c in domain.constants}
    for p, sym in typed_names(s.items[1:], ":objects", types):
        if p.name in objects:
            raise sym.pos.error(f"object '{p.name}' is declared twice")
        if p.name in constants:
            raise sym.pos.error(f"object '{p.name}' is already a constant of the domain")
        objects[p.name] = p.type
        spelling.setdefault(sym.text, sym.written)


def _read_init(
    items: tuple[SExpr, ...], init: list[Atom], costs: dict[FuncTerm, float], domain: Domain
) -> None:
    for x in items:
        s = expect_list(x, "an init atom")
        if not s.items or isinstance(s.items[0], SList):
            raise s.pos.error("expected an init atom '(PREDICATE OBJECT ...)'")
        if s.head() == "=":
            if len(s) != 3:
                raise s.pos.error("expected '(= (FUNCTION OBJECT ...) NUMBER)'")
            term = expect_list(s[1], "a function term")
            if not term.items:
                raise term.pos.error("expected '(FUNCTION OBJECT ...)', found '()'")
            head = expect_sym(term[0], "a function name").text
            args = tuple(expect_sym(t, "an object").text for t in term.items[1:])
            text = expect_sym(s[2], "a number").text
            try:
                value = float(text)
            except ValueError:
                raise s[2].pos.error(f"expected a number, found '{text}'") from None
            if not (value >= 0 and value != float("inf")):
                raise s[2].pos.error(f"expected a finite number >= 0, found '{text}'")
            if head != TOTAL_COST:
                _known_function(term, head, len(args), domain)
                costs[FuncTerm(head, args)] = value
            continue
        _no_nesting(s)
        init.append(
            Atom(
                expect_sym(s[0], "a predicate").text,
                tuple(expect_sym(t, "an object").text for t in s.items[1:]),
            )
        )


def _known_function(term: SList, name: str, arity: int, domain: Domain) -> None:
    sig = domain.functions.get(name)
    if sig is None:
        raise term.pos.error(f"function '{name}' is not declared in the domain's ':functions'")
    if sig.arity != arity:
        raise term.pos.error(f"function '{name}' takes {sig.arity} arguments, given {arity}")


def _no_nesting(s: SList) -> None:
    if s.head() in ("not", "and", "or"):
        raise s.pos.error(f"init holds atoms only, found '{s.head()}'")
    for t in s.items[1:]:
        if isinstance(t, SList):
            raise t.pos.error("init atoms take object names as arguments")


def read_problem(
    domain: str | Path | Domain,
    problem: str | Path,
    streams: str | Path | StreamSpec | None = None,
    implementations: Mapping[str, Any] | None = None,
    info: Mapping[str, StreamInfo] | None = None,
    values: Mapping[str, Any] | None = None,
) -> Problem:
    """Read ``domain.pddl`` + ``problem.pddl`` (+ ``stream.pddl``) and bind implementations.

    ``values`` gives the Python value of objects of the problem file (names matched without
    regard to case), e.g. ``{"pA0": np.array([0.0, 1.5])}``: streams receive those values. Other
    objects reach streams as their names, spelled as in the file."""
    dom = domain if isinstance(domain, Domain) else read_domain(domain)
    if streams is None:
        spec = EMPTY_STREAMS
    elif isinstance(streams, StreamSpec):
        spec = streams
    else:
        spec = read_streams(streams)
    path = Path(problem)
    text = read_text(path, "PDDL problem file", PDDL_LIMIT)
    pf = parse_problem_text(text, dom, str(path))
    bs, bf = bind(spec, implementations or {}, info)
    given = {str(k).lower(): v for k, v in (values or {}).items()}
    unknown = sorted(given.keys() - pf.objects.keys())
    if unknown:
        raise ModelError(
            f"{path}: a value is given for {unknown[0]!r}, which is not an object here"
        )
    try:
        prob = Problem(
            dom,
            spec,
            {o: given.get(o, pf.spelling.get(o, o)) for o in pf.objects},
            frozenset(pf.init),
            pf.goal,
            bs,
            bf,
            pf.costs,
            pf.objects,
            name=pf.name,
            spelling=pf.spelling,
        )
    except ModelError as e:
        raise ModelError(f"{path}: {e}") from None
    missing = missing_function_value(prob)
    if missing:
        raise ModelError(f"{path}: {missing}")
    return prob
