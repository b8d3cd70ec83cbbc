"""Proof of test strength: generated wrong answers must earn no marks.

`assign` grades, next to the reference solution, a set of wrong answers built from it:
for every function a question tests, a version returning `None`, the first input
unchanged, zeros like the right result, the right result plus or minus one (numbers
only), a constant (the right result of the test's first call, returned for every call:
a hard-coded answer), and for every parameter the right function with that input
replaced by zeros (a loss that ignores its data), and every helper function of the
public-test cells (copied verbatim into the handout) used as the answer, called with the
same inputs: a handout whose public tests compute the answer is refused. All of them
run in one sandboxed
student process next to the reference. Any test a wrong answer passes is reported, and
`assign` refuses the assignment.
"""

from __future__ import annotations

import ast
import dataclasses
import time

from . import authoring

HELPERS = """
def _gx_map(value, fn):
    if type(value) in (list, tuple):
        return type(value)(_gx_map(v, fn) for v in value)
    if value is None or isinstance(value, (str, bool)) or getattr(value, "dtype", None) == bool:
        raise TypeError("no number to change")
    return fn(value)


def _gx_traced(value):
    if type(value) in (list, tuple):
        return any(_gx_traced(v) for v in value)
    return type(value).__module__.startswith("jax") and "Tracer" in type(value).__name__


def _gx_public(sources):
    import numpy

    found = {}
    for source in sources:
        namespace = dict(globals())
        namespace.setdefault("np", numpy)
        namespace.setdefault("check_array", lambda value, **options: value)
        namespace["run_tests"] = lambda *a, **k: None
        try:
            exec(source, namespace)
        except Exception:
            continue
        for key, value in namespace.items():
            if callable(value) and key not in globals() and not key.startswith("test"):
                found[key] = value
    return found


def _gx_apply(made, x):
    # What a helper without inputs made, applied to the first input: a matrix as a
    # (separable) transform, a list of index tuples as an order to read the input in.
    import numpy

    x = numpy.asarray(x)
    if type(made) in (list, tuple) and made and all(type(i) is tuple for i in made):
        return numpy.array([x[i] for i in made], dtype=x.dtype)
    made = numpy.asarray(made)
    if made.ndim != 2:
        raise TypeError("not a transform")
    return made @ x @ made.T if x.ndim == 2 else made @ x


def _gx_mutant(ref, kind, arg=None):
    memo = []

    def mutant(*args, **kwargs):
        if kind == "none":
            return None
        if kind in ("helper", "helper1", "helper0"):
            if arg is None:
                raise TypeError("the helper did not load")
            if kind == "helper":
                return arg(*args, **kwargs)
            if kind == "helper0":
                return _gx_apply(arg(), args[0])
            import numpy  # numbers as length-1 arrays, the result's first row back

            args = [numpy.atleast_1d(a) if numpy.ndim(a) == 0 else a for a in args]
            result = arg(*args, **kwargs)
            return result[0] if numpy.ndim(result) and len(result) == 1 else result
        if kind == "identity":
            return args[0] if args else None
        if kind == "ignore":
            args = list(args)
            args[arg] = _gx_map(args[arg], lambda x: x * 0)
            return ref(*args, **kwargs)
        result = ref(*args, **kwargs)
        if kind == "const":
            if _gx_traced(result):  # under jax.grad/jit: a constant has no derivative
                import jax

                return jax.tree_util.tree_map(jax.lax.stop_gradient, result)
            if not memo:
                memo.append(result)
            return memo[0]
        if kind == "zero":
            return _gx_map(result, lambda x: x * 0)
        return _gx_map(result, (lambda x: x + 1) if kind == "plus" else (lambda x: x - 1))

    return mutant
"""

KINDS = ("none", "identity", "zero", "plus", "minus")


@dataclasses.dataclass(frozen=True)
class Mutant:
    """A wrong variant (`kind`) of one reference function, for one question's tests."""

    question: str
    function: str
    kind: str
    name: str  # the mutant's name in the student process
    tests: tuple[str, ...] | None = None  # None: every test of the question


