"""What the closed loop does for the LLM beyond asking it (the *assists*), as named switches.

The paper's protocol reads the model's goals and checks their syntax, nothing more: one answer per
consultation, planned as given. This project's loop helps the model in five ways, each a switch
of :class:`Assists`:

- ``search_rewrite`` — ``(on X P)`` for a lost object X and a place P is read as the search it
  states, ``(scanned P)`` (no plan can put X anywhere before it is found);
- ``grammar_pruning`` — grammar decoding leaves out searches of places already searched in vain
  and every literal a check rejected in an earlier answer;
- ``unsearched_list`` — the prompt (and the feedback on a repeated search) lists the places not
  searched yet for a lost object;
- ``validation`` — answers are checked against the belief and the planner before they are taken:
  goals that already hold are dropped, repeated searches and attempts that did not help are
  rejected, unreachable goals are dropped or rejected, with feedback;
- ``repair`` — a rejected answer is sent back with its errors (up to the method's ``repairs``).

:data:`PROTOCOLS` names the two ends: ``paper`` (none) and ``assisted`` (all, today's loop).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from types import MappingProxyType


@dataclass(frozen=True)
class Assists:
    """Which assists the loop gives the LLM (all on: the ``assisted`` protocol)."""

    search_rewrite: bool = True
    grammar_pruning: bool = True
    unsearched_list: bool = True
    validation: bool = True
    repair: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            if not isinstance(getattr(self, f.name), bool):
                raise ValueError(f"assist {f.name} must be true or false")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def none(cls) -> Assists:
        """The paper's protocol: goals parsed and syntax-checked only."""
        return cls(**dict.fromkeys(cls.names(), False))

    @classmethod
    def only(cls, names: Iterable[str]) -> Assists:
        """Exactly the named assists (ValueError naming an unknown one)."""
        chosen = set(names)
        unknown = sorted(chosen - set(cls.names()))
        if unknown:
            raise ValueError(f"unknown assist {unknown[0]!r}; assists: {', '.join(cls.names())}")
        return cls(**{n: n in chosen for n in cls.names()})

    @property
    def on(self) -> tuple[str, ...]:
        return tuple(n for n in self.names() if getattr(self, n))

    @property
    def label(self) -> str:
        """``paper``, ``assisted``, or the assists on joined by ``+``."""
        for name, value in PROTOCOLS.items():
            if value == self:
                return name
        return "+".join(self.on)


PROTOCOLS: Mapping[str, Assists] = MappingProxyType(
    {"paper": Assists.none(), "assisted": Assists()}
)


def parse_assists(text: str) -> Assists:
    """A protocol name, ``none``, or assists joined by ``,`` or ``+`` (``-`` or ``_`` in names)."""
    text = text.strip()
    if text in PROTOCOLS:
        return PROTOCOLS[text]
    if text == "none":
        return Assists.none()
    names = [n.strip().replace("-", "_") for n in text.replace("+", ",").split(",") if n.strip()]
    return Assists.only(names)


def ablation() -> tuple[Assists, ...]:
    """The ablation's variants: none, each assist alone, all of them."""
    alone = tuple(Assists.only((n,)) for n in Assists.names())
    return (Assists.none(), *alone, Assists())


__all__ = ["PROTOCOLS", "Assists", "ablation", "parse_assists"]
