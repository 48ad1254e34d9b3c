"""A 2-D continuous TAMP domain in the shape of PDDLStream's 2-D example, and its benchmark
families ``mirror`` and ``packed`` (see :mod:`.world`); plans are checked by :mod:`.validate`."""

from llmpas.examples.tamp2d_pds.pds2d_problem import PACKAGE, goal_facts, init_facts, make_problem
from llmpas.examples.tamp2d_pds.pds2d_streams import DEFERRABLE, STREAM_NAMES, implementations
from llmpas.examples.tamp2d_pds.pds2d_world import FAMILIES, Scene, make_world

__all__ = [
    "DEFERRABLE",
    "FAMILIES",
    "PACKAGE",
    "STREAM_NAMES",
    "Scene",
    "goal_facts",
    "implementations",
    "init_facts",
    "make_problem",
    "make_world",
]
