"""A wall-clock limit for code that cannot be asked to stop (user code, a hung call).

:func:`time_limit` arms ``SIGALRM`` in the main thread; when it fires, the code running is
interrupted by :class:`TimeLimitExpired` (a ``BaseException``, so that user code catching
``Exception`` does not swallow it), and the ``with`` block raises the given error instead.
Elsewhere (another thread, a platform without ``setitimer``, a timer already armed) it only
runs the block.

:func:`interruptible` makes Ctrl-C (``SIGINT``) raise ``KeyboardInterrupt`` in a block even when
the process was started with ``SIGINT`` ignored: a shell without job control starts every
background command (``cmd &``, a test suite run as ``pytest &``) that way, and Python then never
installs its handler, so a Ctrl-C sent to the run was dropped and the run waited for its LLM.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType


class TimeLimitExpired(BaseException):
    """Raised inside the limited code when its time is up."""


def _can_arm() -> bool:
    return (
        hasattr(signal, "setitimer")
        and threading.current_thread() is threading.main_thread()
        and signal.getitimer(signal.ITIMER_REAL)[0] == 0.0
    )


@contextmanager
def time_limit(seconds: float, error: Exception) -> Iterator[None]:
    """Run the block for at most ``seconds``; then raise ``error`` (one line naming what)."""
    if not _can_arm():
        yield
        return

    def expire(signum: int, frame: FrameType | None) -> None:
        raise TimeLimitExpired()

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    except TimeLimitExpired:
        raise error from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


@contextmanager
def interruptible() -> Iterator[None]:
    """Run the block with ``SIGINT`` raising ``KeyboardInterrupt`` (Python's own handler),
    whatever the process inherited; the previous handling is restored after it. Elsewhere than
    the main thread it only runs the block."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


__all__ = ["TimeLimitExpired", "interruptible", "time_limit"]
