"""Autograded assignments that hold in a real course.

- `assign(source, out)`: instructor notebook -> `out/student/NAME.ipynb` (runs top to
  bottom in Jupyter) and `out/autograder/` (hidden tests, reference solution,
  configuration), optionally `out/autograder.zip` for Gradescope; it proves the tests
  (reference passes; the unsolved notebook and generated wrong answers earn nothing,
  `gfxlab.grading.mutants`) or raises `AuthoringError`.
- `Autograder(dir).grade(notebook)` -> `GradeResult` (`.table()`, `.to_gradescope()`);
  `grade_many(notebooks, dir, out)` grades in parallel and writes a summary CSV.
- `check(notebook)`: the notebook's public tests, run in the sandbox too.

Student code runs only in a bubblewrap sandbox (`gfxlab.grading.sandbox`: allow-list
filesystem, every namespace, unprivileged, limits and a per-submission time budget);
tests run in the grader and see the student's functions through a plain-data RPC. An
assignment's `separate` rules (`gfxlab.grading.reuse`) give no marks to an answer that
calls another graded answer; `forbid` makes modules (all of gfxlab: `"gfxlab"`)
unimportable. The
authoring format is documented in `gfxlab.grading.authoring`. Command line:
`python -m gfxlab assign|check|grade` (`gfxlab.grading.cli`).
"""

from .authoring import Assignment, AuthoringError, parse_notebook, strip_solutions
from .checks import Feedback, check_array
from .commands import assign, check, grade_many
from .grader import Autograder, GradeResult, QuestionResult, StudentFunction, TestResult
from .sandbox import IsolationUnavailable, Limits, Protections, Sandbox, detect_protections

__all__ = [
    "Assignment",
    "AuthoringError",
    "Autograder",
    "Feedback",
    "GradeResult",
    "IsolationUnavailable",
    "Limits",
    "Protections",
    "QuestionResult",
    "Sandbox",
    "StudentFunction",
    "TestResult",
    "assign",
    "check",
    "check_array",
    "detect_protections",
    "grade_many",
    "parse_notebook",
    "strip_solutions",
]
