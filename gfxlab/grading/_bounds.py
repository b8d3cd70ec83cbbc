"""The grader's own bounds: a CPU deadline per test, a hard wall limit per submission.

Student data can make the grader's *own* code slow (a test building a set of tuples whose
hashes the student chose to collide). `_CpuDeadline` stops one test after its CPU seconds
(the test fails as "timed out"); `run_bounded` runs a whole grading in a forked child
killed at the hard limit, so a single `grade` and Gradescope's `run_autograder` are
bounded like a batch's grader processes.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading

# CPU seconds the grader itself may spend in one test (its own checks on the student's
# data; time waiting for the student process does not count): config `test_cpu_seconds`.
TEST_CPU_SECONDS = 20.0


class _TestTimedOut(BaseException):
    """A test used more than its CPU seconds in the grader (a `BaseException`, so that a
    test's own `except Exception` does not swallow it)."""


class _CpuDeadline:
    """A per-test CPU deadline (`ITIMER_PROF`) in the grader's main thread.

    The signal never interrupts an RPC to the student process (that would leave the
    session mid-message): it is held until the call returns.
    """

    def __init__(self, seconds: float):
        self.seconds, self.in_rpc, self.pending = float(seconds), 0, False
        self.active = False

    def _handler(self, signum, frame):
        if self.in_rpc:
            self.pending = True
        else:
            raise _TestTimedOut

    def __enter__(self):
        usable = self.seconds > 0 and threading.current_thread() is threading.main_thread()
        if usable:
            self.old = signal.signal(signal.SIGPROF, self._handler)
            signal.setitimer(signal.ITIMER_PROF, self.seconds)
            self.active = True
        return self

    def __exit__(self, *exc):
        if self.active:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.signal(signal.SIGPROF, self.old)
            self.active = False
        return False

    def rpc_done(self):
        """After a call: raise the deadline held during it."""
        if self.pending and self.active and not self.in_rpc:
            self.pending = False
            raise _TestTimedOut


_NO_DEADLINE = _CpuDeadline(0)

# Beyond the submission's own budget: the grader's start-up and result writing.
HARD_MARGIN_SECONDS = 30.0


def _bounded_child(work, conn):
    try:
        conn.send(("ok", work()))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which decides
        try:
            conn.send(("raise", exc))
        except Exception:  # an exception that does not pickle
            conn.send(("raise", RuntimeError(repr(exc)[:2000])))
    finally:
        conn.close()
        os._exit(0)


def run_bounded(work, seconds: float):
    """Run `work()` in a forked child killed after `seconds` wall seconds, whatever it does.

    Returns `("ok", result)`, `("raise", exception)`, `("timeout", None)` or
    `("died", None)`. Grading one submission (`grade NB`, Gradescope's `run_autograder`)
    goes through it, as a batch's grader processes are bounded by `grade_many`.
    """
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    proc = context.Process(target=_bounded_child, args=(work, send), daemon=True)
    proc.start()
    send.close()
    try:
        outcome = receive.recv() if receive.poll(seconds) else ("timeout", None)
    except (EOFError, OSError):
        outcome = ("died", None)
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        receive.close()
    return outcome


def _bounded(text: str, limit: int) -> str:
    """At most `limit` characters of printable text (control characters become spaces)."""
    text = str(text)
    if len(text) > limit:
        text = text[:limit] + " [...]"
    return "".join(c if c.isprintable() or c == "\n" else " " for c in text)
