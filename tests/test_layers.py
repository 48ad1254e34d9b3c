"""The layers stay as built: import-linter's contracts (``.importlinter``) hold on the code, and
they do fail when a lower layer imports a higher one (checked on a copy with a back-import)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / ".importlinter"


def lint(src: Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(src)}
    script = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    return subprocess.run(
        [sys.executable, "-c", script, "--config", str(cwd / ".importlinter"), "--no-cache"],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_contracts_hold() -> None:
    result = lint(ROOT / "src", ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


@pytest.mark.parametrize(
    ("module", "back_import", "contract"),
    [
        ("language/logic.py", "import llmpas.planning.tamp", "language is the base"),
        ("execution/space.py", "import llmpas.system", "execution never imports"),
        ("reasoning/goal_reading.py", "import llmpas.worlds.household.scenario", "reasoning never"),
        ("system/search_memory.py", "import llmpas.system.loop", "inside system"),
        ("system/records.py", "import llmpas.system.entry_points", "inside system"),
        # llmpas run and the product's registry import nothing of the experiments
        ("commands/cmd_run.py", "import llmpas.experiments.prompting", "the product imports"),
        ("system/catalog.py", "import llmpas.experiments.worlds", "the product imports"),
        ("cli.py", "import llmpas.experiments.jobs", "main module imports the experiments"),
        (
            "commands/cmd_world.py",
            "import llmpas.worlds.household.household_plugin",
            "imports no world",
        ),
    ],
)
def test_a_back_import_breaks_a_contract(
    tmp_path: Path, module: str, back_import: str, contract: str
) -> None:
    src = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "llmpas", src / "llmpas")
    shutil.copy(CONFIG, tmp_path / ".importlinter")
    target = src / "llmpas" / module
    target.write_text(target.read_text() + f"\n{back_import}  # noqa\n")
    result = lint(src, tmp_path)
    assert result.returncode != 0
    assert f"{contract}" in result.stdout and "BROKEN" in result.stdout


@pytest.mark.parametrize(
    ("importer", "back_import", "contract"),
    [
        # a new world package is covered by the contracts as it is, with no edit to them
        ("worlds/newworld/session.py", "import llmpas.reasoning.goal_reading", "worlds take only"),
        ("system/loop.py", "import llmpas.worlds.newworld.session", "system imports no world"),
        (
            "system/goal_checks.py",
            "import llmpas.worlds.newworld.session",
            "system imports no world",
        ),
        ("worlds/api.py", "import llmpas.worlds.newworld.session", "the world protocol"),
        ("reasoning/tables.py", "import llmpas.reasoning.methods", "data tables are a leaf"),
    ],
)
def test_a_new_world_is_held_to_the_contracts_unchanged(
    tmp_path: Path, importer: str, back_import: str, contract: str
) -> None:
    src = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "llmpas", src / "llmpas")
    shutil.copy(CONFIG, tmp_path / ".importlinter")
    world = src / "llmpas" / "worlds" / "newworld"
    world.mkdir()
    (world / "__init__.py").write_text('"""a world the contracts do not name"""\n')
    (world / "session.py").write_text("from llmpas.reasoning.tables import Vocabulary  # noqa\n")
    assert "0 broken" in lint(src, tmp_path).stdout  # the data tables are allowed to worlds
    target = src / "llmpas" / importer
    target.write_text(target.read_text() + f"\n{back_import}  # noqa\n")
    result = lint(src, tmp_path)
    assert result.returncode != 0
    assert contract in result.stdout and "BROKEN" in result.stdout
