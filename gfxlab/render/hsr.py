"""Hidden-surface removal on screen-space triangle scenes.

Scenes are `(F, 3, 3)` triangles (pixel x, pixel y, depth; smaller depth is nearer,
depth affine across each triangle such as NDC z): `zbuffer`, `painter` (depth sort),
`warnock` (area subdivision), `scanline` and `raycast`. A pixel is covered by a triangle
when its centre lies inside or on the triangle. `zbuffer`, `warnock`, `scanline` and
`raycast` show the nearest covering triangle (ties: the lower index). `painter` shows
the same where depths differ, but paints faces of equal depth in index order, so at a
tie the higher index shows; with cyclic overlaps it fails (the textbook limitation).
`screen_scene` turns a mesh and a camera into such a scene.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_shape,
    static_shape,
    value_error_if,
)
from .._pixels import pixel_centers, row_to_y
from ._coverage import (
    _check_scene,
    _compose,
    _covers,
    _covers_own,
    _edge_functions,
    _int,
    _nearest,
    _scene,
)
from ._project import screen_scene
from ._tiles import cross2

__all__ = [
    "screen_scene",
    "VisibilityResult",
    "zbuffer",
    "painter",
    "warnock",
    "scanline",
    "raycast",
    "quadtree_cells",
    "WARNOCK_CODES",
]


def _image_field(image: Float[Array, "H W C"]) -> jax.Array:
    image = as_float(image, "image")
    check_shape(image, "image", (None, None, None))
    if not 1 <= image.shape[2] <= 4:
        raise ValueError(f"`image` must have 1 to 4 channels, got shape {tuple(image.shape)}")
    return check_finite(image, "image")


def _depth_field(depth: Float[Array, "H W"] | None) -> jax.Array | None:
    if depth is None:
        return None
    depth = as_float(depth, "depth")
    return value_error_if(depth, jnp.isnan(depth), "`depth` must not hold NaN (inf: nothing drawn)")


def _counters_field(counters: dict) -> dict:
    if isinstance(counters, dict):
        return counters
    raise TypeError(f"`counters` must be a dict of counts, got {type(counters).__name__}")


def _quadtree_field(quadtree: tuple | None) -> tuple | None:
    if quadtree is None or isinstance(quadtree, tuple):
        return quadtree
    raise TypeError(f"`quadtree` must be a tuple of arrays or None, got {quadtree!r:.60}")


class VisibilityResult(eqx.Module):
    """What the hidden-surface methods return, a pytree whose fields are the arguments of
    `VisibilityResult(image, depth, counters, quadtree=None)`:

    - `image`: `(H, W, C)` the rendered image, 1 to 4 channels, finite.
    - `depth`: `(H, W)` the depth buffer (`inf` where nothing is drawn, no NaN), or
      `None` for methods without one.
    - `counters`: dict of integer scalars: `memory_bytes` (buffers the method keeps),
      `depth_tests` (depth comparisons), `polygon_tests` (polygon-vs-polygon or
      polygon-vs-area tests), and method-specific extras.
    - `quadtree`: for `warnock`, a tuple with one `(2^l, 2^l)` array of
      `WARNOCK_CODES` per level; default `None`.
    """

    image: Float[Array, "H W C"] = eqx.field(converter=_image_field)
    depth: Float[Array, "H W"] | None = eqx.field(converter=_depth_field)
    counters: dict = eqx.field(converter=_counters_field)
    quadtree: tuple | None = eqx.field(default=None, converter=_quadtree_field)

    def __check_init__(self):
        """`depth` covers the pixels of `image`."""
        if self.depth is not None:
            check_shape(self.depth, "depth", self.image.shape[:2])


#: Decision codes of `warnock`'s quadtree cells.
WARNOCK_CODES = {
    0: "not visited",
    1: "test 1: all polygons disjoint (background)",
    2: "test 2: one intersecting or contained polygon (scan-converted)",
    3: "test 3: one surrounding polygon",
    4: "test 4: surrounding polygon in front of all others",
    5: "subdivided",
    6: "pixel: nearest surface",
}


def zbuffer(
    triangles: Float[Array, "F 3 3"],
    colors: Float[Array, "F C"],
    shape: tuple[int, int],
    *,
    background=0.0,
) -> VisibilityResult:
    """Z-buffer (depth-buffer) visible-surface algorithm, one polygon at a time.

    Frame buffer = background and depth buffer = inf; then for each triangle and each
    pixel it covers, a depth test: if nearer than the stored depth, store its depth and
    colour.

    **Arguments:**

    - `triangles`: `(F, 3, 3)` corners as (pixel x, pixel y, depth); smaller depth is
      nearer; finite. Triangles with no area are skipped.
    - `colors`: `(F, C)` one finite colour per triangle, `C` in 1..4.
    - `shape`: image shape `(H, W)`.
    - `background`: finite background colour `(C,)` or a scalar.

    **Returns:** a `VisibilityResult` with the image, the depth buffer and counters.
    """
    shape, *arrays = _check_scene(triangles, colors, shape, background)
    return _zbuffer(*arrays, shape=shape)


@functools.partial(jax.jit, static_argnames=("shape",))
def _zbuffer(triangles, colors, background, *, shape):
    triangles, colors, valid = _scene(triangles, colors)
    grid = pixel_centers(shape, dtype=triangles.dtype)

    def draw(carry, face):
        frame, depth, tests = carry
        tri, color, ok = face
        cover, z = _covers(grid, tri[None], ok[None])
        cover, z = cover[..., 0], z[..., 0]
        nearer = cover & (z < depth)
        frame = jnp.where(nearer[..., None], color, frame)
        depth = jnp.where(nearer, z, depth)
        return (frame, depth, tests + jnp.sum(cover)), None

    frame = jnp.broadcast_to(background, shape + background.shape)
    depth = jnp.full(shape, jnp.inf, triangles.dtype)
    (frame, depth, tests), _ = jax.lax.scan(
        draw, (frame, depth, _int(0)), (triangles, colors, valid)
    )
    memory = frame.size * frame.dtype.itemsize + depth.size * depth.dtype.itemsize
    counters = {"memory_bytes": _int(memory), "depth_tests": tests, "polygon_tests": _int(0)}
    return VisibilityResult(frame, depth, counters)


def _obscures(triangles, valid):
    """`(F, F)`: triangle i is nearer than triangle j somewhere where both are drawn.

    The depth difference is affine over the overlap of the two projections, so its
    minimum is at a corner of the overlap: a corner of one triangle inside the other or
    a crossing of two edges. Also returns how many pairs needed this exact test.
    """
    xy = triangles[..., :2]
    zmin, zmax = triangles[..., 2].min(-1), triangles[..., 2].max(-1)
    lo, hi = xy.min(1), xy.max(1)
    boxes = jnp.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), -1)
    candidates = valid[:, None] & valid[None] & boxes & ~jnp.eye(len(xy), dtype=bool)
    # quick test: i entirely behind j in depth cannot obscure it
    candidates = candidates & ~(zmin[:, None] >= zmax[None])
    scale = jnp.maximum(jnp.max(jnp.abs(xy)), 1.0)
    tol = 1e-9 * scale * scale

    def pair(ti, tj):
        pi, pj = ti[:, :2], tj[:, :2]
        # corners of i and j, and the 9 edge crossings
        ri = jnp.roll(pi, -1, 0) - pi
        rj = jnp.roll(pj, -1, 0) - pj
        denom = cross2(ri[:, None], rj[None])
        qp = pj[None] - pi[:, None]
        ok = jnp.abs(denom) > 0
        safe = jnp.where(ok, denom, 1.0)
        t = cross2(qp, rj[None]) / safe
        u = cross2(qp, ri[:, None]) / safe
        crossing = ok & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
        cross_pts = (pi[:, None] + t[..., None] * ri[:, None]).reshape(9, 2)
        points = jnp.concatenate([pi, pj, cross_pts])
        fi, di = _edge_functions(points, ti[None])
        fj, dj = _edge_functions(points, tj[None])
        # corners of i inside j, corners of j inside i, and real edge crossings
        inside = jnp.concatenate(
            [jnp.all(fj[:3, 0] >= -tol, -1), jnp.all(fi[3:6, 0] >= -tol, -1), crossing.reshape(9)]
        )
        diff = di[:, 0] - dj[:, 0]
        depth_tol = 1e-9 * jnp.maximum(jnp.max(jnp.abs(ti[:, 2])), jnp.max(jnp.abs(tj[:, 2])))
        return jnp.any(inside & (diff < -depth_tol - 1e-12))

    nearer = jax.vmap(lambda ti: jax.vmap(lambda tj: pair(ti, tj))(triangles))(triangles)
    return candidates & nearer, jnp.sum(candidates)


def painter(
    triangles: Float[Array, "F 3 3"],
    colors: Float[Array, "F C"],
    shape: tuple[int, int],
    *,
    background=0.0,
) -> VisibilityResult:
    """Painter's algorithm (depth sort): paint far to near, over-painting.

    Triangles are sorted by their farthest depth; then every pair whose projections
    and depth ranges overlap is tested, and a triangle that is nearer than another
    anywhere in their common area is painted after it (a topological order). With
    cyclic overlaps no such order exists (`counters["cycle"]` is 1): the plain depth
    sort is painted and the picture is wrong where the cycle overlaps, which is the
    textbook failure (fixing it needs polygon splitting). Faces at exactly the same
    depth are painted in index order: the later one shows.

    Arguments and result as for `zbuffer`; there is no depth buffer (`depth` is None).
    """
    shape, *arrays = _check_scene(triangles, colors, shape, background)
    return _painter(*arrays, shape=shape)


@functools.partial(jax.jit, static_argnames=("shape",))
def _painter(triangles, colors, background, *, shape):
    triangles, colors, valid = _scene(triangles, colors)
    count = triangles.shape[0]
    obscures, exact_tests = _obscures(triangles, valid)

    # level[i] = length of the longest chain of triangles that must be painted before i
    def body(state):
        level, _, steps = state
        new = jnp.max(jnp.where(obscures, level[None, :] + 1, 0), axis=1, initial=0)
        return new, jnp.any(new != level), steps + 1

    level, changing, _ = jax.lax.while_loop(
        lambda s: s[1] & (s[2] <= count),
        body,
        (jnp.zeros(count, jnp.int32), jnp.array(True), jnp.int32(0)),
    )
    cycle = changing
    far_first = -triangles[..., 2].max(-1)
    level = jnp.where(cycle, 0, level)
    order = jnp.lexsort((far_first, level))

    grid = pixel_centers(shape, dtype=triangles.dtype)

    def paint(carry, index):
        frame, writes = carry
        cover, _ = _covers(grid, triangles[index][None], valid[index][None])
        cover = cover[..., 0]
        return (jnp.where(cover[..., None], colors[index], frame), writes + jnp.sum(cover)), None

    frame = jnp.broadcast_to(background, shape + background.shape)
    (frame, writes), _ = jax.lax.scan(paint, (frame, _int(0)), order)
    pairs = count * (count - 1) // 2
    counters = {
        "memory_bytes": _int(frame.size * frame.dtype.itemsize + count * 8),
        "depth_tests": _int(0),
        "polygon_tests": _int(pairs) + exact_tests,
        "pixel_writes": writes,
        "cycle": cycle.astype(_int(0).dtype),
    }
    return VisibilityResult(frame, None, counters)


def _warnock_decide(rects, triangles, valid, active):
    """Warnock's four tests on every cell of one level, `rects (..., 4)` as
    (xmin, ymin, xmax, ymax) of pixel centres: the decision code, the owning triangle
    (tests 3, 4), the first relevant triangle (test 2) and the counts."""
    corners = jnp.stack(
        [rects[..., [0, 1]], rects[..., [2, 1]], rects[..., [2, 3]], rects[..., [0, 3]]], -2
    )  # (..., 4, 2)
    fn, corner_depth = _edge_functions(corners, triangles)  # (..., 4, F, 3), (..., 4, F)
    surrounding = valid & jnp.all(fn >= 0, axis=(-3, -1))
    xy = triangles[..., :2]
    lo, hi = xy.min(1), xy.max(1)
    apart = (
        (lo[:, 0] > rects[..., 2:3])
        | (hi[:, 0] < rects[..., 0:1])
        | (lo[:, 1] > rects[..., 3:4])
        | (hi[:, 1] < rects[..., 1:2])
    )
    separated = jnp.any(jnp.all(fn < 0, axis=-3), axis=-1)  # an edge with all corners out
    relevant = valid & ~apart & ~separated  # intersecting, contained or surrounding
    n_rel = jnp.sum(relevant, -1)
    n_sur = jnp.sum(surrounding, -1)
    first_rel = jnp.argmax(relevant, -1)
    corner_depth = jnp.where(relevant[..., None, :], corner_depth, jnp.inf)
    # test 4: a surrounding triangle strictly nearer than every other relevant one at
    # each corner, i.e. the only one at the corner's minimum depth
    nearest = jnp.min(corner_depth, axis=-1, keepdims=True)  # (..., 4, 1)
    unique = jnp.sum(corner_depth == nearest, axis=-1, keepdims=True) == 1
    front = surrounding & jnp.all((corner_depth == nearest) & unique, axis=-2)
    test1 = n_rel == 0
    test2 = (n_rel == 1) & (n_sur == 0)
    test3 = (n_rel == 1) & (n_sur == 1)
    test4 = ~test1 & ~test2 & ~test3 & jnp.any(front, -1)
    code = jnp.select([test1, test2, test3, test4], [1, 2, 3, 4], 5)
    code = jnp.where(active, code, 0)
    cell_owner = jnp.select([test3, test4], [first_rel, jnp.argmax(front, -1)], -1)
    undecided = ~test1 & ~test2 & ~test3
    return code, cell_owner, first_rel, n_rel, n_sur, undecided


def warnock(
    triangles: Float[Array, "F 3 3"],
    colors: Float[Array, "F C"],
    shape: tuple[int, int],
    *,
    background=0.0,
) -> VisibilityResult:
    """Warnock's area-subdivision algorithm, breadth first over the quadtree.

    The image is padded to a `2^L x 2^L` square. At each level every undecided cell
    (a rectangle of pixel centres) is classified against every triangle as disjoint,
    surrounding, or intersecting/contained, and decided by the exam's tests: (1) all
    disjoint: background; (2) one intersecting or contained polygon: background, then
    that polygon scan-converted; (3) one surrounding polygon and nothing else: its
    colour; (4) a surrounding polygon nearer than all others at the cell's four
    corners: its colour. Otherwise the cell is split into four. At pixel size the
    nearest surface is used.

    Arguments as for `zbuffer`. The result has no depth buffer; `quadtree` holds the
    decision code (`WARNOCK_CODES`) of every cell at every level, for overlays
    (`quadtree_cells`).
    """
    shape, *arrays = _check_scene(triangles, colors, shape, background)
    return _warnock(*arrays, shape=shape)


@functools.partial(jax.jit, static_argnames=("shape",))
def _warnock(triangles, colors, background, *, shape):
    # The levels above pixel size are one `lax.scan` step each, on a grid of 2 x 2 pixel
    # blocks (such a level's cells are unions of blocks): each block stands for the
    # cell that holds it, and the cell's first block counts it. One compiled step
    # instead of one program section per level (a 64 x 64 image compiled in 12-20 s
    # unrolled, 2 s scanned). At pixel size a cell is its pixel centre, where the
    # four tests reduce to the pixel's covering triangles and their depths.
    triangles, colors, valid = _scene(triangles, colors)
    height, width = shape
    levels = _quadtree_levels(height, width)
    size = 2**levels
    grid = pixel_centers((size, size), dtype=triangles.dtype).at[..., 1].add(height - size)
    zero = _int(0)
    counts = (zero, zero, zero, zero)  # polygon tests, depth tests, max active, cells
    owner = jnp.full((size, size), -1)
    if levels > 0:
        decided, counts, owner, codes = _warnock_blocks(
            triangles, valid, grid, owner, counts, height=height, levels=levels
        )
        active = ~_blow_up(decided, 2)
        quadtree = [codes[d, :: size >> d + 1, :: size >> d + 1] for d in range(levels)]
    else:
        active, quadtree = jnp.ones((1, 1), bool), []
    code, owner, counts = _warnock_pixels(triangles, valid, grid, active, owner, counts)
    polygon_tests, depth_tests, max_active, cells = counts
    image = _compose(owner[:height, :width], colors, background)
    memory = image.size * image.dtype.itemsize + max_active * 4 * 4
    counters = {
        "memory_bytes": _int(memory),
        "depth_tests": depth_tests,
        "polygon_tests": polygon_tests,
        "cells": cells,
    }
    return VisibilityResult(image, None, counters, (*quadtree, code.astype(jnp.int8)))


def _quadtree_levels(height: int, width: int) -> int:
    """Levels below the root: the image is padded to a `2^levels` square."""
    return max(0, math.ceil(math.log2(max(height, width))))


def _blow_up(blocks, k):
    return jnp.repeat(jnp.repeat(blocks, k, 0), k, 1)


def _warnock_blocks(triangles, valid, grid, owner, counts, *, height, levels):
    """Warnock's levels above pixel size, on the grid of 2 x 2 pixel blocks."""
    dtype = triangles.dtype
    first_pixel = 2 * jnp.arange(2 ** (levels - 1))  # of each block, per axis

    def level(carry, depth):
        decided, owner, (polygon_tests, depth_tests, max_active, cells) = carry
        s = jnp.right_shift(2**levels, depth)  # the cell size in pixels (>= 2)
        first = first_pixel - first_pixel % s  # each block's cell: first and last pixel
        last = first + s - 1
        x0, x1 = first.astype(dtype)[None, :], last.astype(dtype)[None, :]
        y0, y1 = row_to_y(last, height)[:, None], row_to_y(first, height)[:, None]
        rects = jnp.stack(jnp.broadcast_arrays(x0, y0, x1, y1), -1).astype(dtype)
        head = (first_pixel % s == 0)[:, None] & (first_pixel % s == 0)[None, :]
        active = ~decided
        code, cell_owner, first_rel, n_rel, n_sur, undecided = _warnock_decide(
            rects, triangles, valid, active
        )
        # test 2: scan-convert the single polygon inside its cell, pixel by pixel
        first_px = _blow_up(first_rel, 2)
        covered_first = _covers_own(grid, triangles[first_px], valid[first_px])
        px_owner = jnp.where(
            _blow_up(code == 2, 2), jnp.where(covered_first, first_px, -1), _blow_up(cell_owner, 2)
        )
        newly = (code >= 1) & (code != 5)
        owner = jnp.where(_blow_up(newly, 2), px_owner, owner)
        n_active = jnp.sum(head & active)
        reached4 = head & active & undecided & (n_sur > 0)
        counts = (
            polygon_tests + n_active * len(valid),
            depth_tests + 4 * jnp.sum(jnp.where(reached4, n_rel, 0)),
            jnp.maximum(max_active, n_active),
            cells + jnp.sum(head & (code > 0)),
        )
        return (decided | newly, owner, counts), code.astype(jnp.int8)

    decided = jnp.zeros((2 ** (levels - 1),) * 2, bool)
    (decided, owner, counts), codes = jax.lax.scan(
        level, (decided, owner, counts), jnp.arange(levels)
    )
    return decided, counts, owner, codes


