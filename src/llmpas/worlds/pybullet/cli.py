"""Command-line entry for the PyBullet world, for ``llmpas`` to delegate to.

``llmpas.cli`` can call :func:`add_arguments` on a sub-parser and :func:`run` from its handler;
the LLM backend comes from the caller (``oracle`` selects this world's oracle).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from llmpas.worlds.pybullet.loop import LoopConfig, oracle_factory, run_loop
from llmpas.worlds.pybullet.run import RunConfig, run_scenario, scenarios


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", choices=sorted(scenarios()), help="a PyBullet scenario")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--gui", action="store_true", help="open the PyBullet window")
    p.add_argument("--out", help="episode folder (report, snapshots, GIF, CSubBT XML)")
    p.add_argument("--rounds", type=int, default=3, help="LLM consultations at most")
    p.add_argument("--no-llm", action="store_true", help="plan and execute once, no recovery")


def run(
    args: argparse.Namespace,
    llm: Any = "oracle",
    method: Any = None,
    echo: Callable[[str], None] = print,
) -> int:
    """Run a scenario; ``llm`` is ``"oracle"``, an LLM backend, or a factory. Prints a summary
    and returns the exit code (0: the goal holds in the simulator)."""
    config = RunConfig(seed=args.seed, gui=args.gui)
    out = Path(args.out) if args.out else None
    if args.no_llm:
        r = run_scenario(args.scenario, config, out)
        status = r.episode.status.value if r.episode else "no plan"
        echo(f"{args.scenario}: {status}; goal achieved: {r.achieved}")
        return 0 if r.succeeded else 1
    deadline = getattr(args, "deadline", None)  # ``llmpas run --deadline``
    loop_config = LoopConfig(max_rounds=args.rounds, deadline=deadline, run=config)
    if method is not None:
        loop_config = replace(loop_config, method=method)
    backend = oracle_factory if llm == "oracle" else llm
    result = run_loop(args.scenario, backend, loop_config, out)
    for i, rnd in enumerate(result.rounds):
        ep = rnd.episode
        echo(f"round {i}: {rnd.goal} -> {ep.status.value if ep else 'no plan'}")
        if ep is not None and ep.anomaly is not None:
            echo(f"  anomaly: {ep.anomaly.constraint} ({ep.anomaly.reason})")
        if rnd.proposal is not None:
            echo(f"  goals: {' '.join(map(str, rnd.proposal.goals))}")
    echo(f"{'task done' if result.success else 'not done'}: {result.message}")
    return 0 if result.success else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m llmpas.worlds.pybullet.cli")
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
