"""Plain-text and Markdown/LaTeX rendering of the values in a worked answer."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from ._model import Table


def indent(text: str, prefix: str = "    ") -> str:
    return "\n".join(prefix + line if line else line for line in text.splitlines())


def number(x, *, fractions: bool = True) -> str:
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


def all_dyadic(arr: np.ndarray) -> bool:
    """Whether every entry prints as an integer or a short dyadic fraction."""
    return all("." not in number(v) and "e" not in number(v) for v in arr.ravel())


def plain(value) -> str:
    if isinstance(value, Table):
        cells = [list(value.columns)] + [[cell(v) for v in row] for row in value.rows]
        widths = [max(len(r[i]) for r in cells) for i in range(len(value.columns))]
        out = ["  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
        out.insert(1, "  ".join("-" * w for w in widths))
        return "\n".join(out)
    if isinstance(value, str):
        return value
    arr = np.asarray(value)
    if arr.ndim == 0:
        return number(arr)
    if arr.ndim == 1:
        return "(" + ", ".join(number(v) for v in arr) + ")"
    exact = all_dyadic(arr)
    cells = [[number(v, fractions=exact) for v in row] for row in arr.reshape(arr.shape[0], -1)]
    width = max(len(c) for row in cells for c in row)
    return "\n".join("[ " + "  ".join(c.rjust(width) for c in row) + " ]" for row in cells)


def cell(v) -> str:
    if isinstance(v, str):
        return v
    arr = np.asarray(v)
    if arr.ndim == 0:
        return number(arr)
    return "(" + ", ".join(number(x) for x in arr.ravel()) + ")"


def latex_number(x, *, fractions: bool = True) -> str:
    text = number(x, fractions=fractions)
    if "/" in text:
        num, den = text.split("/")
        sign = "-" if num.startswith("-") else ""
        return f"{sign}\\tfrac{{{num.lstrip('-')}}}{{{den}}}"
    return text


def markdown(value) -> str:
    if isinstance(value, Table):
        head = "| " + " | ".join(value.columns) + " |"
        rule = "| " + " | ".join("---" for _ in value.columns) + " |"
        body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in value.rows]
        return "\n".join([head, rule, *body])
    if isinstance(value, str):
        if "\n" in value and value.lstrip().startswith("["):
            return "```\n" + value + "\n```"
        return value
    arr = np.asarray(value)
    if arr.ndim == 0:
        return f"${latex_number(arr)}$"
    if arr.ndim == 1:
        return "$(" + ", ".join(latex_number(v) for v in arr) + ")$"
    exact = all_dyadic(arr)
    rows = [
        " & ".join(latex_number(v, fractions=exact) for v in row)
        for row in arr.reshape(arr.shape[0], -1)
    ]
    return "$$\\begin{pmatrix}" + " \\\\ ".join(rows) + "\\end{pmatrix}$$"


def plot_polygon(ax, points, **kw):
    """Fill a closed polygon on a matplotlib axis."""
    p = np.asarray(points)
    ax.fill(*np.r_[p, p[:1]].T, **kw)
