"""Clipping lines and polygons against a rectangular window.

Windows are `(xmin, ymin, xmax, ymax)`; points on the window's edges are inside.

**Outcodes.** Each endpoint gets a 4-bit region code read in the order LRBT (left,
right, bottom, top), as in the exam's table:

```
1001 | 0001 | 0101          left   = 0b1000   (x < xmin)
-----+------+-----          right  = 0b0100   (x > xmax)
1000 | 0000 | 0100          bottom = 0b0010   (y < ymin)
-----+------+-----          top    = 0b0001   (y > ymax)
1010 | 0010 | 0110
```

**Cohen-Sutherland.** If `code0 | code1 == 0` both ends are inside: trivially accept.
If `code0 & code1 != 0` both ends are outside the same edge: trivially reject.
Otherwise pick an outside endpoint (`p0` if its code is not zero, else `p1`) and move
it to the window edge of its first set bit, testing the edges in the order
**top, bottom, right, left** (`EDGE_ORDER`, the low bit first), then repeat. This is
the order of the textbook walkthrough the exam follows: `AD` is clipped at the top
edge first although `D` (code 1001) is also left of the window.

The exam prints the codes of the `EI` walkthrough in its source's bit order
(top, bottom, right, left): there `E = 0100` means "below" and `I = 1010` "above and
right". Read in the LRBT order used everywhere else (and here) the same points have
`E = 0010`, `I = 0101`, `H = 0100`; the edges used, bottom then top then right, are the
same. `WALKTHROUGH_EXAMPLE` gives concrete coordinates for the walkthrough and
`cohen_sutherland_trace` reproduces it step by step.

Three line clippers and one polygon clipper:

- `cohen_sutherland` (vectorized over any number of segments: a fixed number of
  masked iterations) and `cohen_sutherland_steps` (the textbook loop,
  `lax.while_loop` per segment) agree exactly; `cohen_sutherland_trace` records each
  iteration of one segment for teaching.
- `liang_barsky`: the parametric clipper.
- `sutherland_hodgman`: polygon clipping, one window edge at a time, with a fixed
  maximum output size and a validity mask.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab.clipping import cohen_sutherland
    >>> segment = jnp.array([[-1.0, 0.5], [3.0, 0.5]])
    >>> clipped, accepted = cohen_sutherland(segment, jnp.array([0.0, 0.0, 2.0, 1.0]))
    >>> clipped.tolist(), bool(accepted)
    ([[0.0, 0.5], [2.0, 0.5]], True)
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int

from ._checks import (
    check_rect,
    check_shape,
    common_finite,
    common_float,
    finite_float,
    static_int,
    value_error_if,
)

#: The largest output buffer `sutherland_hodgman` accepts (`max_vertices`).
MAX_VERTICES = 1_000_000


__all__ = [
    "LEFT",
    "RIGHT",
    "BOTTOM",
    "TOP",
    "EDGE_ORDER",
    "WALKTHROUGH_EXAMPLE",
    "outcode",
    "cohen_sutherland",
    "cohen_sutherland_steps",
    "cohen_sutherland_trace",
    "liang_barsky",
    "sutherland_hodgman",
    "polygon_area",
    "MAX_VERTICES",
]

LEFT = 0b1000
RIGHT = 0b0100
BOTTOM = 0b0010
TOP = 0b0001

#: The order in which Cohen-Sutherland tests the edges of an outside endpoint.
EDGE_ORDER = ("top", "bottom", "right", "left")
_EDGE_BITS = {"top": TOP, "bottom": BOTTOM, "right": RIGHT, "left": LEFT}

#: Concrete coordinates for the exam's Q1f walkthrough (window `(xmin, ymin, xmax, ymax)`).
#: `AD` (A inside, D = 1001) is clipped at the top edge in B and accepted as `AB`; `C` is
#: where `AD` crosses the left edge's line, which the top-first order never computes.
#: `EI` (E = 0010 below, I = 0101 above-right) is clipped at the bottom edge in F, then
#: at the top edge in H (= 0100, right), then at the right edge in G, and `FG` is
#: accepted.
WALKTHROUGH_EXAMPLE = {
    "window": (2.0, 2.0, 10.0, 8.0),
    "A": (6.0, 5.0),
    "B": (3.0, 8.0),
    "C": (2.0, 9.0),
    "D": (0.0, 11.0),
    "E": (7.0, 0.0),
    "F": (8.0, 2.0),
    "G": (10.0, 6.0),
    "H": (11.0, 8.0),
    "I": (13.0, 12.0),
}


def _window(window) -> jax.Array:
    return check_rect(window, "window")


def _check_segments(segments) -> jax.Array:
    """Finite `(..., 2, 2)` segments (callers check the window with `_window`)."""
    segments = finite_float(segments, "segments")
    check_shape(segments, "segments", (..., 2, 2))
    return segments


def _codes(x, y, w) -> jax.Array:
    code = jnp.where(x < w[0], LEFT, 0)
    code = code | jnp.where(x > w[2], RIGHT, 0)
    code = code | jnp.where(y < w[1], BOTTOM, 0)
    return code | jnp.where(y > w[3], TOP, 0)


def outcode(points: Float[Array, "*batch 2"], window: Float[Array, "4"]) -> Int[Array, "*batch"]:
    """Cohen-Sutherland region codes (LRBT: left 8, right 4, bottom 2, top 1).

    **Arguments:**

    - `points`: `(..., 2)` points `(x, y)`.
    - `window`: `(xmin, ymin, xmax, ymax)` with `xmax > xmin`, `ymax > ymin`.

    **Returns:** int32 codes `(...)`; 0 inside or on the window's boundary.
    """
    points, window = common_finite(points, window, names=("points", "window"))
    check_shape(points, "points", (..., 2))
    window = _window(window)
    return _codes(points[..., 0], points[..., 1], window).astype(jnp.int32)


def _first_edge_bit(code):
    """The bit of the first edge in `EDGE_ORDER` set in `code` (top, bottom, right, left)."""
    return jnp.where(
        code & TOP, TOP, jnp.where(code & BOTTOM, BOTTOM, jnp.where(code & RIGHT, RIGHT, LEFT))
    )


def _edge_intersection(p0, p1, bit, w):
    """Where the line through `p0`, `p1` meets the window edge named by `bit`.

    The divisions are safe: a bit is only ever used when the two ends are on different
    sides of that edge, so the denominator is not zero; inactive lanes get a dummy 1.
    """
    x0, y0, x1, y1 = p0[..., 0], p0[..., 1], p1[..., 0], p1[..., 1]
    horizontal_edge = (bit == TOP) | (bit == BOTTOM)
    y_edge = jnp.where(bit == TOP, w[3], w[1])
    x_edge = jnp.where(bit == RIGHT, w[2], w[0])
    dy = jnp.where(horizontal_edge & (y1 != y0), y1 - y0, 1.0)
    dx = jnp.where(~horizontal_edge & (x1 != x0), x1 - x0, 1.0)
    x_on_h = x0 + (x1 - x0) * (y_edge - y0) / dy
    y_on_v = y0 + (y1 - y0) * (x_edge - x0) / dx
    x = jnp.where(horizontal_edge, x_on_h, x_edge)
    y = jnp.where(horizontal_edge, y_edge, y_on_v)
    return jnp.stack([x, y], -1)


def _cs_iteration(p0, p1, w, active):
    """One iteration of Cohen-Sutherland on every lane where `active` holds.

    Returns the new endpoints and `(accepted, rejected)` for lanes decided now.
    """
    c0 = _codes(p0[..., 0], p0[..., 1], w)
    c1 = _codes(p1[..., 0], p1[..., 1], w)
    accept = active & ((c0 | c1) == 0)
    reject = active & ((c0 & c1) != 0)
    clip = active & ~accept & ~reject
    use_p0 = c0 != 0
    outside = jnp.where(use_p0, c0, c1)
    bit = _first_edge_bit(outside)
    new = _edge_intersection(p0, p1, bit, w)
    p0 = jnp.where((clip & use_p0)[..., None], new, p0)
    p1 = jnp.where((clip & ~use_p0)[..., None], new, p1)
    return p0, p1, accept, reject


# Each endpoint is moved at most twice (once onto a horizontal edge, once onto a
# vertical one) before the segment is accepted or rejected, so four clipping
# iterations and one final test decide every segment.
_CS_MAX_CLIPS = 4


def _finish(segments, p0, p1, visible):
    clipped = jnp.stack([p0, p1], axis=-2)
    return jnp.where(visible[..., None, None], clipped, jnp.nan).astype(segments.dtype), visible


def cohen_sutherland(
    segments: Float[Array, "*batch 2 2"], window: Float[Array, "4"]
) -> tuple[Float[Array, "*batch 2 2"], Bool[Array, "*batch"]]:
    """Cohen-Sutherland line clipping of many segments at once (vectorized).

    Every segment goes through the same fixed number of iterations of the textbook
    loop (see the module docstring), masked once it has been accepted or rejected;
    the result equals `cohen_sutherland_steps` exactly.

    **Arguments:**

    - `segments`: `(..., 2, 2)` segments `((x0, y0), (x1, y1))`.
    - `window`: `(xmin, ymin, xmax, ymax)` with `xmax > xmin`, `ymax > ymin`.

    **Returns:** `(clipped, visible)`: `clipped` `(..., 2, 2)` the visible part, with
    the endpoints in the input's order (NaN where nothing is visible), and `visible`
    `(...)` boolean: `False` for a rejected segment. A trivially accepted segment comes
    back unchanged. Differentiable in the segments and the window.
    """
    segments, window = common_float(segments, window, names=("segments", "window"))
    segments = _check_segments(segments)
    return _cohen_sutherland(segments, _window(window))


@jax.jit
def _cohen_sutherland(segments, w):
    def iteration(_, state):  # one round over all segments
        p0, p1, active, accepted = state
        p0, p1, accept, reject = _cs_iteration(p0, p1, w, active)
        return p0, p1, active & ~accept & ~reject, accepted | accept

    active = jnp.ones(segments.shape[:-2], bool)
    state = (segments[..., 0, :], segments[..., 1, :], active, jnp.zeros_like(active))
    p0, p1, _, accepted = jax.lax.fori_loop(0, _CS_MAX_CLIPS + 1, iteration, state)
    return _finish(segments, p0, p1, accepted)


def cohen_sutherland_steps(
    segments: Float[Array, "*batch 2 2"], window: Float[Array, "4"]
) -> tuple[Float[Array, "*batch 2 2"], Bool[Array, "*batch"]]:
    """Textbook Cohen-Sutherland: a `lax.while_loop` per segment (vmapped over segments).

    Loop: compute both outcodes; accept if their OR is 0, reject if their AND is not
    0; otherwise move the outside endpoint to the first edge (top, bottom, right,
    left) its code names, and repeat. Same arguments and results as `cohen_sutherland`.
    """
    segments, window = common_float(segments, window, names=("segments", "window"))
    segments = _check_segments(segments)
    return _cohen_sutherland_steps(segments, _window(window))


@jax.jit
def _cohen_sutherland_steps(segments, w):
    def one(segment):
        def cond(state):
            return state[2] == 0  # 0 undecided, 1 accepted, 2 rejected

        def body(state):
            p0, p1, _ = state
            active = jnp.asarray(True)
            p0, p1, accept, reject = _cs_iteration(p0, p1, w, active)
            return p0, p1, jnp.where(accept, 1, jnp.where(reject, 2, 0))

        p0, p1, decision = jax.lax.while_loop(cond, body, (segment[0], segment[1], 0))
        return p0, p1, decision == 1

    flat = segments.reshape(-1, 2, 2)
    p0, p1, visible = jax.vmap(one)(flat)
    batch = segments.shape[:-2]
    return _finish(segments, p0.reshape(*batch, 2), p1.reshape(*batch, 2), visible.reshape(batch))


def cohen_sutherland_trace(segment, window) -> list[dict]:
    """Every iteration of Cohen-Sutherland on one segment, for teaching (eager, concrete).

    Uses the same iteration as `cohen_sutherland`. With `WALKTHROUGH_EXAMPLE`'s window, segment
    `(A, D)` gives a clip at the top edge (new point B) and an accept; `(E, I)` gives
    clips at the bottom (F), top (H) and right (G) edges and an accept.

    **Arguments:**

    - `segment`: `(2, 2)` concrete segment `((x0, y0), (x1, y1))`.
    - `window`: `(xmin, ymin, xmax, ymax)`.

    **Returns:** a list with one dict per iteration: `"p0"`, `"p1"` (the current
    endpoints, tuples of floats), `"code0"`, `"code1"` (ints), `"and"`, `"or"` (their
    bitwise AND and OR), `"action"` (`"accept"`, `"reject"` or `"clip"`), `"edge"`
    (`"top"`, `"bottom"`, `"right"`, `"left"` or None), `"clipped_point"` (`"p0"`,
    `"p1"` or None) and `"new_point"` (a tuple, or None).
    """
    segment, window = common_finite(segment, window, names=("segment", "window"))
    check_shape(segment, "segment", (2, 2))
    w = _window(window)
    if isinstance(segment, jax.core.Tracer) or isinstance(w, jax.core.Tracer):
        raise TypeError("`cohen_sutherland_trace` needs concrete values; call it outside jit")
    p0, p1 = segment[0], segment[1]
    names = {bit: name for name, bit in _EDGE_BITS.items()}
    steps = []
    for _ in range(_CS_MAX_CLIPS + 1):  # iterations of one segment, at most five
        c0 = int(_codes(p0[0], p0[1], w))
        c1 = int(_codes(p1[0], p1[1], w))
        row = {
            "p0": tuple(float(v) for v in p0),
            "p1": tuple(float(v) for v in p1),
            "code0": c0,
            "code1": c1,
            "and": c0 & c1,
            "or": c0 | c1,
            "action": "clip",
            "edge": None,
            "clipped_point": None,
            "new_point": None,
        }
        steps.append(row)
        if c0 | c1 == 0:
            row["action"] = "accept"
            break
        if c0 & c1:
            row["action"] = "reject"
            break
        new0, new1, _, _ = _cs_iteration(p0, p1, w, jnp.asarray(True))
        use_p0 = c0 != 0
        bit = int(_first_edge_bit(jnp.asarray(c0 if use_p0 else c1)))
        new = new0 if use_p0 else new1
        row["edge"] = names[bit]
        row["clipped_point"] = "p0" if use_p0 else "p1"
        row["new_point"] = tuple(float(v) for v in new)
        p0, p1 = new0, new1
    return steps


def liang_barsky(
    segments: Float[Array, "*batch 2 2"], window: Float[Array, "4"]
) -> tuple[Float[Array, "*batch 2 2"], Bool[Array, "*batch"]]:
    """Liang-Barsky parametric line clipping, vectorized.

    With `p(t) = p0 + t (p1 - p0)`, each window edge gives `t * p_k <= q_k` with
    `p = (-dx, dx, -dy, dy)` and `q = (x0 - xmin, xmax - x0, y0 - ymin, ymax - y0)`.
    Edges with `p_k < 0` raise the entry parameter `t0 = max(0, q_k / p_k)`, edges with
    `p_k > 0` lower the exit parameter `t1 = min(1, q_k / p_k)`, and a segment parallel
    to an edge (`p_k = 0`) is outside if `q_k < 0`. Visible iff `t0 <= t1`.

    **Arguments:**

    - `segments`: `(..., 2, 2)` segments `((x0, y0), (x1, y1))`.
    - `window`: `(xmin, ymin, xmax, ymax)` with `xmax > xmin`, `ymax > ymin`.

    **Returns:** `(clipped, visible)` as `cohen_sutherland` (NaN where not visible).
    """
    segments, window = common_float(segments, window, names=("segments", "window"))
    segments = _check_segments(segments)
    return _liang_barsky(segments, _window(window))


@jax.jit
def _liang_barsky(segments, w):
    start, end = segments[..., 0, :], segments[..., 1, :]
    d = end - start
    p = jnp.stack([-d[..., 0], d[..., 0], -d[..., 1], d[..., 1]], -1)
    q = jnp.stack(
        [start[..., 0] - w[0], w[2] - start[..., 0], start[..., 1] - w[1], w[3] - start[..., 1]],
        -1,
    )
    parallel = p == 0
    ratio = q / jnp.where(parallel, 1.0, p)
    t0 = jnp.max(jnp.where(p < 0, ratio, 0.0), axis=-1)
    t1 = jnp.min(jnp.where(p > 0, ratio, 1.0), axis=-1)
    t0 = jnp.maximum(t0, 0.0)
    t1 = jnp.minimum(t1, 1.0)
    visible = (t0 <= t1) & ~jnp.any(parallel & (q < 0), axis=-1)
    p0 = start + t0[..., None] * d
    p1 = start + t1[..., None] * d
    return _finish(segments, p0, p1, visible)


def _clip_stage(points, count, inside_fn, intersect_fn, size_out):
    """Sutherland-Hodgman against one edge: each input edge `v_i -> v_{i+1}` emits the
    crossing point (if it crosses) and then `v_{i+1}` (if inside), into two slots."""
    size_in = points.shape[0]
    idx = jnp.arange(size_in)
    valid = idx < count
    nxt = jnp.where(idx + 1 < count, idx + 1, 0)
    a, b = points, points[nxt]
    a_in, b_in = inside_fn(a), inside_fn(b)
    crossing = valid & (a_in != b_in)
    keep_b = valid & b_in
    cross_pt = intersect_fn(a, b)
    emitted = jnp.stack([cross_pt, b], axis=1).reshape(-1, 2)
    flags = jnp.stack([crossing, keep_b], axis=1).reshape(-1)
    order = jnp.argsort(~flags, stable=True)  # compact: emitted points first, in order
    out = emitted[order][:size_out]
    new_count = jnp.sum(flags)
    out = jnp.where((jnp.arange(size_out) < new_count)[:, None], out, 0.0)
    return out, jnp.minimum(new_count, size_out), new_count


def sutherland_hodgman(
    vertices: Float[Array, "V 2"], window: Float[Array, "4"], *, max_vertices: int | None = None
) -> tuple[Float[Array, "M 2"], Bool[Array, " M"]]:
    """Sutherland-Hodgman polygon clipping against a rectangular window.

    The polygon is clipped against the left, right, bottom and top edges in turn; for
    each edge every polygon edge `v_i -> v_{i+1}` emits its crossing with the window
    edge (if it crosses) and then `v_{i+1}` (if inside). All polygon edges of a stage
    are handled at once, and the output is compacted into a fixed-size buffer.

    A concave polygon that the window cuts into several pieces comes back as one
    polygon joined along the window's boundary (zero-width bridges), as in the
    textbook algorithm; its area is still right.

    **Arguments:**

    - `vertices`: `(V, 2)` polygon vertices in order (either orientation), `V >= 3`.
    - `window`: `(xmin, ymin, xmax, ymax)` with `xmax > xmin`, `ymax > ymin`.
    - `max_vertices`: size `M` of the output buffer (static); default `2 V + 8`, which
      a convex polygon never exceeds (it gains at most one vertex per window edge).
      Raises an error if the clipped polygon needs more.

    **Returns:** `(vertices, valid)`: `(M, 2)` clipped vertices, the valid ones first
    in order (invalid rows are 0), and the `(M,)` mask. No valid vertex when the
    polygon misses the window.
    """
    vertices, window = common_finite(vertices, window, names=("vertices", "window"))
    check_shape(vertices, "vertices", (None, 2))
    if vertices.shape[0] < 3:
        raise ValueError(
            f"`vertices` must hold at least 3 polygon vertices, got shape {tuple(vertices.shape)}"
        )
    w = _window(window)
    count_in = vertices.shape[0]
    size = (
        2 * count_in + 8
        if max_vertices is None
        else static_int(max_vertices, "max_vertices", minimum=3, maximum=MAX_VERTICES)
    )
    points, count, needed = _sutherland_hodgman(vertices, w, size)
    points = value_error_if(
        points,
        needed > size,
        f"the clipped polygon needs more than max_vertices={size} vertices; pass a larger "
        "`max_vertices`",
    )
    return points, jnp.arange(size) < count


@jax.jit(static_argnames="size")
def _sutherland_hodgman(polygon, w, size):
    count_in = polygon.shape[0]

    def vertical(x_edge, keep_right):
        def inside(p):
            return p[:, 0] >= x_edge if keep_right else p[:, 0] <= x_edge

        def cross(a, b):
            dx = b[:, 0] - a[:, 0]
            t = (x_edge - a[:, 0]) / jnp.where(dx == 0, 1.0, dx)
            return jnp.stack([jnp.full_like(t, x_edge), a[:, 1] + t * (b[:, 1] - a[:, 1])], -1)

        return inside, cross

    def horizontal(y_edge, keep_above):
        def inside(p):
            return p[:, 1] >= y_edge if keep_above else p[:, 1] <= y_edge

        def cross(a, b):
            dy = b[:, 1] - a[:, 1]
            t = (y_edge - a[:, 1]) / jnp.where(dy == 0, 1.0, dy)
            return jnp.stack([a[:, 0] + t * (b[:, 0] - a[:, 0]), jnp.full_like(t, y_edge)], -1)

        return inside, cross

    stages = [
        vertical(w[0], True),
        vertical(w[2], False),
        horizontal(w[1], True),
        horizontal(w[3], False),
    ]
    points = jnp.concatenate([polygon, jnp.zeros((max(size - count_in, 0), 2), polygon.dtype)])
    count = jnp.asarray(count_in)
    needed = jnp.asarray(0)
    for inside_fn, cross_fn in stages:  # the four window edges
        points, count, wanted = _clip_stage(points, count, inside_fn, cross_fn, size)
        needed = jnp.maximum(needed, wanted)
    return points, count, needed


def polygon_area(
    vertices: Float[Array, "*batch M 2"], valid: Bool[Array, "*batch M"] | None = None
) -> Float[Array, "*batch"]:
    """Area of a polygon by the shoelace formula (absolute value), optionally masked.

    **Arguments:**

    - `vertices`: `(..., M, 2)` vertices in order.
    - `valid`: `(..., M)` mask with the valid vertices first (as `sutherland_hodgman`
      returns); default all valid.

    **Returns:** the area `(...)`.
    """
    vertices = finite_float(vertices, "vertices")
    check_shape(vertices, "vertices", (..., None, 2))
    size = vertices.shape[-2]
    if valid is None:
        valid = jnp.ones(vertices.shape[:-1], bool)
    try:
        valid = jnp.asarray(valid)
    except (TypeError, ValueError) as err:
        raise TypeError(f"`valid` must be a boolean mask, got {type(valid).__name__}") from err
    if valid.dtype != jnp.bool_:
        raise TypeError(f"`valid` must be a boolean mask, got dtype {valid.dtype}")
    check_shape(valid, "valid", (*vertices.shape[:-1],))
    count = jnp.sum(valid, axis=-1, keepdims=True)
    idx = jnp.arange(size)
    nxt = jnp.where(idx + 1 < count, idx + 1, 0)
    following = jnp.take_along_axis(vertices, nxt[..., None], axis=-2)
    cross = vertices[..., 0] * following[..., 1] - following[..., 0] * vertices[..., 1]
    return 0.5 * jnp.abs(jnp.sum(jnp.where(valid, cross, 0.0), axis=-1))
