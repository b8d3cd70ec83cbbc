"""The course exam, solved step by step with gfxlab.

Every question of the course's exam (Q1a..Q5f, with the unnumbered Bezier
question of section 4 as Q4f) is registered here with its marks and a `solve()` that
computes the answer with the library itself and returns the steps (numbers, matrices,
tables), the mistakes found in the answer key, a pointer to the lab section and
gfxlab call that demonstrate it, and a figure where one helps.

    >>> from gfxlab import exam
    >>> answer = exam.solve("Q4f")
    >>> "123/64" in answer.to_text()
    True

Solvers compute in float64 locally (a `jax.enable_x64` context): calling them leaves the
caller's `jax_enable_x64` setting alone.

From the shell: `python -m gfxlab exam` lists the questions, `python -m gfxlab exam
Q2b` prints one worked answer, `--markdown [FILE]` writes Markdown with LaTeX.

The package: `_model` (Question, Answer, Step, Table), `_format` (text and Markdown),
`_section1` .. `_section5` (one module per exam section), `_registry` (QUESTIONS and
the lookups), `_cli` (the command line).
"""

from ._cli import main
from ._model import Answer, Question, Step, Table
from ._registry import QUESTIONS, errata, question, solve

__all__ = [
    "Question",
    "Answer",
    "Step",
    "Table",
    "QUESTIONS",
    "question",
    "solve",
    "errata",
    "main",
]
