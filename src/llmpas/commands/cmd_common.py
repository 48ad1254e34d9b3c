"""The command line's shared parts: its usage error, the planner's options, and bad option values
as one-line errors."""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable

from rich.console import Console

from llmpas.errors import ExitCode, LlmpasError, PlannerError, UsageError
from llmpas.options import positive_float, seed
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, planner_registry
from llmpas.planning.quality import DEFAULT_QUALITY, QUALITIES

Handler = Callable[[argparse.Namespace, Console], int]


class CliError(UsageError):
    """A user error: printed as one line; exit status 2 (usage) unless ``code`` says another."""

    def __init__(self, message: str, code: ExitCode | None = None) -> None:
        super().__init__(message)
        if code is not None:
            self.code = code


def add_planner_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--algorithm",
        choices=planner_registry.algorithm_names(),
        default=planner_registry.DEFAULT_ALGORITHM,
        help="the planning algorithm: "
        + "; ".join(f"{e.name}: {e.description}" for e in planner_registry.ALGORITHMS.values()),
    )
    p.add_argument(
        "--classical",
        choices=planner_registry.classical_names(),
        default=planner_registry.DEFAULT_CLASSICAL,
        help="the classical planner every search runs on",
    )
    p.add_argument(
        "--defer",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="leave deferred streams (e.g. BaseMotion, Kin) to execution; --no-defer: nothing "
        "deferred, every stream computed while planning",
    )
    p.add_argument("--eager", action="store_true", help=argparse.SUPPRESS)  # old --no-defer
    p.add_argument(
        "--max-time", type=positive_float, default=60.0, help="seconds for the whole plan"
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--quality",
        choices=tuple(QUALITIES),
        default=DEFAULT_QUALITY,
        help="plan quality: fast (first plan, cost-blind search), anytime (then cheaper plans "
        "while time and patience remain), optimal (A* on h^max: cheapest for the samples drawn)",
    )


def planner_config(args: argparse.Namespace) -> PlannerConfig:
    if args.eager:
        logging.getLogger(__name__).warning("--eager is deprecated: say --no-defer")
    try:
        return PlannerConfig(
            algorithm=args.algorithm,
            classical=args.classical,
            defer=args.defer and not args.eager,
            max_time=args.max_time,
            search_time=args.max_time,
            seed=args.seed,
            quality=getattr(args, "quality", DEFAULT_QUALITY),
        )
    except ValueError as e:
        raise CliError(str(e)) from None


def planning_failed(result: PlanResult) -> CliError | PlannerError:
    """The error for a plan that was not found: the planner's own failure, or none found."""
    if result.status is PlanStatus.ERROR:
        return PlannerError(f"planner: {result.message}")
    return CliError(f"no plan: {result.status.value}: {result.message}", code=ExitCode.FAILED)


def one_line_errors(command: Handler) -> Handler:
    """``command`` with bad option values (``ValueError`` from a configuration) turned into
    one-line usage errors; input, planner and LLM errors keep their own class."""

    def handler(args: argparse.Namespace, console: Console) -> int:
        try:
            return command(args, console)
        except LlmpasError:
            raise
        except ValueError as e:
            raise CliError(str(e)) from None

    return handler


__all__ = [
    "CliError",
    "Handler",
    "add_planner_options",
    "one_line_errors",
    "planner_config",
    "planning_failed",
]
