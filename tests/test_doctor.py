"""``llmpas doctor``: every part present or missing, each missing one with its fixing command,
and a non-zero exit status when a required part is missing."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.cli import main
from llmpas.commands import doctor
from llmpas.commands.doctor import Check, Verdict


def test_a_missing_model_is_required_and_names_its_install_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["doctor", "--cache", str(tmp_path), "--no-self-test"]) == 1
    out = capsys.readouterr().out
    assert "model qwen2.5-coder-1.5b" in out and "llmpas model install" in out
    assert "missing or failing: model qwen2.5-coder-1.5b" in " ".join(out.split())


def test_without_the_model_the_self_test_is_skipped_not_run(tmp_path: Path) -> None:
    found = {c.name: c for c in doctor.checks("qwen2.5-coder-0.5b", str(tmp_path))}
    assert found["model qwen2.5-coder-0.5b"].verdict is Verdict.MISSING
    fix = f"llmpas model install qwen2.5-coder-0.5b --cache {tmp_path}"
    assert found["model qwen2.5-coder-0.5b"].fix == fix
    assert found["llama.cpp self-test"].verdict is Verdict.SKIPPED
    assert found["Fast Downward"].verdict is Verdict.OK  # installed with llmpas


def test_a_wrong_sized_model_fails_with_the_reinstall_command(tmp_path: Path) -> None:
    (tmp_path / "qwen2.5-coder-1.5b.gguf").write_bytes(b"GGUF")
    check, path = doctor.model("qwen2.5-coder-1.5b", str(tmp_path))
    assert check.verdict is Verdict.FAILED and path is None and check.blocking
    assert "has 4 bytes" in check.detail and check.fix == f"llmpas model install --cache {tmp_path}"


def test_missing_system_programs_are_optional_with_their_apt_command() -> None:
    for check in (doctor.compiler(lambda _: None), doctor.graphviz(lambda _: None)):
        assert check.verdict is Verdict.MISSING and not check.blocking
        assert check.fix.startswith("sudo apt-get install -y ")
    assert doctor.graphviz(lambda name: f"/opt/{name}").detail == "/opt/dot"


def test_a_failed_self_test_is_blocking_and_says_what_to_do(tmp_path: Path) -> None:
    bad = tmp_path / "m.gguf"
    bad.write_bytes(b"GGUF" + bytes(100))
    check = doctor.self_test(bad, installed=True, timeout=120)
    assert check.verdict is Verdict.FAILED and check.blocking
    assert check.detail.startswith(f"cannot load {bad}") and "--force-reinstall" in check.fix


def test_a_missing_part_without_a_fix_is_refused() -> None:
    with pytest.raises(ValueError, match="needs its fix"):
        Check("x", Verdict.MISSING, "gone")
