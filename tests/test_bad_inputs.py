"""The bad-input corpus, run through the real command line: one process per case.

Every case runs ``python -m llmpas.cli ...`` in a subprocess (PYTHONPATH passed through) under
a shell ``ulimit -v`` of 2 GB and a time limit, and must end with: no traceback, the exit status
of its class (2 usage, 3 input, 4 planner, 6 output: ``llmpas.errors.ExitCode``), and stderr
holding exactly one line ``error: ...`` that names the place (the file, with line and column
where the case says so, or the option).

Cases come from two sources:

- ``tests/data/bad_inputs/KIND/*``: one defective file each (domain, problem and stream PDDL,
  ``--bindings`` Python files, household scenario TOML), whose first line says what to expect:
  ``; expect: CODE TEXT`` (``#`` for Python and TOML). Each runs with good companions
  (``hangs/``: bindings whose streams never return, planned with ``--max-time 2``);
- :data:`GENERATED`: cases that cannot be committed as small text files (encodings, FIFOs,
  devices, multi-MB and deeply nested inputs, hostile file names) and bad options and paths.

The cases run a few at a time (the fixture :func:`results`); each is reported as its own test.
"""

from __future__ import annotations

import codecs
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from llmpas.errors import ExitCode

HERE = Path(__file__).parent
BAD = HERE / "data" / "bad_inputs"
GOOD = HERE / "planning" / "data"
MEMORY_KB = 2 * 1024 * 1024  # ulimit -v: 2 GB of address space
PEAK_MB = 1024  # and at most this much resident memory at any time
TIMEOUT = 60.0  # seconds per case
WORKERS = min(4, max(2, os.cpu_count() or 2))

USAGE, INPUT, PLANNER, IO = ExitCode.USAGE, ExitCode.INPUT, ExitCode.PLANNER, ExitCode.IO
LLM = ExitCode.LLM


@dataclass(frozen=True)
class Case:
    """One bad input: the command line (``{good}``, ``{bad}`` and ``{gen}`` are folders), the
    exit status expected and the texts its one error line must contain."""

    id: str
    argv: tuple[str, ...]
    code: ExitCode
    needles: tuple[str, ...]
    timeout: float = TIMEOUT
    marks: tuple[pytest.MarkDecorator, ...] = ()


@dataclass
class Outcome:
    code: int | None
    stdout: str
    stderr: str
    seconds: float
    peak_mb: float
    hung: bool = False
    argv: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------- command lines


def plan_domain(domain: str) -> tuple[str, ...]:
    return plan_files(domain=domain)


def plan_files(
    domain: str = "{good}/domain.pddl",
    problem: str = "{good}/problem.pddl",
    streams: str = "{good}/stream.pddl",
    bindings: str = "{good}/streams.py:STREAMS",
) -> tuple[str, ...]:
    return (
        "plan", domain, problem, "--streams", streams, "--bindings", bindings, "--max-time", "20",
    )  # fmt: skip


def execute(scenario: str, *more: str) -> tuple[str, ...]:
    return ("execute", scenario, "--max-time", "20", *more)


STATIC_ARGV: dict[str, Callable[[str], tuple[str, ...]]] = {
    "domain": plan_domain,
    "problem": lambda f: plan_files(problem=f),
    "stream": lambda f: plan_files(streams=f),
    "bindings": lambda f: plan_files(bindings=f"{f}:STREAMS"),
    # stream implementations that never return: planning is stopped 1.5 x --max-time + 10 s in
    "hangs": lambda f: (*plan_files(bindings=f"{f}:STREAMS"), "--max-time", "2"),
    "scenario": execute,
}
EXPECT = re.compile(rb"^[;#] expect: (\d+) ?(.*)$")


def static_cases() -> list[Case]:
    cases = []
    for path in sorted(BAD.glob("*/*")):
        first = path.read_bytes().split(b"\n", 1)[0]
        m = EXPECT.match(first)
        assert m, f"{path}: the first line must say '; expect: CODE TEXT'"
        rel = path.relative_to(BAD)
        argv = STATIC_ARGV[rel.parts[0]]("{bad}/" + rel.as_posix())
        needles = (path.name, m.group(2).decode()) if m.group(2) else (path.name,)
        cases.append(Case(rel.as_posix(), argv, ExitCode(int(m.group(1))), needles))
    return cases


# ------------------------------------------------------------------------- generated files

DOMAIN = (GOOD / "domain.pddl").read_bytes()
PROBLEM = (GOOD / "problem.pddl").read_bytes()


def _nominal() -> bytes:
    from llmpas.worlds.household.scenario import SCENARIO_DIR

    return (SCENARIO_DIR / "nominal.toml").read_bytes()


