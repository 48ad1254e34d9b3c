"""What each name of a four-operator blocks-world domain means, read from its structure.

Files in the wild name the same domain differently: ``ontable``/``on-table``,
``handempty``/``arm-empty``, ``pickup``/``pick-up``. :func:`detect_roles` finds the roles by
what the actions do, not by their names:

- ``stack`` adds the one binary predicate (``on``), ``unstack`` deletes it;
- ``pickup`` is the one-parameter action whose precondition has the nullary predicate
  (``handempty``) and that adds ``holding``; ``putdown`` is the other one-parameter action;
- ``clear`` is required of the lower block by ``stack``; ``ontable`` is what ``putdown`` adds
  besides ``clear``.

Prompts, descriptions and the in-context example are then written in the domain's own words.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from llmpas.language.domain import Action, Domain
from llmpas.language.logic import Atom, Formula, Not, conjuncts


class RolesError(ValueError):
    """The domain is not a four-operator blocks world (one line naming what is missing)."""


@dataclass(frozen=True)
class BlocksRoles:
    """The domain's names for the blocks-world predicates and actions."""

    on: str = "on"
    ontable: str = "ontable"
    clear: str = "clear"
    holding: str = "holding"
    handempty: str = "handempty"
    pickup: str = "pickup"
    putdown: str = "putdown"
    stack: str = "stack"
    unstack: str = "unstack"

    def __post_init__(self) -> None:
        names = [self.on, self.ontable, self.clear, self.holding, self.handempty]
        if len(set(names)) != len(names):
            raise RolesError(f"predicate roles must be distinct names, got {names}")
        acts = [self.pickup, self.putdown, self.stack, self.unstack]
        if len(set(acts)) != len(acts):
            raise RolesError(f"action roles must be distinct names, got {acts}")


SHIPPED_ROLES = BlocksRoles()  # the names of llmpas's own blocks domain


def _adds(action: Action) -> list[Atom]:
    return [e for e in action.effects if isinstance(e, Atom)]


def _deletes(action: Action) -> list[Atom]:
    return [e.arg for e in action.effects if isinstance(e, Not) and isinstance(e.arg, Atom)]


def _pre(action: Action) -> list[Atom]:
    return [f for f in conjuncts(action.precondition) if isinstance(f, Atom)]


def _one(found: list[str], what: str, domain: Domain) -> str:
    unique = sorted(set(found))
    if len(unique) != 1:
        got = ", ".join(unique) if unique else "none"
        raise RolesError(
            f"{domain.filename}: not a four-operator blocks world: expected exactly one "
            f"{what}, found {got}"
        )
    return unique[0]


def detect_roles(domain: Domain) -> BlocksRoles:
    """The roles of ``domain``'s names; :class:`RolesError` when it is not such a domain."""
    binary = [p for p, s in domain.predicates.items() if s.arity == 2]
    on = _one(binary, "binary predicate (on)", domain)
    nullary = [p for p, s in domain.predicates.items() if s.arity == 0]
    handempty = _one(nullary, "nullary predicate (hand empty)", domain)
    two = [a for a in domain.actions if len(a.params) == 2]
    one = [a for a in domain.actions if len(a.params) == 1]
    stack_a = _action(two, lambda a: any(x.predicate == on for x in _adds(a)), "stack", domain)
    unstack_a = _action(
        two, lambda a: any(x.predicate == on for x in _deletes(a)), "unstack", domain
    )
    pickup_a = _action(
        one, lambda a: any(x.predicate == handempty for x in _pre(a)), "pickup", domain
    )
    putdown_a = _action([a for a in one if a is not pickup_a], lambda a: True, "putdown", domain)
    lower = stack_a.params[1].name
    holding = _one(
        [x.predicate for x in _adds(pickup_a) if len(x.args) == 1], "predicate pickup adds", domain
    )
    clear = _one(
        [x.predicate for x in _pre(stack_a) if x.args == (lower,)],
        "predicate stack requires of the lower block",
        domain,
    )
    ontable = _one(
        [x.predicate for x in _adds(putdown_a) if len(x.args) == 1 and x.predicate != clear],
        "table predicate putdown adds",
        domain,
    )
    return BlocksRoles(
        on, ontable, clear, holding, handempty,
        pickup_a.name, putdown_a.name, stack_a.name, unstack_a.name,
    )  # fmt: skip


def _action(
    candidates: list[Action], test: Callable[[Action], bool], what: str, domain: Domain
) -> Action:
    matches = [a for a in candidates if test(a)]
    if len(matches) != 1:
        names = ", ".join(a.name for a in matches) or "none"
        raise RolesError(
            f"{domain.filename}: not a four-operator blocks world: expected one {what} "
            f"action, found {names}"
        )
    return matches[0]


def goal_words(f: Formula, roles: BlocksRoles) -> str:
    """One goal literal in words."""
    if isinstance(f, Atom):
        if f.predicate == roles.on and len(f.args) == 2:
            return f"{f.args[0]} is on {f.args[1]}"
        if f.predicate == roles.ontable and len(f.args) == 1:
            return f"{f.args[0]} is on the table"
        if f.predicate == roles.clear and len(f.args) == 1:
            return f"nothing is on {f.args[0]}"
        if f.predicate == roles.holding and len(f.args) == 1:
            return f"the hand holds {f.args[0]}"
        if f.predicate == roles.handempty and not f.args:
            return "the hand is empty"
    return str(f)


__all__ = ["SHIPPED_ROLES", "BlocksRoles", "RolesError", "detect_roles", "goal_words"]
