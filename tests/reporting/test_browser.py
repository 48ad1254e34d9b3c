"""The web reports in a real browser: Debian's headless Chromium through the system's
chromedriver (selenium; nothing downloaded). Without Chromium the tests fail in CI (CI set)
and are skipped elsewhere."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from llmpas.cli import main
from llmpas.reporting import browser, build_report, read_run, render

from ..system_packages import needs_dot, skip_without_chromium
from .conftest import HOSTILE


@needs_dot  # the 4 diagrams are counted
def test_the_main_job_page_loads_clean_with_every_image_decoded(
    driver: Any, main_job: Path
) -> None:
    seen = browser.check(driver, main_job / "index.html")
    assert seen.console == ()
    run = read_run(main_job)
    # the GIF, the diagrams, every snapshot and camera image
    assert seen.images >= 1 + 4 + len(run.media)
    assert seen.broken == ()
    assert {"outcome", "round-0", "round-1", "round-2", "files"} <= set(seen.sections)
    assert seen.title.startswith("object-loss")
    assert seen.scripts == 0 and not seen.alerted


def test_linked_images_decode_too(driver: Any, main_job: Path, tmp_path: Path) -> None:
    page = main_job / "linked.html"
    page.write_text(render(read_run(main_job), budget=0), encoding="utf-8")
    seen = browser.check(driver, page)
    assert seen.broken == () and seen.images > 10 and seen.console == ()


def test_a_hostile_llm_answer_is_shown_as_text_and_runs_nothing(
    driver: Any, hostile_run: Path
) -> None:
    seen = browser.check(driver, hostile_run / "index.html")
    assert not seen.alerted and seen.scripts == 0 and seen.console == ()
    injected = driver.execute_script("return document.querySelectorAll('img[onerror]').length;")
    assert injected == 0
    answers = driver.execute_script(
        "return Array.from(document.querySelectorAll('.answer pre')).map(p => p.textContent);"
    )
    assert answers and all("<script>alert(1)</script>" in a for a in answers)
    assert all("\x1b" not in a and "\\x1b[31mred" in a for a in answers)
    assert HOSTILE not in driver.page_source


def test_the_screenshot_is_the_whole_page(main_job: Path, tmp_path: Path) -> None:
    skip_without_chromium()
    from PIL import Image

    shot = browser.screenshot(main_job / "index.html", tmp_path / "page.png", width=1000)
    with Image.open(shot) as img:
        width, height = img.size
        colours = img.convert("RGB").resize((50, 200)).getcolors(10_000)
    assert width == 1000 and height > 3000  # full page, not the window
    assert colours is not None and len(colours) > 50  # a drawn page, not a blank one
    top = tmp_path / "top.png"
    assert main(["report", str(main_job), "--screenshot", str(top), "--height", "700"]) == 0
    with Image.open(top) as img:
        assert img.size == (1280, 700)


def test_a_page_built_again_after_a_run_loads_the_same(driver: Any, tmp_path: Path) -> None:
    (tmp_path / "episode.json").write_text('{"status": "success", "timeline": []}')
    built = build_report(tmp_path)
    seen = browser.check(driver, built.path)
    assert seen.console == () and seen.broken == () and "outcome" in seen.sections


def test_the_checks_see_what_they_look_for(driver: Any, tmp_path: Path) -> None:
    """A page with a script, a missing image and a console error: the checks notice all."""
    page = tmp_path / "bad.html"
    page.write_text(
        '<html><body><section id="s"></section><img src="missing.png">'
        "<script>console.error('boom'); alert(1);</script></body></html>"
    )
    seen = browser.check(driver, page)
    assert seen.alerted and seen.scripts == 1 and seen.sections == ("s",)
    assert seen.broken and any("boom" in m or "missing.png" in m for m in seen.console)


def test_selenium_manager_is_never_asked(driver: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """The driver and browser paths are given: nothing is looked up or downloaded."""
    from selenium.webdriver.common import selenium_manager

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("Selenium Manager was asked")

    monkeypatch.setattr(selenium_manager.SeleniumManager, "binary_paths", refuse)
    with browser.chromium() as fresh:
        fresh.get("about:blank")
        assert fresh.capabilities["browserName"] in ("chrome", "chromium")