def _arity(cells: list[str]) -> dict[str, int]:
    """Positional parameters of the functions the reference defines at top level."""
    out = {}
    for cell in cells:
        try:
            tree = ast.parse(cell)
        except SyntaxError:
            continue
        for node in tree.body:
            if isinstance(node, ast.FunctionDef):
                out[node.name] = len(node.args.posonlyargs) + len(node.args.args)
    return out


def plan(questions: list[authoring.Question], solution_cells: list[str], public=None):
    """The mutants of every tested function and the cell that defines them.

    `public`: the public-test cells' sources (default: the questions' `public_source`).
    """
    arity = _arity(solution_cells)
    if public is None:
        public = [src for q in questions for src in q.public_source]
    helpers = {
        name: n
        for name, n in _arity(public).items()
        if not name.startswith("test") and name not in arity
    }
    mutants, lines = [], [HELPERS, f"_gx_pub = _gx_public({public!r})"]

    def add(question, function, kind, call, tests=None):
        name = f"_gx_{function}_{len(mutants)}"
        lines.append(f"{name} = _gx_mutant({function}, {call})")
        mutants.append(Mutant(question.name, function, kind, name, tests))

    for q in questions:
        for function in q.functions:
            if function not in arity:
                continue
            for kind in KINDS:
                add(q, function, kind, f"{kind!r}")
            for i in range(arity[function]):
                add(q, function, f"ignore input {i + 1}", f"'ignore', {i}")
            for helper, n in helpers.items():
                if n == 0:
                    call = f"'helper0', _gx_pub.get({helper!r})"
                    add(q, function, f"= the public-test helper `{helper}` applied", call)
                if n == arity[function]:
                    for kind in ("helper", "helper1"):
                        call = f"{kind!r}, _gx_pub.get({helper!r})"
                        add(q, function, f"= the public-test helper `{helper}`", call)
            for t in q.tests:
                if function in t.params:  # a fresh memo per test: its first answer is right
                    add(q, function, f"constant ({t.name})", "'const'", (t.name,))
    return mutants, "\n".join(lines)


def grade_reference_and_mutants(grader, mutants, cell, limits=None, *, fail_fast=False):
    """Grade the reference and the mutants, question by question, in one sandboxed process.

    A question's mutants run once the reference passes all its tests. With `fail_fast`,
    stops at the first failing reference test or weak test (the questions after it are
    then missing from the returned reference result).

    **Returns:** (the reference's `GradeResult`, the tests wrong answers pass).
    """
    from .grader import GradeResult

    prot = grader_confinement()
    started = time.perf_counter()
    session = grader.session([*grader.solution_cells(), cell], limits)
    weak, questions = [], []
    try:
        try:
            session.start()
        except Exception as exc:
            session._note(str(exc))
        if session.infrastructure_error:
            raise authoring.AuthoringError(
                f"the sandbox did not start: {session.infrastructure_error}"
            )
        if session.status and session.status[-1] != "ok":
            raise authoring.AuthoringError(f"the wrong answers did not load: {session.notes}")
        for q in grader.questions:
            result = grader._grade_question(q, session)
            questions.append(result)
            if not all(t.passed for t in result.tests):
                if fail_fast:
                    break
                continue
            weak += _weak_tests(
                grader, session, q, [m for m in mutants if m.question == q.name], fail_fast
            )
            if weak and fail_fast:
                break
    finally:
        session.close()
    reference = GradeResult(
        "reference",
        questions,
        session.notes,
        prot.describe(),
        time.perf_counter() - started,
        session.infrastructure_error,
    )
    return reference, weak


def _weak_tests(grader, session, question, mutants, fail_fast) -> list[str]:
    weak = []
    for m in mutants:
        tests = [t for t in question.tests if m.tests is None or t.name in m.tests]
        sub = authoring.Question(question.name, question.points, tests)
        result = grader._grade_question(sub, session, "all", {m.function: m.name})
        passed = [t.name for t in result.tests if t.passed]
        if passed:
            weak.append(f"{m.question}: `{m.function}` {m.kind} passes {', '.join(passed)}")
            if fail_fast:
                break
    return weak


def grader_confinement():
    """The sandbox protections, or `IsolationUnavailable` if student code cannot be confined."""

    from .sandbox import require_confinement

    return require_confinement()
