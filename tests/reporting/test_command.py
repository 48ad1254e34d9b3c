"""What the run commands write down about themselves for the page."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from llmpas.reporting.report_command import after_run, public_llm


def test_credentials_in_an_llm_url_are_not_written_down() -> None:
    spec = "openai:gpt-4o@https://user:s3cret@example.test:8443/v1"
    assert public_llm(spec) == "openai:gpt-4o@https://example.test:8443/v1"
    assert public_llm("oracle") == "oracle"


def test_after_run_records_the_command_and_reports_a_bad_folder_in_one_line(
    tmp_path: Path,
) -> None:
    lines: list[str] = []
    args = argparse.Namespace(
        command="run",
        scenario="x",
        out=str(tmp_path),
        llm="openai:m@http://u:pw@h/v1",
        method="flp",
        decoding="grammar",
    )
    after_run(args, lines.append)  # nothing to report in an empty folder
    assert len(lines) == 1 and lines[0].startswith("no index.html:")
    about = json.loads((tmp_path / "about.json").read_text())
    assert "pw" not in json.dumps(about) and about["llm"] == "openai:m@http://h/v1"
    assert about["command"].startswith("llmpas run x --llm openai:m@http://h/v1 --method flp")
    after_run(argparse.Namespace(out=None), lines.append)  # no --out: nothing at all
    assert len(lines) == 1
