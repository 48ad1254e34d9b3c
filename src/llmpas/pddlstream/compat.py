"""The module paths PDDLStream scripts import from (``pddlstream.language.constants``, ...),
built as modules whose names come from this package: what the runner's import hook serves.

Each run gets its own modules (:func:`build_modules`), whose ``solve`` functions report to that
run's :class:`~llmpas.pddlstream.solving.SolveContext`; nothing global is changed.
"""

from __future__ import annotations

import functools
import importlib
import types
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from llmpas.pddlstream import expressions, pddl_solve, solving, utils, wrappers
from llmpas.pddlstream.expressions import INF, DurativeAction


class PlanConstraints(NamedTuple):
    """PDDLStream's plan constraints: only their absence (``skeletons=None``) is planned."""

    skeletons: Any = None
    groups: Any = None
    exact: bool = True
    hint: bool = False
    max_cost: float = INF


WILD = "*"


def retime_plan(plan: Any, duration: float = 1.0) -> Any:
    """A sequential plan as durative actions, one after another, each ``duration`` long."""
    if plan is None:
        return None
    return [DurativeAction(a.name, a.args, i * duration, duration) for i, a in enumerate(plan)]


def get_end(action: Any) -> float:
    return float(action.start + action.duration)


def compute_duration(plan: Any) -> float:
    return max((get_end(a) for a in plan or ()), default=0.0)


class OptimizerOutput(NamedTuple):
    assignments: Any = ()
    facts: Any = ()
    infeasible: Any = ()


class SharedOptValue(NamedTuple):
    stream: Any
    inputs: Any
    values: Any
    output: Any


class UniqueOptValue(NamedTuple):
    instance: Any
    sequence_index: Any
    output: Any


def get_cost_scale() -> float:
    return 1.0


def set_cost_scale(scale: float) -> None:
    """Accepted: llmpas scales costs itself."""


_SOLVERS = (
    "solve",
    "solve_focused",
    "solve_binding",
    "solve_adaptive",
    "solve_incremental",
    "solve_serialized",
    "solve_from_pddl",
)

# alias module -> (modules whose public names it holds, extra names)
_TABLE: Mapping[str, tuple[tuple[types.ModuleType, ...], Mapping[str, Any]]] = {
    "pddlstream": ((), {}),
    "pddlstream.algorithms": ((), {}),
    "pddlstream.language": ((), {}),
    "pddlstream.algorithms.meta": ((solving,), {}),
    "pddlstream.algorithms.focused": ((solving,), {}),
    "pddlstream.algorithms.incremental": ((solving,), {}),
    "pddlstream.algorithms.serialized": ((solving,), {}),
    "pddlstream.algorithms.search": ((pddl_solve,), {}),
    "pddlstream.algorithms.common": ((), {}),  # SOLUTIONS: a fresh list per run
    "pddlstream.algorithms.constraints": ((), {"PlanConstraints": PlanConstraints, "WILD": WILD}),
    "pddlstream.algorithms.downward": (
        (),
        {"get_cost_scale": get_cost_scale, "set_cost_scale": set_cost_scale, "MAX_FD_COST": 1e8},
    ),
    "pddlstream.algorithms.visualization": ((), {"VISUALIZATIONS_DIR": "visualizations/"}),
    # switches between parts of PDDLStream's own implementation (kitchen/run.py sets them):
    # their values as PDDLStream has them; setting them changes nothing here
    "pddlstream.algorithms.instantiate_task": ((), {"FD_INSTANTIATE": True}),
    "pddlstream.algorithms.instantiation": ((), {"USE_RELATION": True}),
    "pddlstream.algorithms.refinement": ((), {"CONSTRAIN_PLANS": False}),
    "pddlstream.language.constants": (
        (expressions,),
        {
            "read_relative": utils.read_relative,
            "read_relative_dir": utils.read_relative_dir,
            "read_pddl_pair": utils.read_pddl_pair,
            "read_pddlstream_pair": utils.read_pddlstream_pair,
        },
    ),
    "pddlstream.language.generator": ((wrappers,), {}),
    "pddlstream.language.stream": ((wrappers,), {}),
    "pddlstream.language.function": ((wrappers,), {}),
    "pddlstream.language.external": ((wrappers,), {}),
    "pddlstream.language.object": (
        (),
        {
            "SharedOptValue": SharedOptValue,
            "UniqueOptValue": UniqueOptValue,
            "DebugValue": wrappers.DebugValue,
            "SharedDebugValue": wrappers.SharedDebugValue,
        },
    ),
    "pddlstream.language.optimizer": ((), {"OptimizerOutput": OptimizerOutput}),
    "pddlstream.language.temporal": (
        (),
        {
            "retime_plan": retime_plan,
            "get_end": get_end,
            "compute_duration": compute_duration,
            "DurativeAction": DurativeAction,
        },
    ),
    "pddlstream.utils": ((utils, expressions), {}),
}

MODULE_NAMES = frozenset(_TABLE)


def build_modules(context: solving.SolveContext) -> dict[str, types.ModuleType]:
    """Fresh alias modules whose solvers report to ``context``."""
    out: dict[str, types.ModuleType] = {}
    for name, (sources, extra) in _TABLE.items():
        module = types.ModuleType(name, f"llmpas's PDDLStream API ({name})")
        module.__dict__["__llmpas__"] = True
        names: dict[str, Any] = {}
        for source in sources:
            names.update({k: v for k, v in vars(source).items() if _public(k, v)})
        names.update(extra)
        if name == "pddlstream.algorithms.common":
            names["SOLUTIONS"] = []
        for solver in _SOLVERS:
            if solver in names:
                names[solver] = _bound(names[solver], context)
        if name in ("pddlstream", "pddlstream.algorithms", "pddlstream.language"):
            module.__path__ = []  # a package: its submodules come from the table
        module.__dict__.update(names)
        out[name] = module
    for name, module in out.items():  # packages know their submodules, as after an import
        parent, _, child = name.rpartition(".")
        if parent in out:
            setattr(out[parent], child, module)
    return out


def _public(name: str, value: Any) -> bool:
    return not name.startswith("_") and not isinstance(value, types.ModuleType)


def _bound(fn: Callable[..., Any], context: solving.SolveContext) -> Callable[..., Any]:
    return functools.wraps(fn)(functools.partial(fn, context=context))


def native(name: str) -> types.ModuleType:
    """The llmpas module behind an alias (for documentation and tests)."""
    return importlib.import_module(name)
