"""Section 2 of the course exam: 2D and 3D transforms, projections."""

from __future__ import annotations

import numpy as np

from ._format import number, plot_polygon
from ._model import Answer, Question, Step, Table


def _q2a(q: Question, *, window=(1.0, 1.0, 5.0, 4.0), viewport=(0.0, 0.0, 320.0, 120.0)) -> Answer:
    import jax.numpy as jnp

    from gfxlab import transforms as tf

    w, v = np.asarray(window, float), np.asarray(viewport, float)
    m = np.asarray(tf.window_to_viewport(jnp.asarray(w), jnp.asarray(v)))
    sx, sy = (v[2] - v[0]) / (w[2] - w[0]), (v[3] - v[1]) / (w[3] - w[1])
    corners = np.asarray(tf.apply(jnp.asarray(m), jnp.array([[w[0], w[1]], [w[2], w[3]]])))
    steps = (
        Step("Translate the window corner to the origin", "T(-xw_min, -yw_min)"),
        Step(
            "Scale to the viewport size",
            "S(sx, sy), sx = (xv_max - xv_min)/(xw_max - xw_min), "
            "sy = (yv_max - yv_min)/(yw_max - yw_min)",
        ),
        Step("Translate to the viewport corner", "T(xv_min, yv_min)"),
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
            note=f"sx = {number(sx)}, sy = {number(sy)}",
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
    plot_polygon(ax, _UNIT_SQUARE, alpha=0.3, color="gray")
    plot_polygon(ax, _UNIT_SQUARE + 1, alpha=0.3, color="C0")
    plot_polygon(ax, moved, alpha=0.6, color="C1")
    for n, p in zip("ABCD", moved, strict=True):
        ax.annotate(n + "'", p, textcoords="offset points", xytext=(4, 4))
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_title("unit square -> translate (1, 1) -> rotate 90°")
    return fig


def _q2c(q: Question, *, factors=(2.0, 3.0), center=(4.0, -1.0)) -> Answer:
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
            note=f"max |difference| = {number(np.max(np.abs(composed - closed)))}",
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
            f"determinant {number(np.linalg.det(_SEED_SHEAR[:3, :3]))}, so volumes shrink by 5 %.",
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


#: Numeric questions: id -> (title, question text, solver).
NUMERIC = {
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
}

#: Descriptive questions: id -> (title, question text).
DESCRIPTIVE = {
    "Q2d": (
        "Affine and perspective geometry",
        "Write a note on affine and perspective geometry.",
    ),
    "Q2e": (
        "Orthographic projection",
        "Explain projection with the help of orthographic projection.",
    ),
}

#: Descriptive answers: id -> (summary, see also[, errata]).
ANSWERS = {
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
}
