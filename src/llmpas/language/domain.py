"""PDDL domains: an immutable model, a lax reader and a writer.

Domain files written for stream-based planners are lax (see ``shared/notes/stream-files.md``):
requirements are incomplete, types are usually absent, derived predicates and stream-certified
predicates may be undeclared. The reader accepts what the body uses; the writer declares every
requirement and predicate, so Fast Downward and the ``pddl`` package both read its output.
"""

from __future__ import annotations

import logging
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.language.language_errors import ModelError
from llmpas.language.logic import (
    FALSE,
    TRUE,
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
    NumExpr,
    Or,
    Param,
    When,
    params_text,
    render_effects,
    typed_list,
)
from llmpas.language.sexpr import (
    Pos,
    SExpr,
    SList,
    Sym,
    expect_list,
    expect_sym,
    keyword_sections,
    parse_definition,
)

log = logging.getLogger(__name__)

FULL_REQUIREMENTS = (
    ":strips",
    ":typing",
    ":negative-preconditions",
    ":disjunctive-preconditions",
    ":equality",
    ":existential-preconditions",
    ":universal-preconditions",
    ":conditional-effects",
    ":derived-predicates",
    ":action-costs",
)


@dataclass(frozen=True)
class Signature:
    """A predicate or function declaration: name and typed parameters."""

    name: str
    params: tuple[Param, ...] = ()

    @property
    def arity(self) -> int:
        return len(self.params)

    def __str__(self) -> str:
        return f"({self.name} {typed_list(self.params)})" if self.params else f"({self.name})"


@dataclass(frozen=True)
class Derived:
    head: Signature
    body: Formula

    def __str__(self) -> str:
        return f"(:derived {self.head} {self.body})"


@dataclass(frozen=True)
class Action:
    name: str
    params: tuple[Param, ...]
    precondition: Formula
    effects: tuple[EffectItem, ...]

    def __str__(self) -> str:
        return (
            f"(:action {self.name}\n  :parameters {params_text(self.params)}\n"
            f"  :precondition {self.precondition}\n  :effect {render_effects(self.effects)})"
        )


def _frozen_map() -> Mapping[str, Any]:
    return MappingProxyType({})


