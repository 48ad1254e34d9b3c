"""Hypothesis strategies: closed first-order formulas over a tiny vocabulary.

Predicates ``p/1``, ``q/2``, ``r/0`` and ``=``; constants ``a`` and ``c``; quantified variables
``?x ?y ?z`` (re-quantifying a bound variable shadows it).
"""

from __future__ import annotations

from hypothesis import strategies as st

from llmpas.language.logic import And, Atom, Exists, Forall, Imply, Not, Or, Param

PREDICATES = {"p": 1, "q": 2, "r": 0}
CONSTANTS = ["a", "c"]
VARIABLES = ["?x", "?y", "?z"]


@st.composite
def formulas(
    draw,
    bound: frozenset[str] = frozenset(),
    depth: int = 3,
    types: tuple[str, ...] = ("object", "block", "room"),
    mixed_types: bool = True,
):
    """A formula whose free variables are among ``bound``.

    With ``mixed_types=False`` all variables of one quantifier share a type.
    """
    terms = sorted(bound) + CONSTANTS
    kinds = ["atom", "eq"]
    if depth > 0:
        kinds += ["not", "and", "or", "imply", "exists", "forall"]
    kind = draw(st.sampled_from(kinds))

    def sub(b: frozenset[str] = bound):
        return formulas(b, depth - 1, types, mixed_types)

    if kind == "atom":
        pred = draw(st.sampled_from(sorted(PREDICATES)))
        n = PREDICATES[pred]
        return Atom(pred, tuple(draw(st.lists(st.sampled_from(terms), min_size=n, max_size=n))))
    if kind == "eq":
        return Atom("=", (draw(st.sampled_from(terms)), draw(st.sampled_from(terms))))
    if kind == "not":
        return Not(draw(sub()))
    if kind == "and":
        return And(tuple(draw(st.lists(sub(), max_size=3))))
    if kind == "or":
        return Or(tuple(draw(st.lists(sub(), min_size=1, max_size=3))))
    if kind == "imply":
        return Imply(draw(sub()), draw(sub()))
    names = draw(st.lists(st.sampled_from(VARIABLES), min_size=1, max_size=2, unique=True))
    if mixed_types:
        params = tuple(Param(n, draw(st.sampled_from(types))) for n in names)
    else:
        ty = draw(st.sampled_from(types))
        params = tuple(Param(n, ty) for n in names)
    body = draw(sub(bound | set(names)))
    return Exists(params, body) if kind == "exists" else Forall(params, body)