def _deep(opening: str, depth: int) -> bytes:
    inner = opening * depth + "(Conf ?q1)" + ")" * depth
    return DOMAIN.replace(b"(and (Conf ?q1) (Conf ?q2) (AtConf ?q1))", inner.encode())


def _blowup() -> bytes:
    """One action with 8 parameters over 40 objects: 40^8 groundings if nothing prunes them."""
    params = " ".join(f"?x{i}" for i in range(8))
    pre = " ".join(f"(Obj ?x{i})" for i in range(8))
    domain = (
        "(define (domain blowup) (:predicates (Obj ?x) (Goal) (Link ?a ?b))\n"
        f"  (:action go :parameters ({params}) :precondition (and {pre} "
        "(not (Link ?x0 ?x7)))\n    :effect (Goal)))\n"
    )
    objects = " ".join(f"o{i}" for i in range(40))
    init = " ".join(f"(Obj o{i})" for i in range(40))
    problem = (
        f"(define (problem p) (:domain blowup) (:objects {objects})\n"
        f"  (:init {init}) (:goal (and (Goal) (Link o0 o1))))\n"
    )
    return (domain + "\x00" + problem).encode()


RAISING = f"""import sys
sys.path.insert(0, {str(GOOD)!r})
from streams import make_streams
from llmpas.language.bindings import sampler, test

def wrong_shape(b, p):
    yield "not a tuple"

def not_bool(*args):
    return "yes"

def raises(b, r):
    raise ZeroDivisionError("calibration")
    yield

SHAPE = {{**make_streams(), "reach": sampler(wrong_shape)}}
TEST = {{**make_streams(), "test-cfree": test(not_bool)}}
RAISES = {{**make_streams(), "sample-pose": sampler(raises)}}
""".encode()


def generated_files() -> dict[str, bytes]:
    """File name -> bytes, written to ``{gen}`` once per session."""
    d, p, n = DOMAIN, PROBLEM, _nominal()
    empty_bindings = b"STREAMS = {}\n"
    blowup_domain, blowup_problem = _blowup().split(b"\x00")
    return {
        "utf16-bom.pddl": codecs.BOM_UTF16_LE + d.decode().encode("utf-16-le"),
        "utf16-be-bom.pddl": codecs.BOM_UTF16_BE + d.decode().encode("utf-16-be"),
        "utf16-no-bom.pddl": d.decode().encode("utf-16-le"),
        "utf32-bom.pddl": d.decode().encode("utf-32"),
        "latin1.pddl": d.replace(b"; a 1-D", "; é 1-D".encode("latin-1")),
        "invalid-byte.pddl": d.replace(b"(Conf ?q1)", b"(Conf \xff?q1)", 1),
        "overlong.pddl": d.replace(b"(Conf ?q1)", b"(Conf \xc0\xaf)", 1),
        "surrogate.pddl": d.replace(b"(Conf ?q1)", b"(Conf \xed\xa0\x80)", 1),
        "truncated-utf8.pddl": d + "é".encode()[:1],
        "nul-byte.pddl": d.replace(b"(HandEmpty)", b"(Hand\x00Empty)", 1),
        "binary.pddl": bytes(range(256)) * 64,
        "gzip.pddl": b"\x1f\x8b\x08\x00" + bytes(200),
        "utf16-problem.pddl": p.decode().encode("utf-16"),
        "invalid-problem.pddl": p.replace(b"(HandEmpty)", b"(Hand\xfeEmpty)"),
        "utf16-stream.pddl": (GOOD / "stream.pddl").read_text().encode("utf-16"),
        "utf16-scenario.toml": n.decode().encode("utf-16"),
        "latin1-scenario.toml": n.replace(b"Put the cube", "Put the cubé".encode("latin-1")),
        "nul-scenario.toml": n.replace(b"seed = 1", b"seed = 1\x00"),
        "utf16-bindings.py": empty_bindings.decode().encode("utf-16"),
        "latin1-bindings.py": b"# caf\xe9\n" + empty_bindings,
        "deep-and.pddl": _deep("(and ", 100_000),
        "deep-not.pddl": _deep("(not ", 50_000),
        "deep-open.pddl": b"(" * 1_000_000,
        "deep-problem.pddl": p.replace(b"(:goal (and", b"(:goal " + b"(or " * 60_000 + b"(and")
        + b")" * 60_000,
        "huge-domain.pddl": d + b"; " + b"x" * (8 * 1024 * 1024) + b"\n",
        "huge-problem.pddl": p + b" " * (8 * 1024 * 1024 + 1),
        "huge-scenario.toml": n + b"# " + b"y" * (1024 * 1024) + b"\n",
        "huge-bindings.py": empty_bindings + b"#" * (4 * 1024 * 1024 + 1),
        "many-tokens.pddl": d.replace(b"(:requirements", b"()" * 500_000 + b"(:requirements"),
        "deep-array.toml": n + b"\nx = " + b"[" * 100_000 + b"]" * 100_000 + b"\n",
        "deep-inline-table.toml": n + b"\nx = " + b"{a=" * 5000 + b"1" + b"}" * 5000 + b"\n",
        "dotted-key.toml": n + b"\n" + b"a." * 200_000 + b"a = 1\n",
        "many-fields.toml": n.replace(
            b"seed = 1", b"seed = 1\n" + b"".join(b"k%d = %d\n" % (i, i) for i in range(20_000))
        ),
        "deep-goal.toml": n.replace(
            b'goal = "(and (On cube bowl))"', b'goal = "' + b"(not " * 50_000 + b'"'
        ),
        "deep-bindings.py": b"x = " + b"[" * 100_000 + b"]" * 100_000 + b"\n",
        "hang-at-import.py": b"while True:\n    pass\n",
        "raising.py": RAISING,
        "blowup-domain.pddl": blowup_domain,
        "blowup-problem.pddl": blowup_problem,
        "empty.pddl": b"",
        "a-file": b"not a folder\n",
        "bom-comment-only.pddl": codecs.BOM_UTF8 + b"; only a comment\n",
        "scenario-dir.toml/placeholder": b"",
        "bindings-dir.py/placeholder": b"",
        "name\nwith newline.pddl": d.replace(b"(:predicates (Block", b"(:predicate (Block"),
        "name\x1b[31mred.pddl": d.replace(b"(:predicates (Block", b"(:predicate (Block"),
        "[bold]markup[/].pddl": d.replace(b"(:predicates (Block", b"(:predicate (Block"),
        "[/].pddl": d.replace(b"(:predicates (Block", b"(:predicate (Block"),
        "escape-in-token.pddl": d.replace(b"(:predicates (Block", b"(:pre\x1b[2Jdicates (Block"),
        "control-in-symbol.pddl": d.replace(b"(:predicates", "(:pre\x07di\u2028cates".encode()),
    }


