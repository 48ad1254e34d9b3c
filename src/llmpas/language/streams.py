"""Stream declarations in PDDLStream's syntax (``stream.pddl``), read unchanged.

A ``:stream`` with ``:outputs`` is a conditional sampler ψ = ⟨I, O, C, f⟩; one without is a
test; a ``:function`` declares a numeric cost computed in Python.

Two more kinds, with PDDLStream's meaning:

- ``(:predicate (P ?x ...) DOMAIN)``: an external predicate computed in Python (a bool), evaluated
  lazily and assumed *false* until evaluated (collision predicates, used as ``(not (P ...))``).
  It is read as a test stream named ``P`` that certifies the complement ``not__P``: the planner
  optimistically assumes ``(not (P ...))`` and evaluates the instances a plan relies on; a
  positive ``(P ...)`` holds only where the implementation said True.
- ``(:rule :inputs (?x ...) :domain ... :certified ...)`` (``:parameters`` is accepted for
  ``:inputs``): an axiom over stream facts with no implementation, read as an always-true test
  named ``rule-N``. A rule with a single ``:domain`` atom is also folded into the certified facts
  of every stream that certifies that atom, as PDDLStream does, so no planning iteration is spent
  on it.

``:optimizer`` is refused with one line naming it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.language.language_errors import ModelError
from llmpas.language.logic import Atom, conjuncts
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


@dataclass(frozen=True)
class StreamSchema:
    name: str
    inputs: tuple[str, ...]
    domain: tuple[Atom, ...]
    outputs: tuple[str, ...]
    certified: tuple[Atom, ...]
    fluents: tuple[str, ...] = ()
    kind: str = "stream"  # "stream", "rule" (no implementation) or "predicate" (external P)

    def __post_init__(self) -> None:
        if self.kind not in STREAM_KINDS:
            raise ModelError(f"stream {self.name!r}: unknown kind {self.kind!r}")
        names = self.inputs + self.outputs
        if len(set(names)) != len(names):
            raise ModelError(f"stream {self.name!r}: a variable is both input and output, or twice")
        dom_vars = {t for a in self.domain for t in a.args if t.startswith("?")}
        missing = [v for v in self.inputs if v not in dom_vars]
        if missing:
            raise ModelError(f"stream {self.name!r}: input {missing[0]} does not occur in :domain")
        for a in self.domain:
            for t in a.args:
                if t.startswith("?") and t not in self.inputs:
                    raise ModelError(f"stream {self.name!r}: :domain uses {t}, not an input")
        for a in self.certified:
            for t in a.args:
                if t.startswith("?") and t not in names:
                    raise ModelError(f"stream {self.name!r}: :certified uses unknown variable {t}")

    @property
    def is_test(self) -> bool:
        return not self.outputs

    @property
    def is_rule(self) -> bool:
        return self.kind == "rule"

    @property
    def is_predicate(self) -> bool:
        return self.kind == "predicate"


STREAM_KINDS = ("stream", "rule", "predicate")
EXTERNAL_PREFIX = "not__"


def complement(predicate: str) -> str:
    """The certified predicate of an external ``:predicate`` P: ``not__P``."""
    return f"{EXTERNAL_PREFIX}{predicate}"


@dataclass(frozen=True)
class FunctionSchema:
    """``(:function (Cost ?x) (Domain ?x))``: a numeric function evaluated in Python."""

    head: Atom
    domain: tuple[Atom, ...]

    @property
    def name(self) -> str:
        return self.head.predicate


@dataclass(frozen=True)
class StreamSpec:
    name: str
    streams: tuple[StreamSchema, ...] = ()
    functions: tuple[FunctionSchema, ...] = ()
    filename: str = "<stream>"

    def __post_init__(self) -> None:
        names = [s.name for s in self.streams] + [f.name for f in self.functions]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ModelError(f"{self.filename}: stream {dup[0]!r} is declared twice")

    def stream(self, name: str) -> StreamSchema:
        for s in self.streams:
            if s.name == name:
                return s
        raise ModelError(f"{self.filename}: unknown stream {name!r}")

    @property
    def external_predicates(self) -> dict[str, str]:
        """``:predicate`` P -> its complement ``not__P`` (what its test stream certifies)."""
        return {s.name: s.certified[0].predicate for s in self.streams if s.is_predicate}

    @property
    def test_predicates(self) -> set[str]:
        """Predicates certified by tests that can fail (rules cannot): those with rejections."""
        return {
            a.predicate for s in self.streams if s.is_test and not s.is_rule for a in s.certified
        }

    @property
    def certified_predicates(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for s in self.streams:
            for a in s.certified:
                out.setdefault(a.predicate, len(a.args))
        return out


EMPTY_STREAMS = StreamSpec("empty")


def read_streams(path: str | Path) -> StreamSpec:
    path = Path(path)
    return parse_streams(read_text(path, "PDDL stream file", PDDL_LIMIT), str(path))


def parse_streams(text: str, filename: str = "<stream>") -> StreamSpec:
    root, name, sections = parse_definition(text, "stream", filename)
    streams: list[StreamSchema] = []
    functions: list[FunctionSchema] = []
    for item in sections:
        s = expect_list(item, "a stream declaration")
        head = s.head()
        if head == ":stream":
            streams.append(_stream(s))
        elif head == ":function":
            functions.append(_function(s))
        elif head == ":predicate":
            streams.append(_predicate(s))
        elif head == ":rule":
            rules = sum(x.is_rule for x in streams)
            streams.append(_stream(s, f"rule-{rules + 1}"))
        elif head in UNSUPPORTED:
            raise s.pos.error(f"'{head}' is not supported ({UNSUPPORTED[head]})")
        else:
            raise s.pos.error(
                f"expected ':stream', ':function', ':predicate' or ':rule', found '{head}'"
            )
    try:
        return StreamSpec(name, fold_rules(streams), tuple(functions), filename)
    except ModelError as e:
        raise root.pos.error(str(e).removeprefix(f"{filename}: ")) from None


def _atoms(e: SExpr, what: str) -> tuple[Atom, ...]:
    s = expect_list(e, what)
    if s.head() == "and":
        return tuple(a for x in s.items[1:] for a in _atoms(x, what))
    return (_atom(s, what),)


def _atom(s: SList, what: str) -> Atom:
    if not s.items:
        raise s.pos.error(f"empty atom in {what}")
    if s.head() in ("not", "or", "exists", "forall", "imply"):
        raise s.pos.error(f"{what} must be a conjunction of atoms, found '{s.head()}'")
    pred = expect_sym(s[0], "a predicate").text
    return Atom(pred, tuple(expect_sym(a, "an argument").text for a in s.items[1:]))


def _vars(e: SExpr, what: str) -> tuple[str, ...]:
    s = expect_list(e, what)
    out = []
    for x in s:
        v = expect_sym(x, "a variable")
        if not v.text.startswith("?"):
            raise v.pos.error(f"expected a '?variable' in {what}, found '{v.text}'")
        out.append(v.text)
    return tuple(out)


UNSUPPORTED = {":optimizer": "PDDLStream's optimizers; declare a ':stream' instead"}


def _stream(s: SList, rule: str = "") -> StreamSchema:
    """A ``:stream``, or (with ``rule`` its generated name) a ``:rule``."""
    if rule:
        name, items, what = rule, s.items[1:], f"':rule' ({rule})"
    elif len(s) < 2:
        raise s.pos.error("expected '(:stream NAME :inputs ... )'")
    else:
        name = expect_sym(s[1], "a stream name").text
        if name.startswith(":"):
            raise s[1].pos.error(f"expected a stream name, found '{name}'")
        items, what = s.items[2:], f"stream '{name}'"
    fields: dict[str, tuple[Sym, SExpr]] = {}
    for key, vals in keyword_sections(items, what):
        if len(vals) != 1:
            raise key.pos.error(f"'{key.text}' takes exactly one value in {what}")
        k = ":inputs" if rule and key.text == ":parameters" else key.text
        if k in fields:
            raise key.pos.error(f"'{key.text}' given twice in {what}")
        fields[k] = (key, vals[0])
    known = {":inputs", ":domain", ":certified"} | (set() if rule else {":outputs", ":fluents"})
    for k, (key, _) in fields.items():
        if k not in known:
            raise key.pos.error(f"unknown keyword '{key.text}' in {what}")

    def get(k: str) -> SExpr | None:
        return fields[k][1] if k in fields else None

    inputs = _vars(get(":inputs") or SList((), s.pos), ":inputs")
    dom = get(":domain")
    domain = _atoms(dom, ":domain") if dom is not None and len(expect_list(dom, "")) else ()
    cert = get(":certified")
    certified = (
        _atoms(cert, ":certified") if cert is not None and len(expect_list(cert, "")) else ()
    )
    outputs = _vars(get(":outputs") or SList((), s.pos), ":outputs")
    fl = get(":fluents")
    fluents = (
        tuple(expect_sym(x, "a predicate").text for x in expect_list(fl, ":fluents")) if fl else ()
    )
    try:
        return StreamSchema(
            name, inputs, domain, outputs, certified, fluents, "rule" if rule else "stream"
        )
    except ModelError as e:
        raise s.pos.error(str(e)) from None


def _predicate(s: SList) -> StreamSchema:
    """``(:predicate (P ?x ...) DOMAIN)``: a test stream named P certifying ``(not__P ?x ...)``."""
    if len(s) not in (2, 3):
        raise s.pos.error("expected '(:predicate (NAME ?x ...) DOMAIN)'")
    head = _atom(expect_list(s[1], "a predicate head"), ":predicate")
    for v in head.args:
        if not v.startswith("?"):
            raise s[1].pos.error(f"expected a '?variable' in ':predicate', found '{v}'")
    domain = _atoms(s[2], ":predicate domain") if len(s) == 3 else ()
    try:
        return StreamSchema(
            head.predicate,
            head.args,
            domain,
            (),
            (Atom(complement(head.predicate), head.args),),
            kind="predicate",
        )
    except ModelError as e:
        raise s.pos.error(str(e)) from None


def fold_rules(streams: list[StreamSchema]) -> tuple[StreamSchema, ...]:
    """Add the certified facts of every single-atom rule to the streams that certify its atom
    (repeatedly, so rules feed rules); the rules stay, for facts from init."""
    out = list(streams)
    changed = True
    while changed:
        changed = False
        for rule in (r for r in out if r.is_rule and len(r.domain) == 1):
            (pattern,) = rule.domain
            for i, st in enumerate(out):
                new = _implied(rule, pattern, st)
                if new:
                    out[i] = replace(st, certified=st.certified + new)
                    changed = True
    return tuple(out)


def _implied(rule: StreamSchema, pattern: Atom, st: StreamSchema) -> tuple[Atom, ...]:
    """What ``rule`` adds to ``st``'s certified facts (none for rules and external predicates)."""
    if st.kind != "stream":
        return ()
    new: list[Atom] = []
    for a in st.certified:
        if a.predicate != pattern.predicate or len(a.args) != len(pattern.args):
            continue
        env: dict[str, str] = {}
        pairs = zip(pattern.args, a.args, strict=True)
        if any((env.setdefault(v, t) if v.startswith("?") else v) != t for v, t in pairs):
            continue
        for c in rule.certified:
            atom = Atom(c.predicate, tuple(env.get(t, t) for t in c.args))
            if atom not in st.certified and atom not in new:
                new.append(atom)
    return tuple(new)


def _function(s: SList) -> FunctionSchema:
    if len(s) not in (2, 3):
        raise s.pos.error("expected '(:function (NAME ?x ...) DOMAIN)'")
    head = _atom(expect_list(s[1], "a function head"), ":function")
    domain = _atoms(s[2], ":function domain") if len(s) == 3 else ()
    dom_vars = {t for a in domain for t in a.args}
    for v in head.args:
        if v.startswith("?") and v not in dom_vars:
            raise s.pos.error(f"function '{head.predicate}': {v} does not occur in its domain")
    return FunctionSchema(head, domain)


__all__ = [
    "EMPTY_STREAMS",
    "FunctionSchema",
    "Pos",
    "StreamSchema",
    "StreamSpec",
    "complement",
    "conjuncts",
    "fold_rules",
    "parse_streams",
    "read_streams",
]
