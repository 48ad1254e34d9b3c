"""Loading ``--bindings FILE.py:NAME``: user code run once, every failure one InputError."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from llmpas.errors import InputError, UsageError
from llmpas.language.bindings import Implementation
from llmpas.language.loading import load_bindings


def _file(tmp_path: Path, text: str, name: str = "b.py") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_a_file_with_classes_and_wrapped_implementations_loads(tmp_path: Path) -> None:
    f = _file(
        tmp_path,
        "from dataclasses import dataclass\n"
        "from llmpas.language.bindings import sampler\n\n"
        "@dataclass(frozen=True)\nclass Pose:\n    x: float\n\n"
        "def gen(b):\n    yield (Pose(1.0),)\n\n"
        "def STREAMS():\n    return {'sample': sampler(gen), 'plain': len}\n",
    )
    streams = load_bindings(f"{f}:STREAMS")
    assert isinstance(streams["sample"], Implementation) and streams["plain"] is len
    (pose,) = next(streams["sample"].fn("b"))
    assert pose.x == 1.0 and type(pose).__module__ in sys.modules


def test_a_failing_file_leaves_no_module_behind(tmp_path: Path) -> None:
    f = _file(tmp_path, "import sys\nx = 1\nraise RuntimeError('no arm')\n")
    before = set(sys.modules)
    with pytest.raises(InputError, match=r"b\.py:3: running it raised RuntimeError: no arm"):
        load_bindings(f"{f}:STREAMS")
    assert set(sys.modules) == before


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("import sys\nsys.exit(7)\n", r"running it called sys.exit\(7\)"),
        ("raise SystemExit\n", r"sys.exit\(None\)"),
        ("def f(:\n", r"b\.py:1:7: "),
        ("STREAMS = {'a': 1}\n", r"STREAMS\['a'\] is int, not callable"),
        ("STREAMS = 3\n", "STREAMS is int, not a mapping"),
        ("def STREAMS():\n    return {None: len}\n", "key None is not a stream name"),
    ],
)
def test_each_failure_is_one_input_error(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        load_bindings(f"{_file(tmp_path, text)}:STREAMS")


def test_loading_that_never_ends_is_stopped(tmp_path: Path) -> None:
    f = _file(tmp_path, "import time\ntime.sleep(1000)\n")
    with pytest.raises(InputError, match=r"b\.py: loading the bindings took longer than 0.3 s"):
        load_bindings(f"{f}:STREAMS", seconds=0.3)


@pytest.mark.parametrize("spec", ["nocolon", "file.py:", ":NAME", "file.py:not-an-identifier"])
def test_malformed_specs_are_usage_errors(spec: str) -> None:
    with pytest.raises(UsageError, match="--bindings"):
        load_bindings(spec)


def test_modules_by_name() -> None:
    with pytest.raises(InputError, match="no module named 'no_such_mod_xyz'"):
        load_bindings("no_such_mod_xyz:STREAMS")
    with pytest.raises(InputError, match="module json: defines no 'NOPE'"):
        load_bindings("json:NOPE")
