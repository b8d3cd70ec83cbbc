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
import concurrent.futures
import csv
import dataclasses
import importlib
import io
import json
import multiprocessing
import os
import pathlib
import shutil
import time
import traceback

import numpy as np

from . import authoring, codec
from .sandbox import (
    Crash,
    Limits,
    ProtocolError,
    Sandbox,
    SandboxError,
    StudentError,
    Timeout,
    detect_protections,
    require_confinement,
)

FORMAT = 1


class StudentCallError(AssertionError):
    """A call to a student function failed (raised, timed out, crashed, bad value)."""


class Feedback(AssertionError):
    """A failure whose message is safe to show even for hidden tests (type, shape)."""


def check_array(value, *, shape=None, dtype=None, kind=None, name="the result"):
    """Check a student's returned value is an array of the expected shape and dtype.

    **Arguments:**

    - `value`: what the student's function returned.
    - `shape`: expected shape (tuple; `None` entries match any size).
    - `dtype`: expected exact dtype (e.g. `np.float64`).
    - `kind`: expected dtype kind: `"f"` float, `"i"` integer (signed or unsigned), `"b"` bool.
    - `name`: how the feedback names the value.

    **Returns:** `value` as a numpy array. Raises `Feedback` (an `AssertionError` shown to
    the student even in hidden tests) with a clear message otherwise.
    """
    arraylike = isinstance(value, (np.ndarray, list, tuple, np.generic, int, float))
    if not arraylike and not hasattr(value, "__array__"):
        raise Feedback(f"{name} should be an array, got {type(value).__name__}")
    try:
        array = np.asarray(value)
    except (ValueError, TypeError):
        raise Feedback(f"{name} should be an array; it is ragged or mixed") from None
    if array.dtype == object:
        raise Feedback(f"{name} should be a numeric array; it is ragged or mixed")
    if shape is not None:
        ok = array.ndim == len(shape) and all(
            s is None or s == n for s, n in zip(shape, array.shape, strict=False)
        )
        if not ok:
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise Feedback(f"{name} should have shape {want}, got shape {array.shape}")
    if kind is not None:
        kinds = {"f": "f", "i": "iu", "b": "b"}[kind]
        if array.dtype.kind not in kinds:
            words = {"f": "a floating-point", "i": "an integer", "b": "a boolean"}[kind]
            raise Feedback(f"{name} should have {words} dtype, got {array.dtype}")
    if dtype is not None and array.dtype != np.dtype(dtype):
        raise Feedback(f"{name} should have dtype {np.dtype(dtype)}, got {array.dtype}")
    return array


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


class StudentFunction:
    """Proxy for a function in the student process; calling it is an RPC."""

    def __init__(self, session: StudentSession, name: str, transforms: tuple = ()):
        self._session, self.name, self.transforms = session, name, transforms

    def __call__(self, *args, **kwargs):
        return self._session.call(self.name, self.transforms, args, kwargs)

    def transformed(self, op: str, **options) -> StudentFunction:
        options = {k: tuple(v) if isinstance(v, list) else v for k, v in options.items()}
        return StudentFunction(self._session, self.name, (*self.transforms, (op, options)))

    def __repr__(self):
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


