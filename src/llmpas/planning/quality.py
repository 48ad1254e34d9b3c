"""Plan quality as a choice: named Fast Downward search configurations and the quality modes
built from them (``fast``, ``anytime``, ``optimal``).

A :class:`SearchConfig` is one engine with its arguments; :meth:`SearchConfig.command` renders
the search string, optionally with a cost ``bound`` (Fast Downward prunes every path whose real
cost reaches the bound, so a bounded search finds only strictly cheaper plans). Every heuristic
carries ``axioms=approximate_negative`` (checked by :func:`~llmpas.planning.downward.
check_axioms_option` when a planner is made).

A :class:`Quality` says which search finds the first plan and which searches, in turn, look for
cheaper ones while time and patience remain (see :class:`~llmpas.planning.config.PlannerConfig`):

- ``fast``: lazy greedy best-first search with FF and preferred operators; it ignores costs.
  The first plan whose streams succeed is returned.
- ``anytime``: the same first plan, then searches bounded by the incumbent's cost, in the
  order of LAMA's iterated search (weighted A* with FF, w = 5, 3, 2, 1), ending with A* on
  h^max; each cheaper plan is realised (its streams evaluated) and replayed before it replaces
  the incumbent. After each new incumbent, searches first assume streams only on real values
  (``improve_depth``), then at full depth once nothing cheaper is found there.
- ``optimal``: A* on h^max (admissible) in every search; once a plan is realised, A* bounded by
  its cost searches the task again with the real values (the optimistic costs that chose the
  plan were lower bounds), first on real values only (``improve_depth``), until it finds no
  cheaper plan. Optimal for the samples drawn, not
  over the continuous space: a stream planner cannot know values it has not sampled.

Both registries are plain mappings: add an entry to add a configuration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal

_AXIOMS = "axioms=approximate_negative"
_FF = f"ff({_AXIOMS})"
_HMAX = f"hmax({_AXIOMS})"


@dataclass(frozen=True)
class SearchConfig:
    """One Fast Downward search: ``engine(arguments..., bound=B)``."""

    name: str
    engine: str
    arguments: tuple[str, ...]
    admissible: bool  # the first plan it finds is the cheapest of its task
    description: str

    def __post_init__(self) -> None:
        if not self.engine.isidentifier():
            raise ValueError(f"search engine must be a name, got {self.engine!r}")
        if any("bound=" in a or "max_time" in a for a in self.arguments):
            raise ValueError(f"search {self.name!r}: bound and max_time are set per call")

    def command(self, bound: int | None = None) -> str:
        """The ``--search`` argument; with ``bound``, only plans cheaper than it are found."""
        arguments = list(self.arguments)
        if bound is not None:
            if bound < 0:
                raise ValueError(f"a cost bound must be >= 0, got {bound}")
            arguments.append(f"bound={bound}")
        return f"{self.engine}({','.join(arguments)})"


def _wastar(weight: int) -> SearchConfig:
    return SearchConfig(
        f"wastar{weight}-ff",
        "lazy_wastar",
        (f"[{_FF}]", f"preferred=[{_FF}]", f"w={weight}", "cost_type=plusone"),
        admissible=False,
        description=f"lazy weighted A* (w={weight}) with FF; g counts cost + 1 (zero-cost safe)",
    )


SEARCHES: Mapping[str, SearchConfig] = MappingProxyType(
    {
        s.name: s
        for s in (
            SearchConfig(
                "lazy-greedy-ff",
                "lazy_greedy",
                (f"[{_FF}]", f"preferred=[{_FF}]", "reopen_closed=false"),
                admissible=False,
                description="lazy greedy best-first search with FF and preferred operators",
            ),
            _wastar(5),
            _wastar(3),
            _wastar(2),
            _wastar(1),
            SearchConfig(
                "astar-hmax",
                "astar",
                (_HMAX,),
                admissible=True,
                description="A* on h^max (admissible; approximate_negative only relaxes "
                "negated derived predicates further)",
            ),
            SearchConfig(
                "astar-blind",
                "astar",
                ("blind()",),
                admissible=True,
                description="A* without a heuristic (uniform cost search)",
            ),
        )
    }
)

QualityName = Literal["fast", "anytime", "optimal"]


@dataclass(frozen=True)
class Quality:
    """A quality mode: the search for the first plan, then the searches for cheaper ones.

    ``improve`` is empty when the first plan is returned; otherwise the k-th improvement is
    looked for with ``improve[k]`` (the last one repeats), bounded by the incumbent's cost.
    ``keep_sampling``: when a bounded search finds no cheaper plan, widen the task (new samples,
    as after any failed search) and go on; otherwise the incumbent is returned then.

    ``improve_depth`` (focused planning): after each new incumbent, the next searches assume
    stream instances only up to this depth (1: only instances whose inputs are all real
    values), until one finds no cheaper plan; then the depth goes back to ``max_level``. The
    values already drawn are exploited before placeholders are chained: a plan through a
    placeholder fed by another placeholder (a sampled pose, then a conf computed from it) is
    costed with optimistic values (a lower bound, e.g. the fixed part of a distance) and so
    looks cheaper than plans over the real values, while it rarely is once evaluated. None:
    every search uses ``max_level``."""

    name: str
    first: str
    improve: tuple[str, ...]
    description: str
    keep_sampling: bool = False
    improve_depth: int | None = None

    def __post_init__(self) -> None:
        unknown = [s for s in (self.first, *self.improve) if s not in SEARCHES]
        if unknown:
            raise ValueError(f"quality {self.name!r}: unknown search {unknown[0]!r}")
        if self.improve_depth is not None and self.improve_depth < 1:
            raise ValueError(f"quality {self.name!r}: improve_depth must be >= 1 or None")

    @property
    def anytime(self) -> bool:
        return bool(self.improve)

    def search(self, improvements: int) -> SearchConfig:
        """The search for the first plan (``improvements=0``) or, after ``improvements``
        incumbents, for a cheaper one."""
        if improvements == 0 or not self.improve:
            return SEARCHES[self.first]
        return SEARCHES[self.improve[min(improvements, len(self.improve)) - 1]]


QUALITIES: Mapping[str, Quality] = MappingProxyType(
    {
        q.name: q
        for q in (
            Quality("fast", "lazy-greedy-ff", (), "the first plan, cost-blind search"),
            Quality(
                "anytime",
                "lazy-greedy-ff",
                ("wastar5-ff", "wastar3-ff", "wastar2-ff", "wastar1-ff", "astar-hmax"),
                "the first plan fast, then cheaper ones while time and patience remain",
                keep_sampling=True,
                improve_depth=1,
            ),
            Quality(
                "optimal",
                "astar-hmax",
                ("astar-hmax",),
                "admissible search (A* on h^max), repeated on the real values until no cheaper "
                "plan is found",
                improve_depth=1,
            ),
        )
    }
)

#: The default quality (chosen from ``llmpas bench tamp``: see README and PlannerConfig).
DEFAULT_QUALITY: QualityName = "fast"


def quality(name: str) -> Quality:
    """The registered quality ``name``; ``ValueError`` naming the choices otherwise."""
    try:
        return QUALITIES[name]
    except KeyError:
        raise ValueError(
            f"unknown quality {name!r}; choose one of {', '.join(QUALITIES)}"
        ) from None


__all__ = [
    "DEFAULT_QUALITY",
    "QUALITIES",
    "SEARCHES",
    "Quality",
    "QualityName",
    "SearchConfig",
    "quality",
]