@dataclass(frozen=True, eq=False)
class Domain:
    name: str
    requirements: tuple[str, ...] = ()
    types: Mapping[str, str] = field(default_factory=_frozen_map)  # type -> parent type
    constants: tuple[Param, ...] = ()
    predicates: Mapping[str, Signature] = field(default_factory=_frozen_map)
    functions: Mapping[str, Signature] = field(default_factory=_frozen_map)
    derived: tuple[Derived, ...] = ()
    actions: tuple[Action, ...] = ()
    # predicates used in the body but declared nowhere, with where they first appear;
    # they are legal only if a stream certifies them (checked when a Problem is built)
    undeclared: Mapping[str, tuple[int, Pos]] = field(default_factory=_frozen_map)
    filename: str = "<domain>"

    def __post_init__(self) -> None:
        for attr in ("types", "predicates", "functions", "undeclared"):
            object.__setattr__(self, attr, MappingProxyType(dict(getattr(self, attr))))
        names = [a.name for a in self.actions]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ModelError(f"{self.filename}: action {sorted(dup)[0]!r} is defined twice")

    @property
    def derived_names(self) -> frozenset[str]:
        return frozenset(d.head.name for d in self.derived)

    def action(self, name: str) -> Action:
        for a in self.actions:
            if a.name == name.lower():
                return a
        raise ModelError(f"{self.filename}: unknown action {name!r}")

    def arity(self, predicate: str) -> int | None:
        if predicate == "=":
            return 2
        sig = self.predicates.get(predicate)
        if sig is not None:
            return sig.arity
        und = self.undeclared.get(predicate)
        return und[0] if und else None

    def supertypes(self, t: str) -> tuple[str, ...]:
        """``t`` and its ancestors up to ``object``."""
        chain = [t]
        while chain[-1] in self.types and self.types[chain[-1]] not in chain:
            chain.append(self.types[chain[-1]])
        if "object" not in chain:
            chain.append("object")
        return tuple(chain)

    def with_additions(
        self,
        predicates: Iterable[Signature] = (),
        actions: Iterable[Action] = (),
        derived: Iterable[Derived] = (),
    ) -> Domain:
        preds = dict(self.predicates)
        for p in predicates:
            preds.setdefault(p.name, p)
        return replace(
            self,
            predicates=preds,
            actions=self.actions + tuple(actions),
            derived=self.derived + tuple(derived),
        )

    def to_pddl(self, numeric_fluents: bool = False) -> str:
        """Standard PDDL that declares every requirement and predicate the body uses.

        Fast Downward reads functions other than ``total-cost`` under ``:action-costs`` and
        rejects ``:numeric-fluents``; strict readers (the ``pddl`` package) want it declared:
        ``numeric_fluents=True`` adds it when such functions exist."""
        preds = dict(self.predicates)
        for name, (arity, _) in self.undeclared.items():
            preds.setdefault(name, Signature(name, tuple(Param(f"?x{i}") for i in range(arity))))
        for d in self.derived:
            preds.setdefault(d.head.name, d.head)
        funcs = [str(f) for f in self.functions.values() if f.name != "total-cost"]
        requirements = FULL_REQUIREMENTS + (
            (":numeric-fluents",) if numeric_fluents and funcs else ()
        )
        lines = [f"(define (domain {self.name})", f"  (:requirements {' '.join(requirements)})"]
        if self.types:
            lines.append("  (:types " + " ".join(f"{t} - {p}" for t, p in self.types.items()) + ")")
        if self.constants:
            lines.append("  (:constants " + typed_list(self.constants) + ")")
        if preds:
            lines.append("  (:predicates " + " ".join(str(p) for p in preds.values()) + ")")
        if self.uses_costs():
            funcs.append("(total-cost)")
        if funcs:
            lines.append("  (:functions " + " ".join(f"{f} - number" for f in funcs) + ")")
        lines += [f"  {d}" for d in self.derived]
        lines += [f"  {a}" for a in self.actions]
        lines.append(")")
        return "\n".join(lines) + "\n"

    def uses_costs(self) -> bool:
        return any(_has_increase(a.effects) for a in self.actions)


def _has_increase(effects: Iterable[EffectItem]) -> bool:
    for e in effects:
        if isinstance(e, Increase):
            return True
        if isinstance(e, When | ForallEffect) and _has_increase(e.effects):
            return True
    return False


# ---------------------------------------------------------------------------------------- reading


def read_domain(path: str | Path) -> Domain:
    path = Path(path)
    return parse_domain(read_text(path, "PDDL domain file", PDDL_LIMIT), str(path))


def parse_domain(text: str, filename: str = "<domain>") -> Domain:
    _, name, sections = parse_definition(text, "domain", filename)
    reader = _DomainReader(filename)
    reader.name = name
    lists = [expect_list(section, "a domain section") for section in sections]
    for s in sorted(lists, key=lambda s: s.head() != ":types"):  # types first: others use them
        reader.section(s)
    return reader.build()


def parse_typed_list(
    items: Iterable[SExpr],
    what: str,
    types: Collection[str] | None = None,
    unique: bool = True,
) -> tuple[Param, ...]:
    """``?a ?b - t ?c`` -> (Param(?a, t), Param(?b, t), Param(?c, object)).

    ``types``: the declared types (``object`` is always one); a name given twice is an error
    unless ``unique`` is false."""
    return tuple(p for p, _ in typed_names(items, what, types, unique))


