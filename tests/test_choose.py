"""Choosing among the loop's candidate recovery goals (issue #31): ``flp-choose`` ranks them by
a scorer's log-probabilities (a test double that prefers one literal: it knows nothing of the
world), falls back to a numbered choice, records and replays its scores; the controls
(``candidates-first``, ``candidates-random``) ask no model; the page shows the ranking. Run on
the development tasks of tests/data/choose (not in the suite)."""

from __future__ import annotations

import json
from pathlib import Path

from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.language.logic import Atom
from llmpas.reasoning.backends.replay import ReplayBackend
from llmpas.reasoning.choose import Ranked
from llmpas.reasoning.llm import ScoreRequest, Scores
from llmpas.reasoning.methods import MethodConfig, Proposal
from llmpas.system import LoopResult
from llmpas.system.catalog import oracle_for
from tests.test_system import Scripted, clean_blackboard  # noqa: F401 (autouse)

DATA = Path(__file__).parent / "data" / "choose"
FROZEN = str(DATA / "frozen-bread-cook.toml")
DRAWER = str(DATA / "bread-moved-to-drawer1.toml")


class Prefers(Scripted):
    """Scores a choice higher the more of ``liked`` it contains (a test double)."""

    def __init__(self, liked: str, answer: str = "It is frozen.") -> None:
        super().__init__(answer)
        self.liked = liked
        self.scored: list[ScoreRequest] = []

    def score(self, request: ScoreRequest) -> Scores:
        self.scored.append(request)
        return Scores(
            tuple(((-0.1,) if self.liked in c else (-5.0, -5.0)) for c in request.choices)
        )


def config(method: str, seed: int = 0) -> LoopConfig:
    return LoopConfig(method=MethodConfig(method=method, seed=seed))


def proposals(result: LoopResult) -> list[Proposal]:
    return [r.proposal for r in result.rounds if r.proposal is not None]


def test_flp_choose_proposes_the_candidate_the_model_scores_best() -> None:
    llm = Prefers("(heated bread)")
    result = run_loop(FROZEN, llm, config("flp-choose"))
    first = proposals(result)[0]
    assert [str(g) for g in first.goals] == ["(heated bread)"]
    assert result.success, result.message
    assert [r.tag for r in llm.requests] == ["first-look"]  # goals are scored, not written
    asked = llm.scored[0]
    assert "It is frozen." in asked.messages[-1].content  # the first look is in the prompt
    assert "(and (heated bread))" in asked.choices
    texts = [c.text for c in first.candidates]
    assert first.chosen.text == "(and (heated bread))" == texts[0]
    assert all("(hot bread)" not in t for t in texts)  # no action makes it true
    assert "(and (cooked bread))" not in texts  # the goal that just failed
    goals = [e for e in first.exchanges if e.tag == "goals"]
    assert goals and goals[0].response.text == "Goals: (and (heated bread))"


def test_the_next_candidates_are_kept_for_later_rounds() -> None:
    """Cooling does not thaw: after it, the same anomaly takes the next candidate of the
    ranking without asking the model again."""
    llm = Prefers("(cooled bread)")
    result = run_loop(FROZEN, llm, config("flp-choose"))
    ps = proposals(result)
    assert len(ps) >= 2 and len(llm.scored) == 1
    assert [str(g) for g in ps[0].goals] == ["(cooled bread)"]
    assert ps[1].ok and ps[1].chosen is not None and ps[1].chosen != ps[0].chosen
    assert ps[1].chosen in ps[0].candidates


def test_without_scores_the_model_names_a_number() -> None:
    llm = Scripted("3")
    result = run_loop(DRAWER, llm, config("flp-choose"))
    first = proposals(result)[0]
    choice = next(r for r in llm.requests if r.tag == "choice")
    listing = [ln for ln in choice.messages[-1].content.splitlines() if ". (and " in ln]
    assert listing[2].startswith("3. ") and first.chosen.text == listing[2][3:]
    assert choice.grammar is not None and '"3"' in choice.grammar


def test_the_controls_ask_no_model_and_are_seeded() -> None:
    firsts = []
    for method, seed in (
        ("candidates-first", 0),
        ("candidates-random", 0),
        ("candidates-random", 0),
        ("candidates-random", 5),
    ):
        llm = Scripted("unused")
        result = run_loop(DRAWER, llm, config(method, seed))
        assert llm.requests == []
        firsts.append(proposals(result)[0])
    first, rand0, again, rand5 = firsts
    # the enumeration's order: the lost bread's looks first, by name
    assert first.chosen.text == "(and (scanned drawer1))"
    assert rand0.chosen == again.chosen  # the same seed, the same pick
    assert {c.text for c in rand0.candidates} == {c.text for c in first.candidates}
    assert [c.text for c in rand5.candidates] != [c.text for c in rand0.candidates]


def test_scores_are_recorded_and_replayed(tmp_path: Path) -> None:
    recorder = ReplayBackend(tmp_path, Prefers("(heated bread)"), mode="auto")
    recorded = run_loop(FROZEN, recorder, config("flp-choose"))
    kinds = [json.loads(p.read_text()).get("kind", "complete") for p in tmp_path.iterdir()]
    assert sorted(kinds) == ["complete", "score"]
    replayed = run_loop(FROZEN, ReplayBackend(tmp_path), config("flp-choose"))
    assert [p.chosen for p in proposals(replayed)] == [p.chosen for p in proposals(recorded)]
    assert [c.score for c in proposals(replayed)[0].candidates] == [
        c.score for c in proposals(recorded)[0].candidates
    ]


def test_the_oracle_scores_its_own_goals_first() -> None:
    result = run_loop(DRAWER, oracle_for("household"), config("flp-choose"))
    assert result.success, result.message
    assert proposals(result)[0].chosen.text == "(and (scanned drawer1))"


def test_the_run_s_page_shows_the_candidates_their_scores_and_the_choice(
    tmp_path: Path,
) -> None:
    from llmpas.reporting import build_report

    result = run_loop(FROZEN, Prefers("(heated bread)"), config("flp-choose"))
    result.save(tmp_path / "loop.json")
    saved = json.loads((tmp_path / "loop.json").read_text())
    cands = next(r["reasoning"]["candidates"] for r in saved["rounds"] if "reasoning" in r)
    assert cands[0] == {"goals": "(and (heated bread))", "score": -0.1, "chosen": True}
    build_report(tmp_path, {"scenario": "frozen-bread-cook"})
    page = (tmp_path / "index.html").read_text()
    assert "candidate goal sets, ranked" in page and "(and (heated bread))" in page
    assert "-0.100" in page and "chosen" in page


def test_ranked_candidates_read_as_one_conjunction() -> None:
    r = Ranked((Atom("open", ("drawer1",)), Atom("scanned", ("drawer1",))), -1.0)
    assert r.text == "(and (open drawer1) (scanned drawer1))"
