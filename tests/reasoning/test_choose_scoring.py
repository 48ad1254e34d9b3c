"""The controls with no knowledge and the scorings of ``flp-choose`` (issue #36, items 1-2).

- ``candidates-shuffled``: the enumeration in an order seeded by the task's name, the run's seed
  and the consultation, the same in every process whatever ``PYTHONHASHSEED``; no model asked.
- ``prior``: the model's score from the prompt with the evidence removed (no anomaly, no first
  look); no first look asked.
- scorings: ``mean`` (today), ``diff`` (only the text where candidates differ is scored),
  ``pmi`` (against the prompt without the evidence), each ``-words`` (plain words).

A test double scores: it knows a favourite it prefers whatever the evidence (its prior) and a
candidate it prefers only when the anomaly is in the prompt; nothing of the world."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import asdict

import pytest

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.choose import (
    PREFIX,
    WORDS_PREFIX,
    Scoring,
    rank,
    shuffle_seed,
    words,
)
from llmpas.reasoning.llm import Message, Request, Response, ScoreRequest, Scores
from llmpas.reasoning.methods import MethodConfig, Situation, controls

ANOMALY = "pick bread failed: the bread is not in drawer1"
SITUATION = Situation(
    anomaly=ANOMALY,
    actions="move, pick, place, scan, open",
    predicates="(scanned ?p) (open ?p) (on ?o ?p)",
    environment="bread in drawer1 (believed)",
    task="the robot must achieve (and (on bread plate))",
)
FAVOURITE = (Atom("scanned", ("sink",)),)  # preferred whatever happened (a prior)
EVIDENT = (Atom("scanned", ("drawer2",)),)  # preferred only with the anomaly shown
OTHER = (Atom("open", ("drawer1",)),)
CANDS = [OTHER, FAVOURITE, EVIDENT]


class Knows:
    """Scores each choice's characters: -1 each for the favourite, -1.5 each for the evident
    one (-0.5 with the anomaly shown), -3 for the rest (a test double)."""

    name = "knows"

    def __init__(self) -> None:
        self.scored: list[ScoreRequest] = []
        self.requests: list[Request] = []

    def complete(self, request: Request) -> Response:
        self.requests.append(request)
        return Response("The bread was moved.", "knows")

    def score(self, request: ScoreRequest) -> Scores:
        self.scored.append(request)
        shown = ANOMALY in request.messages[-1].content
        out = []
        for choice in request.choices:
            each = -3.0
            if "sink" in choice:
                each = -1.0
            elif "drawer2" in choice:
                each = -0.5 if shown else -1.5
            out.append(tuple([each] * len(choice)))
        return Scores(tuple(out), "knows")


def ranked(method: str, scoring: str = "mean", **kw: object) -> tuple[list[str], Knows, list]:
    llm = Knows()
    config = MethodConfig(method=method, scoring=scoring, **kw)  # type: ignore[arg-type]
    got, exchanges, _ = rank(SITUATION, llm, CANDS, config)
    return [r.text for r in got], llm, list(exchanges)


def test_flp_choose_with_the_evidence_prefers_the_evident_candidate() -> None:
    order, llm, _ = ranked("flp-choose")
    assert order[0] == "(and (scanned drawer2))"
    assert [r.tag for r in llm.requests] == ["first-look"]
    assert ANOMALY in llm.scored[0].messages[-1].content


def test_prior_scores_the_prompt_without_the_evidence_and_asks_no_first_look() -> None:
    order, llm, exchanges = ranked("prior")
    assert order[0] == "(and (scanned sink))"  # the favourite: no evidence to overturn it
    assert llm.requests == []  # no first look
    prompt = llm.scored[0].messages[-1].content
    assert ANOMALY not in prompt and "The bread was moved." not in prompt
    assert SITUATION.task in prompt and SITUATION.environment in prompt  # the rest stays
    assert [e.tag for e in exchanges] == ["goals"]


def test_pmi_discounts_a_candidate_s_own_prior() -> None:
    order, llm, exchanges = ranked("flp-choose", "pmi")
    assert order[0] == "(and (scanned drawer2))"
    with_evidence, blind = llm.scored
    assert ANOMALY in with_evidence.messages[-1].content
    assert ANOMALY not in blind.messages[-1].content
    assert "The bread was moved." not in blind.messages[-1].content
    goals = next(e for e in exchanges if e.tag == "goals")
    assert goals.response.meta == {"scored": 3, "scoring": "pmi", "requests": 2}


class Sums(Knows):
    """The evident candidate scores -0.5 on its differing characters, -2 elsewhere (its
    shared text); the other two -1 on every character."""

    def score(self, request: ScoreRequest) -> Scores:
        self.scored.append(request)
        out = []
        for choice in request.choices:
            full = request.prefix + choice
            if "drawer2" in full:
                out.append(tuple([-0.5] * len(choice)))
            else:
                out.append(tuple([-1.0] * len(choice)))
        return Scores(tuple(out), "sums")


def test_diff_scores_only_the_text_after_what_every_candidate_shares() -> None:
    cands = [(Atom("scanned", ("drawer2",)),), (Atom("scanned", ("drawer3",)),)]
    llm = Sums()
    rank(SITUATION, llm, cands, MethodConfig(method="flp-choose", scoring="diff"))
    asked = llm.scored[0]
    assert asked.prefix == PREFIX + "(and (scanned drawer"
    assert asked.choices == ("2))", "3))")
    llm = Sums()
    rank(SITUATION, llm, cands, MethodConfig(method="flp-choose", scoring="mean"))
    assert llm.scored[0].prefix == PREFIX
    assert llm.scored[0].choices == ("(and (scanned drawer2))", "(and (scanned drawer3))")


def test_diff_sums_where_mean_averages() -> None:
    """Two tokens of -1 against one of -1.5: the mean prefers the first, the sum the second."""

    class Fixed(Knows):
        def score(self, request: ScoreRequest) -> Scores:
            self.scored.append(request)
            return Scores(((-1.0, -1.0), (-1.5,)), "fixed")

    cands = [(Atom("scanned", ("drawer2",)),), (Atom("scanned", ("drawer3",)),)]
    config = MethodConfig(method="flp-choose", scoring="mean")
    mean, _, _ = rank(SITUATION, Fixed(), cands, config)
    summed, _, _ = rank(
        SITUATION, Fixed(), cands, MethodConfig(method="flp-choose", scoring="diff")
    )
    assert mean[0].text == "(and (scanned drawer2))" and mean[0].score == -1.0
    assert summed[0].text == "(and (scanned drawer3))" and summed[0].score == -1.5


def test_words_rendering_scores_plain_words_after_a_plain_prefix() -> None:
    order, llm, exchanges = ranked("flp-choose", "mean-words")
    asked = llm.scored[0]
    assert asked.prefix == WORDS_PREFIX
    assert set(asked.choices) == {"open drawer1", "scanned sink", "scanned drawer2"}
    assert order[0] == "(and (scanned drawer2))"  # the ranking is of the goals themselves
    goals = next(e for e in exchanges if e.tag == "goals")
    assert goals.response.text == "Goals: (and (scanned drawer2))"
    assert words(Not(Atom("on", ("mug", "table2_right")))) == "not on mug table2 right"
    assert Scoring.parse("pmi-words").render(FAVOURITE + OTHER) == "scanned sink and open drawer1"


@pytest.mark.parametrize("bad", ["", "median", "pmi-latex", "words"])
def test_an_unknown_scoring_is_refused_naming_the_choices(bad: str) -> None:
    with pytest.raises(ValueError, match="mean, mean-words, diff"):
        MethodConfig(method="flp-choose", scoring=bad)


def order_of(task: str, seed: int, consultation: int = 0) -> list[str]:
    llm = Knows()
    config = MethodConfig(method="candidates-shuffled", seed=seed, task=task)
    got, exchanges, _ = rank(SITUATION, llm, CANDS * 3, config, consultation)
    assert llm.requests == [] and llm.scored == [] and exchanges == ()
    return [r.text for r in got]


def test_the_shuffled_control_is_seeded_by_task_and_run() -> None:
    assert order_of("ol01-table2", 0) == order_of("ol01-table2", 0)
    tasks = [f"t{i}" for i in range(8)]
    assert len({tuple(order_of(t, 0)) for t in tasks}) > 1  # the task changes the order
    assert len({tuple(order_of("ol01-table2", s)) for s in range(8)}) > 1  # so does the seed
    assert sorted(order_of("t1", 3)) == sorted(r for c in CANDS * 3 for r in [_text(c)])


def _text(c: Sequence[Atom]) -> str:
    return f"(and {' '.join(map(str, c))})"


def test_the_shuffled_order_is_the_same_in_every_process() -> None:
    """``hash()`` is salted per process; the seed is not."""
    code = "from llmpas.reasoning.choose import shuffle_seed; print(shuffle_seed('ab06', 2, 1))"
    seen = set()
    for salt in ("0", "1", "random"):
        env = {**os.environ, "PYTHONHASHSEED": salt}
        out = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        )
        seen.add(out.stdout.strip())
    assert seen == {str(shuffle_seed("ab06", 2, 1))}


def test_each_row_names_its_control() -> None:
    assert controls("flp-choose")[0] == "candidates-shuffled" and "prior" in controls("flp-choose")
    assert controls("candidates-shuffled") == ("replan",) == controls("flp")


def test_cached_runs_keep_their_keys_at_the_default_scoring() -> None:
    from llmpas.experiments.prompting import PromptingConfig, _loop_key, loop_config

    config = PromptingConfig(methods=("flp-choose", "candidates-shuffled"))
    old = loop_config(config, "flp-choose", 0)
    key = _loop_key(old)["method"]
    assert "scoring" not in key and "task" not in key
    assert _loop_key(old)["method"] == {
        k: v for k, v in asdict(old)["method"].items() if k not in ("scoring", "task")
    }
    shuffled = loop_config(config, "candidates-shuffled", 0, task="ol01-table2")
    assert _loop_key(shuffled)["method"]["task"] == "ol01-table2"
    pmi = loop_config(PromptingConfig(scoring="pmi"), "flp-choose", 0, task="ol01-table2")
    assert _loop_key(pmi)["method"]["scoring"] == "pmi" and pmi.method.task == ""


def test_the_table_names_the_control_of_each_row() -> None:
    from llmpas.experiments.prompting import PromptingConfig, control_lines

    config = PromptingConfig(methods=("flp-choose", "candidates-shuffled"), scoring="pmi")
    text = "\n".join(
        control_lines(["oracle", "replan", "flp-choose", "candidates-shuffled"], config)
    )
    assert "| flp-choose | candidates-shuffled, prior (not run here), replan |" in text
    assert "| candidates-shuffled | replan |" in text
    assert "`pmi`" in text


def test_messages_are_unchanged_for_the_default_scoring() -> None:
    """The default scoring asks exactly what #31's flp-choose asked: cached scores replay."""
    _, llm, _ = ranked("flp-choose")
    asked = llm.scored[0]
    assert asked.prefix == PREFIX and asked.choices[0] == "(and (open drawer1))"
    assert asked.messages[0] == Message("system", asked.messages[0].content)
