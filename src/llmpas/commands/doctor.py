"""``llmpas doctor``: what this machine has and lacks for llmpas, each with the fixing command.

Required (the main job cannot run without it): Fast Downward's search binary, llama-cpp-python,
the offline model, and the llama.cpp self-test (the model decodes a few tokens in a worker
process, so a crash there is reported, not suffered). Optional: a C++ compiler (pip builds
llama-cpp-python from source where PyPI has no wheel), Graphviz ``dot`` (PNG subtrees) and
headless Chromium with its driver (``--screenshot``, the report tests). Nothing is installed or
downloaded; the checks only look.
"""

from __future__ import annotations

import importlib.util
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

APT = "sudo apt-get install -y"


class Verdict(Enum):
    OK = "ok"
    MISSING = "missing"
    FAILED = "failed"
    SKIPPED = "skipped"  # could not be checked: what it needs is missing


@dataclass(frozen=True)
class Check:
    """One thing looked at: what, the verdict, what was found, and the command that fixes it."""

    name: str
    verdict: Verdict
    detail: str
    fix: str = ""
    required: bool = True

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a check needs a name")
        if self.verdict in (Verdict.MISSING, Verdict.FAILED) and not self.fix:
            raise ValueError(f"check {self.name!r}: a missing or failed part needs its fix")

    @property
    def blocking(self) -> bool:
        """A required part that is missing or failed (``llmpas doctor`` then exits non-zero)."""
        return self.required and self.verdict in (Verdict.MISSING, Verdict.FAILED)


Which = Callable[[str], str | None]


def tool(name: str, programs: Sequence[str], fix: str, why: str, which: Which) -> Check:
    """A program on PATH (the first of ``programs`` found)."""
    for program in programs:
        found = which(program)
        if found:
            return Check(name, Verdict.OK, found, required=False)
    return Check(name, Verdict.MISSING, f"no {' / '.join(programs)} on PATH ({why})", fix, False)


def compiler(which: Which = shutil.which) -> Check:
    why = "pip builds llama-cpp-python from source"
    return tool("C++ compiler", ("c++", "g++", "clang++"), f"{APT} g++", why, which)


def graphviz(which: Which = shutil.which) -> Check:
    why = "PNG renderings of subtrees"
    return tool("Graphviz dot", ("dot",), f"{APT} graphviz", why, which)


def chromium() -> Check:
    from llmpas.reporting import browser

    fix = f"{APT} chromium chromium-driver"
    missing = [p for p in (browser.CHROMIUM, browser.CHROMEDRIVER) if not Path(p).is_file()]
    if missing:
        why = "web report screenshots and their tests"
        return Check("Chromium", Verdict.MISSING, f"no {', '.join(missing)} ({why})", fix, False)
    return Check("Chromium", Verdict.OK, f"{browser.CHROMIUM}, {browser.CHROMEDRIVER}", "", False)


def fast_downward() -> Check:
    from llmpas.planning.downward import PlannerNotFound, find_downward_binary

    fix = 'pip install -e ".[llm]" (or pip install up-fast-downward)'
    try:
        binary = find_downward_binary()
    except PlannerNotFound as err:
        return Check("Fast Downward", Verdict.MISSING, str(err), fix)
    if not binary.is_file():
        return Check("Fast Downward", Verdict.MISSING, f"{binary} is not there", fix)
    return Check("Fast Downward", Verdict.OK, str(binary))


def llama_cpp() -> Check:
    fix = 'pip install -e ".[llm]" (builds llama-cpp-python: 6-15 min, needs a C++ compiler)'
    if importlib.util.find_spec("llama_cpp") is None:
        return Check("llama-cpp-python", Verdict.MISSING, "not installed", fix)
    from importlib.metadata import version

    return Check("llama-cpp-python", Verdict.OK, version("llama-cpp-python"))


def model(name: str, cache: str | None = None) -> tuple[Check, Path | None]:
    from llmpas.reasoning.models import DEFAULT_MODEL, get_spec, model_path

    path = model_path(name, cache)
    command = "llmpas model install" + ("" if name == DEFAULT_MODEL else f" {name}")
    command += "" if cache is None else f" --cache {cache}"
    spec = get_spec(name)
    if not path.is_file():
        return Check(f"model {name}", Verdict.MISSING, f"no {path}", command), None
    if path.stat().st_size != spec.size:
        detail = f"{path} has {path.stat().st_size} bytes, not {spec.size}"
        return Check(f"model {name}", Verdict.FAILED, detail, command), None
    return Check(f"model {name}", Verdict.OK, str(path)), path


SELF_TEST_FIX = (
    "pip install --force-reinstall --no-cache-dir llama-cpp-python (a build for this CPU), "
    "or use another backend: --llm openai:MODEL@URL"
)


def self_test(path: Path | None, installed: bool, timeout: float = 300.0) -> Check:
    """Decode a few tokens with the model in a worker process."""
    name = "llama.cpp self-test"
    if path is None or not installed:
        return Check(name, Verdict.SKIPPED, "needs llama-cpp-python and the model")
    from llmpas.reasoning.backends.llamacpp import self_test as run_self_test

    result = run_self_test(path, timeout)
    if not result.ok:
        return Check(name, Verdict.FAILED, result.message, SELF_TEST_FIX)
    return Check(name, Verdict.OK, result.message)


def checks(model_name: str, cache: str | None = None, decode: bool = True) -> list[Check]:
    """Every check, required ones first (``decode``: run the llama.cpp self-test)."""
    llama = llama_cpp()
    weights, path = model(model_name, cache)
    found = [fast_downward(), llama, weights]
    if decode:
        found.append(self_test(path, llama.verdict is Verdict.OK))
    return [*found, compiler(), graphviz(), chromium()]


__all__ = ["Check", "Verdict", "checks", "self_test"]
