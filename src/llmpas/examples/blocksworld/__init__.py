"""The classic four-operator blocks world, with a seeded problem generator."""

from llmpas.examples.blocksworld.generator import (
    PACKAGE,
    BlocksInstance,
    generate,
    make_problem,
    problem_text,
    shipped_problem_text,
)

__all__ = [
    "PACKAGE",
    "BlocksInstance",
    "generate",
    "make_problem",
    "problem_text",
    "shipped_problem_text",
]
