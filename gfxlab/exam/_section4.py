"""Section 4 of the course exam: hidden surfaces and curves."""

from __future__ import annotations

import numpy as np

from ._format import cell, number
from ._model import Answer, Question, Step, Table


def _q4c(q: Question, *, center=(1.0, 1.0), radii=(3.0, 2.0), angle=0.0) -> Answer:
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
    import jax.numpy as jnp

    from gfxlab import curves

    u = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    weights = np.asarray(curves.bernstein(3, jnp.asarray(u)))
    points = np.asarray(curves.bezier(jnp.asarray(_SEED_BEZIER), jnp.asarray(u)))
    table = Table(
        ("u", "(1-u)³", "3u(1-u)²", "3u²(1-u)", "u³", "P(u)", "decimal"),
        tuple(
            (number(ui), *(number(w) for w in wi), cell(p), f"({p[0]:g}, {p[1]:g})")
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
        see_also="Lab 06 §the exam's Bezier question; gfxlab.curves.bezier(control_points, u), "
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


#: Numeric questions: id -> (title, question text, solver).
NUMERIC = {
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
}

#: Descriptive questions: id -> (title, question text).
DESCRIPTIVE = {
    "Q4a": ("Z-buffer", "Explain the z-buffer algorithm with advantages and disadvantages."),
    "Q4b": ("Warnock's algorithm", "What are the basic tests in Warnock's algorithm?"),
    "Q4d": ("B-spline curves", "Write a note on B-spline curves."),
    "Q4e": (
        "Visible-surface methods compared",
        "Compare all visible surface detection methods.",
    ),
}

#: Descriptive answers: id -> (summary, see also[, errata]).
ANSWERS = {
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
}
