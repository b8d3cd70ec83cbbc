"""Grading: tests run in the grader, student functions run in the sandbox.

The grader loads each question's tests (public and hidden) into its own interpreter and
calls them with `StudentFunction` proxies. A proxy call becomes one request to the
student process (`gfxlab.grading.sandbox`): the function's name, an optional chain of
transforms from a fixed menu (`jit`, `grad`, `value_and_grad`, `vmap`) and plain-data
arguments; the student process evaluates it and returns plain data, which the tests then
check here. `jax.grad(f)` / `jax.jit(f)` / `jax.value_and_grad(f)` / `jax.vmap(f)` on a
proxy (with `import jax` or `from jax import grad` in a test cell) build that chain, so
tests read like ordinary JAX tests while differentiation happens in the student process.
"""

from __future__ import annotations

import builtins
import dataclasses
import importlib
import io
import json
import os
import pathlib
import stat
import time
import traceback

import numpy as np

from . import authoring, reuse
from ._args import flag, limits_arg, module_names, read_config, run_test_args
from ._bounds import (
    _NO_DEADLINE,
    HARD_MARGIN_SECONDS,
    TEST_CPU_SECONDS,
    _bounded,
    _CpuDeadline,
    _TestTimedOut,
    run_bounded,
)
from .checks import Feedback, check_array
from .sandbox import Limits, Sandbox, detect_protections, require_confinement
from .session import StudentCallError, StudentRaised, StudentSession

__all__ = [
    "Autograder",
    "GradeResult",
    "QuestionResult",
    "StudentFunction",
    "TestResult",
    "check_array",
    "Feedback",
]

MAX_NOTEBOOK_BYTES = 16 * 2**20


class StudentFunction:
    """Proxy for a function in the student process; calling it is an RPC."""

    def __init__(self, session: StudentSession, name: str, transforms: tuple = (), deadline=None):
        """**Arguments:**

        - `session`: the `StudentSession` whose process defines the function.
        - `name`: the function's name in the student's namespace.
        - `transforms`: `(op, options)` pairs applied in the student process before the
          call, innermost first (see `transformed`); default none.
        - `deadline`: the running test's CPU deadline, told when an RPC starts and ends
          (so its signal never interrupts one); default none.
        """
        self._session, self.name, self.transforms = session, name, transforms
        self._deadline = deadline or _NO_DEADLINE

    def __call__(self, *args, **kwargs):
        """Call the function in the student process (arguments and result are plain data).

        **Arguments:**

        - `*args`, `**kwargs`: the call's arguments: `None`, `bool`, `int`, `float`, `str`,
          lists, tuples and dicts of them, arrays (NumPy, JAX: sent as NumPy arrays);
          anything else raises `TypeError`.

        **Returns:**

        The function's result, sent back from the student process as plain data. A
        failed call raises `StudentCallError` (`StudentRaised` when the student's code
        raised; timeouts and crashes stop further calls of this function).
        """
        self._deadline.in_rpc += 1
        try:
            return self._session.call(self.name, self.transforms, args, kwargs)
        finally:
            self._deadline.in_rpc -= 1
            self._deadline.rpc_done()

    def transformed(self, op: str, **options) -> StudentFunction:
        """This function with the transform `op` (e.g. `grad`) applied in the student process."""
        options = {k: tuple(v) if isinstance(v, list) else v for k, v in options.items()}
        chain = (*self.transforms, (op, options))
        return StudentFunction(self._session, self.name, chain, self._deadline)

    def __repr__(self):
        """`<student function name>`, wrapped in the transforms' names (`grad(name)`)."""
        chain = "".join(f"{op}(" for op, _ in reversed(self.transforms))
        return f"<student function {chain}{self.name}{')' * len(self.transforms)}>"


class _JaxShim:
    """`jax` as seen by test code: transforms of student proxies run in the student process."""

    def __getattr__(self, attr):
        return getattr(importlib.import_module("jax"), attr)

    @staticmethod
    def _wrap(op):
        def transform(fn, *args, **options):
            if isinstance(fn, StudentFunction):
                if args:
                    options["argnums" if op != "vmap" else "in_axes"] = args[0]
                return fn.transformed(op, **options)
            return getattr(importlib.import_module("jax"), op)(fn, *args, **options)

        transform.__name__ = op
        return transform


for _op in ("jit", "grad", "value_and_grad", "vmap"):
    setattr(_JaxShim, _op, staticmethod(_JaxShim._wrap(_op)))
JAX = _JaxShim()


