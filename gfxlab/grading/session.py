"""The student process of one submission, seen from the grader.

`StudentSession` runs the submission's cells in a `gfxlab.grading.sandbox.Sandbox`,
restarts it after crashes (replaying the cells), calls student functions for the tests,
and keeps the submission's one wall-clock budget; `StudentCallError` is how a failed call
reaches a test.
"""

from __future__ import annotations

import time

import numpy as np

from . import codec
from .sandbox import Crash, Limits, ProtocolError, Sandbox, SandboxError, StudentError, Timeout


class StudentCallError(AssertionError):
    """A call to a student function failed (raised, timed out, crashed, bad value)."""

    def __init__(self, message: str, generic: str | None = None):
        """**Arguments:**

        - `message`: what went wrong, shown with public tests.
        - `generic`: what a hidden test may show instead, if it differs: the message's part
          before `" failed: "` followed by `generic` (e.g. `"crashed"`) is kept as the
          `generic` attribute; default `None` (nothing different).
        """
        super().__init__(message)
        self.generic = None if generic is None else message.split(" failed: ")[0] + " " + generic


def _plain_arg(value):
    """Test-side argument -> plain data (numpy arrays; jax arrays become numpy)."""
    kind = type(value)
    if value is None or kind in (bool, int, float, str):
        return value
    if kind in (list, tuple):
        return kind(_plain_arg(v) for v in value)
    if kind is dict:
        return {k: _plain_arg(v) for k, v in value.items()}
    if isinstance(value, (np.ndarray, np.generic)) or hasattr(value, "__array__"):
        return np.asarray(value)
    raise TypeError(f"cannot send a {kind.__name__} to a student function: plain data only")