def _warnock_pixels(triangles, valid, grid, active, owner, counts):
    """Warnock's last level: every undecided pixel. Its four corners are its centre, so
    the relevant and the surrounding triangles are those that cover it: test 1 (none),
    3 (one), 4 (one strictly nearest), else the nearest surface (code 6)."""
    polygon_tests, depth_tests, max_active, cells = counts
    cover, depth = _covers(grid, triangles, valid)
    depth = jnp.where(cover, depth, jnp.inf)
    nearest_depth = jnp.min(depth, axis=-1, keepdims=True)
    nearest = jnp.where(jnp.any(cover, -1), jnp.argmin(depth, axis=-1), -1)
    covering = jnp.sum(cover, axis=-1)
    unique = jnp.sum(cover & (depth == nearest_depth), axis=-1) == 1
    code = jnp.select([covering == 0, covering == 1, unique], [1, 3, 4], 6)
    code = jnp.where(active, code, 0)
    n_active = jnp.sum(active)
    counts = (
        polygon_tests + n_active * len(valid),
        depth_tests
        + jnp.sum(jnp.where(code == 6, covering, 0))  # the nearest-surface comparisons
        + 4 * jnp.sum(jnp.where(active & (covering >= 2), covering, 0)),  # test 4
        jnp.maximum(max_active, n_active),
        cells + n_active,
    )
    return code, jnp.where(active, nearest, owner), counts


