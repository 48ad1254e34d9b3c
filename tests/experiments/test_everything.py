"""``llmpas bench all``: every experiment runs as its own ``bench`` command; failures are
reported without stopping the rest; the summary links each table and plot."""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import pytest
from rich.console import Console

from llmpas.cli import build_parser, main
from llmpas.experiments.everything import AllConfig, Step, plan_steps, run_all


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_every_step_is_a_bench_command_the_cli_accepts(tmp_path: Path) -> None:
    parser = build_parser()
    for quick in (False, True):
        steps = plan_steps(AllConfig(llm="openai:m", quick=quick, out_dir=tmp_path))
        names = [s.name for s in steps]
        assert names[-5:] == ["planning-time", "tamp", "perturbation", "prompting", "blocksworld"]
        assert ("validate-data" in names) is not quick
        for step in steps:
            args = parser.parse_args(step.argv)  # exits (fails the test) on a wrong option
            assert args.bench == step.name
            if step.name in ("prompting", "blocksworld"):
                assert args.llm == "openai:m"
            if step.name != "validate-data":
                assert Path(args.out) == tmp_path / step.name


def test_the_oracle_runs_only_its_own_prompting_row(tmp_path: Path) -> None:
    prompting = next(s for s in plan_steps(AllConfig(llm="oracle")) if s.name == "prompting")
    assert build_parser().parse_args(prompting.argv).methods == ["none"]
    prompting = next(s for s in plan_steps(AllConfig(llm="llama-cpp")) if s.name == "prompting")
    assert build_parser().parse_args(prompting.argv).methods == ["all"]


def test_a_failing_step_is_reported_and_the_others_still_run(tmp_path: Path) -> None:
    ran: list[str] = []

    def run(argv: Sequence[str]) -> int:
        ran.append(argv[1])
        if argv[1] == "perturbation":
            raise RuntimeError("simulator crashed")
        folder = Path(argv[argv.index("--out") + 1]) if "--out" in argv else None
        if folder is not None:
            folder.mkdir(parents=True)
            (folder / f"{argv[1]}.md").write_text("| table |\n")
        return 2 if argv[1] == "blocksworld" else 0

    config = AllConfig(llm="oracle", out_dir=tmp_path)
    outcomes = run_all(config, run, quiet())
    assert ran == [
        "validate-data",
        "planning-time",
        "tamp",
        "perturbation",
        "prompting",
        "blocksworld",
    ]
    assert [o.status for o in outcomes] == [0, 0, 0, 1, 0, 2]
    summary = (tmp_path / "summary.md").read_text()
    assert "| perturbation | failed (exit 1) |" in summary
    assert "| blocksworld | failed (exit 2) |" in summary
    assert "[prompting.md](prompting/prompting.md)" in summary


def test_bad_settings_are_one_line_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "all", "--jobs", "0"]) == 2
    assert "jobs must be >= 1" in capsys.readouterr().err
    with pytest.raises(ValueError, match="bench"):
        Step("x", ("run", "object-loss"))


@pytest.mark.slow
def test_quick_slice_with_the_oracle_writes_every_table(tmp_path: Path) -> None:
    assert main(["bench", "all", "--llm", "oracle", "--quick", "--out", str(tmp_path)]) == 0
    for name in ("planning-time", "tamp", "perturbation", "prompting", "blocksworld"):
        assert list((tmp_path / name).glob("*.md")), name
    assert "| prompting | ok |" in (tmp_path / "summary.md").read_text()
