"""Stream declarations in PDDLStream's syntax (``stream.pddl``), read unchanged.

A ``:stream`` with ``:outputs`` is a conditional sampler ψ = ⟨I, O, C, f⟩; one without is a
test; a ``:function`` declares a numeric cost computed in Python.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.language.errors import ModelError
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

    def __post_init__(self) -> None:
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
            raise s.pos.error("':predicate' streams are not supported; use a test stream")
        else:
            raise s.pos.error(f"expected ':stream' or ':function', found '{head}'")
    try:
        return StreamSpec(name, tuple(streams), tuple(functions), filename)
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


def _stream(s: SList) -> StreamSchema:
    if len(s) < 2:
        raise s.pos.error("expected '(:stream NAME :inputs ... )'")
    name = expect_sym(s[1], "a stream name").text
    if name.startswith(":"):
        raise s[1].pos.error(f"expected a stream name, found '{name}'")
    fields: dict[str, tuple[Sym, SExpr]] = {}
    for key, vals in keyword_sections(s.items[2:], f"stream '{name}'"):
        if len(vals) != 1:
            raise key.pos.error(f"'{key.text}' takes exactly one value in stream '{name}'")
        if key.text in fields:
            raise key.pos.error(f"'{key.text}' given twice in stream '{name}'")
        fields[key.text] = (key, vals[0])
    known = {":inputs", ":domain", ":outputs", ":certified", ":fluents"}
    for k, (key, _) in fields.items():
        if k not in known:
            raise key.pos.error(f"unknown keyword '{k}' in stream '{name}'")

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
        return StreamSchema(name, inputs, domain, outputs, certified, fluents)
    except ModelError as e:
        raise s.pos.error(str(e)) from None


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
    "conjuncts",
    "parse_streams",
    "read_streams",
]