def quadtree_cells(quadtree, shape: tuple[int, int]) -> np.ndarray:
    """Warnock's decided cells as rows `(xmin, ymin, xmax, ymax, level, code)` (NumPy).

    Coordinates are pixel edges (a cell of pixel centres 0..3 spans -0.5..3.5), for
    drawing rectangles over `plt.imshow(image, extent=image_extent(shape))`; cells
    entirely outside the image are dropped.
    """
    height, width = static_shape(shape)
    if not isinstance(quadtree, tuple | list) or not quadtree:
        raise TypeError(
            "`quadtree` must be the tuple of per-level code arrays of a `warnock` result "
            f"(`result.quadtree`), got {type(quadtree).__name__}"
        )
    size = 2 ** (len(quadtree) - 1)
    levels = _quadtree_levels(height, width)
    if len(quadtree) != levels + 1:
        raise ValueError(
            f"`shape` {(height, width)} is not the shape `quadtree` was computed for: a "
            f"warnock result for it has {levels + 1} levels, `quadtree` has {len(quadtree)}"
        )
    rows = []
    for level, code in enumerate(quadtree):
        code = np.asarray(code)
        if code.shape != (2**level, 2**level) or not np.issubdtype(code.dtype, np.integer):
            raise ValueError(
                f"`quadtree[{level}]` must be a ({2**level}, {2**level}) integer array of "
                f"WARNOCK_CODES, got shape {code.shape} and dtype {code.dtype}"
            )
        s = size // code.shape[0]
        r, c = np.nonzero(code > 0)
        if len(r) == 0:
            continue
        x0, x1 = c * s - 0.5, np.minimum(c * s + s, width) - 0.5
        top = r * s  # array row of the cell's first pixel row
        y1 = height - 0.5 - top
        y0 = np.maximum(height - 0.5 - (top + s), -0.5)
        keep = (c * s < width) & (top < height)
        rows.append(np.stack([x0, y0, x1, y1, np.full_like(x0, level), code[r, c]], -1)[keep])
    return np.concatenate(rows) if rows else np.zeros((0, 6))