def _test_import(name, globals=None, locals=None, fromlist=(), level=0):
    module = builtins.__import__(name, globals, locals, fromlist, level)
    if level == 0 and (name == "jax" or (name.startswith("jax.") and not fromlist)):
        return JAX
    return module


def load_tests(source: str, label: str) -> dict:
    """Execute a question's test code in a fresh namespace of the grader."""
    namespace = {
        "__name__": f"gfxlab_tests_{label}",
        "__builtins__": {**vars(builtins), "__import__": _test_import},
        "np": np,
        "jax": JAX,
        "check_array": check_array,
        **{op: getattr(JAX, op) for op in ("jit", "grad", "value_and_grad", "vmap")},
    }
    exec(compile(source, f"<tests {label}>", "exec"), namespace)
    return namespace


@dataclasses.dataclass
class TestResult:
    """Outcome of one test: passed or not, its weight, and its failure message."""

    name: str
    hidden: bool
    passed: bool
    weight: float
    message: str = ""


@dataclasses.dataclass
class QuestionResult:
    """Outcomes of one question's tests and the points at stake."""

    name: str
    points: float
    tests: list[TestResult]

    @property
    def score(self) -> float:
        """Points earned: `points` times the weighted fraction of tests passed."""
        total = sum(t.weight for t in self.tests)
        won = sum(t.weight for t in self.tests if t.passed)
        return self.points * won / total if total else 0.0

    def feedback(self) -> str:
        """PASS/FAIL per test; hidden tests are numbered, never named."""
        lines, hidden = [], 0
        for t in self.tests:
            if t.hidden:
                hidden += 1
                name = f"hidden test {hidden}"
            else:
                name = t.name
            lines.append(f"{'PASS' if t.passed else 'FAIL'} {name}")
            if t.message:
                lines.extend("    " + m for m in _bounded(t.message, 2000).splitlines())
        return "\n".join(lines)


def _gradescope_entries(q: QuestionResult) -> list[dict]:
    """A question as Gradescope tests: its public part (visible now) and its hidden part
    (pass/fail and points, shown once the instructor publishes the grades)."""
    total = sum(t.weight for t in q.tests)
    entries = []
    for hidden, suffix, visibility in (
        (False, "", "visible"),
        (True, " (hidden tests)", "after_published"),
    ):
        part = [t for t in q.tests if t.hidden == hidden]
        if not part or not total:
            continue
        share = QuestionResult(q.name, q.points * sum(t.weight for t in part) / total, part)
        entries.append(
            {
                "name": _bounded(q.name, 100) + suffix,
                "score": round(share.score, 4),
                "max_score": round(share.points, 4),
                "output": _bounded(share.feedback(), 20_000),
                "visibility": visibility,
            }
        )
    return entries


@dataclasses.dataclass
class GradeResult:
    """Scores of one submission, per question, with feedback.

    `error` is set when the grader itself failed (the sandbox could not start, ...): the
    score is then not the student's, and the command line exits with an error.
    `notes` are shown to the student; `staff_notes` (what happened once hidden tests had
    started) only to the staff: in `results.json`'s `extra_data`, the summary and the
    command line's output.
    """

    submission: str
    questions: list[QuestionResult]
    notes: list[str]
    protections: list[str]
    seconds: float
    error: str | None = None
    staff_notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def score(self) -> float:
        """Total points earned."""
        return sum(q.score for q in self.questions)

    @property
    def max_score(self) -> float:
        """Total points available."""
        return sum(q.points for q in self.questions)

    def to_gradescope(self) -> dict:
        """Gradescope's `results.json` structure, bounded in size whatever the submission."""
        notes = "\n".join(_bounded(n, 1000) for n in self.notes[:20])
        if self.error:
            notes = (
                "GRADING ERROR (not your fault; staff will regrade): "
                + _bounded(self.error, 2000)
                + ("\n" + notes if notes else "")
            )
        return {
            "score": round(self.score, 4),
            "output": notes or "Graded by gfxlab.grading.",
            "visibility": "visible",
            "stdout_visibility": "hidden",
            "tests": [entry for q in self.questions for entry in _gradescope_entries(q)],
            "extra_data": {
                "isolation": [_bounded(p, 1000) for p in self.protections],
                "grading_error": bool(self.error),
                "staff_notes": [_bounded(n, 1000) for n in self.staff_notes[:20]],
            },
        }

    def table(self) -> str:
        """Plain-text table of scores per question, with a total row."""
        rows = [("question", "score", "max", "tests passed")]
        for q in self.questions:
            passed = sum(t.passed for t in q.tests)
            rows.append((q.name, f"{q.score:.2f}", f"{q.points:g}", f"{passed}/{len(q.tests)}"))
        rows.append(("total", f"{self.score:.2f}", f"{self.max_score:g}", ""))
        widths = [max(len(r[i]) for r in rows) for i in range(4)]
        out = io.StringIO()
        for j, row in enumerate(rows):
            out.write("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip())
            out.write("\n")
            if j == 0 or j == len(rows) - 2:
                out.write("  ".join("-" * w for w in widths) + "\n")
        return out.getvalue()


def _failure_message(exc: BaseException, hidden: bool) -> str:
    """What the student sees: for hidden tests, the kind of failure only.

    A hidden test's own text (assertion messages, the student's exception text, shapes)
    could carry its hidden inputs, so none of it is shown.
    """
    if hidden:
        if isinstance(exc, StudentRaised):
            return exc.short
        if isinstance(exc, StudentCallError):  # timeouts, budget: fixed texts
            return exc.generic or str(exc)[:300]
        if isinstance(exc, Feedback):
            return "wrong type, shape or dtype of the result"
        return "wrong result" if isinstance(exc, AssertionError) else "error in the test"
    if isinstance(exc, (StudentCallError, Feedback)):
        return _bounded(str(exc), 2000)
    if isinstance(exc, AssertionError):
        frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename.startswith("<")]
        where = f" (line {frames[-1].lineno} of the test)" if frames else ""
        return _bounded(str(exc).strip() or "assertion failed", 2000) + where
    return _bounded(f"{type(exc).__name__}: {exc}", 2000)


