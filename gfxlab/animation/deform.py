"""Deformers: the bone deformer (linear blend skinning) and the curve deformer.

Linear blend skinning moves each vertex by a weighted average of its bones' motions:

    v' = sum_b w[v, b] * M_b @ v,     M_b = global_b(pose) @ inverse(global_b(rest))

so a vertex bound to one bone moves rigidly with it, and a vertex near a joint blends
the two neighbours. Averaging matrices is not a rotation: at large twists the blend
shrinks the mesh towards the axis (the "candy-wrapper" artefact).

The curve deformer lays a shape's x axis along a path: the point `(x, y)` goes to
`path(s) + y * normal(s)` where `s` is `x` measured as arc length along the path.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .. import curves
from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    check_range,
    check_shape,
    checked_jit,
    safe_norm,
    static_int,
    value_error_if,
)
from .quaternions import _number
from .skeleton import Skeleton, _check_pose, _fk

__all__ = [
    "skin",
    "skinning_matrices",
    "bone_weights",
    "bezier_path",
    "curve_deform",
    "MAX_PATH_SAMPLES",
]

#: The most arc-length samples `curve_deform` takes.
MAX_PATH_SAMPLES = 1 << 20


def skin(
    vertices: Float[Array, "*batch N d"],
    weights: Float[Array, "N B"],
    bone_transforms: Float[Array, "*batch B n n"],
    *,
    atol: float = 1e-6,
) -> Float[Array, "*batch N d"]:
    """Linear blend skinning: `v' = (sum_b w[v, b] M_b) v` (in homogeneous coordinates).

    **Arguments:**

    - `vertices`: `(..., N, d)` rest-pose vertices (d = 2 or 3).
    - `weights`: `(N, B)` non-negative bone weights, each row summing to 1 (checked to
      `atol`; rows not summing to 1 would scale the mesh towards the origin).
    - `bone_transforms`: `(..., B, d+1, d+1)` skinning matrices (`skinning_matrices`),
      batch dimensions broadcast against `vertices`' (e.g. many frames at once).
    - `atol`: tolerance of the row sums, finite and >= 0.

    **Returns:** `(..., N, d)` deformed vertices. NaN/inf inputs raise `ValueError`.
    """
    vertices = as_float(vertices, "vertices")
    weights = as_float(weights, "weights")
    bone_transforms = as_float(bone_transforms, "bone_transforms")
    d = check_last_dim(vertices, "vertices", (2, 3), "2D or 3D points")
    if vertices.ndim < 2:
        raise ValueError(f"`vertices` must have shape (..., N, {d}), got {vertices.shape}")
    n = vertices.shape[-2]
    if weights.ndim != 2 or weights.shape[0] != n:
        raise ValueError(
            f"`weights` must have shape ({n}, B) (one row per vertex of `vertices` "
            f"{vertices.shape}), got {weights.shape}"
        )
    b = weights.shape[1]
    if bone_transforms.shape[-3:] != (b, d + 1, d + 1):
        raise ValueError(
            f"`bone_transforms` must have shape (..., {b}, {d + 1}, {d + 1}): one matrix per "
            f"column of `weights` {weights.shape} for {d}D `vertices`, got {bone_transforms.shape}"
        )
    atol = _number(atol, "atol")
    return _skin_kernel(vertices, weights, bone_transforms, atol)


@checked_jit
def _skin_kernel(vertices, weights, bone_transforms, atol):
    dtype = jnp.result_type(vertices, weights, bone_transforms)
    vertices = check_finite(vertices.astype(dtype), "vertices")
    weights = check_finite(weights.astype(dtype), "weights")
    bone_transforms = check_finite(bone_transforms.astype(dtype), "bone_transforms")
    atol = check_range(check_finite(atol.astype(dtype), "atol"), "atol", minimum=0)
    bad = (jnp.abs(jnp.sum(weights, axis=-1) - 1) > atol) | jnp.any(weights < 0, axis=-1)
    weights = value_error_if(
        weights, bad, "`weights` rows must be non-negative and sum to 1 (within `atol`)"
    )
    n, b = weights.shape
    d = vertices.shape[-1]
    # Blend the top d rows of the matrices with one GEMM, then apply them.
    flat = bone_transforms[..., :d, :].reshape(bone_transforms.shape[:-3] + (b, d * (d + 1)))
    blended = jnp.einsum("nb,...bk->...nk", weights, flat).reshape(flat.shape[:-2] + (n, d, d + 1))
    return jnp.einsum("...nij,...nj->...ni", blended[..., :d], vertices) + blended[..., d]


def skinning_matrices(
    skeleton: Skeleton, pose: Float[Array, "*batch J n n"] | None = None, *, per: str = "bone"
) -> Float[Array, "*batch B n n"]:
    """The transforms that `skin` blends: `global(pose) @ inverse(global(rest))`.

    They map a rest-pose point to where it goes when rigidly attached to a joint
    (identity in the rest pose).

    **Arguments:**

    - `skeleton`, `pose`: as for `forward_kinematics`.
    - `per`: `"bone"` (default): one matrix per bone in `skeleton.bones` (the bone's
      parent joint's), matching `bone_weights(..., skeleton.bone_segments())`;
      `"joint"`: one per joint.

    **Returns:** `(..., B, n, n)` or `(..., J, n, n)`.
    """
    if not isinstance(per, str) or per not in ("bone", "joint"):
        raise ValueError(f"`per` must be 'bone' or 'joint', got {per!r}")
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"`skeleton` must be a Skeleton, got {type(skeleton).__name__}")
    pose = _check_pose(skeleton, pose)
    bones = tuple(p for p, _ in skeleton.bones) if per == "bone" else None
    return _skinning_kernel(skeleton.rest, pose, parents=skeleton.parents, bones=bones)


@functools.partial(checked_jit, static_argnames=("parents", "bones"))
def _skinning_kernel(rest, pose, *, parents, bones):
    dtype = jnp.result_type(rest, pose)
    rest = check_finite(rest.astype(dtype), "skeleton.rest")
    pose = check_finite(pose.astype(dtype), "pose")
    bind = _fk(rest, jnp.eye(rest.shape[-1], dtype=dtype), parents)
    mats = _fk(rest, pose, parents) @ jnp.linalg.inv(bind)
    return mats if bones is None else mats[..., jnp.array(bones), :, :]


def _point_segment_distance(points, a, b):
    ab = b - a
    denom = jnp.sum(ab * ab, axis=-1)
    t = jnp.sum((points[:, None, :] - a) * ab, axis=-1) / jnp.where(denom > 0, denom, 1.0)
    t = jnp.clip(t, 0.0, 1.0)
    closest = a + t[..., None] * ab
    return safe_norm(points[:, None, :] - closest)


def bone_weights(
    vertices: Float[Array, "N d"],
    segments: Float[Array, "B 2 d"],
    *,
    falloff: float = 0.1,
    power: float = 2.0,
) -> Float[Array, "N B"]:
    """Automatic skinning weights from distances to bone segments.

    `w[v, b]` is proportional to `(falloff + dist(v, bone b)) ** -power`, normalised per
    vertex: the nearest bone dominates and neighbours blend smoothly near joints.

    **Arguments:**

    - `vertices`: `(N, d)` rest-pose vertices.
    - `segments`: `(B, 2, d)` bones as (start, end) points (`Skeleton.bone_segments()`).
    - `falloff`: distance scale that softens the blend (larger: smoother, more blending);
      finite and > 0.
    - `power`: sharpness of the blend, finite and >= 0.

    **Returns:** `(N, B)` weights, rows summing to 1.
    """
    vertices, segments = as_float(vertices, "vertices"), as_float(segments, "segments")
    d = check_last_dim(vertices, "vertices", (2, 3), "2D or 3D points")
    check_shape(vertices, "vertices", (None, d))
    check_shape(segments, "segments", (None, 2, d))
    falloff, power = _number(falloff, "falloff"), _number(power, "power")
    return _weights_kernel(vertices, segments, falloff, power)


@checked_jit
def _weights_kernel(vertices, segments, falloff, power):
    dtype = jnp.result_type(vertices, segments)
    vertices = check_finite(vertices.astype(dtype), "vertices")
    segments = check_finite(segments.astype(dtype), "segments")
    falloff = check_finite(falloff.astype(dtype), "falloff")
    falloff = value_error_if(
        falloff, falloff <= 0, "`falloff` must be positive (it keeps weights finite on a bone)"
    )
    power = check_finite(power.astype(dtype), "power")
    power = value_error_if(power, power < 0, "`power` must be >= 0")
    dist = _point_segment_distance(vertices, segments[:, 0], segments[:, 1])
    # log-space normalisation: stable for high powers
    logits = -power * jnp.log(falloff + dist)
    return jax.nn.softmax(logits, axis=-1)


def bezier_path(control_points: Float[Array, "M d"]) -> Callable[[jax.Array], jax.Array]:
    """A Bezier curve as a path function `u -> point` for `curve_deform` (any degree).

    Evaluated by `gfxlab.curves.bezier` (Bernstein form); `u` of any shape in `[0, 1]`
    gives points of shape `(*u.shape, d)`.
    """
    control_points = as_float(control_points, "control_points")
    if control_points.ndim != 2 or control_points.shape[0] < 2:
        raise ValueError(
            f"`control_points` must have shape (M >= 2, d), got {control_points.shape}"
        )
    check_last_dim(control_points, "control_points", (2, 3), "2D or 3D points")
    control_points = check_finite(control_points, "control_points")

    def path(u):
        u = as_float(u, "u")
        points = curves.bezier(control_points, u.reshape(-1))
        return points.reshape(u.shape + control_points.shape[-1:])

    return path


def curve_deform(
    vertices: Float[Array, "N d"],
    path: Callable[[jax.Array], jax.Array],
    *,
    length: float | None = None,
    tangent: Callable[[jax.Array], jax.Array] | None = None,
    up: Float[Array, " 3"] | None = None,
    samples: int = 256,
) -> Float[Array, "N d"]:
    """Bend a shape along a path (the curve deformer).

    The shape's x axis is laid along the path by arc length: a vertex `(x, y[, z])` goes to
    `path(s) + y * normal(s) [+ z * binormal(s)]`, where `s` is the path parameter at
    arc length `x * total_length / length`. The path's unit tangent gives the frame
    (2D normal: the tangent turned 90 degrees; 3D: normal `= up x tangent` normalised,
    binormal `= tangent x normal`).

    **Arguments:**

    - `vertices`: `(N, 2)` or `(N, 3)` shape in its rest frame, x along the length.
    - `path`: any function `u (...,) -> points (..., d)` for `u` in `[0, 1]` (a Bezier
      from `bezier_path`, a B-spline, a circle).
    - `length`: the rest length mapped onto the whole path (default the shape's x
      extent `max(x)`, with x starting at 0).
    - `tangent`: `u -> (..., d)` derivative of the path; default the exact derivative by
      automatic differentiation (`jax.jvp`).
    - `up`: 3D only, the up direction that fixes the frame's roll (default `(0, 0, 1)`).
    - `samples`: samples for the arc-length table (static).

    **Returns:** the deformed vertices, same shape.
    """
    vertices = as_float(vertices, "vertices")
    d = check_last_dim(vertices, "vertices", (2, 3), "2D or 3D points")
    check_shape(vertices, "vertices", (None, d))
    if vertices.shape[0] == 0:
        raise ValueError("`vertices` must hold at least one vertex, got shape (0, d)")
    vertices = check_finite(vertices, "vertices")
    samples = static_int(samples, "samples", minimum=2, maximum=MAX_PATH_SAMPLES)
    if not callable(path):
        raise TypeError(f"`path` must be a function u -> points, got {type(path).__name__}")
    dtype = vertices.dtype
    grid = jnp.linspace(0.0, 1.0, samples, dtype=dtype)
    pts = as_float(path(grid), "path(u)").astype(dtype)
    if pts.shape != (samples, d):
        raise ValueError(
            f"`path(u)` must return ({samples}, {d}) points for u of shape "
            f"({samples},), got {pts.shape}"
        )
    seg = safe_norm(jnp.diff(pts, axis=0))
    arc = jnp.concatenate([jnp.zeros((1,), dtype), jnp.cumsum(seg)])
    total = arc[-1]
    if length is None:
        length = jnp.max(vertices[:, 0])
    length = check_finite(as_float(length, "length").astype(dtype), "length")
    length = value_error_if(
        length, length <= 0, "`length` must be positive (the shape's x extent along the path)"
    )
    s_target = jnp.clip(vertices[:, 0] / length, 0.0, 1.0) * total
    u = jnp.interp(s_target, arc, grid)
    if tangent is None:
        base = path(u)
        _, tan = jax.jvp(path, (u,), (jnp.ones_like(u),))
    else:
        base, tan = path(u), as_float(tangent(u), "tangent(u)")
    base, tan = base.astype(dtype), tan.astype(dtype)
    tnorm = safe_norm(tan, keepdims=True)
    t_hat = tan / jnp.where(tnorm > 0, tnorm, 1.0)
    if d == 2:
        normal = jnp.stack([-t_hat[:, 1], t_hat[:, 0]], axis=-1)
        return base + vertices[:, 1:2] * normal
    if up is None:
        up = jnp.array([0.0, 0.0, 1.0], dtype)
    up = check_finite(as_float(up, "up").astype(dtype), "up")
    check_shape(up, "up", (3,))
    normal = jnp.cross(up, t_hat)
    nnorm = safe_norm(normal, keepdims=True)
    normal = normal / jnp.where(nnorm > 0, nnorm, 1.0)
    binormal = jnp.cross(t_hat, normal)
    return base + vertices[:, 1:2] * normal + vertices[:, 2:3] * binormal