class StudentSession:
    """The student process of one submission: runs its cells, restarts after crashes.

    After a crash or timeout the process is restarted and the cells that ran before are
    replayed (the cell that failed is skipped). A function whose call timed out or
    crashed the process is not called again: its remaining tests fail at once. The whole
    submission has one wall-clock budget (`Limits.budget_seconds`), restarts included.
    """

    def __init__(
        self,
        cells,
        limits: Limits,
        *,
        preload=("numpy",),
        x64=True,
        forbid=(),
        numbers=None,
        sandbox: Sandbox | None = None,
    ):
        """**Arguments:**

        - `cells`: the submission's code cells (strings), run in order when the process
          first starts (not here).
        - `limits`: the `Limits` of the submission; its `budget_seconds` starts now.
        - `preload`, `x64`, `forbid`: as for `Sandbox` (used when `sandbox` is not given).
        - `numbers`: how the student numbers the cells (`In [n]`), for messages; default
          1, 2, ...
        - `sandbox`: a `Sandbox` (perhaps launched ahead of time) to serve the first
          start; default a new one. Restarts start a fresh process in it.
        """
        self.cells = list(cells)
        # How the student numbers the cells (In [n]); by default, 1, 2, ...
        self.numbers = list(numbers) if numbers else list(range(1, len(self.cells) + 1))
        self.limits = limits
        # A spare launched ahead of time serves the first start; restarts get fresh ones.
        self.sandbox = sandbox or Sandbox(
            limits, preload=tuple(preload), x64=x64, forbid=tuple(forbid)
        )
        self.status: list[str | None] = [None] * len(self.cells)
        self.stopped: dict[str, str] = {}
        self.restarts = -1
        self.notes: list[str] = []
        # Notes made once hidden tests have started (the budget running out there): their
        # timing is the student's to choose and could spell out a hidden input, so they
        # are for the staff only.
        self.staff_notes: list[str] = []
        self.infrastructure_error: str | None = None
        self.deadline = time.monotonic() + limits.budget_seconds
        self.hidden_started = False

    def _note(self, text: str, *, staff_only: bool = False) -> None:
        # One line each: a student's exception text cannot start a line of its own that
        # reads like the grader's (e.g. a forged "GRADING ERROR ... staff will regrade").
        text = " ".join(str(text).split())[:1000]
        notes = self.staff_notes if staff_only else self.notes
        if text not in notes and len(notes) < 20:
            notes.append(text)

    def _timeout(self, seconds: float) -> float:
        remaining = self.deadline - time.monotonic()
        if remaining <= 0:
            message = (
                f"the submission's time budget of {self.limits.budget_seconds:g} s "
                "ran out; the rest is not graded"
            )
            self._note(message, staff_only=self.hidden_started)
            self.sandbox.close()
            raise StudentCallError(message)
        return seconds  # CPU seconds; the wall clock is bounded by `remaining()`

    def _timed_out(self, seconds: float) -> str:
        wall = self.limits.wall_limit(seconds)
        return f"timed out after {seconds:g} s of CPU time (or {wall:g} s of wall time)"

    def remaining(self) -> float:
        """Wall seconds left of the submission's budget."""
        return max(0.0, self.deadline - time.monotonic())

    def _ensure(self):
        while not self.sandbox.alive:
            self.restarts += 1
            if self.restarts > self.limits.max_restarts:
                raise StudentCallError("the student process crashed too often; giving up")
            self._timeout(1)
            try:
                if self.sandbox.launched and self.restarts == 0:
                    self.sandbox.wait_ready()
                else:
                    self.sandbox.start()
            except SandboxError as exc:
                # No student code runs before the process is ready: this is the grader's
                # problem (host, sandbox), never the student's.
                self.infrastructure_error = str(exc)[:2000]
                raise StudentCallError("the grader could not start the sandbox") from None
            for i, source in enumerate(self.cells):
                if self.status[i] not in (None, "ok"):
                    continue
                try:
                    self.sandbox.request(
                        "exec",
                        self._timeout(self.limits.exec_timeout),
                        budget=self.remaining(),
                        source=source,
                        cell=self.numbers[i],
                    )
                    self.status[i] = "ok"
                except StudentError as exc:
                    self.status[i] = f"code cell {self.numbers[i]} raised {exc}"
                except Timeout:
                    self.status[i] = f"code cell {self.numbers[i]} " + self._timed_out(
                        self.limits.exec_timeout
                    )
                except (Crash, ProtocolError) as exc:
                    self.status[i] = (
                        f"code cell {self.numbers[i]} stopped the student process: {exc}"
                    )
                if self.status[i] != "ok":
                    self._replay_failed(i)
                if not self.sandbox.alive:
                    break

    def _replay_failed(self, i: int) -> None:
        """A cell failed. On a replay after a crash, its text is the student's to choose
        (it can depend on what a hidden call did): shown without text, and not at all
        once hidden tests have started."""
        if self.restarts == 0:
            self._note(self.status[i])
        elif not self.hidden_started:
            self.status[i] = f"code cell {self.numbers[i]} failed when replayed after a restart"
            self._note(self.status[i])
        else:
            self.status[i] = "failed on a replay"

    def start(self):
        """Start the student process and run the cells (see `_ensure`)."""
        self._ensure()

    def defined(self, names) -> dict[str, bool]:
        """Which of `names` are functions in the student process."""
        try:
            self._ensure()
            flags = self.sandbox.request(
                "names",
                self._timeout(self.limits.call_timeout),
                budget=self.remaining(),
                names=codec.encode(list(names)),
            )
        except (SandboxError, StudentCallError):
            return {n: True for n in names}  # let the call itself report the problem
        if type(flags) is not list or len(flags) != len(names):
            return {n: True for n in names}
        return {n: f is True for n, f in zip(names, flags, strict=True)}

    def call(self, name, transforms, args, kwargs):
        """Call student function `name` (through `transforms`) on plain-data arguments."""
        label = f"`{name}`"
        if name in self.stopped:
            raise StudentCallError(f"{label} is not called again: {self.stopped[name]}")
        payload = dict(
            name=name,
            transforms=codec.encode([(op, dict(opts)) for op, opts in transforms]),
            args=codec.encode([_plain_arg(a) for a in args]),
            kwargs=codec.encode({k: _plain_arg(v) for k, v in kwargs.items()}),
        )
        self._ensure()
        timeout = self._timeout(self.limits.call_timeout)
        try:
            return self.sandbox.request("call", timeout, budget=self.remaining(), **payload)
        except StudentError as exc:
            raise StudentRaised(label, str(exc)) from None
        except Timeout:
            if time.monotonic() >= self.deadline:
                self._timeout(0)
            reason = "it " + self._timed_out(timeout)
            self.stopped[name] = reason
            raise StudentCallError(f"{label} failed: {reason}") from None
        except (Crash, ProtocolError) as exc:
            # The details (exit status, signal) are the student's to choose: kept out of
            # anything shown later, where they could carry a hidden input.
            self.stopped[name] = "it crashed the student process before"
            raise StudentCallError(f"{label} failed: {exc}", generic="crashed") from None

    def close(self):
        """Stop the student process."""
        self.sandbox.close()


class StudentRaised(StudentCallError):
    """The student's function raised: the text is shown for public tests only."""

    def __init__(self, label: str, error: str):
        """**Arguments:**

        - `label`: the function's name as shown (e.g. `` `f` ``).
        - `error`: the exception's text from the student process; the message is
          `"<label> raised <error>"`, the `short` attribute `"<label> raised an exception"`.
        """
        super().__init__(f"{label} raised {error}")
        # Not even a built-in exception's name: the student picks which one is raised,
        # and ~6 bits per hidden call spell out its inputs.
        self.short = f"{label} raised an exception"
