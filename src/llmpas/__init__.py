"""llmpas: closed-loop planning, acting and LLM-guided recovery for TAMP."""

__version__ = "0.1.0"
