"""Errors of the problem language: each renders as one line naming where the problem is."""

from __future__ import annotations

from llmpas.errors import InputError


class LanguageError(InputError):
    """Base class of every error raised while reading or checking a problem."""


class PddlSyntaxError(LanguageError):
    """Malformed PDDL text: ``file:line:col: message``."""

    def __init__(self, filename: str, line: int, col: int, message: str) -> None:
        self.filename = filename
        self.line = line
        self.col = col
        self.message = message
        super().__init__(f"{filename}:{line}:{col}: {message}")


class ModelError(LanguageError):
    """Well-formed text or values that make no consistent problem (unknown names, arity)."""


class BindingError(LanguageError):
    """Stream declarations and Python implementations that do not match."""