def make_generated(folder: Path) -> None:
    for name, data in generated_files().items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    os.mkfifo(folder / "fifo.pddl")
    os.mkfifo(folder / "fifo.toml")
    os.mkfifo(folder / "fifo.py")
    (folder / "folder.pddl").mkdir()
    (folder / "problems-utf16").mkdir()
    (folder / "problems-utf16" / "p1.pddl").write_bytes(PROBLEM.decode().encode("utf-16"))
    (folder / "problems-fifo").mkdir()
    os.mkfifo(folder / "problems-fifo" / "p1.pddl")
    bad_name = os.fsencode(folder / "undecodable-") + b"\xff\xfe.pddl"
    with open(bad_name, "wb") as f:
        f.write(DOMAIN.replace(b"(:predicates (Block", b"(:predicate (Block"))


def _gen(name: str) -> str:
    return "{gen}/" + name


# ------------------------------------------------------------------------- generated cases

_ENCODING = [
    ("utf16-bom.pddl", "UTF-16 text (byte-order mark)"),
    ("utf16-be-bom.pddl", "UTF-16 text (byte-order mark)"),
    ("utf16-no-bom.pddl", "NUL byte at byte offset 1 (UTF-16 text?)"),
    ("utf32-bom.pddl", "UTF-32 text (byte-order mark)"),
    ("latin1.pddl", ":1: PDDL domain file is not UTF-8 text: byte 0xe9 at byte offset 2"),
    ("invalid-byte.pddl", ":11: PDDL domain file is not UTF-8 text: byte 0xff"),
    ("overlong.pddl", "not UTF-8 text: byte 0xc0"),
    ("surrogate.pddl", "not UTF-8 text: byte 0xed"),
    ("truncated-utf8.pddl", "not UTF-8 text: byte 0xc3"),
    ("nul-byte.pddl", ":5: PDDL domain file holds a NUL byte"),
    ("binary.pddl", "not UTF-8 text: byte 0x80 at byte offset 128"),
    ("gzip.pddl", "not UTF-8 text: byte 0x8b at byte offset 1"),
    ("deep-and.pddl", ":11:509: parentheses nested deeper than 100 levels"),
    ("deep-not.pddl", ":11:509: parentheses nested deeper than 100 levels"),
    ("deep-open.pddl", ":1:101: parentheses nested deeper than 100 levels"),
    ("huge-domain.pddl", "larger than the 8 MiB limit"),
    ("many-tokens.pddl", ":3:3: expected a domain section such as '(:action ...)', found '()'"),
    ("folder.pddl", "expected a PDDL domain file, found a folder"),
    ("fifo.pddl", "expected a PDDL domain file, found a FIFO"),
    ("empty.pddl", ":1:1: empty file"),
    ("bom-comment-only.pddl", "empty file"),
    ("escape-in-token.pddl", "unknown domain section ':pre\\x1b[2jdicates'"),
    ("control-in-symbol.pddl", "unknown domain section ':pre\\x07di'"),
]

