"""The seed exam, solved step by step with gfxlab.

Every question of the exam in `shared/seed/` (Q1a..Q5f, with the unnumbered Bezier
question of section 4 as Q4f) is registered here with its marks and a `solve()` that
computes the answer with the library itself and returns the steps (numbers, matrices,
tables), the mistakes found in the answer key, a pointer to the lab section and
gfxlab call that demonstrate it, and a figure where one helps.

    >>> from gfxlab import exam
    >>> answer = exam.solve("Q4f")
    >>> print(answer.to_text())

From the shell: `python -m gfxlab exam` lists the questions, `python -m gfxlab exam
Q2b` prints one worked answer, `--markdown [FILE]` writes Markdown with LaTeX.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np

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


# --------------------------------------------------------------------------- data model


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
    - `errata`: mistakes found in the seed's answer key for this question.
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
        """Compute the worked answer (options are question-specific, e.g. `radius=`)."""
        return self.solver(self, **options)


# --------------------------------------------------------------------------- formatting


def _indent(text: str, prefix: str = "    ") -> str:
    return "\n".join(prefix + line if line else line for line in text.splitlines())


def _number(x, *, fractions: bool = True) -> str:
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    if fractions:
        # Exact dyadic fractions (Bezier weights, halves) read better as fractions.
        f = Fraction(x).limit_denominator(4096)
        dyadic = f.denominator & (f.denominator - 1) == 0
        if dyadic and abs(float(f) - x) < 1e-12 * max(1.0, abs(x)):
            return f"{f.numerator}/{f.denominator}"
    return f"{x:.6g}"


def _all_dyadic(arr: np.ndarray) -> bool:
    """Whether every entry prints as an integer or a short dyadic fraction."""
    return all("." not in _number(v) and "e" not in _number(v) for v in arr.ravel())


def _plain(value) -> str:
    if isinstance(value, Table):
        cells = [list(value.columns)] + [[_cell(v) for v in row] for row in value.rows]
        widths = [max(len(r[i]) for r in cells) for i in range(len(value.columns))]
        out = ["  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
        out.insert(1, "  ".join("-" * w for w in widths))
        return "\n".join(out)
    if isinstance(value, str):
        return value
    arr = np.asarray(value)
    if arr.ndim == 0:
        return _number(arr)
    if arr.ndim == 1:
        return "(" + ", ".join(_number(v) for v in arr) + ")"
    exact = _all_dyadic(arr)
    cells = [[_number(v, fractions=exact) for v in row] for row in arr.reshape(arr.shape[0], -1)]
    width = max(len(c) for row in cells for c in row)
    return "\n".join("[ " + "  ".join(c.rjust(width) for c in row) + " ]" for row in cells)


def _cell(v) -> str:
    if isinstance(v, str):
        return v
    arr = np.asarray(v)
    if arr.ndim == 0:
        return _number(arr)
    return "(" + ", ".join(_number(x) for x in arr.ravel()) + ")"


def _latex_number(x, *, fractions: bool = True) -> str:
    text = _number(x, fractions=fractions)
    if "/" in text:
        num, den = text.split("/")
        sign = "-" if num.startswith("-") else ""
        return f"{sign}\\tfrac{{{num.lstrip('-')}}}{{{den}}}"
    return text


def _markdown(value) -> str:
    if isinstance(value, Table):
        head = "| " + " | ".join(value.columns) + " |"
        rule = "| " + " | ".join("---" for _ in value.columns) + " |"
        body = ["| " + " | ".join(_cell(v) for v in row) + " |" for row in value.rows]
        return "\n".join([head, rule, *body])
    if isinstance(value, str):
        if "\n" in value and value.lstrip().startswith("["):
            return "```\n" + value + "\n```"
        return value
    arr = np.asarray(value)
    if arr.ndim == 0:
        return f"${_latex_number(arr)}$"
    if arr.ndim == 1:
        return "$(" + ", ".join(_latex_number(v) for v in arr) + ")$"
    exact = _all_dyadic(arr)
    rows = [
        " & ".join(_latex_number(v, fractions=exact) for v in row)
        for row in arr.reshape(arr.shape[0], -1)
    ]
    return "$$\\begin{pmatrix}" + " \\\\ ".join(rows) + "\\end{pmatrix}$$"


# --------------------------------------------------------------------------- helpers


def _x64():
    """Exact-looking arithmetic for the worked answers (float64)."""
    import jax

    jax.config.update("jax_enable_x64", True)


def _plot_polygon(ax, points, **kw):
    p = np.asarray(points)
    ax.fill(*np.r_[p, p[:1]].T, **kw)


# --------------------------------------------------------------------------- section 1


def _q1b(q: Question, *, radius: int = 10) -> Answer:
    _x64()
    from gfxlab import raster

    trace = np.asarray(raster.midpoint_circle_trace(radius))
    pixels = np.asarray(raster.midpoint_circle(radius))
    rows = tuple((int(k), int(p), (int(x), int(y))) for k, p, x, y in trace)
    steps = [
        Step(
            "Decision parameter",
            "p_k = f(x_k + 1, y_k - 1/2) = (x_k + 1)^2 + (y_k - 1/2)^2 - r^2; "
            "plot (x_k + 1, y_k) if p_k < 0, else (x_k + 1, y_k - 1).",
        ),
        Step(
            "Initial value for integer r",
            f"p0 = 1 - r = {1 - radius}",
            note="5/4 - r rounded; all increments are integers.",
        ),
        Step(
            "Increments",
            "p_{k+1} = p_k + 2 x_{k+1} + 1 if p_k < 0, else p_k + 2 x_{k+1} + 1 - 2 y_{k+1}",
        ),
        Step(
            f"First octant, r = {radius} (from (0, r) until x >= y)",
            Table(("k", "p_k", "(x_{k+1}, y_{k+1})"), rows),
        ),
        Step(
            "Other seven octants by symmetry",
            f"(±x, ±y) and (±y, ±x): {len(pixels)} distinct pixels in all.",
        ),
    ]
    return Answer(
        q,
        summary=(
            f"Midpoint circle for r = {radius}: start at (0, {radius}) with p0 = {1 - radius}, "
            "step x by one and use the sign of p_k to choose between y_k and y_k - 1; "
            "mirror the octant eight ways."
        ),
        steps=tuple(steps),
        values={"trace": trace, "pixels": pixels, "p0": 1 - radius},
        errata=("The circle equation is printed as 'X_2+Y_2=r_2' (twice); it is x² + y² = r².",),
        see_also="Lab 01 §midpoint circle; gfxlab.raster.midpoint_circle_trace(r), "
        "gfxlab.raster.midpoint_circle(r).",
        figure=lambda: _figure_pixels(pixels, trace, radius),
    )


def _figure_pixels(pixels, trace, radius):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.scatter(pixels[:, 0], pixels[:, 1], marker="s", s=40, c="lightgray", label="all octants")
    ax.scatter(trace[:, 2], trace[:, 3], marker="s", s=40, c="C0", label="traced octant")
    t = np.linspace(0, 2 * np.pi, 400)
    ax.plot(radius * np.cos(t), radius * np.sin(t), "C3", lw=1, label="x² + y² = r²")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Midpoint circle, r = {radius}")
    return fig


def _q1f(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import clipping

    example = clipping.SEED_EXAMPLE
    window = np.asarray(example["window"], float)
    xmin, ymin, xmax, ymax = window
    xs, ys = (xmin - 1, (xmin + xmax) / 2, xmax + 1), (ymax + 1, (ymin + ymax) / 2, ymin - 1)
    samples = jnp.array([[x, y] for y in ys for x in xs])
    codes = np.asarray(clipping.outcode(samples, jnp.asarray(window))).reshape(3, 3)
    region_table = Table(
        ("", "left", "centre", "right"),
        tuple(
            (name, *(format(int(c), "04b") for c in row))
            for name, row in zip(("top", "middle", "bottom"), codes, strict=True)
        ),
    )
    steps = [
        Step(
            "Outcode bits (read LRBT)",
            "left = 1000 (x < xmin), right = 0100 (x > xmax), "
            "bottom = 0010 (y < ymin), top = 0001 (y > ymax)",
        ),
        Step(f"The nine regions around the window {tuple(window.tolist())}", region_table),
        Step(
            "Tests",
            "trivially accept when code0 OR code1 == 0000; trivially reject when "
            "code0 AND code1 != 0000; otherwise clip an outside endpoint against an edge "
            "whose bit it has set and repeat.",
        ),
    ]
    values = {"region_codes": codes}
    for name in ("AD", "EI"):
        segment = jnp.array([example[name[0]], example[name[1]]], float)
        trace = clipping.cohen_sutherland_trace(segment, jnp.asarray(window))
        rows = tuple(
            (
                i + 1,
                _cell(s["p0"]),
                _cell(s["p1"]),
                format(s["code0"], "04b"),
                format(s["code1"], "04b"),
                format(s["and"], "04b"),
                format(s["or"], "04b"),
                s["action"],
                s["edge"] or "-",
                _cell(s["new_point"]) if s["new_point"] is not None else "-",
            )
            for i, s in enumerate(trace)
        )
        steps.append(
            Step(
                f"Segment {name}: {name[0]}{tuple(example[name[0]])} to "
                f"{name[1]}{tuple(example[name[1]])}",
                Table(
                    (
                        "iter",
                        "p0",
                        "p1",
                        "code0",
                        "code1",
                        "AND",
                        "OR",
                        "action",
                        "edge",
                        "new point",
                    ),
                    rows,
                ),
            )
        )
        values[name] = trace
    return Answer(
        q,
        summary=(
            "Each endpoint gets a 4-bit region code. OR = 0000 accepts the segment at once, "
            "AND != 0000 rejects it at once (both ends beyond the same edge); otherwise an "
            "outside endpoint is moved to the window edge named by one of its set bits and "
            "the tests repeat. On the seed's picture AD is clipped once (at the top edge) "
            "and EI three times."
        ),
        steps=tuple(steps),
        values=values,
        errata=(
            "The bit order is stated two ways: the prose sets first = left, second = top, third = "
            "right, fourth = bottom (LTRB), while the conditions, the stated reading order and the "
            "nine-region table use left, right, bottom, top (LRBT; top-left = 1001). LRBT is the "
            "consistent reading.",
            "The EI walkthrough's codes contradict its edges. It gives E = 0100 (right only) but "
            "clips E against the bottom edge, I = 1010 (left and bottom) but clips I against the "
            "top edge, and H = 0010 (bottom) but clips H against the right edge; an endpoint can "
            "only be clipped against an edge whose bit it has set. Coordinates that reproduce the "
            "key's sequence of edges (bottom, top, right), as above, have E = 0010 below the "
            "window, I = 0101 above and right of it, and H = 0100.",
        ),
        see_also="Lab 02 §walkthrough; gfxlab.clipping.outcode, "
        "gfxlab.clipping.cohen_sutherland_trace, gfxlab.clipping.cohen_sutherland.",
        figure=lambda: _figure_clip(example, window, values),
    )


def _figure_clip(example, window, values):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 5))
    xmin, ymin, xmax, ymax = window
    ax.add_patch(plt.Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False, lw=2))
    for name in ("AD", "EI"):
        a, b = np.asarray(example[name[0]], float), np.asarray(example[name[1]], float)
        ax.plot(*np.stack([a, b]).T, "C3:", lw=1)
        last = values[name][-1]
        if last["action"] == "accept":
            ax.plot(*np.asarray([last["p0"], last["p1"]]).T, "C0", lw=3)
        for label, p in ((name[0], a), (name[1], b)):
            ax.annotate(label, p, textcoords="offset points", xytext=(4, 4))
    ax.set_aspect("equal")
    ax.set_title("Cohen-Sutherland: dotted before, solid after clipping")
    return fig


# --------------------------------------------------------------------------- section 2


def _q2a(q: Question, *, window=(1.0, 1.0, 5.0, 4.0), viewport=(0.0, 0.0, 320.0, 120.0)) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import transforms as tf

    w, v = np.asarray(window, float), np.asarray(viewport, float)
    m = np.asarray(tf.window_to_viewport(jnp.asarray(w), jnp.asarray(v)))
    sx, sy = (v[2] - v[0]) / (w[2] - w[0]), (v[3] - v[1]) / (w[3] - w[1])
    corners = np.asarray(tf.apply(jnp.asarray(m), jnp.array([[w[0], w[1]], [w[2], w[3]]])))
    steps = (
        Step("1. translate the window corner to the origin", "T(-xw_min, -yw_min)"),
        Step(
            "2. scale to the viewport size",
            "S(sx, sy), sx = (xv_max - xv_min)/(xw_max - xw_min), "
            "sy = (yv_max - yv_min)/(yw_max - yw_min)",
        ),
        Step("3. translate to the viewport corner", "T(xv_min, yv_min)"),
        Step(
            "Combined (column vectors, p' = W p)",
            "[ sx  0   xv_min - sx·xw_min ]\n"
            "[ 0   sy  yv_min - sy·yw_min ]\n"
            "[ 0   0   1                  ]",
            note="The key writes the transpose for row vectors (p' = p·W), translation in the "
            "bottom row.",
        ),
        Step(
            f"Numeric instance: window {tuple(w.tolist())}, viewport {tuple(v.tolist())}",
            m,
            note=f"sx = {_number(sx)}, sy = {_number(sy)}",
        ),
        Step("Check: the window corners land on the viewport corners", corners),
    )
    return Answer(
        q,
        summary="W = T(xv_min, yv_min) · S(sx, sy) · T(-xw_min, -yw_min): move the window's "
        "lower-left corner to the origin, scale it to the viewport's size, move it to the "
        "viewport's corner.",
        steps=steps,
        values={"matrix": m, "sx": sx, "sy": sy},
        errata=(
            "The key writes W = T · S · T⁻¹, but its third factor translates by (xv_min, yv_min), "
            "the viewport corner; T⁻¹ would translate back by (+xw_min, +yw_min). The product it "
            "then prints is right for W = T(-xw_min) · S · T(xv_min) in row-vector order.",
            "A stray matrix 'G_y = [[1 0 0], [0 1 0]]' and the subscripts 'x_y max' (for x_v max) "
            "are typesetting errors.",
        ),
        see_also="Lab 03 §2 and §9 (fitting a window mapping); "
        "gfxlab.transforms.window_to_viewport(window, viewport).",
    )


_UNIT_SQUARE = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])


def _q2b(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import transforms as tf

    t, r = tf.translate(jnp.array([1.0, 1.0])), tf.rotate(jnp.pi / 2)
    m = np.asarray(tf.compose(t, r)).round(15) + 0.0
    column = np.asarray(tf.apply(jnp.asarray(m), jnp.asarray(_UNIT_SQUARE))).round(15) + 0.0
    row = (np.c_[_UNIT_SQUARE, np.ones(4)] @ m.T)[:, :2]
    table = Table(
        ("vertex", "P", "P' (column: M·P)", "P' (row: P·T)"),
        tuple(
            (n + "'", p, c, rr)
            for n, p, c, rr in zip("ABCD", _UNIT_SQUARE, column, row, strict=True)
        ),
    )
    steps = (
        Step("Translation T_T(1, 1), column form", np.asarray(t)),
        Step("Rotation R(90°), column form", np.asarray(r).round(15) + 0.0),
        Step("Column vectors: M = R · T (translate first)", m),
        Step("Row vectors (the key): T = T_T · T_R = Mᵀ", m.T),
        Step("The unit square, both conventions", table),
    )
    return Answer(
        q,
        summary="A'(-1/2, 1/2), B'(-1/2, 3/2), C'(-3/2, 3/2), D'(-3/2, 1/2).",
        steps=steps,
        values={"matrix": m, "vertices": column},
        errata=(
            "B' is printed as (-3/2, 3/2), the same as C'. It is (-1/2, 3/2): B = (1/2, -1/2) "
            "translates to (3/2, 1/2), and a quarter turn maps (x, y) to (-y, x).",
        ),
        see_also="Lab 03 §3; gfxlab.transforms.compose(translate((1, 1)), rotate(pi/2)), "
        "gfxlab.transforms.apply.",
        figure=lambda: _figure_square(column),
    )


def _figure_square(moved):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.5, 4))
    _plot_polygon(ax, _UNIT_SQUARE, alpha=0.3, color="gray")
    _plot_polygon(ax, _UNIT_SQUARE + 1, alpha=0.3, color="C0")
    _plot_polygon(ax, moved, alpha=0.6, color="C1")
    for n, p in zip("ABCD", moved, strict=True):
        ax.annotate(n + "'", p, textcoords="offset points", xytext=(4, 4))
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_title("unit square -> translate (1, 1) -> rotate 90°")
    return fig


def _q2c(q: Question, *, factors=(2.0, 3.0), center=(4.0, -1.0)) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import transforms as tf

    s, f = np.asarray(factors, float), np.asarray(center, float)
    composed = np.asarray(
        tf.compose(
            tf.translate(jnp.asarray(-f)), tf.scale(jnp.asarray(s)), tf.translate(jnp.asarray(f))
        )
    )
    closed = np.array([[s[0], 0, f[0] * (1 - s[0])], [0, s[1], f[1] * (1 - s[1])], [0, 0, 1]])
    steps = (
        Step(
            "Sequence",
            "T(xf, yf) · S(sx, sy) · T(-xf, -yf): move the fixed point to the origin, "
            "scale, move it back.",
        ),
        Step("Product", "[ sx  0   xf(1 - sx) ]\n[ 0   sy  yf(1 - sy) ]\n[ 0   0   1          ]"),
        Step(
            f"Numeric check, s = {tuple(s.tolist())}, fixed point = {tuple(f.tolist())}: "
            "gfxlab's composition",
            composed,
        ),
        Step(
            "Closed form with the same numbers",
            closed,
            note=f"max |difference| = {_number(np.max(np.abs(composed - closed)))}",
        ),
        Step(
            "The fixed point does not move",
            np.asarray(tf.apply(jnp.asarray(composed), jnp.asarray(f))),
        ),
    )
    return Answer(
        q,
        summary="S(xf, yf, sx, sy) = [[sx, 0, xf(1 - sx)], [0, sy, yf(1 - sy)], [0, 0, 1]].",
        steps=steps,
        values={"composed": composed, "closed_form": closed},
        errata=(
            "Not an error in this answer, but the key switches conventions: Q2c uses column "
            "vectors (translation in the last column) while Q2a and Q2b use row vectors.",
        ),
        see_also="Lab 03 §4; gfxlab.transforms.scale(factors, center=fixed_point).",
    )


_CUBE_NAMES = "ABCDEFGH"
_CUBE = np.array(
    [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float
)
_SEED_SHEAR = np.array([[1, 1.5, 3, 0], [0.8, 0, 1, 0], [0.5, 1, 1, 0], [0, 0, 0, 1]])


def _q2f(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import transforms as tf

    m = np.asarray(tf.linear(jnp.asarray(_SEED_SHEAR[:3, :3].T)))
    moved = np.asarray(tf.apply(jnp.asarray(m), jnp.asarray(_CUBE)))
    row_form = np.c_[_CUBE, np.ones(8)] @ _SEED_SHEAR
    table = Table(
        ("vertex", "V", "V' = V·T_shear"),
        tuple((n, v, w) for n, v, w in zip(_CUBE_NAMES, _CUBE, moved, strict=True)),
    )
    steps = (
        Step("The key's matrix (row vectors)", _SEED_SHEAR),
        Step("In column form M = T_shearᵀ", m),
        Step(
            "Homogeneous vertex matrix V (rows A..H, with G = (1, 1, 0))", np.c_[_CUBE, np.ones(8)]
        ),
        Step("V' = V · T_shear", row_form),
        Step("Transformed vertices", table),
    )
    return Answer(
        q,
        summary="A'(0.5, 1, 1), B'(1.5, 2.5, 4), C'(2.3, 2.5, 5), D'(1.3, 1, 2), E'(0, 0, 0), "
        "F'(1, 1.5, 3), G'(1.8, 1.5, 4), H'(0.8, 0, 1).",
        steps=steps,
        values={"vertices": moved},
        errata=(
            "Vertex G is printed as (1, 1, 1), the same as C; on the face z = 0 (E, F, G, H) it is "
            "(1, 1, 0).",
            "The key stops at 'Multiply V' = V · T_shear' without computing V'; the table above "
            "completes it.",
            "The matrix has a 0 on its diagonal (y' takes no y), so it is a general linear map "
            "rather than a pure shear, which has a unit diagonal and determinant 1; this one has "
            f"determinant {_number(np.linalg.det(_SEED_SHEAR[:3, :3]))}, so volumes shrink by 5 %.",
        ),
        see_also="Lab 03 §5; gfxlab.transforms.linear(T[:3, :3].T), gfxlab.transforms.shear(...).",
        figure=lambda: _figure_cube(moved),
    )


def _figure_cube(moved):
    import matplotlib.pyplot as plt

    edges = [
        (0, 1),
        (1, 2),
        (2, 3),
        (3, 0),
        (4, 5),
        (5, 6),
        (6, 7),
        (7, 4),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ]
    fig = plt.figure(figsize=(9, 4))
    for i, (title, pts) in enumerate((("unit cube", _CUBE), ("after T_shear", moved))):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        for a, b in edges:
            ax.plot(*pts[[a, b]].T, color="C0")
        for n, p in zip(_CUBE_NAMES, pts, strict=True):
            ax.text(*p, n)
        ax.set_title(title)
    return fig


# --------------------------------------------------------------------------- section 3


def _q3d(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import color

    wl = jnp.asarray(color.CIE_WAVELENGTHS)
    v = np.asarray(color.v_lambda(wl))
    peak = float(wl[int(np.argmax(v))])
    sources = []
    for name, spd, power in (
        ("1 W laser at 555 nm", color.line_spectrum(wl, 555.0, 1.0), None),
        ("1 W laser at 650 nm (red)", color.line_spectrum(wl, 650.0, 1.0), None),
        ("equal-energy spectrum, 360-830 nm", jnp.full(wl.shape, 1.0), None),
        (
            "blackbody 2856 K (CIE illuminant A), all wavelengths",
            color.planck(wl, 2856.0),
            color.planck_total_radiance(2856.0),
        ),
        (
            "blackbody 6500 K, all wavelengths",
            color.planck(wl, 6500.0),
            color.planck_total_radiance(6500.0),
        ),
    ):
        flux = float(color.luminous_flux(wl, spd))
        efficacy = float(color.luminous_efficacy(wl, spd, radiant_power=power))
        sources.append((name, f"{flux:.4g}", f"{efficacy:.4g}"))
    # A screen-like white: three narrow-ish primaries, 1 W/(sr m^2) in total.
    screen = sum(
        a * jnp.exp(-0.5 * ((wl - c) / 12.0) ** 2)
        for a, c in ((0.35, 610.0), (0.3, 545.0), (0.35, 455.0))
    )
    screen = screen / jnp.trapezoid(screen, wl)
    screen_luminance = float(color.luminance(wl, screen))
    steps = (
        Step(
            "Photometric quantity",
            "f_p = 683 lm/W · ∫ V(λ) f_r(λ) dλ (V = ȳ, the CIE 1924 "
            "photopic luminous efficiency function)",
        ),
        Step("Peak of V(λ)", f"{peak:g} nm, V = {v.max():.4g}"),
        Step(
            "Luminous flux and efficacy of example sources (1 W of radiant power each, "
            "spectrum normalised on the CIE grid)",
            Table(("source", "flux (lm per W)", "efficacy (lm/W)"), tuple(sources)),
        ),
        Step(
            "Luminance of a screen-like white spectrum of radiance 1 W/(sr·m²)",
            f"{screen_luminance:.4g} cd/m² (lm per sr per m²)",
        ),
    )
    return Answer(
        q,
        summary="Photometry weights a radiometric quantity by the eye's sensitivity V(λ) and the "
        "constant 683 lm/W: radiant flux becomes luminous flux (lm), radiance becomes "
        "luminance (cd/m²). Light at 555 nm gives the maximum 683 lm/W; an incandescent "
        "lamp gives about 16 lm/W because most of its power is infrared.",
        steps=steps,
        values={"peak_nm": peak, "sources": sources, "screen_luminance": screen_luminance},
        errata=(
            "The key integrates from 380 to 800 nm and says ȳ is zero outside; the CIE tables "
            "run from 360 to 830 nm and V is small but not zero there (V(800 nm) ≈ "
            f"{float(np.interp(800.0, np.asarray(wl), v)):.1e}), so the limits change the "
            "result slightly.",
        ),
        see_also="Lab 04 §photometry; gfxlab.color.luminous_flux, luminous_efficacy, luminance, "
        "planck, line_spectrum.",
        figure=lambda: _figure_v(np.asarray(wl), v),
    )


def _figure_v(wl, v):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot(wl, v)
    ax.axvline(555, color="k", ls=":")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("V(λ)")
    ax.set_title("CIE 1924 photopic luminous efficiency")
    return fig


def _q3e(q: Question) -> Answer:
    _x64()
    import jax
    import jax.numpy as jnp

    from gfxlab import color

    wl = jnp.asarray(color.CIE_WAVELENGTHS)
    key_a, key_b, key_c = jax.random.split(jax.random.PRNGKey(0), 3)
    a = jax.random.uniform(key_a, (1000, wl.shape[0]))
    c = jax.random.uniform(key_b, (1000, wl.shape[0]))
    alpha = jax.random.uniform(key_c, (1000, 1), minval=0.1, maxval=10.0)
    xyz = lambda s: color.spectrum_to_xyz(wl, s)  # noqa: E731
    additivity = float(jnp.max(jnp.abs(xyz(a + c) - xyz(a) - xyz(c)) / jnp.abs(xyz(a + c))))
    proportionality = float(
        jnp.max(jnp.abs(xyz(alpha * a) - alpha * xyz(a)) / jnp.abs(xyz(alpha * a)))
    )
    steps = (
        Step("Symmetry", "A ~ B implies B ~ A."),
        Step("Transitivity", "A ~ B and B ~ C imply A ~ C."),
        Step("Proportionality", "A ~ B implies αA ~ αB for α > 0."),
        Step("Additivity", "A ~ B and C ~ D imply A + C ~ B + D."),
        Step(
            "Why they hold: a match means equal tristimulus values, and XYZ = ∫ spectrum · CMF "
            "is linear. Checked on 1000 random spectra",
            f"max relative error, additivity {additivity:.1e}; "
            f"proportionality {proportionality:.1e}",
        ),
    )
    return Answer(
        q,
        summary="Colour matches obey the rules of linear algebra (Grassmann 1853): matching is an "
        "equivalence (symmetric, transitive) that survives scaling and adding. That is why "
        "three numbers (XYZ, or RGB) suffice to describe a colour.",
        steps=steps,
        values={"additivity": additivity, "proportionality": proportionality},
        errata=(
            "The additivity law is stated as 'if A matches B, C matches D, and A + C matches "
            "B + D, then A + D matches B + C': the middle premise is redundant (it follows "
            "from the first two), and the usual statement is simply 'A ~ B and C ~ D imply "
            "A + C ~ B + D'.",
        ),
        see_also="Lab 04 §Grassmann's laws; gfxlab.color.spectrum_to_xyz, "
        "gfxlab.color.make_metamer.",
    )


# --------------------------------------------------------------------------- section 4


def _q4c(q: Question, *, center=(1.0, 1.0), radii=(3.0, 2.0), angle=0.0) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import curves

    t = np.array([0, np.pi / 4, np.pi / 2, np.pi, 3 * np.pi / 2])
    pts = np.asarray(curves.ellipse(jnp.asarray(center), jnp.asarray(radii), angle, jnp.asarray(t)))
    names = ("0", "π/4", "π/2", "π", "3π/2")
    c, s = np.cos(angle), np.sin(angle)
    local = (pts - np.asarray(center)) @ np.array([[c, -s], [s, c]])  # undo the rotation
    steps = (
        Step(
            "Parametric form",
            "x = h + a cos t, y = k + b sin t, 0 <= t < 2π; rotating by θ "
            "adds the rotation matrix: (x, y) = (h, k) + R(θ) (a cos t, b sin t).",
        ),
        Step(
            f"Example: centre (h, k) = {tuple(center)}, a = {radii[0]:g}, b = {radii[1]:g}",
            Table(
                ("t", "x", "y"),
                tuple((n, f"{p[0]:.6g}", f"{p[1]:.6g}") for n, p in zip(names, pts, strict=True)),
            ),
        ),
        Step(
            "Check: every point satisfies ((x-h)/a)² + ((y-k)/b)² = 1",
            f"max deviation {np.max(np.abs(np.sum((local / radii) ** 2, 1) - 1)):.1e}",
        ),
    )
    return Answer(
        q,
        summary="An ellipse is traced by x = h + a cos t, y = k + b sin t; equal steps in t give "
        "points denser near the ends of the major axis. a = b gives a circle.",
        steps=steps,
        values={"points": pts},
        see_also="Lab 06 §parametric ellipse; gfxlab.curves.ellipse(center, radii, angle, t), "
        "gfxlab.curves.Ellipse (fitted to noisy points in the lab).",
    )


_SEED_BEZIER = np.array([[1.0, 1.0], [2.0, 3.0], [4.0, 3.0], [6.0, 4.0]])


def _q4f(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import curves

    u = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    weights = np.asarray(curves.bernstein(3, jnp.asarray(u)))
    points = np.asarray(curves.bezier(jnp.asarray(_SEED_BEZIER), jnp.asarray(u)))
    table = Table(
        ("u", "(1-u)³", "3u(1-u)²", "3u²(1-u)", "u³", "P(u)", "decimal"),
        tuple(
            (_number(ui), *(_number(w) for w in wi), _cell(p), f"({p[0]:g}, {p[1]:g})")
            for ui, wi, p in zip(u, weights, points, strict=True)
        ),
    )
    steps = (
        Step("Cubic Bezier", "P(u) = (1-u)³ A + 3u(1-u)² B + 3u²(1-u) C + u³ D"),
        Step("Control points", _SEED_BEZIER),
        Step("Bernstein weights and points", table),
    )
    return Answer(
        q,
        summary="P(0) = (1, 1), P(1/4) = (123/64, 139/64), P(1/2) = (25/8, 23/8), "
        "P(3/4) = (289/64, 217/64), P(1) = (6, 4).",
        steps=steps,
        values={"points": points, "weights": weights},
        errata=(
            "The question says 'order 3' for four control points; that curve has degree 3, "
            "i.e. order 4 in the B-spline sense (order = degree + 1).",
            "The key stops after writing the formula; the points are computed above.",
        ),
        see_also="Lab 06 §the seed's Bezier question; gfxlab.curves.bezier(control_points, u), "
        "gfxlab.curves.de_casteljau.",
        figure=lambda: _figure_bezier(points),
    )


def _figure_bezier(points):
    import jax.numpy as jnp
    import matplotlib.pyplot as plt

    from gfxlab import curves

    dense = np.asarray(curves.bezier(jnp.asarray(_SEED_BEZIER), jnp.linspace(0.0, 1.0, 200)))
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(*_SEED_BEZIER.T, "o--", color="gray", label="control polygon ABCD")
    ax.plot(*dense.T, "C0", label="P(u)")
    ax.plot(*points.T, "C3o", label="u = 0, 1/4, 1/2, 3/4, 1")
    ax.legend(fontsize=8)
    ax.set_aspect("equal")
    return fig


# --------------------------------------------------------------------------- section 5


_SEED_MEDIAN = np.array([[91, 55, 90], [77, 68, 95], [115, 151, 210]], float)


def _q5c(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import image

    full = float(np.asarray(image.median_filter(jnp.asarray(_SEED_MEDIAN), size=3))[1, 1])
    cross = float(
        np.asarray(
            image.median_filter(jnp.asarray(_SEED_MEDIAN), footprint=image.cross_footprint(1))
        )[1, 1]
    )
    even = np.array([55.0, 68.0, 77.0, 91.0])
    even_median = float(image.median(jnp.asarray(even)))
    x, y = np.array([1.0, 5.0, 2.0]), np.array([4.0, 0.0, 3.0])
    mx, my, mxy = (float(image.median(jnp.asarray(s))) for s in (x, y, x + y))
    steps = (
        Step(
            "3×3 window, sorted",
            f"{sorted(_SEED_MEDIAN.ravel().astype(int).tolist())} -> "
            f"median (5th of 9) = {_number(full)}",
        ),
        Step(
            "5-pixel cross (centre and its 4 neighbours), sorted",
            f"{sorted([55, 77, 68, 95, 151])} -> median (3rd of 5) = {_number(cross)}",
        ),
        Step(
            "Even window (2K values): mean of the K-th and (K+1)-th",
            f"{even.astype(int).tolist()} -> ({_number(even[1])} + {_number(even[2])})/2 = "
            f"{_number(even_median)}",
        ),
        Step(
            "Non-linear: median{x + y} != median{x} + median{y}",
            f"x = {x.astype(int).tolist()}, y = {y.astype(int).tolist()}: median(x + y) = "
            f"{_number(mxy)} but median(x) + median(y) = {_number(mx)} + {_number(my)} = "
            f"{_number(mx + my)}",
        ),
    )
    return Answer(
        q,
        summary="A median filter replaces each pixel by the median of its neighbourhood: it "
        "removes impulse (salt-and-pepper) noise while keeping edges, and it is "
        "non-linear. The seed's 3×3 block gives 91; the cross gives 77.",
        steps=steps,
        values={"full": full, "cross": cross, "even": even_median},
        errata=(
            "The even-window formula is printed with its denominator garbled "
            "('(K+1)th classified value' under the fraction bar): the output is "
            "(K-th value + (K+1)-th value) / 2.",
            "The key says 'sort the original image values on the 3×3 cross window' for the "
            "5-pixel cross: the cross has 5 values, not 9.",
        ),
        see_also="Lab 07 §median filtering; gfxlab.image.median_filter(image, size=3), "
        "footprint=gfxlab.image.cross_footprint(1).",
    )


# The seed's block after the level shift (pixel - 128).
_SEED_JPEG_BLOCK = np.array(
    [
        [-76, -73, -67, -62, -58, -67, -64, -55],
        [-65, -69, -73, -38, -19, -43, -59, -56],
        [-66, -69, -60, -15, 16, -24, -62, -55],
        [-65, -70, -57, -6, 26, -22, -58, -59],
        [-61, -67, -60, -24, -2, -40, -60, -58],
        [-49, -63, -68, -58, -51, -60, -70, -53],
        [-43, -57, -64, -69, -73, -67, -63, -45],
        [-41, -49, -59, -60, -63, -52, -50, -34],
    ],
    float,
)


def _q5f(q: Question) -> Answer:
    _x64()
    import jax.numpy as jnp

    from gfxlab import jpeg

    coefficients = np.asarray(jpeg.dct2(jnp.asarray(_SEED_JPEG_BLOCK)))
    table = np.asarray(jpeg.LUMINANCE_TABLE)
    quantized = np.asarray(jpeg.quantize(jnp.asarray(coefficients), jnp.asarray(table))).astype(int)
    sequence = np.asarray(jpeg.zigzag(jnp.asarray(quantized))).astype(int)
    last = int(np.max(np.nonzero(sequence)[0])) if np.any(sequence) else -1
    kept = sequence[: last + 1].tolist()
    steps = (
        Step("8×8 block after the level shift (pixel - 128)", _SEED_JPEG_BLOCK),
        Step(
            "DCT-II, G(u,v) = α(u)α(v) Σ g(x,y) cos[(2x+1)uπ/16] cos[(2y+1)vπ/16] (rounded to 2 "
            "decimals)",
            coefficients.round(2),
        ),
        Step("Luminance quantization table (ITU-T T.81 Annex K, all eight rows)", table),
        Step("Quantized B(j,k) = round(G(j,k) / Q(j,k))", quantized),
        Step(
            "Zig-zag sequence up to the last non-zero coefficient, then EOB",
            ", ".join(str(v) for v in kept) + ", EOB",
            note=f"{last + 1} of 64 coefficients kept; the remaining {63 - last} zeros are "
            "replaced by a single end-of-block code.",
        ),
    )
    return Answer(
        q,
        summary=f"The DC coefficient is {coefficients[0, 0]:.2f}, quantized to {quantized[0, 0]}; "
        f"the zig-zag scan is {', '.join(str(v) for v in kept[:10])}, ... ending with EOB "
        f"after {last + 1} coefficients.",
        steps=steps,
        values={"dct": coefficients, "quantized": quantized, "zigzag": np.asarray(kept)},
        errata=(
            "The luminance table is printed with only six of its eight rows. ITU-T T.81 Table K.1 "
            "continues with 49 64 78 87 103 121 120 101 and 72 92 95 98 112 100 103 99; the "
            "quantization above uses all 64 entries.",
            "The key never shows the DCT coefficients, the quantized matrix or the zig-zag "
            "sequence it describes ('We got this result after applying.'); they are computed "
            "above.",
            "The original 8×8 pixel values are not shown, only the block after subtracting 128.",
        ),
        see_also="Lab 07 §JPEG step by step; gfxlab.jpeg.dct2, gfxlab.jpeg.quant_tables, "
        "gfxlab.jpeg.quantize, gfxlab.jpeg.zigzag, gfxlab.jpeg.encode.",
        figure=lambda: _figure_jpeg(coefficients, quantized),
    )


def _figure_jpeg(coefficients, quantized):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.5))
    for ax, data, title in (
        (axes[0], _SEED_JPEG_BLOCK, "level-shifted block"),
        (axes[1], coefficients, "DCT coefficients"),
        (axes[2], quantized, "quantized"),
    ):
        im = ax.imshow(data, cmap="RdBu_r")
        ax.set_title(title)
        fig.colorbar(im, ax=ax, shrink=0.8)
    return fig


# --------------------------------------------------------------------------- descriptive


def _descriptive(summary: str, see_also: str, errata: tuple[str, ...] = ()):
    def solver(q: Question) -> Answer:
        return Answer(q, summary=summary, see_also=see_also, errata=errata)

    return solver


_DESCRIPTIVE = {
    "Q1a": (
        "Computer graphics is the computation of pictures: modelling shapes, light and motion as "
        "data, and turning that data into an image. On a CRT an electron gun sends a beam, "
        "focused and deflected, onto a phosphor screen that glows where it is hit; the glow fades, "
        "so the picture is redrawn (refreshed) many times a second. A raster-scan display sweeps "
        "the beam over every scan line, left to right and top to bottom (with horizontal and "
        "vertical retrace), lighting each pixel from a frame buffer; a random-scan (vector) "
        "display steers the beam along the line segments of a display list only.",
        "Lab 01 §displays; gfxlab.raster.raster_scan, gfxlab.raster.random_scan, "
        "gfxlab.raster.phosphor_frames.",
    ),
    "Q1c": (
        "An active (interactive) graphics device lets the user change the picture while it is "
        "shown — two-way communication through mouse, keyboard, tablet or touch, with the "
        "program redrawing in response. A passive device only presents pictures the computer "
        "produces (a plotter, a slide show, a film): one-way communication, no control by the "
        "viewer.",
        "Lab 01 §active and passive devices (an ipywidgets demo driven by the user versus a fixed "
        "playback of gfxlab.raster.raster_scan frames).",
    ),
    "Q1d": (
        "Aliasing is the error of sampling a continuous picture at too few points (below twice "
        "its highest frequency): detail above the pixel grid's Nyquist limit reappears as false "
        "low-frequency patterns. It shows as (1) jagged, stair-stepped edges on lines and "
        "polygons; (2) small or thin objects rendered wrongly — vanishing or flickering between "
        "frames when they fall between pixel centres; (3) fine textures disintegrating into "
        "moiré patterns; and in time, wheels that seem to spin backwards. Cures filter before "
        "sampling: supersampling, area coverage, pre-filtered textures (mipmaps), motion blur.",
        "Lab 01 §aliasing (errors measured against a 256× supersampled reference); "
        "gfxlab.raster.supersample, gfxlab.raster.polygon_coverage, gfxlab.raster.line_coverage.",
    ),
    "Q1e": (
        "A video file is a container that interleaves compressed streams (video, audio, "
        "subtitles) with timing and index data. AVI (Microsoft, 1992) is a RIFF container of "
        "chunks; FLV is Adobe Flash's tagged stream container; WMV is Microsoft's Windows Media "
        "Video codec, usually inside an ASF container; MOV is Apple QuickTime's container of "
        "nested atoms; MP4 (MPEG-4 Part 14) is the ISO base media file format derived from it, "
        "typically with H.264/AVC or H.265 video and AAC audio. The codec compresses; the "
        "container only packages.",
        "Lab 08 §video formats (a table built from files the lab writes, with their container "
        "structure); gfxlab.animation.save_animation, gfxlab.animation.container_info.",
    ),
    "Q2d": (
        "Affine maps (linear map plus translation; homogeneous last row 0 … 0 1) keep straight "
        "lines straight, parallel lines parallel and ratios of lengths along a line, but not "
        "angles or lengths in general; they compose into affine maps. Perspective (projective) "
        "maps have a non-trivial last row; after the divide by w, parallel lines converge to "
        "vanishing points and distant objects shrink. A projection is defined by a centre of "
        "projection and a view plane: a finite centre gives a perspective projection, a centre "
        "at infinity (a direction) a parallel projection.",
        "Lab 03 §6 (a grid under an affine and a projective map); "
        "gfxlab.transforms.apply (with the perspective divide), gfxlab.viewing.perspective.",
        (
            "'Affine geometry is identical to Euclidean geometry' is not right: affine geometry "
            "keeps parallelism and ratios along lines but not distances or angles, which Euclidean "
            "geometry keeps.",
            "'It forms a subset of bilinear transformations' should read 'of projective (linear "
            "fractional) transformations'.",
        ),
    ),
    "Q2e": (
        "A projection maps 3D points to a 2D view plane along projectors. In an orthographic "
        "projection the projectors are parallel to each other and perpendicular to the view "
        "plane, which is perpendicular to a principal axis: lengths and angles in planes parallel "
        "to it are kept, as engineering drawings need. The front, side and top views (elevations "
        "and plan) zero one coordinate: [T_z] = diag(1, 1, 0, 1) (front, onto z = 0), "
        "[T_y] = diag(1, 0, 1, 1) (top), [T_x] = diag(0, 1, 1, 1) (side).",
        "Lab 03 §7 (all six views of a block); gfxlab.viewing.plane_projection('z'), "
        "gfxlab.viewing.orthographic_view('front'), gfxlab.viewing.orthographic.",
    ),
    "Q3a": (
        "Viewing places a camera in the scene and maps what it sees to the screen: world → eye "
        "coordinates (the view transform), eye → clip coordinates (the projection), a divide by "
        "w to normalised device coordinates, and the viewport map to pixels. The view volume (a "
        "box for orthographic, a frustum for perspective viewing) is mapped onto the canonical "
        "view volume, the cube [-1, 1]³: clipping becomes comparisons with ±1, independent of "
        "the camera.",
        "Lab 03 §8; gfxlab.viewing.perspective, gfxlab.viewing.orthographic, "
        "gfxlab.viewing.in_view_volume, gfxlab.viewing.ndc_to_pixels.",
    ),
    "Q3b": (
        "The pinhole camera model: a camera position C, a point A it looks at (the view axis "
        "A − C), an up direction and a field of view α. Rays through C and the image window form "
        "a pyramid with apex C (the viewing pyramid); near and far planes cut it into a frustum, "
        "and the viewing transform maps that frustum onto −1 <= x, y, z <= 1.",
        "Lab 03 §8 (the pyramid drawn in 3D) and §10 (a camera pose fitted to projected points); "
        "gfxlab.viewing.Camera, gfxlab.viewing.look_at, gfxlab.viewing.frustum.",
    ),
    "Q3c": (
        "A BRDF f_r(ω_i, ω_o) gives reflected radiance per unit incident irradiance. Domain: "
        "pairs of directions in the hemisphere above the surface (4 angles; 3 for isotropic "
        "surfaces), zero below it. Range: non-negative values in 1/sr, unbounded (a mirror is a "
        "delta). Reciprocity (Helmholtz): f_r(ω_i, ω_o) = f_r(ω_o, ω_i). Energy conservation: "
        "the directional albedo ∫ f_r cos θ_i dω_i is at most 1 for every outgoing direction.",
        "Lab 04 §BRDF properties (original Phong is not reciprocal; GGX loses energy at high "
        "roughness); gfxlab.brdf.reciprocity_error, gfxlab.brdf.directional_albedo, "
        "gfxlab.brdf.cook_torrance.",
    ),
    "Q3f": (
        "Colorimetry measures colour by what a standard observer matches. Three cone types make "
        "colour vision three-dimensional, so any stimulus can be matched by a mix of three "
        "primaries; the CIE 1931 colour-matching functions x̄, ȳ, z̄ turn a spectrum into "
        "tristimulus values X, Y, Z (Y is luminance), and chromaticity (x, y) = (X, Y)/(X+Y+Z) "
        "separates colour from brightness. Different spectra with equal XYZ (metamers) look the "
        "same.",
        "Lab 04 §colorimetry (chromaticity diagram with the sRGB gamut, metamers); "
        "gfxlab.color.spectrum_to_xyz, gfxlab.color.xyz_to_xy, gfxlab.color.xyz_to_srgb.",
    ),
    "Q4a": (
        "The z-buffer (Catmull 1974) keeps, beside the frame buffer, a depth per pixel. Clear "
        "depth to 'farthest' and colour to the background; rasterise each polygon in any order; "
        "at each covered pixel compute the polygon's depth and, if it is nearer than the stored "
        "depth, store the new depth and colour. Advantages: simple, any order, any primitive "
        "that can be scan-converted, hardware-friendly. Disadvantages: memory for the depth "
        "buffer, work on hidden pixels (overdraw), depth precision (z-fighting), no "
        "transparency without sorting.",
        "Lab 05 §z-buffer step by step; gfxlab.render.zbuffer (returns the image, the depth "
        "buffer and counters).",
        (
            "The key names the inventor 'Cutmull'; it is Catmull.",
            "It says the closest surface has the smallest z, then initialises the depth buffer "
            "to 0 "
            "and keeps z > depthbuffer(x, y) with 1 = front plane: the test is right only with "
            "its second convention (larger = nearer).",
        ),
    ),
    "Q4b": (
        "Warnock's algorithm subdivides the screen: for an area, each polygon is surrounding "
        "(it contains the area), intersecting, contained (inside the area) or disjoint. The area "
        "is drawn directly when (1) all polygons are disjoint (background); (2) exactly one "
        "polygon is intersecting or contained (background, then that polygon); (3) exactly one "
        "surrounding polygon and nothing else (fill with it); (4) a surrounding polygon is in "
        "front of all others at the area's corners (fill with it). Otherwise split the area into "
        "four and recurse, down to pixel size, where the nearest polygon wins.",
        "Lab 05 §Warnock (quadtree drawn over the image); gfxlab.render.warnock.",
        (
            "'Surrounding polygons are completely inside the area of interest' is wrong: a "
            "surrounding polygon completely contains the area (the key's own 'contained' case is "
            "the one inside the area).",
        ),
    ),
    "Q4d": (
        "A B-spline curve P(u) = Σ p_k B_{k,d}(u) blends n+1 control points with piecewise "
        "polynomial basis functions of degree d−1 (order d), defined by the Cox–de Boor "
        "recursion on a knot vector. Unlike a Bezier curve its degree does not grow with the "
        "number of control points, and each basis function is non-zero on only d knot spans, so "
        "moving a control point changes the curve locally. The bases sum to one (partition of "
        "unity), so the curve lies in the convex hull of its control points; clamped knots make "
        "it start and end at the first and last control points.",
        "Lab 06 §B-splines (bases for uniform and clamped knots, local control, a B-spline "
        "fitted to noisy data); gfxlab.curves.bspline_basis, gfxlab.curves.bspline, "
        "gfxlab.curves.clamped_knots.",
    ),
    "Q4e": (
        "Z-buffer: image space, memory for two buffers, time grows with depth complexity "
        "(overdraw), any order, simple, the hardware standard. Painter's (depth sort): object "
        "space sort then draw back to front, one buffer, fails on cyclic overlaps unless "
        "polygons are split. Ray casting: per pixel find the nearest hit, cost ~ pixels × "
        "objects without acceleration structures, good for CSG, shadows and transparency. "
        "Scanline: processes one scan line at a time with active edge lists, exploits coherence, "
        "little memory, complex. Area subdivision (Warnock): recursive quadtree, exploits area "
        "coherence, good for large uniform areas, hard to generalise beyond polygons.",
        "Lab 05 §comparison (the table regenerated from measurements — memory, time, tests — on "
        "scenes of growing size); gfxlab.render.zbuffer, painter, warnock, scanline.",
    ),
    "Q5a": (
        "An image is a two-dimensional signal: a raster image (bitmap) stores samples on a grid "
        "(pixels with one or more channels); a vector image stores geometry (lines, curves, "
        "fills) and is rasterised when shown. Formats: JPEG (lossy DCT compression, 8-bit "
        "photographs, no transparency), PNG (lossless deflate, up to 16-bit, alpha), GIF "
        "(lossless LZW, 256-colour palette, one transparent index, animation), BMP (usually "
        "uncompressed, simple), TIFF (flexible tagged container: many compressions, bit depths, "
        "pages).",
        "Lab 07 §formats (a table built from files the lab writes, and an SVG next to its "
        "rasterisation); gfxlab.image.image_info, gfxlab.image.write_image, "
        "gfxlab.image.write_svg.",
    ),
    "Q5b": (
        "Computer animation is any change of a picture over time — position, shape, colour, "
        "camera, light — shown as a sequence of frames fast enough to look continuous. "
        "Character animation gives a character believable motion and personality: a rigged "
        "skeleton drives a skinned surface, posed by key frames or motion capture and refined "
        "by the animator, following principles such as timing, anticipation and "
        "squash-and-stretch.",
        "Lab 08 §character (a 2D character with bones and a skinned outline walking from key "
        "frames, saved as video); gfxlab.animation.Skeleton, gfxlab.animation.skin.",
    ),
    "Q5d": (
        "Key-frame animation: the animator sets values at chosen times (key frames) and the "
        "computer interpolates the in-betweens (linear, spline, easing curves); full control, "
        "labour grows with the amount of motion. Procedural animation: a program (physics, "
        "rules, noise) generates the motion from initial conditions and parameters; lots of "
        "detailed motion for little work, but harder to direct.",
        "Lab 08 §key frames versus procedural (the same bouncing ball both ways); "
        "gfxlab.animation.interpolate, gfxlab.animation particle and spring simulations.",
    ),
    "Q5e": (
        "Deformers change a shape's vertices. A bone (skeleton) deformer moves each vertex with "
        "the bones that influence it: linear blend skinning v' = Σ w_i M_i v with weights "
        "summing to one (the 'candy-wrapper' collapse at large twists is its known artefact). A "
        "curve deformer bends a shape along a path: each vertex keeps its offset from the path, "
        "measured in the path's moving frame (tangent and normal).",
        "Lab 08 §deformation (skinning weights, the candy-wrapper artefact, a curve deformer); "
        "gfxlab.animation.skin, the curve deformer in gfxlab.animation.",
        (
            "The key pairs 'Curve Deformer' with 'Skinning deformation'. Skinning is the bone "
            "(skeleton) deformer's technique; a curve deformer bends a mesh along a curve.",
        ),
    ),
}


# --------------------------------------------------------------------------- registry


def _question_texts() -> list[tuple[str, str, str, bool, Callable]]:
    numeric = {
        "Q1b": (
            "Midpoint circle algorithm",
            "Explain the method of circle drawing using the Midpoint Circle Algorithm.",
            _q1b,
        ),
        "Q1f": (
            "Cohen-Sutherland acceptance and rejection tests",
            "Explain the acceptance and rejection test using bit codes in the Cohen-Sutherland "
            "line clipping algorithm.",
            _q1f,
        ),
        "Q2a": (
            "Window to viewport",
            "Perform mapping from window to viewport coordinate transformation.",
            _q2a,
        ),
        "Q2b": (
            "Translate, then rotate the unit square",
            "Using homogeneous coordinate "
            "transformation matrices, apply translation by (1, 1) and then rotation by 90° to "
            "a unit square centred at the origin.",
            _q2b,
        ),
        "Q2c": (
            "Scaling about a fixed point",
            "Obtain the general combined matrix for scaling about a fixed point P(xf, yf).",
            _q2c,
        ),
        "Q2f": (
            "Shear of the unit cube",
            "Shear a unit cube situated at the origin with the given shear transformation matrix.",
            _q2f,
        ),
        "Q3d": ("Photometry", "Write a note on photometry.", _q3d),
        "Q3e": ("Grassmann's laws", "Explain Grassmann's laws.", _q3e),
        "Q4c": (
            "Parametric ellipse",
            "Explain the parametric representation of an ellipse with an example.",
            _q4c,
        ),
        "Q4f": (
            "Bezier curve through A, B, C, D",
            "Construct the Bezier curve of order 3 with "
            "polygon vertices A(1,1) B(2,3) C(4,3) D(6,4) at u = 0, 1/4, 1/2, 3/4, 1.",
            _q4f,
        ),
        "Q5c": (
            "Median filtering",
            "Explain the concept of median filtering with an example.",
            _q5c,
        ),
        "Q5f": ("JPEG compression", "Explain the JPEG compression process in detail.", _q5f),
    }
    descriptive_text = {
        "Q1a": (
            "Computer graphics and video display devices",
            "What is computer graphics? How is an image displayed on a video display device?",
        ),
        "Q1c": (
            "Active and passive graphics devices",
            "Distinguish between active and passive graphics devices.",
        ),
        "Q1d": ("Aliasing", "Explain the problems of aliasing with examples."),
        "Q1e": ("Video formats", "Explain different types of video formats."),
        "Q2d": (
            "Affine and perspective geometry",
            "Write a note on affine and perspective geometry.",
        ),
        "Q2e": (
            "Orthographic projection",
            "Explain projection with the help of orthographic projection.",
        ),
        "Q3a": (
            "Viewing and the canonical view volume",
            "What is viewing? Explain the canonical view volume.",
        ),
        "Q3b": (
            "Camera model and viewing pyramid",
            "Explain the camera model and the viewing pyramid with a diagram.",
        ),
        "Q3c": ("Properties of the BRDF", "Explain different properties of the BRDF."),
        "Q3f": ("Colorimetry", "Explain colour with the help of colorimetry."),
        "Q4a": ("Z-buffer", "Explain the z-buffer algorithm with advantages and disadvantages."),
        "Q4b": ("Warnock's algorithm", "What are the basic tests in Warnock's algorithm?"),
        "Q4d": ("B-spline curves", "Write a note on B-spline curves."),
        "Q4e": (
            "Visible-surface methods compared",
            "Compare all visible surface detection methods.",
        ),
        "Q5a": (
            "Images and file formats",
            "What is an image? Explain different file formats of an image.",
        ),
        "Q5b": ("Animation and character animation", "Explain animation with character animation."),
        "Q5d": (
            "Key-frame and procedural animation",
            "Distinguish key-frame animation from procedural animation.",
        ),
        "Q5e": ("Deformation", "Explain different types of deformation."),
    }
    out = []
    for section in "12345":
        for letter in "abcdef":
            qid = f"Q{section}{letter}"
            if qid in numeric:
                title, text, solver = numeric[qid]
                out.append((qid, title, text, True, solver))
            else:
                title, text = descriptive_text[qid]
                out.append((qid, title, text, False, _descriptive(*_DESCRIPTIVE[qid])))
    return out


#: Every question of the seed, by id, in exam order. Each is worth 5 marks.
QUESTIONS: dict[str, Question] = {
    qid: Question(qid, 5, title, text, numeric, solver)
    for qid, title, text, numeric, solver in _question_texts()
}


def question(qid: str) -> Question:
    """A question by id, case-insensitively (`"q4f"` -> Q4f)."""
    key = qid.strip()
    key = key[0].upper() + key[1:].lower() if key else key
    if key not in QUESTIONS:
        raise KeyError(f"no question {qid!r}; the ids are {', '.join(QUESTIONS)}")
    return QUESTIONS[key]


def solve(qid: str, **options) -> Answer:
    """Solve a question by id (options are question-specific, e.g. `radius=12` for Q1b)."""
    return question(qid).solve(**options)


def errata() -> list[tuple[str, str]]:
    """Every mistake found in the answer key, as `(question id, description)` pairs."""
    return [(qid, e) for qid, q in QUESTIONS.items() for e in q.solve().errata]


# --------------------------------------------------------------------------- CLI


def _parse_value(text: str):
    import ast

    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def main(command: str = "exam", argv: list[str] | None = None) -> int:
    """`python -m gfxlab exam [ID] [--markdown [FILE]] [--set NAME=VALUE ...]`."""
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab exam",
        description="The seed exam solved with gfxlab: list the questions or show one answer.",
    )
    parser.add_argument("id", nargs="?", help="question id, e.g. Q2b; 'all' for every answer")
    parser.add_argument(
        "--markdown",
        nargs="?",
        const="-",
        metavar="FILE",
        help="write Markdown with LaTeX (to FILE, or stdout)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a question option, e.g. --set radius=12 for Q1b",
    )
    args = parser.parse_args(argv if argv is not None else sys.argv[1:])
    if args.id is None:
        for q in QUESTIONS.values():
            kind = "numeric" if q.numeric else "descriptive"
            print(f"{q.id}  {q.marks} marks  {kind:<11}  {q.title}")
        return 0
    options = {}
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep:
            parser.error(f"--set expects NAME=VALUE, got {item!r}")
        options[name] = _parse_value(value)
    try:
        ids = list(QUESTIONS) if args.id.lower() == "all" else [question(args.id).id]
    except KeyError as err:
        print(err.args[0], file=sys.stderr)
        return 2
    try:
        answers = [solve(qid, **options) for qid in ids]
    except TypeError as err:
        print(f"bad option for {args.id}: {err}", file=sys.stderr)
        return 2
    if args.markdown:
        text = "\n".join(a.to_markdown() for a in answers)
        if args.markdown == "-":
            print(text)
        else:
            with open(args.markdown, "w", encoding="utf-8") as handle:
                handle.write(text)
            print(f"wrote {args.markdown}")
    else:
        print("\n".join(a.to_text() for a in answers))
    return 0
