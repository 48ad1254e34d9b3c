"""A :class:`PDDLProblem` (PDDL texts, Python values, wrapped implementations) as llmpas's own
:class:`~llmpas.language.problem.Problem`.

Values get PDDL names: a string that is a PDDL name is that name (lower case; its value stays the
string as written), a value equal to a ``constant_map`` value is that constant, anything else
``v0``, ``v1``, ... Two values are the same object when :func:`~llmpas.language.problem.value_key`
says so: equal hashable values, numpy arrays with the same bytes, shape and dtype (PDDLStream
compares arrays by identity), anything else by identity.
"""

from __future__ import annotations

import dataclasses
import numbers
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from llmpas.errors import InputError
from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.language.bindings import Implementation, Kind, StreamInfo, bind
from llmpas.language.domain import Domain, Signature, parse_domain
from llmpas.language.language_errors import BindingError, ModelError
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
    When,
)
from llmpas.language.problem import TOTAL_COST, Problem, missing_function_value, value_key
from llmpas.language.streams import EMPTY_STREAMS, StreamSpec, parse_streams
from llmpas.pddlstream.expressions import DEBUG_MAPS, PDDLProblem, is_parameter
from llmpas.pddlstream.wrappers import ExternalInfo, Notes, Procedure, Shape, debug_stream

MAX_OUTPUTS = 100  # outputs one stream instance may give while planning (llmpas: 10)


class Unsupported(InputError):
    """A PDDLStream construct llmpas does not plan: one line naming it (exit status 3)."""


_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_\-@]*\Z")
_RESERVED = frozenset({"and", "or", "not", "imply", "exists", "forall", "when", "either", "object"})


class Naming:
    """PDDL names of Python values (module docstring); ``values``: name -> value."""

    def __init__(self, constants: Mapping[str, Any], taken: Iterable[str]) -> None:
        self.values: dict[str, Any] = {}
        self.by_key: dict[Any, str] = {}
        self.taken = set(taken) | _RESERVED
        for name, value in constants.items():
            self.by_key.setdefault(value_key(value), name)
            self.values[name] = value
            self.taken.add(name)

    def name(self, value: Any) -> str:
        key = value_key(value)
        found = self.by_key.get(key)
        if found is not None:
            return found
        name = value.lower() if isinstance(value, str) and _NAME.match(value) else ""
        if not name or name in self.taken:
            n = len(self.by_key)
            while f"v{n}" in self.taken:
                n += 1
            name = f"v{n}"
        self.taken.add(name)
        self.by_key[key] = name
        self.values[name] = value
        return name


@dataclass(frozen=True, eq=False)
class Translation:
    """The llmpas problem and the Python value of every name it uses."""

    problem: Problem
    values: Mapping[str, Any]

    def value(self, name: str) -> Any:
        if name in self.values:
            return self.values[name]
        return self.problem.objects.get(name, name)


def translate(
    pds: PDDLProblem,
    stream_info: Mapping[str, Any] | None = None,
    *,
    unit_costs: bool = False,
    notes: Notes | None = None,
) -> Translation:
    """The llmpas problem of ``pds`` (raises a one-line :class:`InputError` for bad input)."""
    notes = notes or Notes()
    if not isinstance(pds, tuple) or len(pds) != 6:
        raise InputError(
            "solve: expected a PDDLProblem(domain_pddl, constant_map, stream_pddl, stream_map, "
            f"init, goal), got {type(pds).__name__}"
        )
    domain_pddl, constant_map, stream_pddl, stream_map, init, goal = pds
    domain = _domain(domain_pddl)
    if unit_costs:
        domain = dataclasses.replace(
            domain,
            actions=tuple(
                dataclasses.replace(a, effects=_costless(a.effects)) for a in domain.actions
            ),
        )
    spec = _streams(stream_pddl)
    constants = {c.name for c in domain.constants}
    given = {str(k).lower(): v for k, v in dict(constant_map or {}).items()}
    naming = Naming(given, constants)
    atoms, costs = _init(init, naming)
    domain = _declare_extra_facts(domain, spec, atoms)
    computed = {f.name for f in spec.functions}
    for term in sorted((t for t in costs if t.name not in domain.functions), key=str):
        if term.name not in computed:  # PDDLStream accepts values no action reads
            del costs[term]
            notes.ignored(
                f"init (= ({term.name} ...) ...)",
                "the domain declares no such function (no action reads it)",
            )
    goal_f = _formula(goal, naming, frozenset(), "goal")
    implementations = _implementations(spec, stream_map, stream_info or {}, notes)
    bs, bf = bind(spec, implementations)
    objects = dict(naming.values)
    for c in constants - objects.keys():
        objects[c] = c
    problem = Problem(
        domain,
        spec,
        objects,
        frozenset(atoms),
        goal_f,
        bs,
        bf,
        costs,
        dict.fromkeys(objects, "object"),
        name="pddlstream",
        spelling={n: v for n, v in naming.values.items() if isinstance(v, str)},
    )
    missing = missing_function_value(problem)
    if missing:
        raise ModelError(f"{domain.filename}: {missing}")
    return Translation(problem, naming.values)


