"""The closed loop of LLM-PAS, once for every world: plan -> execute -> on an anomaly, reason ->
validate -> replan from the believed state with the new goals (and the task goals when they can
be planned together) -> resume, for a bounded number of rounds.

A world supplies parts (:class:`llmpas.worlds.api.Session`): the problem for a goal from its
belief, the decomposition of a plan into conditional subtrees, the robot and its perception, the
prompt tables and a search model. This package is the only place that plans, executes and asks
the LLM in a run; it imports no world. Its modules:

- :mod:`~llmpas.system.loop`: round control (:func:`close_loop`, :class:`LoopSettings`);
- :mod:`~llmpas.system.anomaly_memory`: the anomaly being resolved (the one place that reads the
  executor's report) and the memory of what was tried for it;
- :mod:`~llmpas.system.consult`: the consultation (the method asked, the candidates of a
  choosing method ranked), its answers checked by :mod:`~llmpas.system.goal_checks` (the
  :class:`GoalChecker`, reasoning's ``Check``), :mod:`~llmpas.system.candidates` and
  :mod:`~llmpas.system.achievable`;
- :mod:`~llmpas.system.next_goal`: the next goal (the task with the recovery goals kept, an
  answer's goals staged in the order written), with :mod:`~llmpas.system.recovery`'s rules;
- :mod:`~llmpas.system.acting`: :func:`plan` and :func:`execute`, memoised per round;
- :mod:`~llmpas.system.llm_factories`: the loop's LLM, a factory of the session (:func:`fixed` for
  a plain backend), asked once per identical request and before the deadline;
- :mod:`~llmpas.system.sweep`: an object-loss consultation's places, searched in order until
  the object is seen, within a budget; :mod:`~llmpas.system.substitution`: a substitute for a
  part of the task a known cause forbids, carried into the task;
- :mod:`~llmpas.system.settings`: :class:`LoopSettings`;
- :mod:`~llmpas.system.observe`: the :class:`Observer` the loop tells of every plan, tick,
  round, consultation and record (a live view, a recording); none by default;
- :mod:`~llmpas.system.search_memory`: the :class:`SearchMemory` (what was searched, what is left);
- :mod:`~llmpas.system.records`: rounds, results (belief and truth side by side), the Markdown
  report and the run folder;
- :mod:`~llmpas.system.entry_points`: the entry points :func:`run` and :func:`run_once`, which
  judge the task in the world's truth.

The belief carries over between rounds (what the robot saw while recovering is what lets it
finish the task); the world's truth is read only by the truth judge (after the loop) and by a
labelled oracle.
"""

from llmpas.system.acting import counted, execute, plan
from llmpas.system.entry_points import judged, run, run_once, truth
from llmpas.system.goal_checks import UNJUDGED, GoalChecker
from llmpas.system.llm_factories import LLMFactory, LLMFor, as_factory, fixed
from llmpas.system.loop import LoopSettings, close_loop
from llmpas.system.observe import NoObserver, Observer
from llmpas.system.records import (
    LoopResult,
    LoopStatus,
    OnRound,
    Round,
    loop_markdown,
    save_loop,
    save_once,
    save_records,
)
from llmpas.system.search_memory import SearchMemory
from llmpas.system.sweep import SweepBudget

__all__ = [
    "UNJUDGED",
    "GoalChecker",
    "LLMFactory",
    "LLMFor",
    "LoopResult",
    "LoopSettings",
    "LoopStatus",
    "NoObserver",
    "Observer",
    "OnRound",
    "Round",
    "SearchMemory",
    "SweepBudget",
    "as_factory",
    "close_loop",
    "counted",
    "execute",
    "fixed",
    "judged",
    "loop_markdown",
    "plan",
    "run",
    "run_once",
    "save_loop",
    "save_once",
    "save_records",
    "truth",
]
