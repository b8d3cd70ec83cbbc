"""`assign`, `check` and `grade_many`: what the command line does.

`assign` writes the student notebook and the autograder directory and proves the tests:
the reference solution passes every test, and neither the unsolved notebook nor any
generated wrong answer (`gfxlab.grading.mutants`) earns a mark. `check` runs a notebook's
public test cells, and `grade_many` grades a folder in parallel; both run all student
code (and, for `check`, the notebook's own test cells) in the sandbox.
"""

from __future__ import annotations

import ast
import csv
import dataclasses
import importlib.util
import json
import multiprocessing
import os
import pathlib
import random
import re
import shutil
import sys
import tempfile
import time

from .._plain_args import flag, path_arg, positive_int, positive_number
from . import authoring, mutants
from ._args import limits_arg
from ._bounds import HARD_MARGIN_SECONDS
from .grader import Autograder, GradeResult, QuestionResult, TestResult, _bounded
from .sandbox import detect_protections, require_confinement

FORMAT = 2


def _imports(source: str) -> set[str]:
    """Top-level module names a test source imports (anywhere in it)."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def check_libraries(assignment: authoring.Assignment) -> list[str]:
    """Modules the tests import, all importable here; `AuthoringError` naming a missing one."""
    needed = set()
    for q in assignment.questions:
        for source in q.full_source:
            for name in sorted(_imports(source)):
                if importlib.util.find_spec(name) is None:
                    raise authoring.AuthoringError(
                        f"the tests of {q.name} import `{name}`, which the grading environment "
                        "lacks: install it (a test must never pass for want of a library)"
                    )
                needed.add(name)
    return sorted(needed)


def write_autograder(assignment: authoring.Assignment, directory) -> pathlib.Path:
    """Write the autograder directory (mode 0700: only the grader's user may read it)."""
    directory = pathlib.Path(directory)
    if directory.exists():
        shutil.rmtree(directory)
    (directory / "tests").mkdir(parents=True)
    questions = []
    for q in assignment.questions:
        (directory / "tests" / f"{q.name}.py").write_text("\n\n".join(q.full_source) + "\n")
        questions.append(
            {
                "name": q.name,
                "points": q.points,
                "tests": [dataclasses.asdict(t) for t in q.tests],
            }
        )
    options = {
        k: v
        for k, v in assignment.config.items()
        if k in ("preload", "x64", "limits", "forbid", "separate")
    }
    _check_separate(assignment)
    config = {
        "format": FORMAT,
        "assignment": assignment.name,
        "questions": questions,
        "test_imports": check_libraries(assignment),
        **options,
    }
    (directory / "config.json").write_text(json.dumps(config, indent=1) + "\n")
    (directory / "solution.json").write_text(json.dumps(assignment.solution_cells, indent=1))
    for root, _dirs, files in os.walk(directory):
        os.chmod(root, 0o700)
        for f in files:
            os.chmod(os.path.join(root, f), 0o600)
    return directory


def _check_separate(assignment: authoring.Assignment) -> None:
    """`separate` names graded functions only: `{function: [functions it may not use]}`."""
    rules = assignment.config.get("separate") or {}
    graded = {f for q in assignment.questions for f in q.functions}
    if not isinstance(rules, dict):
        raise authoring.AuthoringError("metadata `separate` must map a function to a list")
    for function, others in rules.items():
        names = [function, *others] if isinstance(others, list) else [function, None]
        unknown = [n for n in names if n not in graded]
        if unknown:
            raise authoring.AuthoringError(
                f"metadata `separate`: {unknown[0]!r} is not a function the tests take"
            )


@dataclasses.dataclass
class AssignResult:
    """What `assign` wrote, and how the reference and a blank notebook scored."""

    student_notebook: pathlib.Path
    autograder: pathlib.Path
    reference: GradeResult | None
    blank: GradeResult | None
    mutants: int = 0
    gradescope: pathlib.Path | None = None


def prove_tests(
    grader: Autograder, assignment: authoring.Assignment, limits=None, *, fail_fast=False
):
    """Reference passes everything; blank notebook and wrong answers earn nothing.

    The reference and the wrong answers (`gfxlab.grading.mutants`) share one sandboxed
    process; the unsolved notebook gets its own. **Returns:** (reference, blank, number of
    wrong answers); raises `AuthoringError` listing every weak test (the first one only
    with `fail_fast`).
    """
    public = [src for q in assignment.questions for src in q.public_source]
    plan, cell = mutants.plan(grader.questions, grader.solution_cells(), public)
    reference, weak = mutants.grade_reference_and_mutants(
        grader, plan, cell, limits, fail_fast=fail_fast
    )
    failures = [
        f"{q.name}.{t.name}: {t.message or 'failed'}"
        for q in reference.questions
        for t in q.tests
        if not t.passed
    ]
    if failures:
        detail = "\n".join(failures + reference.notes)
        raise authoring.AuthoringError(f"tests fail on the reference solution:\n{detail}")
    if not (weak and fail_fast):
        blank = grader.grade_cells(
            authoring.student_code_cells(assignment.student), label="blank", limits=limits
        )
        weak = [
            f"{q.name}: the unsolved notebook passes {t.name}"
            for q in blank.questions
            for t in q.tests
            if t.passed
        ] + weak
    if weak:
        raise authoring.AuthoringError(
            "tests too weak: wrong answers earn marks (strengthen these tests):\n" + "\n".join(weak)
        )
    return reference, blank, len(plan)


def assign(
    source, out, *, verify_tests=True, limits=None, gradescope=False, fail_fast=False, verify=None
) -> AssignResult:
    """Split an instructor notebook into `out/student/NAME.ipynb` and `out/autograder/`.

    With `verify_tests` (default), the reference solution must pass every test (public
    and hidden), and neither the unsolved student notebook nor any generated wrong answer
    may pass any test; otherwise `AuthoringError`. With `gradescope`, also writes
    `out/autograder.zip` for Gradescope (`gfxlab.grading.gradescope`). `fail_fast` stops
    at the first weak test.
    """
    if verify is not None:  # old keyword
        verify_tests = verify
    assignment = authoring.parse_notebook(source)
    authoring.check_student_notebook(assignment)
    out = pathlib.Path(out)
    grader_dir = write_autograder(assignment, out / "autograder")
    student_path = out / "student" / f"{assignment.name}.ipynb"
    student_path.parent.mkdir(parents=True, exist_ok=True)
    authoring.write_notebook(assignment.student, student_path)
    result = AssignResult(student_path, grader_dir, None, None)
    if verify_tests:
        grader = Autograder(grader_dir)
        result.reference, result.blank, result.mutants = prove_tests(
            grader, assignment, limits, fail_fast=fail_fast
        )
    if gradescope:
        from .gradescope import write_zip

        result.gradescope = write_zip(grader_dir, out / "autograder.zip")
    return result


def check(notebook, *, limits=None) -> GradeResult:
    """Run the public test cells of a student notebook on that notebook, in the sandbox.

    The test cells come from the notebook (the student may have edited them), so they run
    inside the sandbox with the student's code; only pass/fail and messages come back.
    """
    path = pathlib.Path(notebook).resolve()
    nb = authoring.read_notebook(path)
    meta = nb["metadata"].get("gfxlab")
    if not isinstance(meta, dict) or not isinstance(meta.get("questions"), list):
        raise authoring.AuthoringError(f"{path} is not a gfxlab assignment notebook")
    cells = authoring.student_code_cells(nb)
    tests = authoring.public_test_cells(nb)
    grader = Autograder.without_tests(
        path.parent,
        assignment=meta.get("assignment", path.stem),
        preload=_module_names(meta.get("preload", ["numpy"]))[:10],
        forbid=_module_names(meta.get("forbid", []))[:50],
    )
    prot = require_confinement()
    numbers = authoring.student_code_cell_numbers(nb)
    session = grader.session(cells + [_CHECK_HELPER], limits, [*numbers, 0])
    questions = []
    try:
        session.start()
        for q in meta["questions"][:100]:
            name = str(q.get("name", "")) if isinstance(q, dict) else ""
            try:
                points = float(q.get("points", 0)) if isinstance(q, dict) else 0.0
            except (TypeError, ValueError):
                points = 0.0
            results = []
            if name in tests:
                try:
                    raw = session.sandbox.request(
                        "call",
                        session._timeout(session.limits.exec_timeout),
                        budget=session.remaining(),
                        name="_gfxlab_check",
                        transforms=[],
                        args=_encode([tests[name], name]),
                        kwargs=_encode({}),
                    )
                except Exception as exc:
                    raw = [["(public tests)", False, _bounded(str(exc), 500)]]
                for item in raw if isinstance(raw, list) else []:
                    if isinstance(item, (list, tuple)) and len(item) == 3:
                        results.append(
                            TestResult(
                                _bounded(item[0], 100),
                                False,
                                item[1] is True,
                                1.0,
                                _bounded(item[2], 1000),
                            )
                        )
            questions.append(QuestionResult(_bounded(name, 100), points, results))
    finally:
        session.close()
    return GradeResult(
        _bounded(path.name, 200),
        questions,
        session.notes,
        session.sandbox.describe() if session.sandbox.applied else prot.describe(),
        0.0,
        session.infrastructure_error,
    )


def _module_names(value) -> list[str]:
    """Dotted module names only (the notebook's metadata is the student's to edit)."""
    if not isinstance(value, list):
        return []
    return [m for m in value if isinstance(m, str) and all(p.isidentifier() for p in m.split("."))]


def _encode(value):
    from .codec import encode

    return encode(value)


_CHECK_HELPER = """
def _gfxlab_check(source, question):
    import gfxlab.grading.checks as _checks
    import numpy as np
    namespace = dict(globals())
    namespace.update(np=np, check_array=_checks.check_array, run_tests=lambda *a, **k: [])
    exec(compile(source, "<public tests " + question + ">", "exec"), namespace)
    names = [n for n in namespace if n.startswith("test") and callable(namespace[n])]
    results = _checks.run_tests(namespace, names, echo=False)
    return [[str(n), bool(p), str(m)[:1000]] for n, p, m in results]
"""


def _grade_one(args):
    autograder_dir, submission, label, limits, *more = args
    try:
        grader = _pool_grader(autograder_dir)
        grader.warm = bool(more[0]) if more else True  # a spare only if more will come
        result = grader.grade(submission, limits=limits)
        result.submission = label
        return result
    except Exception as exc:  # never lose a submission: report it, as a grader error
        return GradeResult(label, [], [], [], 0.0, f"grader error: {exc!r}"[:2000])


_GRADERS: dict[str, Autograder] = {}


def _pool_grader(directory) -> Autograder:
    if directory not in _GRADERS:
        # A batch: the next submission's sandbox starts while this one is graded.
        _GRADERS[directory] = Autograder(directory, warm=True)
    return _GRADERS[directory]


def safe_names(paths) -> list[str]:
    """One distinct, harmless folder name per submission (never `.`, `..`, or a clash)."""
    used, out = {"summary.csv", "summary"}, []
    for path in paths:
        stem = pathlib.Path(path).name.removesuffix(".ipynb")
        safe = re.sub(r"[^A-Za-z0-9_-]+", "_", stem).strip("_")[:80] or "submission"
        name, k = safe, 1
        while name.lower() in used:
            k += 1
            name = f"{safe}-{k}"
        used.add(name.lower())
        out.append(name)
    return out


def csv_cell(text) -> str:
    """A spreadsheet-safe cell: no formula (`=`, `+`, `-`, `@`, tab, CR), bounded."""
    text = _bounded(str(text), 500).replace("\n", " ")
    # Lone surrogates (a student's exception text) cannot be written as UTF-8: escaped.
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def _pool_worker(conn, grade=None, scratch=None):
    """A grader process: grades the tasks it is sent, one at a time, until `None`.

    Its sandboxes' working folders go under `scratch`, which the pool removes when this
    process ends, even if it was killed mid-submission.
    """
    if scratch is not None:
        tempfile.tempdir = scratch
    grade = grade or _grade_one
    conn.send("ready")  # the hard limit counts from here, not from the process's start-up
    while True:
        task = conn.recv()
        if task is None:
            for grader in _GRADERS.values():
                grader.close()  # the spare sandbox, launched for a task that went elsewhere
            return
        conn.send(grade(task))


STARTUP_SECONDS = 300.0  # a grader process's own start (imports), before any submission


class _Worker:
    def __init__(self, context, grade):
        self.conn, child = context.Pipe()
        # Traversable by a sandbox's own uid, like the sandboxes' folders inside it.
        self.scratch = tempfile.mkdtemp(prefix="gfxlab-grader-")
        os.chmod(self.scratch, 0o711)
        self.proc = context.Process(
            target=_pool_worker, args=(child, grade, self.scratch), daemon=True
        )
        self.proc.start()
        child.close()
        self.task, self.started, self.ready = None, 0.0, False
        self.born = time.monotonic()

    def kill(self):
        self.proc.kill()
        self.proc.join()
        self.conn.close()
        self.remove_scratch()

    def remove_scratch(self):
        """The working folders of this process's sandboxes (once it has ended)."""
        shutil.rmtree(self.scratch, ignore_errors=True)


def run_pool(tasks, jobs: int, hard_limit: float, *, grade=None) -> list:
    """The grader processes of `grade_many`: grade `tasks` in `jobs` processes, killing
    (and replacing) one that runs past `hard_limit` seconds on a task, whatever happens
    in it, while the rest go on.

    The grader processes are *spawned* (fresh interpreters that import the calling
    script's main module): a script that calls `run_pool` (or `grade_many`) must do so
    under `if __name__ == "__main__":`, or each process would run the script again.

    **Arguments:**

    - `tasks`: a list or tuple with one tuple per submission, `(autograder folder,
      notebook path, label, overrides of the limits: None, a dict or a Limits, whether a
      spare sandbox should start for the next one: True or False)`; with `grade`, tuples
      whose third item is the label (a str), the rest as `grade` takes them.
    - `jobs`: grader processes (a positive int; at most one per task).
    - `hard_limit`: wall seconds one task may take in its process (a positive number).
    - `grade`: the function a process applies to a task (default: grade the notebook
      with the autograder); a picklable top-level function, since the processes are
      spawned.

    **Returns:** the results of `grade`, in the order of `tasks`; a task that was stopped
    or whose process died gets a `GradeResult` whose `error` says so.

    **Raises:** `TypeError`/`ValueError` naming a wrong argument, before any process
    starts; `RuntimeError` when a grader process does not start within `STARTUP_SECONDS`.
    """
    from multiprocessing.connection import wait

    _check_pool_args(tasks, jobs, hard_limit, grade)

    context = multiprocessing.get_context("spawn")
    results: list = [None] * len(tasks)
    pending = list(range(len(tasks)))
    workers = [_Worker(context, grade) for _ in range(max(1, min(jobs, len(tasks))))]
    try:
        while pending or any(w.task is not None for w in workers):
            for w in workers:
                if w.ready and w.task is None and pending:
                    w.task, w.started = pending.pop(0), time.monotonic()
                    w.conn.send(tasks[w.task])
            busy = {w.conn: w for w in workers if w.task is not None or not w.ready}
            for conn in wait(list(busy), timeout=0.5):
                w = busy[conn]
                try:
                    message = conn.recv()
                except (EOFError, OSError):  # the grader process died: a fresh one
                    if w.task is not None:
                        results[w.task] = _grader_error(tasks[w.task], "the grader process died")
                    w.kill()
                    workers[workers.index(w)] = _Worker(context, grade)
                    continue
                if not w.ready:
                    w.ready = message == "ready"
                    continue
                results[w.task], w.task = message, None
            now = time.monotonic()
            for i, w in enumerate(workers):
                if not w.ready and now - w.born > STARTUP_SECONDS:
                    raise RuntimeError(f"a grader process did not start in {STARTUP_SECONDS} s")
                if w.task is not None and now - w.started > hard_limit:
                    results[w.task] = _grader_error(
                        tasks[w.task], f"grading took longer than {hard_limit:g} s and was stopped"
                    )
                    w.kill()
                    workers[i] = _Worker(context, grade)
    finally:
        for w in workers:
            try:
                w.conn.send(None)
            except OSError:
                pass
            w.proc.join(5)
            if w.proc.is_alive():
                w.kill()
            w.remove_scratch()
    return results


def _check_pool_args(tasks, jobs, hard_limit, grade) -> None:
    """`run_pool`'s arguments as its docstring says, or `TypeError`/`ValueError`."""
    positive_int(jobs, "jobs")
    positive_number(hard_limit, "hard_limit")
    if grade is not None and not callable(grade):
        raise TypeError(f"`grade` must be a function or None, got {grade!r:.60}")
    if not isinstance(tasks, list | tuple):
        raise TypeError(f"`tasks` must be a list or tuple of task tuples, got {tasks!r:.60}")
    exact = grade is None  # the default `grade` takes the documented 5-tuples
    for i, task in enumerate(tasks):
        if not isinstance(task, tuple) or (len(task) != 5 if exact else len(task) < 3):
            size = "5" if exact else "at least 3"
            raise TypeError(f"`tasks[{i}]` must be a tuple of {size} items, got {task!r:.80}")
        if not isinstance(task[2], str):
            raise TypeError(f"`tasks[{i}]`: the label (item 2) must be a str, got {task[2]!r:.60}")
        if exact:
            path_arg(task[0], f"tasks[{i}][0] (the autograder folder)")
            path_arg(task[1], f"tasks[{i}][1] (the notebook)")
            limits_arg(task[3], f"tasks[{i}][3] (the limits)", overrides=True)
            flag(task[4], f"tasks[{i}][4] (start a spare sandbox)")


def _grader_error(task, text):
    return GradeResult(task[2], [], [], [], 0.0, f"grader error: {text}"[:2000])


def grade_many(submissions, autograder_dir, out_dir, *, jobs=None, limits=None):
    """Grade many notebooks in parallel (a process pool sized to the cores).

    Writes `out_dir/<safe name>/results.json` per submission and `out_dir/summary.csv`;
    returns the `GradeResult`s in input order. A submission the grader fails on gets a
    results file with `grading_error` set (see `GradeResult.error`).
    """
    submissions = [os.path.abspath(s) for s in submissions]  # links are not followed
    jobs = jobs or os.cpu_count() or 1
    directory = str(pathlib.Path(autograder_dir).resolve())
    require_confinement()
    grader = Autograder(directory)
    labels = [_bounded(pathlib.Path(s).name, 200) for s in submissions]
    # In a random order: a grader process starts the next submission's sandbox while it
    # grades one, and code in that sandbox can tell how long it waited (the previous
    # submission's time, which that submission chose); so no one can choose to follow a
    # given submission.
    order = list(range(len(submissions)))
    random.SystemRandom().shuffle(order)
    tasks = [
        (directory, submissions[k], labels[k], limits, n < len(order) - jobs)
        for n, k in enumerate(order)
    ]
    # An assignment with `separate` rules may grade a question again in a second sandbox.
    budgets = 2 if grader.config.get("separate") else 1
    hard_limit = budgets * grader.limits(limits).budget_seconds + HARD_MARGIN_SECONDS
    results = [None] * len(order)
    for k, result in zip(order, run_pool(tasks, jobs, hard_limit), strict=True):
        results[k] = result
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [q.name for q in grader.questions]
    maximum = sum(q.points for q in grader.questions)
    with open(out_dir / "summary.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(
            ["submission", "folder", *names, "total", "max", "seconds", "grading_error", "notes"]
        )
        for folder, result in zip(safe_names(submissions), results, strict=True):
            (out_dir / folder).mkdir(exist_ok=True)
            (out_dir / folder / "results.json").write_text(
                json.dumps(result.to_gradescope(), indent=1)
            )
            scores = {q.name: f"{q.score:.2f}" for q in result.questions}
            writer.writerow(
                [
                    csv_cell(result.submission),
                    folder,
                    *[scores.get(n, "0.00") for n in names],
                    f"{result.score:.2f}",
                    f"{maximum:g}",
                    f"{result.seconds:.2f}",
                    csv_cell(result.error or ""),
                    csv_cell(" | ".join(result.notes + result.staff_notes)),
                ]
            )
    return results


def protections_summary() -> str:
    """This machine's sandbox protections, one line per layer."""
    return "\n".join(detect_protections().describe())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(0)