GENERATED: list[Case] = [
    *(Case(f"domain:{n}", plan_domain(_gen(n)), INPUT, (n, t)) for n, t in _ENCODING),
    Case("domain:/dev/zero", plan_domain("/dev/zero"), INPUT, ("/dev/zero", "a device")),
    Case("domain:/dev/null", plan_domain("/dev/null"), INPUT, ("/dev/null", "a device")),
    Case("domain:/dev/stdin", plan_domain("/dev/stdin"), INPUT, ("/dev/stdin", "a device")),
    Case("domain:/proc/self/mem", plan_domain("/proc/self/mem"), INPUT, ("/proc/self/mem",)),
    Case("domain:/", plan_domain("/"), INPUT, ("expected a PDDL domain file, found a folder",)),
    Case("domain:missing", plan_domain("nope.pddl"), INPUT, ("nope.pddl", "no such file")),
    Case("domain:not-a-dir", plan_domain(_gen("a-file/domain.pddl")), INPUT, ("a-file/domain",)),
    Case("domain:too-long-name", plan_domain("d" * 5000 + ".pddl"), INPUT, ("name too long",)),
    Case(
        "domain:newline-in-name",
        plan_domain(_gen("name\nwith newline.pddl")),
        INPUT,
        ("name\\nwith newline.pddl:4:3: unknown domain section",),
    ),
    Case(
        "domain:escape-in-name",
        plan_domain(_gen("name\x1b[31mred.pddl")),
        INPUT,
        ("name\\x1b[31mred.pddl:4:3",),
    ),
    Case(
        "domain:markup-in-name",
        plan_domain(_gen("[bold]markup[/].pddl")),
        INPUT,
        ("[bold]markup[/].pddl:4:3",),
    ),
    Case("domain:closing-markup-name", plan_domain(_gen("[/].pddl")), INPUT, ("[/].pddl:4:3",)),
    Case(
        "domain:undecodable-name",
        plan_domain(_gen("undecodable-\udcff\udcfe.pddl")),
        INPUT,
        ("undecodable-\\udcff\\udcfe.pddl:4:3",),
    ),
    Case(
        "problem:utf16",
        plan_files(problem=_gen("utf16-problem.pddl")),
        INPUT,
        ("utf16-problem.pddl", "PDDL problem file is UTF-16"),
    ),
    Case(
        "problem:invalid-byte",
        plan_files(problem=_gen("invalid-problem.pddl")),
        INPUT,
        ("invalid-problem.pddl:5:", "byte 0xfe"),
    ),
    Case(
        "problem:deep-or",
        plan_files(problem=_gen("deep-problem.pddl")),
        INPUT,
        ("deep-problem.pddl:8:402:", "nested deeper than 100"),
    ),
    Case(
        "problem:huge",
        plan_files(problem=_gen("huge-problem.pddl")),
        INPUT,
        ("huge-problem.pddl", "larger than the 8 MiB limit"),
    ),
    Case("problem:/dev/zero", plan_files(problem="/dev/zero"), INPUT, ("/dev/zero", "device")),
    Case("problem:folder", plan_files(problem="{gen}/folder.pddl"), INPUT, ("folder.pddl",)),
    Case("problem:missing", plan_files(problem="nope.pddl"), INPUT, ("nope.pddl",)),
    Case(
        "stream:utf16",
        plan_files(streams=_gen("utf16-stream.pddl")),
        INPUT,
        ("utf16-stream.pddl", "PDDL stream file is UTF-16"),
    ),
    Case("stream:fifo", plan_files(streams=_gen("fifo.pddl")), INPUT, ("fifo.pddl", "FIFO")),
    Case("stream:missing", plan_files(streams="nope.pddl"), INPUT, ("nope.pddl",)),
    Case(
        "bindings:utf16",
        plan_files(bindings=_gen("utf16-bindings.py:STREAMS")),
        INPUT,
        ("utf16-bindings.py", "UTF-16"),
    ),
    Case(
        "bindings:latin1",
        plan_files(bindings=_gen("latin1-bindings.py:STREAMS")),
        INPUT,
        ("latin1-bindings.py:1:", "byte 0xe9"),
    ),
    Case(
        "bindings:huge",
        plan_files(bindings=_gen("huge-bindings.py:STREAMS")),
        INPUT,
        ("huge-bindings.py", "4 MiB limit"),
    ),
    Case(
        "bindings:deep",
        plan_files(bindings=_gen("deep-bindings.py:STREAMS")),
        INPUT,
        ("deep-bindings.py:1:",),
    ),
    Case("bindings:fifo", plan_files(bindings=_gen("fifo.py:STREAMS")), INPUT, ("fifo.py", "FIFO")),
    Case(
        "bindings:folder",
        plan_files(bindings=_gen("bindings-dir.py:STREAMS")),
        INPUT,
        ("bindings-dir.py", "folder"),
    ),
    Case(
        "bindings:missing-file",
        plan_files(bindings="nope.py:STREAMS"),
        INPUT,
        ("nope.py", "no such file"),
    ),
    Case(
        "bindings:/dev/zero",
        plan_files(bindings="/dev/zero:STREAMS"),
        INPUT,
        ("/dev/zero", "device"),
    ),
    Case(
        "bindings:hang",
        plan_files(bindings=_gen("hang-at-import.py:STREAMS")),
        INPUT,
        ("hang-at-import.py", "took longer than 30 s"),
        timeout=90,
    ),
    Case(
        "bindings:wrong-output-shape",
        plan_files(bindings=_gen("raising.py:SHAPE")),
        PLANNER,
        ("planner: stream reach(", "produced 'not a tuple'; expected a tuple of 1 output"),
    ),
    Case(
        "bindings:test-not-bool",
        plan_files(bindings=_gen("raising.py:TEST")),
        PLANNER,
        ("planner: stream test-cfree(", "returned str, not bool"),
    ),
    Case(
        "bindings:sampler-raises",
        plan_files(bindings=_gen("raising.py:RAISES")),
        PLANNER,
        ("planner: stream sample-pose(", "raised ZeroDivisionError: calibration"),
    ),
    Case("bindings:no-name", plan_files(bindings="{good}/streams.py"), USAGE, ("--bindings",)),
    Case("bindings:empty-name", plan_files(bindings="{good}/streams.py:"), USAGE, ("--bindings",)),
    Case("bindings:bad-name", plan_files(bindings="{good}/streams.py:1x"), USAGE, ("--bindings",)),
    Case("bindings:no-file", plan_files(bindings=":STREAMS"), USAGE, ("--bindings",)),
    Case(
        "bindings:no-module",
        plan_files(bindings="no_such_module_xyz:STREAMS"),
        INPUT,
        ("--bindings", "no_such_module_xyz"),
    ),
    Case(
        "bindings:relative-module",
        plan_files(bindings="..x:STREAMS"),
        INPUT,
        ("--bindings", "'..x'"),
    ),
    Case(
        "bindings:module-not-mapping",
        plan_files(bindings="os:path"),
        INPUT,
        ("module os: path is module, not a mapping",),
    ),
    Case(
        "bindings:module-callable",
        plan_files(bindings="json:loads"),
        INPUT,
        ("calling loads() raised TypeError",),
    ),
    Case(
        "bindings:module-missing-name",
        plan_files(bindings="json:STREAMS"),
        INPUT,
        ("module json: defines no 'STREAMS'",),
    ),
    Case(
        "scenario:utf16",
        execute(_gen("utf16-scenario.toml")),
        INPUT,
        ("utf16-scenario.toml", "UTF-16"),
    ),
    Case(
        "scenario:latin1",
        execute(_gen("latin1-scenario.toml")),
        INPUT,
        ("latin1-scenario.toml:3:", "byte 0xe9"),
    ),
    Case(
        "scenario:nul",
        execute(_gen("nul-scenario.toml")),
        INPUT,
        ("nul-scenario.toml:5:", "NUL byte"),
    ),
    Case(
        "scenario:huge",
        execute(_gen("huge-scenario.toml")),
        INPUT,
        ("huge-scenario.toml", "1 MiB limit"),
    ),
    Case(
        "scenario:deep-array",
        execute(_gen("deep-array.toml")),
        INPUT,
        ("deep-array.toml", "nested too deeply"),
    ),
    Case(
        "scenario:deep-inline-table",
        execute(_gen("deep-inline-table.toml")),
        INPUT,
        ("deep-inline-table.toml",),
    ),
    Case(
        "scenario:dotted-key",
        execute(_gen("dotted-key.toml")),
        INPUT,
        ("dotted-key.toml", "more than 16 dotted parts"),
    ),
    Case(
        "scenario:many-fields",
        execute(_gen("many-fields.toml")),
        INPUT,
        ("many-fields.toml", "k0: unknown field"),
    ),
    Case(
        "scenario:deep-goal",
        execute(_gen("deep-goal.toml")),
        INPUT,
        ("deep-goal.toml", "nested deeper than 100 levels"),
    ),
    Case("scenario:fifo", execute(_gen("fifo.toml")), INPUT, ("fifo.toml", "FIFO")),
    Case(
        "scenario:folder",
        execute(_gen("scenario-dir.toml")),
        INPUT,
        ("scenario-dir.toml", "folder"),
    ),
    Case("scenario:/dev/zero", execute("/dev/zero"), INPUT, ("/dev/zero", "device")),
    Case("scenario:missing-toml", execute("nope.toml"), INPUT, ("nope.toml", "no such file")),
    Case("scenario:unknown-name", execute("nosuch"), USAGE, ("'nosuch'", "nominal")),
    Case("run:unknown-scenario", ("run", "nosuch", "--llm", "oracle"), USAGE, ("'nosuch'",)),
    Case("run:fifo", ("run", _gen("fifo.toml"), "--llm", "oracle"), INPUT, ("fifo.toml",)),
    Case("bt:unknown-scenario", ("bt", "show", "nosuch"), USAGE, ("'nosuch'",)),
    Case("names:long-scenario", execute("s" * 5000), USAGE, ("File name too long",)),
    Case(
        "names:path-traversal",
        execute("../" * 12 + "etc/passwd"),
        INPUT,
        ("etc/passwd", "invalid TOML"),
    ),
    Case("names:scenario-with-newline", execute("nomi\nnal"), USAGE, ("'nomi\\nnal'",)),
    Case(
        "bench:problems-utf16",
        ("bench", "blocksworld", "--llm", "oracle", "--problems", _gen("problems-utf16")),
        INPUT,
        ("p1.pddl", "UTF-16"),
    ),
    Case(
        "bench:problems-fifo",
        ("bench", "blocksworld", "--llm", "oracle", "--problems", _gen("problems-fifo")),
        INPUT,
        ("p1.pddl", "FIFO"),
    ),
    Case(
        "bench:problems-missing",
        ("bench", "blocksworld", "--llm", "oracle", "--problems", "nope"),
        INPUT,
        ("nope",),
    ),
    Case(
        "bench:suite-device",
        ("bench", "prompting", "--llm", "oracle", "--suite", "/dev/null"),
        INPUT,
        ("/dev/null",),
    ),
    Case(
        "llm:model-is-a-device",
        ("run", "nominal", "--llm", "llama-cpp:/dev/zero"),
        LLM,
        ("/dev/zero",),
    ),
    Case("llm:model-is-a-folder", ("run", "nominal", "--llm", "llama-cpp:/"), LLM, ("model",)),
    Case("bt:utf16", ("bt", "export", _gen("utf16-scenario.toml")), INPUT, ("utf16-scenario",)),
    # ------------------------------------------------------------------ options
    *(
        Case(
            f"option:--max-time {v}",
            ("plan", "--example", "blocksworld", "--max-time", v),
            USAGE,
            ("--max-time", repr(v) if v != "-inf" else "expected one argument"),
        )
        for v in ("nan", "inf", "-inf", "-1", "0", "abc", "1e309", "", "1e9")
    ),
    *(
        Case(
            f"option:--size {v}",
            ("plan", "--example", "mobile", "--size", v),
            USAGE,
            ("--size", repr(v)),
        )
        for v in ("-3", "0", "2.5", "1e3", "1_000", "99999999999999999999", "x")
    ),
    *(
        Case(f"option:--seed {v}", ("plan", "--example", "tamp2d", "--seed", v), USAGE, ("--seed",))
        for v in ("-1", "0.5", "nan", str(2**64))
    ),
    Case(
        "option:--algorithm",
        ("plan", "--example", "mobile", "--algorithm", "astar"),
        USAGE,
        ("--algorithm", "'astar'"),
    ),
    Case("option:--example", ("plan", "--example", "sokoban"), USAGE, ("sokoban", "blocksworld")),
    Case("option:plan-no-files", ("plan",), USAGE, ("DOMAIN and PROBLEM",)),
    Case("option:plan-one-file", ("plan", "{good}/domain.pddl"), USAGE, ("DOMAIN and PROBLEM",)),
    Case("option:no-command", (), USAGE, ("llmpas",)),
    Case("option:unknown-command", ("plann",), USAGE, ("'plann'",)),
    Case("option:unknown-option", ("plan", "--example", "mobile", "--fast"), USAGE, ("--fast",)),
    Case(
        "option:missing-value",
        ("plan", "--example", "mobile", "--bindings"),
        USAGE,
        ("--bindings",),
    ),
    Case(
        "option:--episodes 0", ("bench", "perturbation", "--episodes", "0"), USAGE, ("--episodes",)
    ),
    Case(
        "option:--episodes -5",
        ("bench", "perturbation", "--episodes", "-5"),
        USAGE,
        ("--episodes",),
    ),
    Case("option:--trials 0", ("bench", "planning-time", "--trials", "0"), USAGE, ("--trials",)),
    Case("option:--sizes 0", ("bench", "planning-time", "--sizes", "4", "0"), USAGE, ("--sizes",)),
    Case("option:--jobs 0", ("bench", "planning-time", "--jobs", "0"), USAGE, ("--jobs",)),
    Case(
        "option:bench max-time inf",
        ("bench", "planning-time", "--max-time", "inf"),
        USAGE,
        ("--max-time",),
    ),
    Case(
        "option:--rounds 0",
        ("run", "nominal", "--llm", "oracle", "--rounds", "0"),
        USAGE,
        ("--rounds",),
    ),
    Case(
        "option:--rounds -1",
        ("run", "nominal", "--llm", "oracle", "--rounds", "-1"),
        USAGE,
        ("--rounds",),
    ),
    Case("option:--llm unknown", ("run", "nominal", "--llm", "gpt5"), USAGE, ("--llm", "gpt5")),
    Case("option:--llm openai:", ("run", "nominal", "--llm", "openai:"), USAGE, ("--llm",)),
    Case("option:--llm replay:", ("run", "nominal", "--llm", "replay:"), USAGE, ("--llm",)),
    Case(
        "option:--record oracle",
        ("run", "nominal", "--llm", "oracle", "--record", "cas"),
        USAGE,
        ("--record",),
    ),
    Case("option:--world", ("run", "nominal", "--world", "mars"), USAGE, ("--world", "'mars'")),
    Case("option:--method", ("run", "nominal", "--method", "cot"), USAGE, ("--method", "'cot'")),
    Case(
        "option:pybullet scenario",
        ("run", "nosuch", "--world", "pybullet"),
        USAGE,
        ("no scenario 'nosuch' in pybullet",),
    ),
    Case("option:model name", ("model", "install", "no-such-model"), USAGE, ("no-such-model",)),
    Case(
        "option:--temperature nan",
        ("bench", "prompting", "--llm", "oracle", "--temperature", "nan"),
        USAGE,
        ("temperature",),
    ),
    Case(
        "option:--samples 0",
        ("bench", "prompting", "--llm", "oracle", "--samples", "0"),
        USAGE,
        ("samples",),
    ),
    Case(
        "option:--count -1",
        ("bench", "blocksworld", "--llm", "oracle", "--count", "-1"),
        USAGE,
        ("count",),
    ),
    Case("option:bench all --jobs -1", ("bench", "all", "--jobs", "-1"), USAGE, ("jobs",)),
    Case(
        "option:--examples",
        ("bench", "planning-time", "--examples", "sokoban"),
        USAGE,
        ("--examples", "'sokoban'", "tamp2d"),
    ),
    Case("option:--seeds -1", ("bench", "validate-data", "--seeds", "-1"), USAGE, ("--seeds",)),
    # ------------------------------------------------------------------ --out and other outputs
    Case("out:/proc", execute("nominal", "--out", "/proc/x"), IO, ("--out /proc/x",)),
    Case("out:/proc/self", execute("nominal", "--out", "/proc/self/x/y"), IO, ("--out",)),
    Case("out:file", execute("nominal", "--out", _gen("a-file")), IO, ("a-file: not a folder",)),
    Case(
        "out:below-file",
        execute("nominal", "--out", _gen("a-file/sub")),
        IO,
        ("a-file", "not a folder"),
    ),
    Case("out:/dev/null", execute("nominal", "--out", "/dev/null"), IO, ("/dev/null",)),
    Case("out:/dev/full-below", execute("nominal", "--out", "/dev/full/x"), IO, ("/dev/full",)),
    Case(
        "out:run",
        ("run", "nominal", "--llm", "oracle", "--out", "/proc/run"),
        IO,
        ("--out /proc/run",),
    ),
    Case(
        "out:run-record",
        ("run", "nominal", "--llm", "replay:x", "--record", "/proc/c"),
        IO,
        ("--record /proc/c",),
    ),
    Case("out:bt-export", ("bt", "export", "nominal", "--out", "/proc/bt"), IO, ("--out /proc",)),
    Case("out:bt-png", ("bt", "show", "nominal", "--png", "/sys/x"), IO, ("--png /sys/x",)),
    Case(
        "out:bench",
        ("bench", "perturbation", "--episodes", "1", "--out", "/proc/b"),
        IO,
        ("--out /proc/b",),
    ),
    Case(
        "out:bench-prompting",
        ("bench", "prompting", "--llm", "oracle", "--out", "/proc/p"),
        IO,
        ("--out /proc/p",),
    ),
    # the grounding blow-up (8 parameters over 40 objects) is not a bad input: it plans to a
    # "timeout" result (exit 1) within --max-time under the memory limit, tested with the planner
    # (tests/planning/test_downward.py)
]


