"""External ``:predicate`` P in formulas: ``(P ...)`` becomes ``(not (not__P ...))`` and
``(not (P ...))`` becomes ``(not__P ...)``, so the planner assumes P false until its test says
otherwise (see :mod:`llmpas.language.streams`)."""

from __future__ import annotations

from collections.abc import Mapping

from llmpas.language.logic import And, Atom, Exists, Forall, Formula, Imply, Not, Or


def external_rewrite(f: Formula, external: Mapping[str, str]) -> Formula:
    """``f`` with every atom of an external predicate replaced by its negated complement."""
    if not external:
        return f
    match f:
        case Atom() as a if a.predicate in external:
            return Not(Atom(external[a.predicate], a.args))
        case Not(arg):
            inner = external_rewrite(arg, external)
            return inner.arg if isinstance(inner, Not) else Not(inner)
        case And(parts):
            return And(tuple(external_rewrite(p, external) for p in parts))
        case Or(parts):
            return Or(tuple(external_rewrite(p, external) for p in parts))
        case Imply(c, t):
            return Imply(external_rewrite(c, external), external_rewrite(t, external))
        case Exists(ps, body):
            return Exists(ps, external_rewrite(body, external))
        case Forall(ps, body):
            return Forall(ps, external_rewrite(body, external))
    return f
