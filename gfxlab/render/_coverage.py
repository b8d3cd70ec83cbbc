"""Coverage and depth of pixel centres by screen-space triangles: the checks and the
tests every hidden-surface method (`gfxlab.render.hsr`) shares."""

from __future__ import annotations

import jax.numpy as jnp

from .._checks import as_float, check_finite, check_shape, common_float, static_shape
from ..mesh import check_colors
from ._tiles import cross2


def _check_scene(triangles, colors, shape, background):
    """The checks of every method, in Python: shapes, dtypes and finite values."""
    height, width = static_shape(shape)
    triangles, colors = common_float(triangles, colors, names=("triangles", "colors"))
    check_shape(triangles, "triangles", (None, 3, 3))
    colors = check_colors(colors, triangles.shape[0], per="triangle")  # (F, 1..4), finite
    background = as_float(background, "background").astype(colors.dtype)
    if background.ndim == 0:
        background = jnp.broadcast_to(background, colors.shape[1:])
    check_shape(background, "background", (colors.shape[1],))
    triangles = check_finite(triangles, "triangles")
    background = check_finite(background, "background")
    return (height, width), triangles, colors, background


def _scene(triangles, colors):
    """Inside a method: the triangles to draw (an empty scene gets one skipped placeholder,
    which keeps shapes valid) and which have an area (`valid`)."""
    if triangles.shape[0] == 0:
        triangles = jnp.zeros((1, 3, 3), triangles.dtype)
        colors = jnp.zeros((1, colors.shape[1]), colors.dtype)
    xy = triangles[..., :2]
    valid = cross2(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]) != 0
    return triangles, colors, valid


def _edge_functions(points, triangles):
    """`(..., F, 3)` oriented edge functions (>= 0 inside) and the plane depth `(..., F)`."""
    xy = triangles[..., :2]
    area2 = cross2(xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0])
    start = xy
    edge = jnp.roll(xy, -1, axis=-2) - start
    rel = points[..., None, None, :] - start
    fn = cross2(edge, rel)  # (..., F, 3)
    safe = jnp.where(area2 != 0, area2, 1.0)
    bary = jnp.roll(fn, -1, axis=-1) / safe[:, None]  # corner k: edge k + 1
    # z0 + b1 (z1 - z0) + b2 (z2 - z0), not sum(b_k z_k): exact on a plane of constant
    # depth (the barycentrics need not sum to exactly 1), so every visibility method
    # sees the same tie between two faces at one depth.
    z = triangles[..., 2]
    depth = z[..., 0] + jnp.sum(bary[..., 1:] * (z[..., 1:] - z[..., :1]), -1)
    return fn * jnp.sign(area2)[:, None], depth


def _covers(points, triangles, valid):
    fn, depth = _edge_functions(points, triangles)
    return valid & jnp.all(fn >= 0, axis=-1), depth


def _covers_own(points, triangles, valid):
    """Coverage of each point `(..., 2)` by its own triangle `(..., 3, 3)`."""
    xy = triangles[..., :2]
    area2 = cross2(xy[..., 1, :] - xy[..., 0, :], xy[..., 2, :] - xy[..., 0, :])
    fn = cross2(jnp.roll(xy, -1, axis=-2) - xy, points[..., None, :] - xy)
    return valid & jnp.all(fn * jnp.sign(area2)[..., None] >= 0, axis=-1)


def _nearest(points, triangles, valid):
    """Index of the nearest covering triangle at `points (..., 2)` (-1: none) and its depth."""
    cover, depth = _covers(points, triangles, valid)
    depth = jnp.where(cover, depth, jnp.inf)
    index = jnp.argmin(depth, axis=-1)  # first minimum: ties go to the lower index
    hit = jnp.any(cover, axis=-1)
    return jnp.where(hit, index, -1), jnp.min(depth, axis=-1), jnp.sum(cover, axis=-1)


def _compose(owner, colors, background):
    return jnp.where((owner >= 0)[..., None], colors[jnp.maximum(owner, 0)], background)


def _int(x):
    return jnp.asarray(x, dtype=jnp.result_type(int))