def typed_names(
    items: Iterable[SExpr],
    what: str,
    types: Collection[str] | None = None,
    unique: bool = True,
) -> list[tuple[Param, Sym]]:
    """:func:`parse_typed_list` with the symbol of each name (for messages naming its place)."""
    out: list[tuple[Param, Sym]] = []
    pending: list[Sym] = []
    seen: set[str] = set()
    seq = list(items)
    i = 0
    while i < len(seq):
        s = expect_sym(seq[i], f"a name in {what}")
        if s.text == "-":
            if i + 1 >= len(seq):
                raise s.pos.error(f"'-' without a type in {what}")
            t = seq[i + 1]
            if isinstance(t, SList):
                raise t.pos.error(f"'(either ...)' types are not supported in {what}")
            if types is not None and t.text != "object" and t.text not in types:
                declared = ", ".join(sorted(set(types) - {"object"})) or "none"
                raise t.pos.error(
                    f"type '{t.text}' in {what} is not declared in the domain's :types "
                    f"(declared: {declared})"
                )
            out += [(Param(p.text, t.text), p) for p in pending]
            pending, i = [], i + 2
            continue
        if unique and s.text in seen:
            raise s.pos.error(f"'{s.text}' is named twice in {what}")
        seen.add(s.text)
        pending.append(s)
        i += 1
    out += [(Param(p.text), p) for p in pending]
    return out


def _twice(pos: Pos, what: str, name: str, first: object, again: object) -> None:
    """A second declaration of ``name``: read with a warning when it says the same as the first
    (Fast Downward does the same), else an error naming both."""
    if _declared(first) != _declared(again):
        raise pos.error(f"{what} '{name}' is declared twice, differently: {first} and {again}")
    where = f"{pos.filename}:{pos.line}:{pos.col}"
    log.warning(
        "%s: %s '%s' is declared twice (identically); the repeat is ignored", where, what, name
    )


def _declared(x: object) -> object:
    """What a declaration says: a signature's parameter types (not their variable names)."""
    return (x.name, tuple(p.type for p in x.params)) if isinstance(x, Signature) else x


UNSUPPORTED_REQUIREMENTS = frozenset(
    {
        ":durative-actions",
        ":duration-inequalities",
        ":continuous-effects",
        ":timed-initial-literals",
    }
)


