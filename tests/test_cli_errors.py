"""The command line's error discipline, in process: classes to exit statuses, one line, -v."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
from rich.console import Console

import llmpas.cli as cli
from llmpas.cli import check_output_folder, main
from llmpas.errors import ExitCode, OutputError


def _fail_with(monkeypatch: pytest.MonkeyPatch, error: BaseException) -> None:
    def handler(args: argparse.Namespace, console: Console) -> int:
        raise error

    monkeypatch.setattr(cli, "_cmd_examples", handler)


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


def test_an_unexpected_exception_is_one_line_and_internal(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _fail_with(monkeypatch, ZeroDivisionError("division by zero\nsecond line"))
    assert main(["examples"]) == ExitCode.INTERNAL
    line = _one_line(capsys)
    assert line.startswith("error: internal error: ZeroDivisionError: division by zero\\n")
    assert "-v" in line


def test_verbose_adds_the_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _fail_with(monkeypatch, ZeroDivisionError("boom"))
    assert main(["-v", "examples"]) == ExitCode.INTERNAL
    err = capsys.readouterr().err
    assert "Traceback" in err and err.rstrip().splitlines()[-1].startswith("error: internal")


@pytest.mark.parametrize(
    ("error", "code", "text"),
    [
        (KeyboardInterrupt(), ExitCode.INTERRUPTED, "error: interrupted"),
        (OSError(28, "No space left on device", "out/x.json"), ExitCode.IO, "out/x.json: No space"),
        (MemoryError(), ExitCode.INTERNAL, "out of memory"),
        (cli.CliError("bad --thing"), ExitCode.USAGE, "error: bad --thing"),
        (cli.CliError("none", code=ExitCode.FAILED), ExitCode.FAILED, "error: none"),
    ],
)
def test_error_classes_map_to_exit_statuses(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    error: BaseException,
    code: ExitCode,
    text: str,
) -> None:
    _fail_with(monkeypatch, error)
    assert main(["examples"]) == code
    assert text in _one_line(capsys)


def test_the_llm_class_maps_to_its_status(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from llmpas.reasoning.llm import LLMError

    _fail_with(monkeypatch, LLMError("http://127.0.0.1:9/v1: connection refused"))
    assert main(["examples"]) == ExitCode.LLM
    assert "127.0.0.1:9" in _one_line(capsys)


def test_markup_in_a_message_is_printed_as_is(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _fail_with(monkeypatch, cli.CliError("[/] and [bold]x[/bold] :smile:"))
    assert main(["examples"]) == ExitCode.USAGE
    assert _one_line(capsys) == "error: [/] and [bold]x[/bold] :smile:"


def test_usage_errors_are_one_line_and_return(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--max-time", "nan"]) == ExitCode.USAGE
    line = _one_line(capsys)
    assert "--max-time" in line and "'nan'" in line and "usage:" not in line


def test_output_folder_checks_leave_nothing_behind(tmp_path: Path) -> None:
    check_output_folder(str(tmp_path / "new" / "deeper"), "--out")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="not a folder"):
        check_output_folder(str(tmp_path / "file"), "--out")
    with pytest.raises(OutputError, match="is not a folder"):
        check_output_folder(str(tmp_path / "file" / "sub"), "--out")
    with pytest.raises(OutputError, match="--out /proc/x: cannot write in /proc"):
        check_output_folder("/proc/x", "--out")


def test_out_is_checked_before_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "taken"
    blocker.write_text("a file")
    assert main(["run", "nominal", "--llm", "oracle", "--out", str(blocker)]) == ExitCode.IO
    assert capsys.readouterr().out == ""  # nothing ran