def all_cases() -> list[Case]:
    return static_cases() + GENERATED


CASES = all_cases()


def test_the_corpus_has_at_least_150_cases_of_every_kind() -> None:
    kinds = {c.id.split("/")[0].split(":")[0] for c in CASES}
    assert len(CASES) >= 150
    assert {"domain", "problem", "stream", "bindings", "scenario", "option", "out"} <= kinds
    assert len({c.id for c in CASES}) == len(CASES)


# ------------------------------------------------------------------------- running


def _fill(argv: tuple[str, ...], folders: dict[str, str]) -> list[str]:
    out = []
    for a in argv:
        for key, value in folders.items():
            a = a.replace("{" + key + "}", value)
        out.append(a)
    return out


def run_cli(argv: list[str], cwd: Path, timeout: float) -> Outcome:
    """``python -m llmpas.cli ARGV`` under ``ulimit -v``; killed (with its process group) when
    it runs longer than ``timeout``. ``peak_mb``: the process's peak resident memory."""
    cmd = ["bash", "-c", f'ulimit -v {MEMORY_KB} && exec "$@"', "bash",
           sys.executable, "-m", "llmpas.cli", *argv]  # fmt: skip
    out_path, err_path = cwd / "stdout.txt", cwd / "stderr.txt"
    started = time.monotonic()
    with out_path.open("wb") as out, err_path.open("wb") as err:
        proc = subprocess.Popen(
            cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
            env=dict(os.environ), start_new_session=True,
        )  # fmt: skip
        hung = False
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - started > timeout:
                hung = True
                os.killpg(proc.pid, signal.SIGKILL)
                _, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.05)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return Outcome(
        code=None if hung else proc.returncode,
        stdout=out_path.read_text(errors="backslashreplace"),
        stderr=err_path.read_text(errors="backslashreplace"),
        seconds=time.monotonic() - started,
        peak_mb=usage.ru_maxrss / 1024,
        hung=hung,
        argv=argv,
    )