@dataclass
class _DomainReader:
    filename: str
    name: str = ""
    requirements: tuple[str, ...] = ()
    types: dict[str, str] = field(default_factory=dict)
    constants: tuple[Param, ...] = ()
    predicates: dict[str, Signature] = field(default_factory=dict)
    functions: dict[str, Signature] = field(default_factory=dict)
    derived: list[tuple[Signature, SExpr, Pos]] = field(default_factory=list)
    actions: list[tuple[SList, Pos]] = field(default_factory=list)
    undeclared: dict[str, tuple[int, Pos]] = field(default_factory=dict)
    derived_names: set[str] = field(default_factory=set)

    @property
    def declared_types(self) -> frozenset[str]:
        """Every type of ``:types``, its parents included, and ``object``."""
        return frozenset(self.types) | frozenset(self.types.values()) | {"object"}

    def section(self, s: SList) -> None:
        key = s.head()
        body = s.items[1:]
        if key == ":requirements":
            reqs = [expect_sym(r, "a requirement") for r in body]
            for r in reqs:
                if r.text in UNSUPPORTED_REQUIREMENTS:
                    raise r.pos.error(
                        f"requirement '{r.text}' is not supported (temporal planning)"
                    )
            self.requirements = tuple(r.text for r in reqs)
        elif key == ":types":
            self._types(body)
        elif key == ":constants":
            before = {c.name: c.type for c in self.constants}
            for c, sym in typed_names(body, ":constants", self.declared_types, unique=False):
                if c.name in before:
                    _twice(sym.pos, "constant", c.name, before[c.name], c.type)
                    continue
                before[c.name] = c.type
                self.constants += (c,)
        elif key == ":predicates":
            for x in body:
                decl = expect_list(x, "a predicate declaration")
                sig = _signature(decl, self.declared_types)
                if sig.name in self.predicates:
                    _twice(decl.pos, "predicate", sig.name, self.predicates[sig.name], sig)
                    continue
                self.predicates[sig.name] = sig
        elif key == ":functions":
            self._functions(body)
        elif key == ":derived":
            if len(body) != 2:
                raise s.pos.error("expected '(:derived (NAME ?x ...) FORMULA)'")
            self.derived.append(
                (
                    _signature(expect_list(body[0], "a derived head"), self.declared_types),
                    body[1],
                    s.pos,
                )
            )
        elif key is None:
            raise s.pos.error("expected a domain section such as '(:action ...)', found '()'")
        elif key == ":action":
            self.actions.append((s, s.pos))
        elif key == ":constraints":
            raise s.pos.error("':constraints' is not supported")
        elif key == ":durative-action":
            raise s.pos.error("':durative-action' is not supported (temporal planning)")
        else:
            raise s.pos.error(f"unknown domain section '{key}'")

    def _types(self, body: tuple[SExpr, ...]) -> None:
        for p, sym in typed_names(body, ":types", unique=False):
            if p.name == "object" and p.type == "object":
                continue
            if p.name in self.types:
                first = f"{p.name} - {self.types[p.name]}"
                _twice(sym.pos, "type", p.name, first, f"{p.name} - {p.type}")
                continue
            self.types[p.name] = p.type
            chain = [p.name]
            while chain[-1] in self.types and chain[-1] != "object":
                chain.append(self.types[chain[-1]])
                if chain[-1] == p.name:
                    raise sym.pos.error(f"type '{p.name}' is its own ancestor: {' - '.join(chain)}")

    def _functions(self, body: tuple[SExpr, ...]) -> None:
        items = list(body)
        i = 0
        while i < len(items):
            x = items[i]
            if isinstance(x, Sym) and x.text == "-":
                i += 2  # skip "- number"
                continue
            decl = expect_list(x, "a function declaration")
            sig = _signature(decl, self.declared_types)
            if sig.name in self.functions:
                _twice(decl.pos, "function", sig.name, self.functions[sig.name], sig)
            self.functions[sig.name] = sig
            i += 1

    def build(self) -> Domain:
        for sig, _, pos in self.derived:
            declared = self.predicates.setdefault(sig.name, sig)
            if declared.arity != sig.arity:
                raise pos.error(
                    f"derived '{sig.name}' has {sig.arity} parameters but is declared with "
                    f"{declared.arity}"
                )
        self.derived_names = {sig.name for sig, _, _ in self.derived}
        fr = _FormulaReader(self, lax_free_variables=True)
        derived = tuple(
            Derived(sig, fr.formula(body, {p.name for p in sig.params}))
            for sig, body, _ in self.derived
        )
        actions: list[Action] = []
        for s, pos in self.actions:
            action = self._action(s, fr)
            if any(a.name == action.name for a in actions):
                raise pos.error(f"action '{action.name}' is defined twice")
            actions.append(action)
        return Domain(
            name=self.name,
            requirements=self.requirements,
            types=self.types,
            constants=self.constants,
            predicates=self.predicates,
            functions=self.functions,
            derived=derived,
            actions=tuple(actions),
            undeclared=self.undeclared,
            filename=self.filename,
        )

    def _action(self, s: SList, fr: _FormulaReader) -> Action:
        if len(s) < 2:
            raise s.pos.error("expected '(:action NAME :parameters (...) ...)'")
        name = expect_sym(s[1], "an action name").text
        if name.startswith(":"):
            raise s[1].pos.error(f"expected an action name, found '{name}'")
        params: tuple[Param, ...] = ()
        pre: Formula = TRUE
        effects: tuple[EffectItem, ...] = ()
        sections = list(keyword_sections(s.items[2:], f"action '{name}'"))
        seen: set[str] = set()
        for key, _ in sections:
            if key.text in seen:
                raise key.pos.error(f"'{key.text}' given twice in action '{name}'")
            seen.add(key.text)
        for key, vals in sections:
            if key.text == ":parameters":
                params = parse_typed_list(
                    expect_list(_single(key, vals), "parameters"),
                    f"the parameters of action '{name}'",
                    self.declared_types,
                )
        scope = {p.name for p in params}
        for key, vals in sections:
            if key.text == ":precondition":
                v = _single(key, vals)
                pre = TRUE if isinstance(v, SList) and len(v) == 0 else fr.formula(v, scope)
            elif key.text == ":effect":
                effects = fr.effects(_single(key, vals), scope)
            elif key.text != ":parameters":
                raise key.pos.error(f"unknown action keyword '{key.text}' in action '{name}'")
        return Action(name, params, pre, effects)


def _arity(s: SList, n: int, form: str) -> None:
    if len(s.items) - 1 != n:
        raise s.pos.error(f"expected {form}")