class StudentSession:
    """The student process of one submission: runs its cells, restarts after crashes.

    After a crash or timeout the process is restarted and the cells that ran before are
    replayed (the cell that failed is skipped). A function whose call timed out or
    crashed the process is not called again: its remaining tests fail at once.
    """

    def __init__(self, cells, limits: Limits, *, hide=(), preload=("numpy",), x64=True,
                 jax_cache=None, trusted=False):
        self.cells = list(cells)
        self.limits = limits
        self.sandbox = Sandbox(limits, hide=tuple(hide), preload=tuple(preload), x64=x64,
                               jax_cache=jax_cache, jax_cache_writable=trusted)
        self.status: list[str | None] = [None] * len(self.cells)
        self.stopped: dict[str, str] = {}
        self.restarts = -1
        self.notes: list[str] = []

    def _ensure(self):
        while not self.sandbox.alive:
            self.restarts += 1
            if self.restarts > self.limits.max_restarts:
                raise StudentCallError("the student process crashed too often; giving up")
            try:
                self.sandbox.start()
            except SandboxError as exc:
                self.notes.append(str(exc))
                continue
            for i, source in enumerate(self.cells):
                if self.status[i] not in (None, "ok"):
                    continue
                try:
                    self.sandbox.request("exec", self.limits.exec_timeout, source=source, cell=i)
                    self.status[i] = "ok"
                except StudentError as exc:
                    self.status[i] = f"cell {i} raised {exc}"
                except Timeout:
                    self.status[i] = f"cell {i} timed out after {self.limits.exec_timeout:g} s"
                except (Crash, ProtocolError) as exc:
                    self.status[i] = f"cell {i} stopped the student process: {exc}"
                if self.status[i] != "ok" and self.status[i] not in self.notes:
                    self.notes.append(self.status[i])
                if not self.sandbox.alive:
                    break

    def start(self):
        self._ensure()

    def defined(self, names) -> dict[str, bool]:
        try:
            self._ensure()
            flags = self.sandbox.request(
                "names", self.limits.call_timeout, names=codec.encode(list(names))
            )
        except (SandboxError, StudentCallError):
            return {n: True for n in names}  # let the call itself report the problem
        if type(flags) is not list or len(flags) != len(names):
            return {n: True for n in names}
        return {n: f is True for n, f in zip(names, flags, strict=True)}

    def call(self, name, transforms, args, kwargs):
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
        try:
            return self.sandbox.request("call", self.limits.call_timeout, **payload)
        except StudentError as exc:
            raise StudentCallError(f"{label} raised {exc}") from None
        except Timeout:
            reason = f"it timed out after {self.limits.call_timeout:g} s"
        except (Crash, ProtocolError) as exc:
            reason = str(exc)
        self.stopped[name] = reason
        raise StudentCallError(f"{label} failed: {reason}")

    def close(self):
        self.sandbox.close()


@dataclasses.dataclass
class TestResult:
    name: str
    hidden: bool
    passed: bool
    weight: float
    message: str = ""


@dataclasses.dataclass
class QuestionResult:
    name: str
    points: float
    tests: list[TestResult]

    @property
    def score(self) -> float:
        total = sum(t.weight for t in self.tests)
        won = sum(t.weight for t in self.tests if t.passed)
        return self.points * won / total if total else 0.0

    def feedback(self) -> str:
        lines = []
        for t in self.tests:
            tag = " (hidden)" if t.hidden else ""
            lines.append(f"{'PASS' if t.passed else 'FAIL'} {t.name}{tag}")
            if t.message:
                lines.extend("    " + m for m in t.message.splitlines())
        return "\n".join(lines)


@dataclasses.dataclass
class GradeResult:
    """Scores of one submission, per question, with feedback."""

    submission: str
    questions: list[QuestionResult]
    notes: list[str]
    protections: list[str]
    seconds: float

    @property
    def score(self) -> float:
        return sum(q.score for q in self.questions)

    @property
    def max_score(self) -> float:
        return sum(q.points for q in self.questions)

    def to_gradescope(self) -> dict:
        """Gradescope's `results.json` structure."""
        return {
            "score": round(self.score, 4),
            "execution_time": round(self.seconds, 3),
            "output": "\n".join(self.notes) if self.notes else "Graded by gfxlab.grading.",
            "visibility": "visible",
            "stdout_visibility": "hidden",
            "tests": [
                {
                    "name": q.name,
                    "score": round(q.score, 4),
                    "max_score": q.points,
                    "output": q.feedback(),
                    "visibility": "visible",
                }
                for q in self.questions
            ],
            "extra_data": {"isolation": self.protections},
        }

    def table(self) -> str:
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
    return _describe_failure(exc, hidden)[:2000]


def _describe_failure(exc: BaseException, hidden: bool) -> str:
    if isinstance(exc, (StudentCallError, Feedback)):
        return str(exc)
    if hidden:
        return "wrong result" if isinstance(exc, AssertionError) else "error in the test"
    if isinstance(exc, AssertionError):
        frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename.startswith("<")]
        where = f" (line {frames[-1].lineno} of the test)" if frames else ""
        return (str(exc).strip() or "assertion failed") + where
    return f"{type(exc).__name__}: {exc}"


