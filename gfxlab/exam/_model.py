"""The data model of a worked answer: `Question`, `Answer`, `Step`, `Table`.

Solvers compute in float64 inside `float64()`, a context that enables 64-bit JAX
types for the calling thread only and restores the caller's setting on exit: the exam
never switches the whole process to float64.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable, Iterator
from typing import Any


@dataclasses.dataclass(frozen=True)
class Table:
    """A small table of results (one row per step of an algorithm, say)."""

    columns: tuple[str, ...]
    rows: tuple[tuple, ...]


@dataclasses.dataclass(frozen=True)
class Step:
    """One step of a worked answer: a title and a value (text, number, matrix or table)."""

    title: str
    value: Any = None
    note: str = ""


@dataclasses.dataclass(frozen=True)
class Answer:
    """A worked answer.

    **Fields:**

    - `question`: the `Question` answered.
    - `summary`: the answer in a few sentences.
    - `steps`: the computation, step by step.
    - `values`: the numeric results by name (for checking and grading).
    - `errata`: mistakes found in the exam's answer key for this question.
    - `see_also`: the lab section and gfxlab calls that demonstrate it.
    - `figure`: a function returning a matplotlib figure, or None.
    """

    question: Question
    summary: str
    steps: tuple[Step, ...] = ()
    values: dict = dataclasses.field(default_factory=dict)
    errata: tuple[str, ...] = ()
    see_also: str = ""
    figure: Callable[[], Any] | None = None

    def to_text(self) -> str:
        """The answer as plain text."""
        from ._format import indent as _indent
        from ._format import plain as _plain

        q = self.question
        lines = [f"{q.id} ({q.marks} marks) {q.title}", "=" * min(78, len(q.title) + 14), ""]
        lines += [q.text, "", "Answer:", _indent(self.summary), ""]
        for i, step in enumerate(self.steps, 1):
            lines.append(f"Step {i}. {step.title}")
            if step.value is not None:
                lines.append(_indent(_plain(step.value)))
            if step.note:
                lines.append(_indent(step.note))
            lines.append("")
        if self.errata:
            lines.append("Errata in the answer key:")
            lines += [_indent(f"- {e}") for e in self.errata]
            lines.append("")
        if self.see_also:
            lines += ["See also:", _indent(self.see_also), ""]
        return "\n".join(lines).rstrip() + "\n"

    def to_markdown(self) -> str:
        """The answer as Markdown, with matrices in LaTeX."""
        from ._format import markdown as _markdown

        q = self.question
        lines = [
            f"## {q.id} — {q.title} ({q.marks} marks)",
            "",
            f"> {q.text}",
            "",
            self.summary,
            "",
        ]
        for i, step in enumerate(self.steps, 1):
            lines.append(f"**Step {i}. {step.title}**")
            lines.append("")
            if step.value is not None:
                lines.append(_markdown(step.value))
                lines.append("")
            if step.note:
                lines += [step.note, ""]
        if self.errata:
            lines += ["**Errata in the answer key**", ""]
            lines += [f"- {e}" for e in self.errata]
            lines.append("")
        if self.see_also:
            lines += [f"*See also:* {self.see_also}", ""]
        return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class Question:
    """One exam question: id, marks, the question text and how to solve it."""

    id: str
    marks: int
    title: str
    text: str
    numeric: bool
    solver: Callable[..., Answer] = dataclasses.field(repr=False)

    def solve(self, **options) -> Answer:
        """Compute the worked answer (options are question-specific, e.g. `radius=`).

        The solver and the answer's figure compute in float64 locally; the caller's
        `jax_enable_x64` setting is left as it was.
        """
        with float64():
            answer = self.solver(self, **options)
        if answer.figure is not None:
            answer = dataclasses.replace(answer, figure=in_float64(answer.figure))
        return answer


@contextlib.contextmanager
def float64() -> Iterator[None]:
    """Enable JAX's 64-bit types inside the block, leaving `jax_enable_x64` as it was after."""
    import jax

    with jax.enable_x64(True):
        yield


def in_float64(fn: Callable) -> Callable:
    """`fn` run inside `float64()`."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with float64():
            return fn(*args, **kwargs)

    return wrapper


def descriptive(summary: str, see_also: str, errata: tuple[str, ...] = ()) -> Callable:
    """A solver for a descriptive question: its answer is fixed text."""

    def solver(q: Question) -> Answer:
        return Answer(q, summary=summary, see_also=see_also, errata=errata)

    return solver