def pddl_text(obj: Any, what: str) -> tuple[str, str]:
    """(text, filename) of a PDDL text, a text from ``read`` (which knows its file) or a path."""
    if isinstance(obj, os.PathLike) or (
        isinstance(obj, str) and "(" not in obj and Path(obj).is_file()
    ):
        return read_text(Path(obj), f"PDDL {what} file", PDDL_LIMIT), str(obj)
    if not isinstance(obj, str):
        raise InputError(f"{what}_pddl: expected PDDL text, got {type(obj).__name__}")
    return str(obj), getattr(obj, "path", f"<{what}_pddl>")


def _domain(obj: Any) -> Domain:
    text, filename = pddl_text(obj, "domain")
    return parse_domain(text, filename)


def _streams(obj: Any) -> StreamSpec:
    if obj is None:
        return EMPTY_STREAMS
    texts = [obj] if isinstance(obj, str | os.PathLike) else list(obj)
    specs = [parse_streams(*pddl_text(t, "stream")) for t in texts if t]
    if not specs:
        return EMPTY_STREAMS
    if len(specs) == 1:
        return specs[0]
    return StreamSpec(
        specs[0].name,
        tuple(s for spec in specs for s in spec.streams),
        tuple(f for spec in specs for f in spec.functions),
        " + ".join(spec.filename for spec in specs),
    )


def _declare_extra_facts(domain: Domain, spec: StreamSpec, init: list[Atom]) -> Domain:
    """The domain with the predicates that only stream domains or the init use declared
    (``Graspable`` in PDDLStream's kuka example, ``AConf`` in its pybullet/tamp one):
    PDDLStream accepts init facts of those."""
    extra: dict[str, Signature] = {}
    certified = spec.certified_predicates
    atoms = [a for s in spec.streams for a in s.domain] + list(init)
    for a in atoms:
        known = a.predicate in domain.predicates or a.predicate in domain.undeclared
        if not known and a.predicate not in extra and a.predicate not in certified:
            params = tuple(Param(f"?x{i}") for i in range(len(a.args)))
            extra[a.predicate] = Signature(a.predicate, params)
    if not extra:
        return domain
    return dataclasses.replace(domain, predicates={**domain.predicates, **extra})


def _costless(effects: tuple[EffectItem, ...]) -> tuple[EffectItem, ...]:
    out: list[EffectItem] = []
    for e in effects:
        if isinstance(e, Increase):
            continue
        if isinstance(e, When | ForallEffect):
            e = dataclasses.replace(e, effects=_costless(e.effects))
        out.append(e)
    return tuple(out)


def _init(init: Any, naming: Naming) -> tuple[list[Atom], dict[FuncTerm, float]]:
    if isinstance(init, str | bytes) or not isinstance(init, Iterable):
        raise ModelError(f"init: expected a list of facts, got {type(init).__name__}")
    atoms: list[Atom] = []
    costs: dict[FuncTerm, float] = {}
    for i, fact in enumerate(init):
        where = f"init[{i}]"
        if not isinstance(fact, tuple | list) or not fact or not isinstance(fact[0], str):
            raise ModelError(f"{where}: {fact!r} is not a fact (PREDICATE, VALUE, ...)")
        if fact[0] != "=":
            atoms.append(Atom(fact[0].lower(), tuple(naming.name(a) for a in fact[1:])))
            continue
        head, value = (fact[1], fact[2]) if len(fact) == 3 else (None, None)
        if not isinstance(head, tuple | list) or not head or not isinstance(head[0], str):
            raise ModelError(f"{where}: {fact!r}: expected Equal((FUNCTION, VALUE, ...), NUMBER)")
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ModelError(f"{where}: the value of {head!r} is {value!r}, not a number")
        if head[0].lower() == TOTAL_COST:
            continue
        term = FuncTerm(head[0].lower(), tuple(naming.name(a) for a in head[1:]))
        costs[term] = float(value)
    return atoms, costs