class Autograder:
    """An assignment's autograder directory: configuration, tests, reference solution."""

    def __init__(self, directory, *, warm: bool = False, limits=None):
        """Load the assignment: its `config.json` and each question's tests.

        **Arguments:**

        - `directory`: the autograder directory (a path); it must hold `config.json`
          (`FileNotFoundError` otherwise) and `tests/<question>.py` for each question.
        - `warm`: keep one spare sandbox launched ahead of the next submission (the first
          one now): True or False; default `False`.
        - `limits`: overrides of the config's limits (a dict or a `Limits`) for that spare
          sandbox; only used with `warm`.

        **Raises:** `ValueError` naming `config.json` and a missing key; `TypeError` for a
        `warm` other than True or False, or `limits` other than None, a dict or a `Limits`.
        """
        warm, limits = flag(warm, "warm"), limits_arg(limits, "limits", overrides=True)
        directory = pathlib.Path(directory).resolve()
        self._initialise(directory, read_config(directory), warm=warm, limits=limits)

    @classmethod
    def without_tests(cls, directory, *, assignment: str, preload, forbid) -> Autograder:
        """An autograder with no tests, for running a notebook's own test cells
        (`gfxlab check`): the same sandbox, preloads and forbidden modules as `grade`.
        """
        grader = cls.__new__(cls)
        config = {
            "assignment": str(assignment),
            "preload": list(module_names(preload, "preload")),
            "forbid": list(module_names(forbid, "forbid")),
            "questions": [],
        }
        grader._initialise(pathlib.Path(directory).resolve(), config, warm=False, limits=None)
        return grader

    def _initialise(self, directory: pathlib.Path, config: dict, *, warm: bool, limits) -> None:
        """The one place that sets the fields: both constructors end here."""
        self.directory, self.config = directory, config
        # `warm`: keep one spare sandbox launched (the next submission's, under `limits`),
        # the first one before the tests load here (`import jax` in both at once).
        self.warm, self._spare = warm, None
        if warm:
            self._launch_spare(self.limits(limits))
        self.questions = [
            authoring.Question(
                q["name"],
                q["points"],
                [
                    authoring.TestSpec(t["name"], tuple(t["params"]), t["hidden"], t["weight"])
                    for t in q["tests"]
                ],
            )
            for q in config["questions"]
        ]
        self._namespaces = {
            q.name: load_tests((directory / "tests" / f"{q.name}.py").read_text(), q.name)
            for q in self.questions
        }

    @property
    def name(self) -> str:
        """The assignment's name."""
        return self.config["assignment"]

    def solution_cells(self) -> list[str]:
        """The reference solution's code cells."""
        return json.loads((self.directory / "solution.json").read_text())

    def limits(self, overrides: dict | Limits | None = None) -> Limits:
        """The assignment's limits (config `limits`), with `overrides` (dict or `Limits`)."""
        if isinstance(limits_arg(overrides, "limits", overrides=True), Limits):
            return overrides
        values = {**self.config.get("limits", {}), **(overrides or {})}
        return dataclasses.replace(Limits(), **values)

    def hard_limit(self, limits=None) -> float:
        """Wall seconds after which grading one submission is stopped, whatever happens:
        its budget (twice, for a second sandbox with `separate` rules) plus a margin."""
        budgets = 2 if self.config.get("separate") else 1
        return budgets * self.limits(limits).budget_seconds + HARD_MARGIN_SECONDS

    def _sandbox_options(self) -> dict:
        return dict(
            preload=tuple(self.config.get("preload", ["numpy"])),
            x64=self.config.get("x64", True),
            forbid=tuple(self.config.get("forbid", [])),
        )

    def _launch_spare(self, limits: Limits) -> None:
        try:
            spare = Sandbox(limits, **self._sandbox_options())
            spare.launch()
        except Exception:  # no sandbox here: the session's own start reports it
            return
        self._spare = spare

    def _take_spare(self, limits: Limits) -> Sandbox | None:
        spare, self._spare = self._spare, None
        if spare is not None and not (spare.limits == limits and spare.launched):
            spare.close()
            spare = None
        if self.warm:
            self._launch_spare(limits)
        return spare

    def close(self) -> None:
        """Stop the spare sandbox, if any."""
        if self._spare is not None:
            self._spare.close()
            self._spare = None

    def session(self, cells, limits=None, numbers=None, *, sandbox=None) -> StudentSession:
        """A `StudentSession` running `cells` (in `sandbox`, else the spare, if any)."""
        limits = self.limits(limits)
        return StudentSession(
            cells,
            limits,
            numbers=numbers,
            sandbox=sandbox or self._take_spare(limits),
            **self._sandbox_options(),
        )

    def grade_cells(
        self, cells, *, label="submission", limits=None, public_only=False, numbers=None
    ) -> GradeResult:
        """Grade a list of code-cell sources (the student's code) in the sandbox; all
        public tests run before any hidden test."""
        prot = require_confinement()
        started = time.perf_counter()
        session = self.session(cells, limits, numbers)
        verdicts, ahead, results = [] if public_only else reuse.pending(self, cells), [], []
        try:
            try:
                session.start()
            except StudentCallError as exc:  # cannot start at all: every test fails, we go on
                session._note(str(exc))
            ahead = reuse.launch_ahead(self, verdicts, limits)
            # Every public test before any hidden one: a public test's feedback shows what
            # the student's code returns or raises, which must not carry hidden inputs kept
            # from an earlier hidden call in the same process.
            public = [self._grade_question(q, session, "public") for q in self.questions]
            # The `separate` rules' second sandboxes, before any hidden call here (see
            # `reuse.rerun`); this session's budget does not run meanwhile.
            paused = time.monotonic()
            reruns = [] if public_only else reuse.rerun(self, cells, limits, verdicts, ahead)
            session.deadline += time.monotonic() - paused
            grade_hidden = [] if public_only else self.questions
            hidden = [self._grade_question(q, session, "hidden") for q in grade_hidden]
            for i, q in enumerate(self.questions):
                done = {t.name: t for t in public[i].tests + (hidden[i].tests if hidden else [])}
                tests = [done[t.name] for t in q.tests if t.name in done]
                results.append(QuestionResult(q.name, q.points, tests))
        finally:
            session.close()
            for sandbox in ahead:  # those `rerun` did not reach (closing twice is harmless)
                sandbox.close()
        error = session.infrastructure_error
        if not public_only:
            notes, staff_notes, reuse_error = reuse.enforce(results, reruns)
            for note, staff_only in [(n, False) for n in notes] + [(n, True) for n in staff_notes]:
                session._note(note, staff_only=staff_only)
            error = error or reuse_error
        return GradeResult(
            label,
            results,
            session.notes,
            session.sandbox.describe() if session.sandbox.applied else prot.describe(),
            time.perf_counter() - started,
            error,
            session.staff_notes,
        )

    def _grade_question(self, question, session, which="all", rename=None) -> QuestionResult:
        """Run a question's tests (`which`: "all", "public" or "hidden")."""
        namespace = self._namespaces[question.name]
        rename = rename or {}
        tests = [t for t in question.tests if which == "all" or t.hidden == (which == "hidden")]
        names = [rename.get(f, f) for f in question.functions]
        present = (
            dict(zip(question.functions, session.defined(names).values(), strict=True))
            if names
            else {}
        )
        out = []
        for spec in tests:
            missing = [p for p in spec.params if not present.get(p, False)]
            if missing:
                message = f"`{missing[0]}` is not defined as a function"
                out.append(TestResult(spec.name, spec.hidden, False, spec.weight, message))
                continue
            if spec.hidden:  # from now on, replays show no student text (see _ensure)
                session.hidden_started = True
            out.append(self.run_test(namespace[spec.name], spec, session, rename))
        return QuestionResult(question.name, question.points, out)

    def run_test(self, test, spec, session, rename=None) -> TestResult:
        """Run `test` (its `authoring.TestSpec` is `spec`) against the student `session`
        (what answers calls of the student's functions: anything with `StudentSession.call`;
        `rename` maps a parameter to another function name) under the CPU deadline
        `config["test_cpu_seconds"]`: a test the student's data makes slow here (e.g.
        colliding hashes in its own sets) fails as "timed out". **Returns:** the
        `TestResult` (a bounded message; for a hidden test, the kind of failure only).
        **Raises:** `TypeError` for a wrong argument (before anything runs)."""
        rename = run_test_args(test, spec, session, rename)
        seconds = float(self.config.get("test_cpu_seconds", TEST_CPU_SECONDS))
        try:
            with _CpuDeadline(seconds) as deadline:
                proxies = [
                    StudentFunction(session, rename.get(p, p), (), deadline) for p in spec.params
                ]
                test(*proxies)
        except _TestTimedOut:
            message = f"timed out: the test's checks of your result took over {seconds:g} s"
            return TestResult(spec.name, spec.hidden, False, spec.weight, message)
        except Exception as exc:  # a failing test, whatever the reason
            message = _failure_message(exc, spec.hidden)
            return TestResult(spec.name, spec.hidden, False, spec.weight, message)
        return TestResult(spec.name, spec.hidden, True, spec.weight)

    def empty_result(self, label: str, note: str, error: str | None = None) -> GradeResult:
        """Zero on every question, with the reason (unreadable notebook, grader failure)."""
        empty = [
            QuestionResult(
                q.name,
                q.points,
                [TestResult(t.name, t.hidden, False, t.weight, "") for t in q.tests],
            )
            for q in self.questions
        ]
        return GradeResult(label, empty, [note], detect_protections().describe(), 0.0, error)

    def grade(self, submission, **kwargs) -> GradeResult:
        """Grade a submitted notebook (path)."""
        path = pathlib.Path(submission)
        label = _bounded(path.name, 200)
        try:
            info = os.lstat(path)
            if not stat.S_ISREG(info.st_mode):  # a FIFO would block, a link could point anywhere
                raise ValueError("not a regular file")
            size = info.st_size
            if size > MAX_NOTEBOOK_BYTES:
                raise ValueError(
                    f"the notebook is too large ({size / 2**20:.0f} MB; at most "
                    f"{MAX_NOTEBOOK_BYTES // 2**20} MB)"
                )
            notebook = authoring.read_notebook(path)
            cells = authoring.student_code_cells(notebook)
            numbers = authoring.student_code_cell_numbers(notebook)
        except Exception as exc:  # unreadable notebook: zero, with the reason (no host path)
            reason = str(exc).replace(str(path), path.name)
            return self.empty_result(label, f"could not read the notebook: {_bounded(reason, 300)}")
        return self.grade_cells(cells, label=label, numbers=numbers, **kwargs)