class Autograder:
    """An assignment's autograder directory: configuration, tests, reference solution."""

    def __init__(self, directory):
        self.directory = pathlib.Path(directory).resolve()
        config_path = self.directory / "config.json"
        if not config_path.is_file():
            raise FileNotFoundError(f"{config_path} not found: is this an autograder directory?")
        self.config = json.loads(config_path.read_text())
        self.questions = [
            authoring.Question(
                q["name"],
                q["points"],
                [authoring.TestSpec(t["name"], tuple(t["params"]), t["hidden"], t["weight"])
                 for t in q["tests"]],
            )
            for q in self.config["questions"]
        ]
        self._namespaces = {
            q.name: load_tests((self.directory / "tests" / f"{q.name}.py").read_text(), q.name)
            for q in self.questions
        }

    @property
    def name(self) -> str:
        return self.config["assignment"]

    def solution_cells(self) -> list[str]:
        return json.loads((self.directory / "solution.json").read_text())

    def limits(self, overrides: dict | Limits | None = None) -> Limits:
        """The assignment's limits (config `limits`), with `overrides` (dict or `Limits`)."""
        if isinstance(overrides, Limits):
            return overrides
        values = {**self.config.get("limits", {}), **(overrides or {})}
        return dataclasses.replace(Limits(), **values)

    def hide_paths(self, *extra) -> tuple[str, ...]:
        paths = [str(self.directory)]
        if self.config.get("source_dir"):
            paths.append(self.config["source_dir"])
        return tuple(paths) + tuple(str(p) for p in extra)

    @property
    def jax_cache(self) -> str | None:
        """The trusted JAX compilation cache (assignments that preload jax)."""
        if "jax" not in self.config.get("preload", []) or not self.config.get("questions"):
            return None
        return str(self.directory / "jax-cache")

    def warm_cache(self) -> None:
        """Fill the JAX cache by grading the reference solution once (trusted code)."""
        cache = self.jax_cache
        if cache and not os.path.exists(os.path.join(cache, ".warm")):
            self.grade_cells(self.solution_cells(), label="reference", trusted=True)

    def grade_cells(self, cells, *, label="submission", hide=(), limits=None,
                    public_only=False, trusted=False, confine=True) -> GradeResult:
        """Grade a list of code-cell sources (the student's code).

        `trusted=True` (the reference solution only) lets the run write the JAX cache.
        With `confine` (default) untrusted code only runs where the sandbox can confine it
        (`IsolationUnavailable` otherwise); `check` turns it off: a student checking their
        own notebook runs only their own code.
        """
        if confine and not trusted:
            require_confinement()
        started = time.perf_counter()
        if not trusted:
            self.warm_cache()
        session = StudentSession(
            cells,
            self.limits(limits),
            hide=self.hide_paths(*hide),
            preload=tuple(self.config.get("preload", ["numpy"])),
            x64=bool(self.config.get("x64", True)),
            jax_cache=self.jax_cache,
            trusted=trusted,
        )
        results = []
        try:
            try:
                session.start()
            except StudentCallError as exc:  # cannot start at all: every test fails, we go on
                session.notes.append(str(exc))
            for question in self.questions:
                results.append(self._grade_question(question, session, public_only))
        finally:
            session.close()
        if trusted and self.jax_cache:
            pathlib.Path(self.jax_cache, ".warm").touch()
        protections = detect_protections().describe()
        if not detect_protections().mount_namespace and os.stat(self.directory).st_mode & 0o077:
            protections.append(f"warning: {self.directory} is readable by other users")
        if session.sandbox.not_hidden:
            protections.append(f"could not hide (contain the interpreter or temp dir): "
                               f"{', '.join(session.sandbox.not_hidden)}")
        return GradeResult(label, results, session.notes, protections,
                           time.perf_counter() - started)

    def _grade_question(self, question, session, public_only) -> QuestionResult:
        namespace = self._namespaces[question.name]
        tests = [t for t in question.tests if not (public_only and t.hidden)]
        present = session.defined(question.functions) if question.functions else {}
        out = []
        for spec in tests:
            missing = [p for p in spec.params if not present.get(p, False)]
            if missing:
                out.append(TestResult(spec.name, spec.hidden, False, spec.weight,
                                      f"`{missing[0]}` is not defined as a function"))
                continue
            proxies = [StudentFunction(session, p) for p in spec.params]
            try:
                namespace[spec.name](*proxies)
            except Exception as exc:  # a failing test, whatever the reason
                message = _failure_message(exc, spec.hidden)
                out.append(TestResult(spec.name, spec.hidden, False, spec.weight, message))
            else:
                out.append(TestResult(spec.name, spec.hidden, True, spec.weight))
        return QuestionResult(question.name, question.points, out)

    def grade(self, submission, **kwargs) -> GradeResult:
        """Grade a submitted notebook (path)."""
        path = pathlib.Path(submission).resolve()
        try:
            notebook = authoring.read_notebook(path)
            cells = authoring.student_code_cells(notebook)
        except Exception as exc:  # unreadable notebook: zero, with the reason
            empty = [QuestionResult(q.name, q.points,
                                    [TestResult(t.name, t.hidden, False, t.weight, "")
                                     for t in q.tests]) for q in self.questions]
            return GradeResult(path.name, empty, [f"could not read the notebook: {exc}"],
                               detect_protections().describe(), 0.0)
        hide = (*kwargs.pop("hide", ()), str(path.parent))
        return self.grade_cells(cells, label=path.name, hide=hide, **kwargs)