def raycast(
    triangles: Float[Array, "F 3 3"],
    colors: Float[Array, "F C"],
    shape: tuple[int, int],
    *,
    background=0.0,
) -> VisibilityResult:
    """Ray casting: through every pixel centre a ray is tested against every polygon and
    the nearest hit is kept.

    Cost `pixels x polygons` intersection tests without a spatial data structure (the
    exam's `O(#pixels, #objects)`); memory is the frame buffer plus the object database
    (the triangles). Arguments as for `zbuffer`; no depth buffer (`depth` is None).
    Counters: `polygon_tests` (ray-polygon intersection tests) and `depth_tests`
    (comparisons of hits along a ray).
    """
    shape, *arrays = _check_scene(triangles, colors, shape, background)
    return _raycast(*arrays, shape=shape)


@functools.partial(jax.jit, static_argnames=("shape",))
def _raycast(triangles, colors, background, *, shape):
    triangles, colors, valid = _scene(triangles, colors)
    owner, _, hits = _nearest(pixel_centers(shape, dtype=triangles.dtype), triangles, valid)
    image = _compose(owner, colors, background)
    database = triangles.size * triangles.dtype.itemsize + colors.size * colors.dtype.itemsize
    counters = {
        "memory_bytes": _int(image.size * image.dtype.itemsize + database),
        "depth_tests": jnp.sum(jnp.maximum(hits - 1, 0)),
        "polygon_tests": _int(shape[0] * shape[1] * triangles.shape[0]),
    }
    return VisibilityResult(image, None, counters)


