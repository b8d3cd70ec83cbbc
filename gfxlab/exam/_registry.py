"""Every question of the course exam, registered by id, and the lookups on it."""

from __future__ import annotations

from . import _section1, _section2, _section3, _section4, _section5
from ._model import Answer, Question, descriptive

_SECTIONS = (_section1, _section2, _section3, _section4, _section5)


def _build() -> dict[str, Question]:
    questions = {}
    for section in _SECTIONS:
        for qid, (title, text, solver) in section.NUMERIC.items():
            questions[qid] = Question(qid, 5, title, text, True, solver)
        for qid, (title, text) in section.DESCRIPTIVE.items():
            solver = descriptive(*section.ANSWERS[qid])
            questions[qid] = Question(qid, 5, title, text, False, solver)
    return {qid: questions[qid] for qid in sorted(questions)}


#: Every question of the exam, by id, in exam order. Each is worth 5 marks.
QUESTIONS: dict[str, Question] = _build()


def question(qid: str) -> Question:
    """A question by id, case-insensitively (`"q4f"` -> Q4f).

    **Arguments:**

    - `qid`: a question id such as `"Q2b"`.

    **Returns:** the `Question`; a `KeyError` listing the ids if there is none.
    """
    if not isinstance(qid, str):
        raise TypeError(f"`qid` must be a question id such as 'Q2b', got {qid!r}")
    key = qid.strip()
    key = key[0].upper() + key[1:].lower() if key else key
    if key not in QUESTIONS:
        raise KeyError(f"no question {qid!r}; the ids are {', '.join(QUESTIONS)}")
    return QUESTIONS[key]


def solve(qid: str, **options) -> Answer:
    """Solve a question by id (options are question-specific, e.g. `radius=12` for Q1b).

    Computes in float64 locally; the caller's `jax_enable_x64` setting is unchanged.

        >>> from gfxlab import exam
        >>> exam.solve("Q4f").values["points"][1].tolist()
        [1.921875, 2.171875]
    """
    return question(qid).solve(**options)


def errata() -> list[tuple[str, str]]:
    """Every mistake found in the answer key, as `(question id, description)` pairs."""
    return [(qid, e) for qid, q in QUESTIONS.items() for e in q.solve().errata]