def _single(key: Sym, vals: tuple[SExpr, ...]) -> SExpr:
    if len(vals) != 1:
        raise key.pos.error(f"'{key.text}' takes exactly one value")
    return vals[0]


def _signature(s: SList, types: Collection[str] | None = None) -> Signature:
    if not s.items:
        raise s.pos.error("empty declaration '()'")
    name = expect_sym(s[0], "a name").text
    return Signature(name, parse_typed_list(s.items[1:], f"'{name}'", types))


class _FormulaReader:
    """Turns s-expressions into formulas, checking predicate arity and variable scope.

    ``lax_free_variables``: an atom of a condition with a variable bound nowhere is read as
    false, with a warning (domains), instead of refused (goals of problems)."""

    def __init__(self, reader: _DomainReader, lax_free_variables: bool = False) -> None:
        self.r = reader
        self.lax_free_variables = lax_free_variables

    def atom(self, s: SList, scope: set[str]) -> Atom:
        pred = expect_sym(s[0], "a predicate name").text
        args = tuple(expect_sym(a, f"an argument of '{pred}'") for a in s.items[1:])
        for a in args:
            if a.text.startswith("?") and a.text not in scope:
                raise a.pos.error(f"variable '{a.text}' is not bound here")
        self._check_arity(pred, len(args), s.pos)
        return Atom(pred, tuple(a.text for a in args))

    def _check_arity(self, pred: str, n: int, pos: Pos) -> None:
        if pred == "=":
            if n != 2:
                raise pos.error("'=' takes two arguments")
            return
        sig = self.r.predicates.get(pred)
        if sig is None:
            known = self.r.undeclared.setdefault(pred, (n, pos))
            if known[0] != n:
                raise pos.error(f"'{pred}' used with {n} arguments here, {known[0]} elsewhere")
        elif sig.arity != n:
            raise pos.error(f"predicate '{pred}' takes {sig.arity} arguments, given {n}")

    def formula(self, e: SExpr, scope: set[str]) -> Formula:
        s = expect_list(e, "a formula")
        head = s.head()
        if head is None:
            raise s.pos.error("expected a formula, found '()'" if not s.items else "bad formula")
        args = s.items[1:]
        if head == "and":
            return And(tuple(self.formula(a, scope) for a in args))
        if head == "or":
            return Or(tuple(self.formula(a, scope) for a in args))
        if head == "not":
            if len(args) != 1:
                raise s.pos.error("'not' takes one formula")
            return Not(self.formula(args[0], scope))
        if head == "imply":
            if len(args) != 2:
                raise s.pos.error("'imply' takes two formulas")
            return Imply(self.formula(args[0], scope), self.formula(args[1], scope))
        if head in ("exists", "forall"):
            if len(args) != 2:
                raise s.pos.error(f"'{head}' takes a variable list and a formula")
            ps = parse_typed_list(expect_list(args[0], "variables"), head, self.r.declared_types)
            body = self.formula(args[1], scope | {p.name for p in ps})
            return Exists(ps, body) if head == "exists" else Forall(ps, body)
        free = _free_variable(s, scope) if self.lax_free_variables else None
        if free is not None:
            # Lax, as the Fast Downward translator PDDLStream ships: a variable bound nowhere
            # names no object, so an atom over it holds in no state (and its negation in all).
            # Today's Fast Downward refuses it; the effects and costs here still do.
            log.warning(
                "%s:%d:%d: variable '%s' is not bound here: read as naming no object, so %s "
                "is false (as PDDLStream's Fast Downward reads it)",
                free.pos.filename,
                free.pos.line,
                free.pos.col,
                free.text,
                _sexpr_text(s),
            )
            self._check_arity(expect_sym(s[0], "a predicate name").text, len(s) - 1, s.pos)
            return FALSE
        return self.atom(s, scope)

    def effects(self, e: SExpr, scope: set[str]) -> tuple[EffectItem, ...]:
        s = expect_list(e, "an effect")
        if not s.items:
            return ()  # '()' is the empty effect
        head = s.head()
        args = s.items[1:]
        if head == "and":
            for a in args:
                if isinstance(a, SList) and not a.items:
                    raise a.pos.error("empty '()' inside an effect conjunction")
            return tuple(x for a in args for x in self.effects(a, scope))
        if head == "not":
            _arity(s, 1, "'(not ATOM)'")
            return (Not(self._effect_atom(expect_list(args[0], "an atom"), scope)),)
        if head == "when":
            _arity(s, 2, "'(when CONDITION EFFECT)'")
            cond = self.formula(args[0], scope)
            return (When(cond, self.effects(args[1], scope)),)
        if head == "forall":
            _arity(s, 2, "'(forall (VARIABLES) EFFECT)'")
            ps = parse_typed_list(
                expect_list(args[0], "variables"), "forall", self.r.declared_types
            )
            return (ForallEffect(ps, self.effects(args[1], scope | {p.name for p in ps})),)
        if head == "increase":
            return (self._increase(s, scope),)
        if head in ("decrease", "assign", "scale-up", "scale-down"):
            raise s.pos.error(f"numeric effect '{head}' is not supported (only total-cost)")
        return (self._effect_atom(s, scope),)

    def _effect_atom(self, s: SList, scope: set[str]) -> Atom:
        if not s.items:
            raise s.pos.error("expected an atom, found '()'")
        a = self.atom(s, scope)
        if a.predicate in self.r.derived_names:
            raise s.pos.error(f"derived predicate '{a.predicate}' cannot be an action effect")
        if a.predicate == "=":
            raise s.pos.error("'=' cannot be an action effect")
        return a

    def _increase(self, s: SList, scope: set[str]) -> Increase:
        if len(s) != 3:
            raise s.pos.error("expected '(increase (total-cost) AMOUNT)'")
        target = expect_list(s[1], "'(total-cost)'")
        if target.head() != "total-cost":
            raise target.pos.error("only '(total-cost)' can be increased")
        amount = self.num(s[2], scope)
        if isinstance(amount, float) and not amount >= 0:
            raise s[2].pos.error(f"action costs must be >= 0, found {amount:g}")
        return Increase(amount)

    def num(self, e: SExpr, scope: set[str]) -> NumExpr:
        if isinstance(e, Sym):
            try:
                return float(e.text)
            except ValueError:
                raise e.pos.error(
                    f"expected a number or a function term, found '{e.text}'"
                ) from None
        if not e.items:
            raise e.pos.error("expected a number or a function term, found '()'")
        name = expect_sym(e[0], "a function name").text
        args = tuple(expect_sym(a, "an argument").text for a in e.items[1:])
        for a in args:
            if a.startswith("?") and a not in scope:
                raise e.pos.error(f"variable '{a}' is not bound here")
        sig = self.r.functions.get(name)
        if sig is not None and sig.arity != len(args):
            raise e.pos.error(f"function '{name}' takes {sig.arity} arguments, given {len(args)}")
        if sig is None:
            self.r.functions[name] = Signature(
                name, tuple(Param(f"?x{i}") for i in range(len(args)))
            )
        return FuncTerm(name, args)


def _free_variable(s: SList, scope: set[str]) -> Sym | None:
    """The first argument of atom ``s`` that is a variable outside ``scope``."""
    for a in s.items[1:]:
        if isinstance(a, Sym) and a.text.startswith("?") and a.text not in scope:
            return a
    return None


def _sexpr_text(s: SExpr) -> str:
    return s.text if isinstance(s, Sym) else "(" + " ".join(_sexpr_text(i) for i in s.items) + ")"


def reader_for_formulas(domain: Domain) -> _FormulaReader:
    """A formula reader that knows ``domain``'s predicates (for problems and goals)."""
    r = _DomainReader(domain.filename)
    r.predicates = dict(domain.predicates)
    r.undeclared = dict(domain.undeclared)
    r.functions = dict(domain.functions)
    r.types = dict(domain.types)
    return _FormulaReader(r)


__all__ = [
    "Action",
    "Derived",
    "Domain",
    "Signature",
    "parse_domain",
    "parse_typed_list",
    "read_domain",
    "reader_for_formulas",
    "typed_names",
]