def write_autograder(assignment: authoring.Assignment, directory, *, source=None) -> pathlib.Path:
    """Write the autograder directory (mode 0700: only the grader's user may read it)."""
    directory = pathlib.Path(directory)
    if directory.exists():
        shutil.rmtree(directory)
    (directory / "tests").mkdir(parents=True)
    questions = []
    for q in assignment.questions:
        (directory / "tests" / f"{q.name}.py").write_text("\n\n".join(q.full_source) + "\n")
        questions.append({
            "name": q.name,
            "points": q.points,
            "tests": [dataclasses.asdict(t) for t in q.tests],
        })
    options = {k: v for k, v in assignment.config.items() if k in ("preload", "x64", "limits")}
    config = {
        "format": FORMAT,
        "assignment": assignment.name,
        "questions": questions,
        "source_dir": str(pathlib.Path(source).resolve().parent) if source else None,
        **options,
    }
    (directory / "config.json").write_text(json.dumps(config, indent=1) + "\n")
    (directory / "solution.json").write_text(json.dumps(assignment.solution_cells, indent=1))
    for root, _dirs, files in os.walk(directory):
        os.chmod(root, 0o700)
        for f in files:
            os.chmod(os.path.join(root, f), 0o600)
    return directory


@dataclasses.dataclass
class AssignResult:
    student_notebook: pathlib.Path
    autograder: pathlib.Path
    reference: GradeResult | None
    blank: GradeResult | None


def assign(source, out, *, verify=True, limits=None) -> AssignResult:
    """Split an instructor notebook into `out/student/NAME.ipynb` and `out/autograder/`.

    With `verify` (default), the reference solution must pass every test (public and
    hidden) and the unsolved student notebook must not get full marks on any question;
    otherwise `AuthoringError`.
    """
    assignment = authoring.parse_notebook(source)
    authoring.check_student_notebook(assignment)
    out = pathlib.Path(out)
    grader_dir = write_autograder(assignment, out / "autograder", source=source)
    student_path = out / "student" / f"{assignment.name}.ipynb"
    student_path.parent.mkdir(parents=True, exist_ok=True)
    authoring.write_notebook(assignment.student, student_path)
    reference = blank = None
    if verify:
        grader = Autograder(grader_dir)
        reference = grader.grade_cells(grader.solution_cells(), label="reference", limits=limits,
                                       trusted=True)
        failures = [
            f"{q.name}.{t.name}: {t.message or 'failed'}"
            for q in reference.questions for t in q.tests if not t.passed
        ]
        if failures:
            detail = "\n".join(failures + reference.notes)
            raise authoring.AuthoringError(f"tests fail on the reference solution:\n{detail}")
        blank = grader.grade_cells(
            authoring.student_code_cells(assignment.student), label="blank", limits=limits
        )
        full = [q.name for q in blank.questions if q.score >= q.points]
        if full:
            raise authoring.AuthoringError(
                f"the unsolved student notebook gets full marks on {full}: tests cannot fail"
            )
    return AssignResult(student_path, grader_dir, reference, blank)


