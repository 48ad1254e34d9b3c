"""The ``llmpas`` commands, one module each (:mod:`llmpas.cli` assembles the parser)."""
