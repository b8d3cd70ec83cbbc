"""Unit quaternions for rotations: axis-angle, products, matrices, slerp and squad.

A quaternion is stored as `(w, x, y, z)` (scalar first) in the last axis. A unit
quaternion `q = (cos(a/2), sin(a/2) k)` rotates by angle `a` about the unit axis `k`;
`q` and `-q` are the same rotation.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import as_float, check_last_dim, common_float, safe_norm, value_error_if

__all__ = [
    "quat_identity",
    "quat_from_axis_angle",
    "quat_from_rotvec",
    "quat_multiply",
    "quat_conjugate",
    "quat_normalize",
    "quat_to_matrix",
    "quat_rotate",
    "quat_log",
    "quat_exp",
    "slerp",
    "squad",
    "squad_inner",
]

Quat = Float[Array, "*batch 4"]


def quat_identity(dtype=None) -> Float[Array, "4"]:
    """The identity rotation `(1, 0, 0, 0)`."""
    return jnp.array([1.0, 0.0, 0.0, 0.0], dtype=dtype)


def quat_from_axis_angle(axis: Float[Array, "*batch 3"], angle: Float[Array, "*batch"]) -> Quat:
    """The unit quaternion rotating by `angle` radians about `axis` (right-handed).

    **Arguments:**

    - `axis`: `(..., 3)`, non-zero (it is normalised).
    - `angle`: radians, broadcast against `axis[..., 0]`.

    **Returns:** `(..., 4)` unit quaternions `(w, x, y, z)`.
    """
    axis, angle = common_float(axis, angle, names=("axis", "angle"))
    check_last_dim(axis, "axis", (3,), "a 3D rotation axis")
    length = safe_norm(axis, keepdims=True)
    axis = value_error_if(axis, length == 0, "`axis` must be a non-zero 3-vector")
    k = axis / jnp.where(length == 0, 1.0, length)
    half = 0.5 * angle[..., None]
    k, half = jnp.broadcast_arrays(k, half)
    return jnp.concatenate([jnp.cos(half[..., :1]), jnp.sin(half) * k], axis=-1)


def quat_from_rotvec(rotvec: Float[Array, "*batch 3"]) -> Quat:
    """The unit quaternion of a rotation vector (axis times angle); smooth at zero.

    This is `quat_exp` of `rotvec / 2`; it has finite gradients at the zero vector, so it
    is a good unconstrained parameterisation of 3D joint rotations for fitting.
    """
    rotvec = as_float(rotvec, "rotvec")
    check_last_dim(rotvec, "rotvec", (3,), "a rotation vector (axis * angle)")
    return quat_exp(0.5 * rotvec)


def quat_multiply(q: Quat, r: Quat) -> Quat:
    """The Hamilton product `q r` (rotate by `r` first, then by `q`)."""
    q, r = common_float(q, r, names=("q", "r"))
    check_last_dim(q, "q", (4,), "quaternions (w, x, y, z)")
    check_last_dim(r, "r", (4,), "quaternions (w, x, y, z)")
    w1, x1, y1, z1 = jnp.moveaxis(q, -1, 0)
    w2, x2, y2, z2 = jnp.moveaxis(r, -1, 0)
    return jnp.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def quat_conjugate(q: Quat) -> Quat:
    """`(w, -x, -y, -z)`: the inverse of a unit quaternion."""
    q = as_float(q, "q")
    check_last_dim(q, "q", (4,), "quaternions (w, x, y, z)")
    return q * jnp.array([1.0, -1.0, -1.0, -1.0], q.dtype)


def quat_normalize(q: Quat) -> Quat:
    """`q / |q|` (the zero quaternion is rejected)."""
    q = as_float(q, "q")
    check_last_dim(q, "q", (4,), "quaternions (w, x, y, z)")
    length = safe_norm(q, keepdims=True)
    q = value_error_if(q, length == 0, "`q` must be non-zero quaternions")
    return q / jnp.where(length == 0, 1.0, length)


def quat_to_matrix(q: Quat) -> Float[Array, "*batch 3 3"]:
    """The 3x3 rotation matrix of unit quaternions (column-vector convention).

    Embed it in a 4x4 with `gfxlab.transforms.linear`.
    """
    q = as_float(q, "q")
    check_last_dim(q, "q", (4,), "quaternions (w, x, y, z)")
    w, x, y, z = jnp.moveaxis(q, -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def quat_rotate(q: Quat, points: Float[Array, "*batch N 3"]) -> Float[Array, "*batch N 3"]:
    """Rotate 3D `points` by unit quaternions `q` (`q` broadcasts over the point axis)."""
    q, points = common_float(q, points, names=("q", "points"))
    check_last_dim(points, "points", (3,), "3D points")
    return jnp.einsum("...ij,...nj->...ni", quat_to_matrix(q), points)


def quat_log(q: Quat) -> Float[Array, "*batch 3"]:
    """Logarithm of unit quaternions: the vector `(angle / 2) * axis`."""
    q = as_float(q, "q")
    check_last_dim(q, "q", (4,), "quaternions (w, x, y, z)")
    v = q[..., 1:]
    s = safe_norm(v, keepdims=True)
    half = jnp.arctan2(s, q[..., :1])
    small = s < 1e-12
    # half / s -> 1 / w as s -> 0 (double where keeps the gradient finite).
    factor = jnp.where(small, 1.0 / q[..., :1], half / jnp.where(small, 1.0, s))
    return factor * v


def quat_exp(v: Float[Array, "*batch 3"]) -> Quat:
    """Exponential of pure quaternions `(0, v)`: `(cos|v|, sin|v| v/|v|)`."""
    v = as_float(v, "v")
    check_last_dim(v, "v", (3,), "a 3-vector (pure quaternion)")
    theta = safe_norm(v, keepdims=True)
    small = theta < 1e-6
    safe_theta = jnp.where(small, 1.0, theta)
    sinc = jnp.where(small, 1.0 - theta**2 / 6.0, jnp.sin(safe_theta) / safe_theta)
    return jnp.concatenate([jnp.cos(theta), sinc * v], axis=-1)


def slerp(q0: Quat, q1: Quat, u: Float[Array, "*batch"], *, shortest: bool = True) -> Quat:
    """Spherical linear interpolation between unit quaternions.

    `slerp(q0, q1, u) = (sin((1-u) W) q0 + sin(u W) q1) / sin W` with `cos W = q0 . q1`:
    constant angular speed along the great arc, unit length throughout.

    **Arguments:**

    - `q0`, `q1`: `(..., 4)` unit quaternions (broadcast together).
    - `u`: interpolation parameter, `0` gives `q0`, `1` gives `q1`; broadcast against
      the batch shape.
    - `shortest`: flip `q1` to `-q1` when that is closer (the shorter of the two arcs
      for the same pair of rotations).

    **Returns:** `(..., 4)` unit quaternions.
    """
    q0, q1, u = common_float(q0, q1, u, names=("q0", "q1", "u"))
    check_last_dim(q0, "q0", (4,), "quaternions (w, x, y, z)")
    check_last_dim(q1, "q1", (4,), "quaternions (w, x, y, z)")
    dot = jnp.sum(q0 * q1, axis=-1, keepdims=True)
    if shortest:
        q1 = jnp.where(dot < 0, -q1, q1)
        dot = jnp.abs(dot)
    dot = jnp.clip(dot, -1.0, 1.0)
    u = u[..., None]
    near = dot > 1 - 1e-7
    omega = jnp.arccos(jnp.where(near, 0.5, dot))
    sin_omega = jnp.sin(omega)
    a = jnp.where(near, 1 - u, jnp.sin((1 - u) * omega) / sin_omega)
    b = jnp.where(near, u, jnp.sin(u * omega) / sin_omega)
    out = a * q0 + b * q1
    # The nearly-parallel branch is a lerp: renormalise it.
    return jnp.where(near, out / safe_norm(out, keepdims=True), out)


def squad_inner(q_prev: Quat, q: Quat, q_next: Quat) -> Quat:
    """The inner control quaternion of squad at key `q` with neighbours `q_prev`, `q_next`:
    `s = q exp(-(log(q^-1 q_next) + log(q^-1 q_prev)) / 4)`."""
    inv = quat_conjugate(q)
    a = quat_log(quat_multiply(inv, q_next))
    b = quat_log(quat_multiply(inv, q_prev))
    return quat_multiply(q, quat_exp(-(a + b) / 4))


def squad(q0: Quat, s0: Quat, s1: Quat, q1: Quat, u: Float[Array, "*batch"]) -> Quat:
    """Spherical quadrangle interpolation (Shoemake's squad), a C1 curve through keys.

    `squad = slerp(slerp(q0, q1, u), slerp(s0, s1, u), 2u(1-u))`, with `s0`, `s1` the inner
    quaternions from `squad_inner`. Without shortest-arc flips inside, so the keys should
    already be sign-aligned (consecutive dot products >= 0), as `interpolate_rotations`
    does.
    """
    u = as_float(u, "u")
    outer = slerp(q0, q1, u, shortest=False)
    inner = slerp(s0, s1, u, shortest=False)
    return slerp(outer, inner, 2 * u * (1 - u), shortest=False)