@pytest.fixture(scope="module")
def results(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, Outcome]:
    """Run the selected cases, a few at a time; case id -> outcome."""
    selected = {
        item.callspec.params["case"].id
        for item in request.session.items
        if hasattr(item, "callspec") and isinstance(item.callspec.params.get("case"), Case)
    }
    gen = tmp_path_factory.mktemp("gen")
    make_generated(gen)
    folders = {"good": str(GOOD), "bad": str(BAD), "gen": str(gen)}
    cases = [c for c in CASES if c.id in selected]

    def one(i_case: tuple[int, Case]) -> tuple[str, Outcome]:
        i, case = i_case
        cwd = tmp_path_factory.mktemp(f"case{i}")
        return case.id, run_cli(_fill(case.argv, folders), cwd, case.timeout)

    with ThreadPoolExecutor(max_workers=WORKERS) as pool:
        outcomes = dict(pool.map(one, enumerate(cases)))
    slowest = sorted(outcomes.items(), key=lambda kv: -kv[1].seconds)[:8]
    print("slowest cases:", ", ".join(f"{k} {o.seconds:.1f} s" for k, o in slowest))
    largest = sorted(outcomes.items(), key=lambda kv: -kv[1].peak_mb)[:8]
    print("largest cases:", ", ".join(f"{k} {o.peak_mb:.0f} MB" for k, o in largest))
    return outcomes


@pytest.mark.parametrize(
    "case", [pytest.param(c, id=c.id, marks=c.marks) for c in CASES]
)  # fmt: skip
def test_bad_input_gets_one_line_and_its_exit_status(
    case: Case, results: dict[str, Outcome]
) -> None:
    got = results[case.id]
    context = f"{got.argv}\nstdout: {got.stdout[-2000:]}\nstderr: {got.stderr[-3000:]}"
    assert not got.hung, f"no exit within {case.timeout:g} s\n{context}"
    assert "Traceback" not in got.stderr, context
    assert got.peak_mb < PEAK_MB, f"peak resident memory {got.peak_mb:.0f} MB\n{context}"
    lines = [line for line in got.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), context
    for needle in case.needles:
        assert needle in lines[0], f"{needle!r} not in the error line\n{context}"
    assert got.code == case.code, f"exit {got.code}, expected {case.code!r}\n{context}"