def grade_one(directory, submission, *, limits=None, warm=True) -> GradeResult:
    """Grade one notebook with the autograder in `directory`, in a child process killed at
    the hard limit (`Autograder.hard_limit`): a submission whose data makes the grader's
    own code slow gets a bounded grader-error result, never a grader that runs forever.

    With `warm` the child starts its sandbox while the tests load (`Autograder(warm=True)`);
    `limits` are overrides as for `Autograder` (None, a dict or a `Limits`).
    `IsolationUnavailable` and other grader failures in the child are raised here; a wrong
    argument or autograder directory as by `Autograder`, before the child starts.
    """
    warm, limits = flag(warm, "warm"), limits_arg(limits, "limits", overrides=True)
    # No tests load here before the fork (a test file could start JAX's threads).
    light = Autograder.without_tests(directory, assignment="", preload=(), forbid=())
    light.config = read_config(light.directory)
    label = _bounded(pathlib.Path(submission).name, 200)

    def work():
        child = Autograder(directory, warm=warm, limits=limits)
        child.warm = False
        try:
            return child.grade(submission, limits=limits)
        finally:
            child.close()

    seconds = light.hard_limit(limits)
    kind, value = run_bounded(work, seconds)
    if kind == "ok":
        return value
    if kind == "raise":
        raise value
    reason = (
        f"grading took longer than {seconds:g} s and was stopped"
        if kind == "timeout"
        else "the grader process died"
    )
    return Autograder(directory).empty_result(label, "", f"grader error: {reason}")
