"""The tabletop world, written only against the world protocol: the protocol's checks, the
nominal task judged in PyBullet's truth, the blocking anomaly, and recovery with the oracle.

The sessions are driven exactly as :mod:`llmpas.system` drives any world: ``session.problem``
-> :func:`llmpas.planning.solve` -> ``session.decompose`` -> the CSubBT executor."""

from __future__ import annotations

import ast
import io
import json
import tokenize
from pathlib import Path

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("ompl")

from llmpas.execution.executor import Episode, ExecStatus, execute
from llmpas.language.logic import Atom, Formula, Not
from llmpas.language.problem import parse_formula
from llmpas.planning import solve
from llmpas.reasoning.llm import Message, Request
from llmpas.reasoning.prompts import situation
from llmpas.reasoning.tables import PromptTables
from llmpas.worlds.api import RunOptions, SearchModel, Session, World
from llmpas.worlds.tabletop import WORLD
from llmpas.worlds.tabletop.tabletop_oracle import oracle

PACKAGE = Path(__file__).parents[3] / "src" / "llmpas" / "worlds" / "tabletop"


def code_lines(source: str) -> int:
    """Lines holding code: not blank, not only a comment, not part of a docstring."""
    tree = ast.parse(source)
    docs: set[int] = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            value = body[0].value
            if isinstance(value, ast.Constant) and isinstance(value.value, str):
                docs |= set(range(body[0].lineno, (body[0].end_lineno or body[0].lineno) + 1))
    code: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in (
            tokenize.COMMENT,
            tokenize.NL,
            tokenize.NEWLINE,
            tokenize.INDENT,
            tokenize.DEDENT,
            tokenize.ENDMARKER,
        ):
            code |= set(range(tok.start[0], tok.end[0] + 1))
    return len(code - docs)


def test_code_lines_counts_code_only() -> None:
    text = '"""Doc\n\nstring."""\n\n# a comment\nx = (1,\n     2)  # trailing\n'
    assert code_lines(text) == 2


def test_the_package_has_at_most_400_code_lines() -> None:
    total = sum(code_lines(f.read_text()) for f in PACKAGE.glob("*.py"))
    assert 0 < total <= 400, total


def test_the_world_satisfies_the_protocol_without_connecting() -> None:
    assert isinstance(WORLD, World)
    assert WORLD.name == "tabletop"
    assert set(WORLD.scenarios()) == {"tabletop-nominal", "tabletop-blocking"}
    with pytest.raises(KeyError, match="tabletop-blocking"), WORLD.open("nope", RunOptions()):
        pass


QUIET = RunOptions(snapshots=False)


def attempt(session: Session, goal: Formula | str, index: int = 0) -> Episode:
    problem = session.problem(goal, index)
    result = solve(problem, session.planner)
    assert result.plan is not None, result.message
    return execute(session.decompose(problem, result.plan), session.context, session.executor)


def test_a_session_satisfies_the_protocol() -> None:
    with WORLD.open("tabletop-blocking", QUIET) as session:
        assert isinstance(session, Session)
        assert isinstance(session.search, SearchModel)
        assert isinstance(session.prompts, PromptTables)
        assert session.name == "tabletop-blocking"
        assert session.task == "(and (on green_cube bowl))"
        assert session.search.places() == ("table",)
        assert session.search.lost("black_cube")  # the robot does not know it is there
        assert not session.search.lost("green_cube")
        assert set(session.vocabulary.predicates) == {"on", "holding", "scanned"}
        assert "black_cube (black cube): location unknown" in session.environment()
        assert session.achieved() is False
        assert session.timings["build"] > 0
        assert "pedestal" in session.scene.bodies and "husky" not in session.scene.bodies
        # no example in the prompt names this world's objects (it would leak the answer)
        sit = situation(session.prompts, "x", session.environment(), session.task)
        for name in session.prompts.objects:
            assert name not in sit.example and name not in sit.example_call
        for name in ("green_cube", "black_cube"):
            assert name not in sit.actions and name not in sit.predicates