def check(notebook, *, limits=None) -> GradeResult:
    """Run the public tests embedded in a student notebook on that notebook."""
    path = pathlib.Path(notebook).resolve()
    nb = authoring.read_notebook(path)
    meta = nb["metadata"].get("gfxlab", {})
    if "questions" not in meta:
        raise authoring.AuthoringError(f"{path} is not a gfxlab assignment notebook")
    sources = {}
    for cell in nb["cells"]:
        name = cell["metadata"].get("gfxlab", {}).get("tests")
        if cell["cell_type"] == "code" and name:
            sources[name] = cell["source"]
    questions = []
    for q in meta["questions"]:
        question = authoring.Question(q["name"], q["points"])
        authoring._split_tests(sources.get(q["name"], ""), question, False, 1.0)
        questions.append(question)
    grader = Autograder.__new__(Autograder)
    grader.directory = path.parent
    grader.config = {"assignment": meta.get("assignment", path.stem), "questions": []}
    grader.questions = [q for q in questions if q.tests]
    grader._namespaces = {q.name: load_tests(sources[q.name], q.name) for q in grader.questions}
    return grader.grade_cells(authoring.student_code_cells(nb), label=path.name, limits=limits,
                              confine=False)


def _grade_one(args):
    autograder_dir, submission, limits = args
    grader = _pool_grader(autograder_dir)
    try:
        return grader.grade(submission, limits=limits)
    except Exception as exc:  # never lose a submission: report it with zero
        return GradeResult(pathlib.Path(submission).name, [], [f"grader error: {exc!r}"], [], 0.0)


_GRADERS: dict[str, Autograder] = {}


def _pool_grader(directory) -> Autograder:
    if directory not in _GRADERS:
        _GRADERS[directory] = Autograder(directory)
    return _GRADERS[directory]


def grade_many(submissions, autograder_dir, out_dir, *, jobs=None, limits=None):
    """Grade many notebooks in parallel (a process pool sized to the cores).

    Writes `out_dir/<name>/results.json` per submission and `out_dir/summary.csv`;
    returns the `GradeResult`s in input order.
    """
    submissions = [str(pathlib.Path(s).resolve()) for s in submissions]
    jobs = jobs or os.cpu_count() or 1
    directory = str(pathlib.Path(autograder_dir).resolve())
    require_confinement()
    grader = Autograder(directory)
    grader.warm_cache()  # once, before the pool, so parallel graders never race on it
    tasks = [(directory, s, limits) for s in submissions]
    if jobs == 1 or len(submissions) == 1:
        results = [_grade_one(t) for t in tasks]
    else:
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=context) as pool:
            results = list(pool.map(_grade_one, tasks))
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [q.name for q in grader.questions]
    with open(out_dir / "summary.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["submission", *names, "total", "max", "seconds", "notes"])
        for path, result in zip(submissions, results, strict=True):
            stem = pathlib.Path(path).stem
            (out_dir / stem).mkdir(exist_ok=True)
            (out_dir / stem / "results.json").write_text(
                json.dumps(result.to_gradescope(), indent=1)
            )
            scores = {q.name: f"{q.score:.2f}" for q in result.questions}
            writer.writerow([
                pathlib.Path(path).name, *[scores.get(n, "0.00") for n in names],
                f"{result.score:.2f}", f"{grader_max(grader):g}", f"{result.seconds:.2f}",
                " | ".join(result.notes)[:500],
            ])
    return results


def grader_max(grader: Autograder) -> float:
    return sum(q.points for q in grader.questions)
