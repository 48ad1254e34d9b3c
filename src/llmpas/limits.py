"""A wall-clock limit for code that cannot be asked to stop (user code, a hung call).

:func:`time_limit` arms ``SIGALRM`` in the main thread; when it fires, the code running is
interrupted by :class:`TimeLimitExpired` (a ``BaseException``, so that user code catching
``Exception`` does not swallow it), and the ``with`` block raises the given error instead.
Elsewhere (another thread, a platform without ``setitimer``, a timer already armed) it only
runs the block.
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


__all__ = ["TimeLimitExpired", "time_limit"]
