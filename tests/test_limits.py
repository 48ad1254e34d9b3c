"""A wall-clock limit for code that does not return by itself."""

from __future__ import annotations

import contextlib
import threading
import time

import pytest

from llmpas.errors import InputError
from llmpas.limits import time_limit


def test_a_busy_loop_that_catches_exception_is_still_stopped() -> None:
    with pytest.raises(InputError, match="too slow"), time_limit(0.2, InputError("too slow")):
        while True:
            with contextlib.suppress(Exception):  # user code swallowing everything still stops
                sum(range(1000))


def test_a_blocking_call_is_stopped() -> None:
    with pytest.raises(InputError, match="asleep"), time_limit(0.2, InputError("asleep")):
        time.sleep(1000)


def test_a_block_that_ends_in_time_is_untouched_and_the_timer_is_disarmed() -> None:
    with time_limit(5.0, InputError("never")):
        value = 1 + 1
    assert value == 2
    time.sleep(0.01)
    import signal

    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


def test_outside_the_main_thread_it_only_runs_the_block() -> None:
    done: list[bool] = []

    def work() -> None:
        with time_limit(0.01, InputError("x")):
            time.sleep(0.05)
        done.append(True)

    t = threading.Thread(target=work)
    t.start()
    t.join(10)
    assert done == [True]
