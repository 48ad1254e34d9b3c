"""A real browser for the reports: Debian's headless Chromium driven by selenium through the
system's chromedriver (nothing is downloaded: the driver and browser paths are given, so
Selenium Manager is never asked). Used by the tests (the page loads without console errors,
every image decodes, no script runs) and by ``llmpas report --screenshot``.
"""

from __future__ import annotations

import base64
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
)
PAGE_TIMEOUT = 60.0  # seconds for a page to load


class BrowserMissing(RuntimeError):
    """Chromium or chromedriver is not installed."""


def available() -> bool:
    return Path(CHROMIUM).is_file() and Path(CHROMEDRIVER).is_file()


@contextmanager
def chromium(width: int = 1280, height: int = 900) -> Iterator[Any]:
    """A headless Chromium (selenium WebDriver) with a fresh profile, closed afterwards."""
    if not available():
        raise BrowserMissing(
            f"the report browser needs {CHROMIUM} and {CHROMEDRIVER} "
            "(apt-get install chromium chromium-driver)"
        )
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        raise BrowserMissing("the report browser needs selenium (pip install selenium)") from None

    profile = tempfile.mkdtemp(prefix="llmpas-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    try:
        driver.set_page_load_timeout(PAGE_TIMEOUT)
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def open_page(driver: Any, page: str | Path) -> None:
    driver.get(Path(page).resolve().as_uri())


@dataclass(frozen=True)
class PageCheck:
    """What the browser saw of a page."""

    title: str
    console: tuple[str, ...]  # console messages of level SEVERE (errors)
    images: int
    broken: tuple[str, ...]  # images that did not decode (naturalWidth == 0)
    sections: tuple[str, ...]  # ids of the page's <section>s
    scripts: int  # <script> elements in the DOM
    alerted: bool  # a dialog (alert) was opened


_IMAGES = """
return Array.from(document.images).map(i => [i.currentSrc.slice(0, 80), i.complete,
  i.naturalWidth]);
"""


def check(driver: Any, page: str | Path) -> PageCheck:
    """Load ``page`` and report what a reader's browser would see (lazy images scrolled in)."""
    open_page(driver, page)
    alerted = _alerted(driver)
    driver.execute_script(
        "document.querySelectorAll('img[loading=lazy]').forEach(i => i.loading = 'eager');"
        "document.querySelectorAll('details').forEach(d => d.open = true);"
    )
    _decoded(driver)
    images = driver.execute_script(_IMAGES)
    broken = tuple(str(src) for src, _, width in images if not width)
    sections = driver.execute_script(
        "return Array.from(document.querySelectorAll('section')).map(s => s.id || '');"
    )
    scripts = driver.execute_script("return document.getElementsByTagName('script').length;")
    logs = driver.get_log("browser")
    return PageCheck(
        title=driver.title,
        console=tuple(str(e.get("message")) for e in logs if e.get("level") == "SEVERE"),
        images=len(images),
        broken=broken,
        sections=tuple(str(s) for s in sections),
        scripts=int(scripts),
        alerted=_alerted(driver) or alerted,
    )


def _decoded(driver: Any) -> None:
    """Wait until every image has decoded (or failed to)."""
    driver.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "Promise.all(Array.from(document.images).map(i => i.decode().catch(() => null)))"
        ".then(() => done(true));"
    )


def _alerted(driver: Any) -> bool:
    """Whether dialogs (alert, confirm) were open; they are dismissed."""
    from selenium.common.exceptions import NoAlertPresentException

    seen = False
    for _ in range(20):
        try:
            driver.switch_to.alert.dismiss()
        except NoAlertPresentException:
            break
        seen = True
    return seen


def screenshot(
    page: str | Path, out: str | Path, width: int = 1280, height: int | None = None
) -> Path:
    """A PNG of ``page`` as Chromium draws it: the whole page, or its top ``height`` pixels;
    written atomically."""
    from llmpas.files import atomic_write

    with chromium(width) as driver:
        open_page(driver, page)
        _decoded(driver)
        full = driver.execute_script("return Math.ceil(document.documentElement.scrollHeight);")
        shown = int(full) if height is None else min(int(full), height)
        driver.execute_cdp_cmd(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": shown, "deviceScaleFactor": 1, "mobile": False},
        )
        shot = driver.execute_cdp_cmd("Page.captureScreenshot", {"format": "png"})
    return atomic_write(out, base64.b64decode(shot["data"]))


def in_ci() -> bool:
    return bool(os.environ.get("CI"))


__all__ = ["BrowserMissing", "PageCheck", "available", "check", "chromium", "screenshot"]
