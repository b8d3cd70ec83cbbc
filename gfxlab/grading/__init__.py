"""Autograded assignments that cannot be cheated.

- `assign(source, out)`: instructor notebook -> `out/student/NAME.ipynb` and
  `out/autograder/` (hidden tests, reference solution, configuration); authoring errors
  (solution left in, tests failing on the reference, a question without tests) raise
  `AuthoringError`.
- `Autograder(dir).grade(notebook)` -> `GradeResult` (`.table()`, `.to_gradescope()`);
  `grade_many(notebooks, dir, out)` grades in parallel and writes a summary CSV.
- `check(notebook)`: the public tests embedded in a student notebook.

Student code runs only in a separate sandboxed process (`gfxlab.grading.sandbox`); tests
run in the grader and see the student's functions through a plain-data RPC. The
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