def scanline(
    triangles: Float[Array, "F 3 3"],
    colors: Float[Array, "F C"],
    shape: tuple[int, int],
    *,
    background=0.0,
) -> VisibilityResult:
    """Scan-line visible-surface algorithm, one image row at a time.

    For each scan line the active triangles are those it crosses; each gives a span
    `[x_left, x_right]` from the crossings of its edges. Where only one span covers a
    pixel it is drawn without a depth test; where several overlap, the depths along
    the line are compared. Only one row of depths is kept. A pixel centre exactly on an
    edge is covered, as in the other methods (the edge functions settle the span ends).

    Arguments as for `zbuffer`; no full depth buffer (`depth` is None).
    """
    shape, *arrays = _check_scene(triangles, colors, shape, background)
    return _scanline(*arrays, shape=shape)


@functools.partial(jax.jit, static_argnames=("shape",))
def _scanline(triangles, colors, background, *, shape):
    triangles, colors, valid = _scene(triangles, colors)
    height, width = shape
    xs = jnp.arange(width, dtype=triangles.dtype)
    start = triangles[..., :2]
    end = jnp.roll(start, -1, axis=-2)
    z_plane = triangles  # plane depth from the edge functions

    def row(carry, r):
        tests, spans = carry
        y = row_to_y(r, height).astype(triangles.dtype)
        dy = end[..., 1] - start[..., 1]
        crosses = ((start[..., 1] - y) * (end[..., 1] - y) <= 0) & (dy != 0)
        t = jnp.where(crosses, (y - start[..., 1]) / jnp.where(dy != 0, dy, 1.0), 0.0)
        x = start[..., 0] + t * (end[..., 0] - start[..., 0])
        left = jnp.min(jnp.where(crosses, x, jnp.inf), -1)
        right = jnp.max(jnp.where(crosses, x, -jnp.inf), -1)
        active = valid & jnp.any(crosses, -1)
        points = jnp.stack([xs, jnp.full_like(xs, y)], -1)
        edges, depth = _edge_functions(points, z_plane)
        # A span's ends are rounded crossings: a pixel centre exactly on a sloped edge
        # can fall just outside. Within a small slack of the span, the edge functions
        # (exact for such a centre) decide, as they do for the other methods.
        slack = 1e-6 * (1.0 + width)  # pixels: far above rounding, far below a pixel
        near = (xs[:, None] >= left - slack) & (xs[:, None] <= right + slack)
        in_span = active & near & jnp.all(edges >= 0, axis=-1)  # (W, F)
        depth = jnp.where(in_span, depth, jnp.inf)
        nearest = jnp.where(jnp.any(in_span, -1), jnp.argmin(depth, -1), -1)
        overlapping = jnp.sum(in_span, -1)
        tests = tests + jnp.sum(jnp.where(overlapping > 1, overlapping, 0))
        return (tests, spans + jnp.sum(active)), nearest

    (tests, spans), owner = jax.lax.scan(row, (_int(0), _int(0)), jnp.arange(height))
    image = _compose(owner, colors, background)
    itemsize = triangles.dtype.itemsize
    edge_table = triangles.shape[0] * 3 * 4 * itemsize
    memory = image.size * image.dtype.itemsize + width * itemsize + edge_table
    counters = {"memory_bytes": _int(memory), "depth_tests": tests, "polygon_tests": spans}
    return VisibilityResult(image, None, counters)
