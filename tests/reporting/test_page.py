"""The run folder's index.html, built from the files on disk (no browser here)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from llmpas.cli import main
from llmpas.reporting import ReportError, build_report, read_run, render

from ..system_packages import needs_dot
from .conftest import HOSTILE


def _page(folder: Path) -> str:
    return (folder / "index.html").read_text(encoding="utf-8")


@needs_dot  # its CSubBT diagrams are counted
def test_the_main_job_writes_a_page_with_every_round_and_the_reasoning(main_job: Path) -> None:
    page = _page(main_job)
    run = read_run(main_job)
    assert run.success is True and run.loop
    assert [r.status for r in run.rounds] == ["anomaly", "success", "success"]
    for i in range(len(run.rounds)):
        assert f'id="round-{i}"' in page
    assert 'id="reasoning-0"' in page  # the anomaly went to the LLM
    assert "(scanned table4)" in page  # the goals taken (the table no camera saw)
    assert "scenario: " in page and "table4" in page  # where the cube went
    assert page.count("data:image/svg+xml;base64,") == 4  # CSubBT diagrams (graphviz)
    assert page.count("drawn above") == 1  # round 2's place is round 0's
    assert "<script" not in page
    # the prompts and answers are on the page (loop.json keeps them for the PyBullet world)
    exchanges = run.rounds[0].reasoning.exchanges if run.rounds[0].reasoning else ()
    assert [e.tag for e in exchanges] == ["first-look", "goals"]
    assert "Look where the truth says." in page


def test_camera_images_are_placed_at_the_look_that_made_them(main_job: Path) -> None:
    run = read_run(main_job)
    looks = [m for m in run.media if m.kind == "camera" and "look:" in m.label]
    assert len(looks) >= 4
    for m in looks:
        rnd = run.round_of(m)
        assert rnd is not None and m.event is not None
        # the look records its event after the image was taken: the next event is that look
        assert rnd.timeline[m.event]["node"] == "look", m
    on_page = _page(main_job).split('id="round-0"')[1].split('id="round-1"')[0]
    assert on_page.count('class="shots"') >= 3  # images between the rows of round 0


def test_rebuilding_from_the_folder_gives_the_same_page(main_job: Path) -> None:
    before = _page(main_job)
    assert main(["report", str(main_job)]) == 0
    assert _page(main_job) == before


def test_every_hostile_string_is_text(hostile_run: Path) -> None:
    page = _page(hostile_run)
    assert "<script" not in page and "<img src=x" not in page
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", page)
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "\\x1b[31mred" in page  # the escape shown, not acted on
    assert "\ufffd" in page and "&lt;U+202E&gt;" in page
    assert page.count('class="sent"') >= 2  # the answers were sent back, with the reasons


def test_images_beyond_the_budget_are_linked_beside_the_page(main_job: Path) -> None:
    page = render(read_run(main_job), budget=0)
    srcs = re.findall(r'<img src="([^"]+)"', page)
    linked = [s for s in srcs if not s.startswith("data:")]
    assert linked and all((main_job / s).is_file() for s in linked)
    assert "data:image" not in page  # the diagrams too: shown as text
    assert page.count('<figure id="tree-') == page.count("<pre>Explore (40 attempts)") + 1


@needs_dot  # its CSubBT diagrams are counted
def test_a_single_episode_from_execute_gets_the_same_page(tmp_path: Path) -> None:
    out = tmp_path / "mw"
    assert main(["execute", "action-blocking-microwave", "--out", str(out)]) == 1
    page = _page(out)
    run = read_run(out)
    assert not run.loop and len(run.rounds) == 1 and run.rounds[0].status == "anomaly"
    assert run.rounds[0].plan and run.task == "(and (Heated bread))"
    assert 'class="anomaly"' in page and "execution only" in page
    assert page.count("data:image/svg+xml;base64,") >= 3


def test_wrong_types_in_loop_json_still_give_a_page(tmp_path: Path) -> None:
    loop = {
        "scenario": ["not", "a", "string"],
        "success": "yes",
        "rounds": [
            {"goal": 5, "plan": {"plan": {"steps": [{"action": 3, "args": "x"}]}}},
            "junk",
            {"goal": "(g)", "episode": {"timeline": [{"t": "x", "node": None}, 7]}},
            {"reasoning": {"exchanges": [{"messages": [["user"], 5]}, None], "goals": [1]}},
        ],
        "timings": {"plan": "fast"},
    }
    (tmp_path / "loop.json").write_text(json.dumps(loop))
    (tmp_path / "media.json").write_text(
        json.dumps([{"file": "../../etc/passwd"}, {"file": "/etc/passwd"}, 3])
    )
    built = build_report(tmp_path)
    page = built.path.read_text()
    assert page.count('class="card round"') == 4 and "passwd" not in page


def test_files_a_world_lists_in_artifacts_json_are_linked_with_what_they_hold(
    tmp_path: Path,
) -> None:
    (tmp_path / "loop.json").write_text(json.dumps({"scenario": "s", "rounds": []}))
    (tmp_path / "ros.mcap").write_bytes(b"\x89MCAP0\r\n")
    listed = [
        {"file": "ros.mcap", "title": "a recording", "holds": "the goals <and> anomalies"},
        {"file": "../../etc/passwd", "title": "out", "holds": "x"},
        {"file": "missing.mcap", "title": "gone", "holds": "x"},
        "junk",
    ]
    (tmp_path / "artifacts.json").write_text(json.dumps(listed))
    run = read_run(tmp_path)
    assert [a.file for a in run.artifacts] == ["ros.mcap"]
    page = build_report(tmp_path).path.read_text()
    assert '<a href="ros.mcap">ros.mcap</a>' in page
    assert "the goals &lt;and&gt; anomalies" in page
    assert "passwd" not in page and "missing.mcap" not in page


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ("{", "loop.json:1:2: not valid JSON"),
        ("", "loop.json:1:1: not valid JSON"),
        ("[" * 100_000, "loop.json"),
    ],
)
def test_a_broken_loop_json_is_one_line_naming_it(
    tmp_path: Path, content: str, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "loop.json").write_text(content)
    with pytest.raises(ReportError, match=re.escape(expected)):
        read_run(tmp_path)
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err and "Traceback" not in err


def test_a_folder_that_is_not_a_run_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert "no such folder" in capsys.readouterr().err
    assert main(["report", str(tmp_path)]) == 2
    assert "not a run folder" in capsys.readouterr().err


def test_hostile_file_names_are_escaped_and_encoded(main_job: Path, tmp_path: Path) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(main_job, folder)
    bad = '<img src=x onerror=alert(1)>".json'
    (folder / bad).write_text("{}")
    page = render(read_run(folder))
    assert "<img src=x" not in page and "%3Cimg%20src%3Dx%20onerror" in page
    assert HOSTILE not in page


def test_the_benchmark_measures_a_given_folder(
    main_job: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", "report", "--run", str(main_job), "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "page size" in out and "build time" in out
    assert main(["bench", "report", "--repeats", "0"]) == 2


def test_a_pybullet_run_without_llm_places_its_images_in_its_one_episode(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    out = tmp_path / "once"
    assert main(["run", "object-loss", "--no-llm", "--out", str(out)]) == 1
    run = read_run(out)
    assert not run.loop and run.success is False and run.task == "(and (On cube bowl))"
    assert run.rounds[0].status == "anomaly" and run.media
    assert all(run.round_of(m) is run.rounds[0] for m in run.media)
    assert 'id="images"' not in _page(out)  # no image left over for a gallery


def test_a_folder_with_many_images_gives_a_bounded_page(tmp_path: Path) -> None:
    from PIL import Image

    from llmpas.reporting import page as webpage

    (tmp_path / "snapshots").mkdir()
    media = []
    for i in range(webpage.MAX_IMAGES + 100):
        name = f"snapshots/{i:04d}.png"
        Image.new("RGB", (64, 48), (i % 256, 80, 160)).save(tmp_path / name)
        media.append(
            {"file": name, "kind": "snapshot", "label": str(i), "episode": 0, "event": i % 3}
        )
    (tmp_path / "media.json").write_text(json.dumps(media))
    events = [{"t": k / 10, "node": "n", "status": "success"} for k in range(3)]
    (tmp_path / "episode.json").write_text(json.dumps({"status": "success", "timeline": events}))
    page = render(read_run(tmp_path), budget=20_000)
    assert page.count("<figure><a") == webpage.MAX_IMAGES
    assert "100 more images are only in the folder" in page
    inlined = page.count('src="data:image/png')
    assert 0 < inlined < webpage.MAX_IMAGES  # inlined up to the budget, then linked
