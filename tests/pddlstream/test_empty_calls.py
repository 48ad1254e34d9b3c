"""A generator's ``None`` ends the call without an output, as in PDDLStream (one call is one
``next``): a sampler that never finds anything for one input does not take the whole time
while another input would do."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

from llmpas.pddlstream import PDDLProblem, from_gen_fn, solve
from llmpas.pddlstream.solving import SolveContext

DOMAIN = """
(define (domain watch)
  (:requirements :strips)
  (:predicates (Target ?o) (Near ?o) (Far ?o) (View ?o ?q) (Seen))
  (:action approach :parameters (?o)
    :precondition (Far ?o)
    :effect (and (Near ?o) (not (Far ?o))))
  (:action observe :parameters (?o ?q)
    :precondition (and (Near ?o) (View ?o ?q))
    :effect (Seen)))
"""
STREAMS = """
(define (stream watch)
  (:stream find-view :inputs (?o) :domain (Target ?o) :outputs (?q)
    :certified (View ?o ?q)))
"""


def test_a_generator_that_yields_none_forever_leaves_time_for_other_inputs() -> None:
    calls: dict[str, int] = {}

    def find_view(o: str) -> Iterator[tuple[int] | None]:
        for k in itertools.count():
            calls[o] = calls.get(o, 0) + 1
            # "hidden" is never visible: its sampler gives up after each batch of attempts
            yield None if o == "hidden" else (k,)

    problem = PDDLProblem(
        DOMAIN,
        {},
        STREAMS,
        {"find-view": from_gen_fn(find_view)},
        # the nearer target (one step shorter) is the hopeless one: it is tried first
        [("Target", "hidden"), ("Near", "hidden"), ("Target", "open"), ("Far", "open")],
        ("Seen",),
    )
    seen: list = []
    plan, _, _ = solve(problem, max_time=8, context=SolveContext(on_attempt=seen.append))
    assert plan is not None, seen[0].result.message
    assert [a.name for a in plan] == ["approach", "observe"]
    assert calls["hidden"] < 10  # a few calls of one next() each, not a loop until max_time