def _formula(expr: Any, naming: Naming, scope: frozenset[str], where: str) -> Formula:
    if isinstance(expr, And | Or | Not | Imply | Exists | Forall | Atom):
        return expr  # already llmpas's (solve_from_pddl)
    if isinstance(expr, list):  # a list of facts, or a formula written as a list
        expr = tuple(expr) if expr and isinstance(expr[0], str) else ("and", *expr)
    if not isinstance(expr, tuple) or not expr or not isinstance(expr[0], str):
        raise ModelError(f"{where}: {expr!r} is not a fact or a formula")
    head, rest = expr[0].lower(), expr[1:]

    def sub(x: Any, inner: frozenset[str] = scope) -> Formula:
        return _formula(x, naming, inner, where)

    if head in ("and", "or"):
        parts = tuple(sub(x) for x in rest)
        return And(parts) if head == "and" else Or(parts)
    if head in ("not", "imply", "exists", "forall") and len(rest) != (1 if head == "not" else 2):
        raise ModelError(f"{where}: {expr!r}: wrong number of parts for '{head}'")
    if head == "not":
        return Not(sub(rest[0]))
    if head == "imply":
        return Imply(sub(rest[0]), sub(rest[1]))
    if head in ("exists", "forall"):
        names = [rest[0]] if isinstance(rest[0], str) else list(rest[0])
        bad = [p for p in names if not is_parameter(p)]
        if bad:
            raise ModelError(f"{where}: {head} over {bad[0]!r}: parameters start with '?'")
        params = tuple(Param(p.lower()) for p in names)
        body = sub(rest[1], scope | {p.name for p in params})
        return Exists(params, body) if head == "exists" else Forall(params, body)
    if head in ("minimize", "maximize"):
        raise Unsupported(
            f"{where}: '{head}' objectives are not supported (costs come from the "
            "domain's total-cost)"
        )

    def term(a: Any) -> str:
        if is_parameter(a):
            if a.lower() not in scope:
                raise ModelError(f"{where}: {a} is not bound by an Exists or ForAll in {expr!r}")
            return str(a).lower()
        return naming.name(a)

    return Atom(head, tuple(term(a) for a in rest))


def _implementations(
    spec: StreamSpec, stream_map: Any, stream_info: Mapping[str, Any], notes: Notes
) -> dict[str, Implementation]:
    if isinstance(stream_map, str) and stream_map.lower() in DEBUG_MAPS:
        stream_map = _debug_map(spec, shared=stream_map.lower() == "shared_debug")
    if stream_map is None:
        stream_map = {}
    if not isinstance(stream_map, Mapping):
        raise BindingError(
            f"stream_map: expected a dict name -> implementation, got {type(stream_map).__name__}"
        )
    given = {str(k).lower(): v for k, v in stream_map.items()}
    infos = {str(k).lower(): v for k, v in dict(stream_info).items()}
    out: dict[str, Implementation] = {}
    for s in spec.streams:
        if s.is_rule or s.name not in given:
            continue
        impl = _with_info(
            _stream_impl(s.name, given[s.name], s.is_predicate), infos.get(s.name), notes, s.name
        )
        if s.outputs and impl.info.max_outputs < MAX_OUTPUTS:  # PDDLStream has no such bound
            impl = dataclasses.replace(
                impl, info=dataclasses.replace(impl.info, max_outputs=MAX_OUTPUTS)
            )
        out[s.name] = impl
    for f in spec.functions:
        if f.name not in given:
            continue
        obj = given[f.name]
        fn = obj.fn if isinstance(obj, Procedure) else obj
        if isinstance(obj, Implementation):
            impl = obj
        elif callable(fn):
            impl = Implementation(fn, Kind.COST)
        else:
            raise BindingError(f"stream_map[{f.name!r}] is {type(obj).__name__}, not callable")
        out[f.name] = _with_info(impl, infos.get(f.name), notes, f.name)
    return out


def _debug_map(spec: StreamSpec, shared: bool) -> dict[str, Any]:
    """PDDLStream's debug streams: each stream gives one output tuple of debug values (shared:
    one value per stream and output; else a new one per call), each test passes, each
    ``:function`` costs 0 and each external ``:predicate`` is false (its ``bool()``)."""
    out: dict[str, Any] = {}
    for s in spec.streams:
        if s.is_rule:
            continue
        out[s.name] = _never if s.is_predicate else debug_stream(s.name, s.outputs, shared)
    out.update({f.name: _free for f in spec.functions})
    return out


def _never(*_: Any) -> bool:
    return False


def _free(*_: Any) -> float:
    return 0.0


def _stream_impl(name: str, obj: Any, predicate: bool) -> Implementation:
    if isinstance(obj, Implementation):
        return obj
    if isinstance(obj, Procedure):
        return Implementation(obj.fn, Kind.TEST) if predicate else obj.implementation()
    if not callable(obj):
        raise BindingError(f"stream_map[{name!r}] is {type(obj).__name__}, not callable")
    if predicate:
        return Implementation(obj, Kind.TEST)
    return Procedure(obj, Shape.LIST_GEN).implementation()  # PDDLStream's own protocol


def _with_info(impl: Implementation, info: Any, notes: Notes, name: str) -> Implementation:
    if info is None:
        return impl
    if isinstance(info, StreamInfo):
        native = info
    elif isinstance(info, ExternalInfo):
        native = info.native(notes, name)
    else:
        raise BindingError(f"stream_info[{name!r}] is {type(info).__name__}, not a StreamInfo")
    return Implementation(impl.fn, impl.kind, native)
