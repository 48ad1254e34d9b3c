"""Marks for tests that need a system package the README's test command does not install:
Graphviz ``dot`` (diagrams) and headless Chromium with its driver (the report pages). Without
the package such a test skips with its reason, unless ``LLMPAS_REQUIRE_SYSTEM_PACKAGES=1`` (set
by ``.ci/run``, which installs them) or ``CI`` is set: there a missing package is a failure.
``llmpas doctor`` lists what is missing and the command that installs it.
"""

from __future__ import annotations

import os
import shutil

import pytest

from llmpas.reporting import browser

INSTALL = "sudo apt-get install -y graphviz chromium chromium-driver"


def required() -> bool:
    return os.environ.get("LLMPAS_REQUIRE_SYSTEM_PACKAGES") == "1" or browser.in_ci()


def has_dot() -> bool:
    return shutil.which("dot") is not None


needs_dot = pytest.mark.skipif(
    not has_dot() and not required(), reason=f"needs graphviz's dot ({INSTALL})"
)


def skip_without_chromium() -> None:
    """Skip (fail where packages are required) when Chromium or chromedriver is missing."""
    if browser.available():
        return
    message = f"{browser.CHROMIUM} / {browser.CHROMEDRIVER} missing ({INSTALL})"
    if required():
        pytest.fail(message)
    pytest.skip(message)