def test_nominal_plans_and_executes_to_success_judged_in_the_truth(tmp_path: Path) -> None:
    with WORLD.open("tabletop-nominal", RunOptions()) as session:
        episode = attempt(session, session.task)
        assert episode.status is ExecStatus.SUCCESS, episode.message
        assert session.achieved()
        files = session.save(tmp_path)
    assert (tmp_path / "episode.gif").is_file() and tmp_path / "episode.gif" in files
    media = json.loads((tmp_path / "media.json").read_text())
    assert {m["kind"] for m in media} == {"snapshot", "camera"}
    assert all((tmp_path / m["file"]).is_file() for m in media)
    assert json.loads((tmp_path / "world.json").read_text())["achieved"] is True


def test_blocking_yields_the_bowl_is_full() -> None:
    with WORLD.open("tabletop-blocking", QUIET) as session:
        episode = attempt(session, session.task)
        assert episode.status is ExecStatus.ANOMALY
        assert episode.anomaly is not None
        assert episode.anomaly.constraint == Not(Atom("full", ("bowl",)))
        assert not session.achieved()
        # what the robot saw when it looked: the black cube, in the bowl
        assert "black_cube (black cube): on bowl" in session.environment()
        assert "green_cube (green cube): held by the arm" in session.environment()


def test_the_bowl_is_a_fixture_no_plan_picks_it() -> None:
    with WORLD.open("tabletop-nominal", QUIET) as session:
        problem = session.problem("(and (holding bowl))", 0)
        assert not solve(problem, session.planner).solved


@pytest.mark.parametrize(
    "seed", [None, *(pytest.param(s, marks=pytest.mark.slow) for s in range(1, 8))]
)
def test_blocking_recovers_with_the_oracles_goals_and_a_replan(seed: int | None) -> None:
    with WORLD.open("tabletop-blocking", RunOptions(seed=seed, snapshots=False)) as session:
        first = attempt(session, session.task)
        assert first.anomaly is not None
        llm = oracle(session)
        assert llm.name == "oracle"
        sit = situation(
            session.prompts,
            first.anomaly.describe(),
            session.environment(),
            session.task,
            constraint=first.anomaly.constraint,
        )
        msgs = (Message("user", "?"),)
        look = llm.complete(Request(msgs, tag="first-look", situation=sit))
        assert look.text and "(" not in look.text
        answer = llm.complete(Request(msgs, tag="goals", situation=sit)).text
        assert answer == "(and (on black_cube table))"
        both = parse_formula("(and (on black_cube table) (on green_cube bowl))", session.domain)
        recovered = attempt(session, both, 1)
        assert recovered.status is ExecStatus.SUCCESS, recovered.message
        assert session.achieved()
        at, _ = session.scene.pose("black_cube")
        assert session.scene.region_of(*at) == "table"


# ------------------------------------------------------------ through the system's one loop

CASSETTES = Path(__file__).parents[2] / "data" / "cassettes" / "qwen1.5b-tabletop"


def test_the_cli_runs_the_tabletop_with_its_oracle(tmp_path: Path) -> None:
    from llmpas.cli import main

    assert main(["run", "tabletop-blocking", "--llm", "oracle", "--out", str(tmp_path)]) == 0
    loop = json.loads((tmp_path / "loop.json").read_text())
    assert loop["rounds"][0]["anomaly"]["constraint"] == "(not (full bowl))"
    assert (tmp_path / "round-0" / "plan.xml").is_file() and (tmp_path / "episode.gif").is_file()


def test_the_offline_models_recorded_answers_recover_the_tabletop() -> None:
    """Qwen2.5-Coder-1.5B, recorded once with ``llmpas run tabletop-blocking --llm llama-cpp
    --record``; replayed through :func:`llmpas.system.run` (a changed prompt fails)."""
    from llmpas.reasoning.backends.replay import ReplayBackend
    from llmpas.system import LoopSettings, run

    llm = ReplayBackend(CASSETTES, mode="replay")
    result = run(WORLD, "tabletop-blocking", llm, LoopSettings(), RunOptions(snapshots=False))
    assert result.success, result.message  # judged in PyBullet's true state
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.first_look and all(e.response.model for e in proposal.exchanges)
