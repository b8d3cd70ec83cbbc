"""Per pixel-face geometry, tiles and bins, and the tile capacity.

The image is cut into `tile_size x tile_size` tiles; each tile sees only the faces whose
(margin-grown) bounding box reaches it, at most `capacity` of them. `needed_capacity`
counts the largest number of faces a tile sees, so the capacity can be found from the
geometry before compiling.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import warnings
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .. import _regrow
from .._check_errors import HostCheckError
from .._checks import is_traced, positive, static_int, trusted_values
from .._pixels import pixel_centers


def cross2(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def pixel_face_terms(points, tri):
    """Squared distance, inside flag and clamped barycentrics of pixels vs triangles.

    `points (P, 2)`, `tri (K, 3, 2)` -> `d2 (P, K)`, `inside (P, K)`, `bary (P, K, 3)`.
    Degenerate triangles are never inside; every value and gradient stays finite.
    """
    d2, inside, bary = pixel_face_planes(points, tri)
    return d2, inside, jnp.stack(bary, -1)


def pixel_face_planes(points, tri):
    """`pixel_face_terms` with the barycentrics as a list of three `(P, K)` planes.

    Written per coordinate (no trailing axes of size 2 or 3, which XLA runs slower);
    per-face quantities (edges, reciprocal lengths and area) are computed once per face.

    A pixel centre on an edge shared by two faces must be inside at least one of them.
    Each edge is evaluated about its midpoint (symmetric in its ends), and a point
    counts as inside up to the edge function's rounding error: the compiler fuses
    multiply-adds differently for the three edges of a face, so the two faces' values
    need not be exact negatives, and a centre outside both was a hole.
    """
    px, py = points[:, 0:1], points[:, 1:2]  # (P, 1)
    cx = [tri[None, :, k, 0] for k in range(3)]  # (1, K) each
    cy = [tri[None, :, k, 1] for k in range(3)]
    d2 = None
    edge_fn, spans = [], []
    for k in range(3):
        ax, ay, bx, by = cx[k], cy[k], cx[(k + 1) % 3], cy[(k + 1) % 3]
        ex, ey = bx - ax, by - ay
        spans.append(jnp.abs(ex) + jnp.abs(ey))
        length2 = ex * ex + ey * ey
        nonzero = length2 > 0
        inv_length2 = jnp.where(nonzero, 1.0 / jnp.where(nonzero, length2, 1.0), 0.0)
        rx, ry = px - (ax + bx) * 0.5, py - (ay + by) * 0.5  # from the midpoint
        t = jnp.clip((rx * ex + ry * ey) * inv_length2, -0.5, 0.5)
        ox, oy = rx - t * ex, ry - t * ey
        dk = ox * ox + oy * oy
        d2 = dk if d2 is None else jnp.minimum(d2, dk)
        edge_fn.append(ex * ry - ey * rx)  # twice the signed area opposite corner k + 2
    area2 = (cx[1] - cx[0]) * (cy[2] - cy[0]) - (cy[1] - cy[0]) * (cx[2] - cx[0])
    proper = area2 != 0
    sign = jnp.sign(area2)
    # |rounding error| <= a few ulps of |e| |r|, and |r| <= the face's span (+ a tile)
    ulps = 8 * jnp.finfo(tri.dtype).eps * (spans[0] + spans[1] + spans[2] + 16.0)
    slack = [jax.lax.stop_gradient(ulps * span) for span in spans]
    inside = proper & (edge_fn[0] * sign >= -slack[0])
    inside = inside & (edge_fn[1] * sign >= -slack[1]) & (edge_fn[2] * sign >= -slack[2])
    inv_area = 1.0 / jnp.where(proper, area2, 1.0)
    bary = [jnp.clip(edge_fn[(k + 1) % 3] * inv_area, 0.0, 1.0) for k in range(3)]
    inv_total = 1.0 / jnp.maximum(bary[0] + bary[1] + bary[2], 1e-12)
    bary = [jnp.where(proper, b * inv_total, 1.0 / 3) for b in bary]
    return d2, inside, bary


def logit_limit(eps: float) -> float:
    return math.log(1.0 / eps - 1.0)


def tile_points(shape, tile_size, dtype):
    """Pixel centres `(T, t*t, 2)` of every tile (the image padded to whole tiles)."""
    height, width = shape
    t = tile_size
    rows, cols = -(-height // t), -(-width // t)
    grid = pixel_centers((rows * t, cols * t), dtype=dtype)
    grid = grid.at[..., 1].add(height - rows * t)  # the padding lies below the image
    return grid.reshape(rows, t, cols, t, 2).transpose(0, 2, 1, 3, 4).reshape(-1, t * t, 2)


def untile(tiles, shape, tile_size):
    """Inverse of `tile_points` for per-pixel results `(T, t*t, C)` -> `(H, W, C)`."""
    height, width = shape
    t = tile_size
    rows, cols = -(-height // t), -(-width // t)
    image = tiles.reshape(rows, cols, t, t, -1).transpose(0, 2, 1, 3, 4)
    return image.reshape(rows * t, cols * t, -1)[:height, :width]


def _face_boxes(tri, margin):
    return jax.lax.stop_gradient(
        jnp.concatenate([jnp.min(tri, 1) - margin, jnp.max(tri, 1) + margin], -1)
    )  # (F, 4): xmin, ymin, xmax, ymax


def tile_grid(shape, tile_size):
    """Rows and columns of tiles covering the image."""
    return -(-shape[0] // tile_size), -(-shape[1] // tile_size)


def _tile_ranges(box, valid, shape, tile_size):
    """Inclusive ranges of tile rows `r0..r1` and columns `c0..c1` each face's box reaches.

    Tile `(r, c)` holds the pixel centres `x in [c t, c t + t - 1]`, `y in [H - t - r t,
    H - 1 - r t]` (`tile_points`). Returns int32 `(r0, r1, c0, c1)` and `n` (tiles per
    face, 0 for an invalid face or one off screen).
    """
    height, _ = shape
    t = float(tile_size)
    rows, cols = tile_grid(shape, tile_size)
    ok = valid & jnp.all(jnp.isfinite(box), -1)
    box = jnp.where(ok[:, None], box, 0.0)
    xmin, ymin, xmax, ymax = (box[:, k] for k in range(4))

    def to_int(value, lo, hi):
        return jnp.clip(value, lo, hi).astype(jnp.int32)

    c0 = to_int(jnp.ceil((xmin - (t - 1)) / t), 0, cols)
    c1 = to_int(jnp.floor(xmax / t), -1, cols - 1)
    r0 = to_int(jnp.ceil((height - t - ymax) / t), 0, rows)
    r1 = to_int(jnp.floor((height - 1 - ymin) / t), -1, rows - 1)
    ok = ok & (c0 <= c1) & (r0 <= r1)
    r1, c1 = jnp.where(ok, r1, r0 - 1), jnp.where(ok, c1, c0 - 1)
    n = jnp.where(ok, (r1 - r0 + 1) * (c1 - c0 + 1), 0)
    return r0, r1, c0, c1, n


def tile_counts(box, valid, shape, tile_size):
    """The number of faces whose box reaches each tile, `(T,)` int32 (a 2D prefix sum)."""
    rows, cols = tile_grid(shape, tile_size)
    r0, r1, c0, c1, n = _tile_ranges(box, valid, shape, tile_size)
    w = (n > 0).astype(jnp.int32)
    diff = jnp.zeros((rows + 1, cols + 1), jnp.int32)
    diff = diff.at[r0, c0].add(w).at[r0, c1 + 1].add(-w)
    diff = diff.at[r1 + 1, c0].add(-w).at[r1 + 1, c1 + 1].add(w)
    return jnp.cumsum(jnp.cumsum(diff, 0), 1)[:rows, :cols].reshape(-1)


def bin_faces(box, valid, shape, tile_size, capacity):
    """The faces each tile sees: `ids (T, capacity)` (ascending, padded with `F`) and the
    true counts `(T,)` (which may exceed `capacity`: an overflow, see `check_capacity`).

    Every (face, tile) pair is enumerated from the faces' tile ranges into a list of
    `T * capacity` slots (enough unless a tile overflows) and sorted by tile: the cost
    follows the number of pairs, not tiles x faces. A pair's face is the number of
    faces whose pairs end at or before its slot (a cumulative sum, not a search), and
    the sort key packs tile and face into one integer where it fits (a single-key sort
    is several times faster than a stable sort of two arrays).
    """
    faces = box.shape[0]
    rows, cols = tile_grid(shape, tile_size)
    total = rows * cols
    slots = total * capacity
    r0, r1, c0, c1, n = _tile_ranges(box, valid, shape, tile_size)
    ends = jnp.cumsum(n)
    pair = jnp.arange(slots, dtype=jnp.int32)
    marks = jnp.zeros(slots + 1, jnp.int32).at[jnp.minimum(ends, slots)].add(1)
    face = jnp.cumsum(marks[:slots], dtype=jnp.int32)  # = searchsorted(ends, pair, "right")
    safe = jnp.minimum(face, faces - 1)
    local = pair - (ends[safe] - n[safe])
    width = jnp.maximum(c1 - c0 + 1, 1)[safe]
    tile = (r0[safe] + local // width) * cols + c0[safe] + local % width
    tile = jnp.where(face < faces, tile, total)
    if (total + 1) * (faces + 1) < 2**31:  # one int32 key: (tile, face) in order
        key = jax.lax.sort(tile * (faces + 1) + face)
        tile, face = key // (faces + 1), key % (faces + 1)
    else:
        tile, face = jax.lax.sort((tile, face), num_keys=1, is_stable=True)
    starts = jnp.searchsorted(tile, jnp.arange(total + 1, dtype=jnp.int32), side="left")
    slot = jnp.arange(capacity, dtype=jnp.int32)
    here = slot[None] < (starts[1:] - starts[:-1])[:, None]
    where = jnp.minimum(starts[:-1, None] + slot[None], slots - 1)
    ids = jnp.where(here, face[where], faces)
    return ids, tile_counts(box, valid, shape, tile_size)


@functools.partial(jax.jit, static_argnames=("shape", "tile_size"))
def max_tile_count(tri, valid, margin, *, shape, tile_size):
    """The largest number of faces any tile sees (batched over leading axes of `tri`)."""
    flat_tri = tri.reshape((-1,) + tri.shape[-3:])
    flat_valid = valid.reshape((-1, valid.shape[-1]))

    def one(tri, valid):
        return jnp.max(tile_counts(_face_boxes(tri, margin), valid, shape, tile_size))

    return jnp.max(jax.vmap(one)(flat_tri, flat_valid))


#: Under tracing, `capacity=None` gives every tile room for all faces up to this many.
TRACED_ALL_FACES = 256


def round_capacity(count: int, faces: int) -> int:
    """A capacity of at least `count`, rounded up to one of four steps per octave (8, 10,
    12, 14, 16, 20, ...: few recompilations, little waste), at most the number of faces."""
    count = max(count, 1)
    step = max(1, 1 << max(0, count.bit_length() - 3))
    return max(1, min(faces, max(8, -(-count // step) * step)))


class _Plan(NamedTuple):
    """Static layout of a tiled evaluation."""

    pixel_fn: Callable
    shape: tuple[int, int]
    tile_size: int
    batch: int
    steps: int
    widths: tuple[int, ...]  # face slots a step evaluates, ascending (the last: capacity)


def step_widths(capacity: int) -> tuple[int, ...]:
    """The kernel widths: a step whose busiest tile sees few faces evaluates fewer slots."""
    if capacity < 24:  # small: one kernel (half the compile time)
        return (capacity,)
    narrow = -(-capacity // 24) * 8  # a third, in multiples of 8
    return tuple(sorted({narrow, capacity}))


def tiled(
    pixel_fn,
    tri,
    valid,
    faces,
    params,
    shape,
    *,
    margin,
    tile_size,
    capacity,
    tiles_per_step,
    binned=True,
    reference=False,
):
    """Evaluate `pixel_fn(points, faces_subset, slot_mask, ids, params)` over the image.

    Each tile sees the faces binned into it (`bin_faces`); tiles are processed in steps
    of `tiles_per_step`, busiest first, each step with the narrowest of `step_widths`
    that holds its faces, and only as many steps as there are tiles with faces (the
    rest get the empty-tile value). Differentiable in `faces` and `params` (pytrees of
    float arrays) through a custom VJP that recomputes each step's pixel-face terms and
    scatters the face gradients with one `segment_sum` (no per-pixel residuals are
    kept). `reference=True`: all pixels against all faces in one plain-autodiff call
    (the tests' reference). Returns `(image (H, W, ...), max_faces_in_a_tile)`.
    """
    count = tri.shape[0]
    if reference:  # every pixel against every face, plain autodiff: the tests' reference
        points = pixel_centers(shape, dtype=tri.dtype).reshape(-1, 2)
        out = pixel_fn(points, faces, valid, jnp.arange(count), params)
        return out.reshape(tuple(shape) + out.shape[1:]), jnp.zeros((), jnp.int32)
    box = _face_boxes(tri, margin)
    rows, cols = tile_grid(shape, tile_size)
    total = rows * cols
    if binned:
        ids, counts = bin_faces(box, valid, shape, tile_size, capacity)
        widths = step_widths(capacity)
    else:
        ids = jnp.broadcast_to(jnp.where(valid, jnp.arange(count), count), (total, count))
        counts = jnp.full(total, jnp.sum(valid, dtype=jnp.int32))
        widths = (count,)
    batch = min(tiles_per_step, total)
    steps = -(-total // batch)
    order = jnp.argsort(-counts).astype(jnp.int32)  # busiest first: empty tiles come last
    order = jnp.concatenate([order, jnp.full(steps * batch - total, total, jnp.int32)])
    busy = (jnp.sum(counts > 0, dtype=jnp.int32) + batch - 1) // batch
    first = jnp.concatenate([counts, jnp.zeros(1, counts.dtype)])[order[::batch]]
    level = jnp.sum(first[:, None] > jnp.asarray(widths[:-1], jnp.int32), -1, dtype=jnp.int32)
    ids = jnp.concatenate([ids, jnp.full((1, ids.shape[1]), count, ids.dtype)])[order]
    plan = _Plan(pixel_fn, tuple(shape), tile_size, batch, steps, widths)
    tiles = _run_tiles(plan, faces, params, ids.astype(jnp.int32), order, busy, level)
    return untile(tiles, shape, tile_size), jnp.max(counts)


def _step_inputs(plan, points, faces, ids, order, step, width):
    """The points `(batch, P, 2)`, slot mask, face ids and faces of a step's tiles."""
    count = jax.tree_util.tree_leaves(faces)[0].shape[0]
    start = step * plan.batch
    slot_ids = jax.lax.dynamic_slice(ids, (start, jnp.int32(0)), (plan.batch, width))
    safe = jnp.minimum(slot_ids, count - 1)
    subset = jax.tree_util.tree_map(lambda a: a[safe], faces)
    pts = points[jax.lax.dynamic_slice_in_dim(order, start, plan.batch)]
    return pts, slot_ids < count, safe, subset


def _evaluate(plan, pts, mask, safe, subset, params):
    return jax.vmap(plan.pixel_fn, (0, 0, 0, 0, None))(pts, subset, mask, safe, params)


def _empty_value(plan, points, faces, params):
    ids0 = jnp.zeros(1, jnp.int32)
    subset = jax.tree_util.tree_map(lambda a: a[ids0], faces)
    return plan.pixel_fn(points[0, :1], subset, jnp.zeros(1, bool), ids0, params)  # (1, C)


@functools.partial(jax.custom_vjp, nondiff_argnums=(0,))
def _run_tiles(plan, faces, params, ids, order, busy, level):
    return _run_tiles_fwd(plan, faces, params, ids, order, busy, level)[0]


def _run_tiles_fwd(plan, *args):
    # A `jax.grad` of a jitted render traces the primal (into the jit's jaxpr) and later
    # the fwd rule (to linearize that jaxpr), in another context: one jit, called in the
    # same context both times (the checked values, the current mesh), is traced once.
    with trusted_values(), _current_mesh():
        return _traced_tiles(plan, *args)


def _current_mesh():
    """Enter the current abstract mesh again, so that "none set" and "set to the empty
    mesh" give jit the same context (a no-op where JAX lacks the API)."""
    use, get = (getattr(jax.sharding, n, None) for n in ("use_abstract_mesh", "get_abstract_mesh"))
    return use(get()) if use is not None and get is not None else contextlib.nullcontext()


def _padded_points(plan, dtype):
    points = tile_points(plan.shape, plan.tile_size, dtype)
    return jnp.concatenate([points, points[:1]])  # the padding tile (index T)


@functools.partial(jax.jit, static_argnums=0, inline=True)
def _traced_tiles(plan, faces, params, ids, order, busy, level):
    dtype = jax.tree_util.tree_leaves(faces)[0].dtype
    points = _padded_points(plan, dtype)
    empty = _empty_value(plan, points, faces, params)
    total = points.shape[0] - 1
    size = plan.steps * plan.batch
    buffer = jnp.broadcast_to(empty, (size, points.shape[1]) + empty.shape[1:])

    def branch(width):
        def run(step):
            pts, mask, safe, subset = _step_inputs(plan, points, faces, ids, order, step, width)
            return _evaluate(plan, pts, mask, safe, subset, params)

        return run

    def body(step, buffer):
        step = jnp.asarray(step, jnp.int32)
        out = jax.lax.switch(level[step], [branch(w) for w in plan.widths], step)
        return jax.lax.dynamic_update_slice_in_dim(buffer, out, step * plan.batch, 0)

    buffer = jax.lax.fori_loop(0, busy, body, buffer)
    inverse = jnp.zeros(total + 1, jnp.int32).at[order].set(jnp.arange(size, dtype=jnp.int32))
    return buffer[inverse[:total]], (faces, params, ids, order, busy, level)


def _run_tiles_bwd(plan, residuals, cotangent):
    faces, params, ids, order, busy, level = residuals
    dtype = jax.tree_util.tree_leaves(faces)[0].dtype
    points = _padded_points(plan, dtype)
    count = jax.tree_util.tree_leaves(faces)[0].shape[0]
    cot = jnp.concatenate([cotangent, jnp.zeros_like(cotangent[:1])])[order]  # sorted
    slots = jax.tree_util.tree_map(
        lambda a: jnp.zeros((plan.steps * plan.batch, ids.shape[1]) + a.shape[1:], a.dtype), faces
    )

    def branch(width):
        def run(step, slots):
            pts, mask, safe, subset = _step_inputs(plan, points, faces, ids, order, step, width)
            start = step * plan.batch
            _, vjp = jax.vjp(lambda s, p: _evaluate(plan, pts, mask, safe, s, p), subset, params)
            g_subset, g_params = vjp(jax.lax.dynamic_slice_in_dim(cot, start, plan.batch))
            slots = jax.tree_util.tree_map(
                lambda buf, g: jax.lax.dynamic_update_slice(
                    buf, g, (start,) + (jnp.int32(0),) * (g.ndim - 1)
                ),
                slots,
                g_subset,
            )
            return slots, g_params

        return run

    def body(step, carry):
        step = jnp.asarray(step, jnp.int32)
        slots, grad_params = carry
        branches = [branch(w) for w in plan.widths]
        slots, g_params = jax.lax.switch(level[step], branches, step, slots)
        return slots, jax.tree_util.tree_map(jnp.add, grad_params, g_params)

    zero_params = jax.tree_util.tree_map(jnp.zeros_like, params)
    slots, grad_params = jax.lax.fori_loop(0, busy, body, (slots, zero_params))
    flat_ids = ids.reshape(-1)  # padding slots carry the id `count`: dropped
    grad_faces = jax.tree_util.tree_map(
        lambda g: jax.ops.segment_sum(g.reshape((-1,) + g.shape[2:]), flat_ids, count), slots
    )
    # the tiles never evaluated hold the empty value: their cotangent goes to the params
    skipped = jnp.arange(cot.shape[0]) >= busy * plan.batch
    rest = jnp.sum(jnp.where(skipped[:, None, None], cot, 0.0), (0, 1))[None]
    _, vjp_empty = jax.vjp(lambda p: _empty_value(plan, points, faces, p), params)
    (g_empty,) = vjp_empty(rest.astype(dtype))
    grad_params = jax.tree_util.tree_map(jnp.add, grad_params, g_empty)
    return grad_faces, grad_params, None, None, None, None


_run_tiles.defvjp(_run_tiles_fwd, _run_tiles_bwd)


class TileCapacityError(HostCheckError):
    """A tile overlaps more faces than the `capacity` a render was compiled with (a
    `ValueError`; under `jax.jit`, `gfxlab.check_message` finds it in JAX's error)."""


class _DropOverflowLogs(logging.Filter):
    """JAX logs an exception raised in a debug callback before re-raising it; keep the
    overflow error to the one message (the exception itself still propagates)."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not isinstance(exc, TileCapacityError)


logging.getLogger("jax._src.debugging").addFilter(_DropOverflowLogs())


def overflow_message(count: int, capacity: int, tile_size: int, faces: int | None) -> str:
    suggested = round_capacity(count, faces if faces is not None else count)
    return (
        f"a {tile_size}x{tile_size} tile overlaps {count} faces, more than `capacity` = "
        f"{capacity}: pass `capacity={suggested}` or more (measure it outside jax.jit with "
        "gfxlab.render.tile_capacity(mesh, camera, shape, sigma=..., slack=1.5), which "
        "leaves room for the geometry to move), or call eagerly with `capacity=None` to "
        "have it found and grown automatically"
    )


def check_capacity(image, max_count, capacity, tile_size, faces=None):
    """`image`, after checking that no tile overflowed `capacity`.

    Eagerly a `TileCapacityError` at once; under `jax.jit` the compiled program raises it
    when it runs (JAX wraps it in its `JaxRuntimeError`, whose last line is this
    message: the number of faces the busiest tile saw and the capacity to pass), after
    reporting the capacity it needs to `gfxlab._regrow`, so that `gfxlab.fit` grows it
    and reruns its steps instead of aborting.
    """
    if not is_traced(max_count):
        count = int(np.max(np.asarray(max_count)))
        if count > capacity:
            raise TileCapacityError(overflow_message(count, capacity, tile_size, faces))
        return image

    def host(count):
        count = int(np.max(np.asarray(count)))
        if count > capacity:
            # `gfxlab.fit` grows the capacity from this report and reruns its steps, with
            # room for the geometry to go on moving (each rerun compiles again).
            needed = round_capacity(math.ceil(1.5 * count), faces if faces else count)
            _regrow.report("tile capacity", capacity, needed, "the render's tile capacity")
            raise TileCapacityError(overflow_message(count, capacity, tile_size, faces))

    jax.debug.callback(host, max_count)
    return image


def check_options(sigma, eps, tile_size, capacity, tiles_per_step):
    sigma = positive(sigma, "sigma", "in pixels^2")
    if not isinstance(eps, float | int) or not 0 < eps < 0.5:
        raise ValueError(f"`eps` must be a Python float in (0, 0.5), got {eps!r}")
    tile_size = static_int(tile_size, "tile_size", minimum=1, maximum=256)
    if capacity is not None:
        capacity = static_int(capacity, "capacity", minimum=1)
    tiles_per_step = static_int(tiles_per_step, "tiles_per_step", minimum=1, maximum=4096)
    return sigma, tile_size, capacity, tiles_per_step


def resolve_capacity(
    capacity, tri, valid, margin, shape, tile_size, traced_inputs, faces=None, *, needed=None
):
    """The capacity to compile with, and whether a run must be checked for overflow.

    `capacity=None`: measured from the geometry (eagerly). Under `jax.jit` the geometry
    is unknown: up to `TRACED_ALL_FACES` faces every tile gets room for all of them,
    beyond that a clear error (at trace time) asks for an explicit capacity. An explicit
    capacity that an eager call overflows is grown, with a warning. `needed`: the
    largest tile count, if measured already (then `tri`, `valid`, `margin` are unused).
    """
    faces = tri.shape[-3] if faces is None else faces
    if capacity is not None:
        capacity = min(capacity, max(faces, 1))  # room for every face is enough
    if traced_inputs:
        if capacity is None and faces <= TRACED_ALL_FACES:
            return max(faces, 1)  # every face fits in every tile: no overflow possible
        if capacity is None:
            raise ValueError(
                f"`capacity=None` finds the tile capacity from the geometry, which is not "
                f"known under jax.jit/grad/vmap tracing (and {faces} faces are too many to "
                "give every tile room for all): measure it first with "
                "`gfxlab.render.tile_capacity(...)` (outside the traced function) and pass "
                "`capacity=`"
            )
        return _regrow.grown("tile capacity", capacity)  # grown by a `fit` that overflowed
    if needed is None:
        needed = int(max_tile_count(tri, valid, margin, shape=shape, tile_size=tile_size))
    if capacity is None:
        return round_capacity(needed, faces)
    if needed > capacity:
        return grown_capacity(needed, capacity, tile_size, faces, stacklevel=4)
    return capacity


def grown_capacity(needed: int, capacity: int, tile_size: int, faces: int, *, stacklevel=3):
    """The capacity to recompile with when an eager call's tile saw `needed` > `capacity`
    faces, with a warning (an eager call grows its capacity, it never aborts)."""
    grown = round_capacity(needed, faces)
    warnings.warn(
        f"a {tile_size}x{tile_size} tile overlaps {needed} faces, more than `capacity` = "
        f"{capacity}; recompiling with capacity {grown}",
        RuntimeWarning,
        stacklevel=stacklevel,
    )
    return grown


def any_traced(*trees) -> bool:
    return any(is_traced(t) for t in trees)
