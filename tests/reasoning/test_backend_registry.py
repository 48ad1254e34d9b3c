"""LLM backends built in one place: the registry of ``--llm`` kinds
(:data:`llmpas.reasoning.backends.backend_registry.KINDS`) is the single source of the command
line's
choices and of the docs' table, and it loads nothing before a spec of a kind is built."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from llmpas.experiments.jobs import add_llm_argument
from llmpas.reasoning.backends.backend_registry import (
    BACKENDS,
    KINDS,
    SPECS,
    BackendKind,
    choices,
    make_backend,
    markdown_table,
)
from llmpas.reasoning.llm import LLM
from llmpas.system.catalog import llm_for

ROOT = Path(__file__).resolve().parents[2]


def test_the_docs_table_is_the_registry() -> None:
    assert markdown_table() in (ROOT / "docs" / "llm-part.md").read_text()


@pytest.mark.parametrize("replan", [False, True])
def test_the_command_lines_choices_are_the_registrys(replan: bool) -> None:
    p = argparse.ArgumentParser()
    add_llm_argument(p, replan=replan)
    help_text = " ".join(p.format_help().split())
    for name, kind in KINDS.items():
        assert (kind.syntax in help_text) is (name != "replan" or replan), name


def test_every_kind_is_listed_once_in_the_registrys_order() -> None:
    assert list(KINDS) == ["oracle", "replan", "replay", "openai", "llama-cpp"]
    assert set(BACKENDS) == {"replay", "openai", "llama-cpp"}  # the rest are supplied
    assert SPECS == "oracle | replay:DIR | openai:MODEL[@BASE_URL] | llama-cpp[:PATH]"
    assert choices(["replay", "oracle"]) == "oracle | replay:DIR"
    with pytest.raises(ValueError, match="unknown backend kind 'gpt'"):
        choices(["gpt"])


def test_a_kinds_syntax_starts_with_its_name() -> None:
    with pytest.raises(ValueError, match="must start with its name"):
        BackendKind("mine", "yours:X", "help")
    with pytest.raises(ValueError, match="without ':'"):
        BackendKind("a:b", "a:b", "help")


def test_a_spec_of_no_kind_names_the_kinds() -> None:
    with pytest.raises(ValueError, match=r"'gpt4': expected oracle \| replay:DIR"):
        make_backend("gpt4")
    with pytest.raises(ValueError, match=r"expected oracle \| replan \| replay:DIR"):
        llm_for("gpt4")


def test_no_backend_library_is_loaded_before_a_spec_of_its_kind_is_built(tmp_path: Path) -> None:
    code = (
        "import sys\n"
        "from llmpas.reasoning.backends.backend_registry import choices, make_backend\n"
        "choices()\n"
        f"make_backend('replay:{tmp_path}')\n"
        "print(sorted(m for m in ('llama_cpp', 'openai', 'httpx') if m in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(ROOT / "src"), "PATH": ""},
    ).stdout
    assert out.strip() == "[]"


def test_the_loop_gets_every_kind_as_a_factory_of_the_session(tmp_path: Path) -> None:
    (tmp_path / "cassette").mkdir()
    replay = llm_for(f"replay:{tmp_path / 'cassette'}")
    assert not isinstance(replay, LLM)
    built = replay(object())
    assert isinstance(built, LLM) and replay(None) is built  # one backend, whatever the session

    class Session:
        task = "(and (on cube bowl))"

    restated = llm_for("replan")(Session())
    assert isinstance(restated, LLM)
