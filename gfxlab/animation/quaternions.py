"""Unit quaternions for rotations: axis-angle, products, matrices, slerp and squad.

A quaternion is stored as `(w, x, y, z)` (scalar first) in the last axis. A unit
quaternion `q = (cos(a/2), sin(a/2) k)` rotates by angle `a` about the unit axis `k`;
`q` and `-q` are the same rotation.
"""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    checked_jit,
    safe_norm,
    safe_normalize,
    static_bool,
    value_error_if,
)
from ..transforms import rotation_from_quaternion

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

# Each public function checks shapes and static arguments in Python, then runs one
# compiled kernel (`checked_jit`) that checks values (NaN/inf, zero quaternions) and does
# the arithmetic. The kernels share the unchecked math below (`_mul`, `_log`, ...), which
# the key-frame code also uses inside its own kernels.


def _vectors(x, name: str, size: int, what: str):
    x = as_float(x, name)
    check_last_dim(x, name, (size,), what)
    return x


def _number(x, name: str):
    """A scalar argument: a Python number stays on the host as a NumPy scalar array (no
    device transfer before the compiled call); anything else goes through `as_float`."""
    if isinstance(x, int | float) and not isinstance(x, bool):
        try:
            return np.asarray(float(x))
        except OverflowError:
            raise ValueError(f"`{name}` is too large for a float, got {x!r:.40}") from None
    x = as_float(x, name)
    if x.ndim != 0:
        raise ValueError(f"`{name}` must be a number, got shape {x.shape}")
    return x


def _quats(q, name: str = "q"):
    return _vectors(q, name, 4, "quaternions (w, x, y, z)")


def _finite(arrays: dict):
    """The arrays of `{name: array}` promoted to one dtype, each checked finite."""
    dtype = jnp.result_type(*arrays.values())
    return [check_finite(a.astype(dtype), n) for n, a in arrays.items()]


def _nonzero(q, name: str):
    return value_error_if(
        q, safe_norm(q) == 0, f"`{name}` must be non-zero quaternions (log(0) is undefined)"
    )


def _mul(q, r):
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


def _conj(q):
    return q * jnp.array([1.0, -1.0, -1.0, -1.0], q.dtype)


def _log(q):
    v = q[..., 1:]
    s = safe_norm(v, keepdims=True)
    half = jnp.arctan2(s, q[..., :1])
    small = s < 1e-12
    # half / s -> 1 / w as s -> 0 (double where keeps the gradient finite).
    w = q[..., :1]
    factor = jnp.where(small, 1.0 / jnp.where(w == 0, 1.0, w), half / jnp.where(small, 1.0, s))
    return factor * v


def _exp(v):
    theta = safe_norm(v, keepdims=True)
    small = theta < 1e-6
    safe_theta = jnp.where(small, 1.0, theta)
    sinc = jnp.where(small, 1.0 - theta**2 / 6.0, jnp.sin(safe_theta) / safe_theta)
    return jnp.concatenate([jnp.cos(theta), sinc * v], axis=-1)


def quat_identity(*, dtype=None) -> Float[Array, "4"]:
    """The identity rotation `(1, 0, 0, 0)`."""
    return jnp.array([1.0, 0.0, 0.0, 0.0], dtype=dtype)


def quat_from_axis_angle(axis: Float[Array, "*batch 3"], angle: Float[Array, "*batch"]) -> Quat:
    """The unit quaternion rotating by `angle` radians about `axis` (right-handed).

    **Arguments:**

    - `axis`: `(..., 3)`, non-zero (it is normalised).
    - `angle`: radians, broadcast against `axis[..., 0]`.

    **Returns:** `(..., 4)` unit quaternions `(w, x, y, z)`.
    """
    axis = _vectors(axis, "axis", 3, "a 3D rotation axis")
    angle = as_float(angle, "angle")
    return _axis_angle_kernel(axis, angle)


@checked_jit
def _axis_angle_kernel(axis, angle):
    axis, angle = _finite({"axis": axis, "angle": angle})
    axis = value_error_if(
        axis, safe_norm(axis) == 0, "`axis` must be a non-zero 3-vector (a rotation axis)"
    )
    k = safe_normalize(axis)
    half = 0.5 * angle[..., None]
    k, half = jnp.broadcast_arrays(k, half)
    return jnp.concatenate([jnp.cos(half[..., :1]), jnp.sin(half) * k], axis=-1)


def quat_from_rotvec(rotvec: Float[Array, "*batch 3"]) -> Quat:
    """The unit quaternion of a rotation vector (axis times angle); smooth at zero.

    This is `quat_exp` of `rotvec / 2`; it has finite gradients at the zero vector, so it
    is a good unconstrained parameterisation of 3D joint rotations for fitting.
    """
    return _rotvec_kernel(_vectors(rotvec, "rotvec", 3, "a rotation vector (axis * angle)"))


@checked_jit
def _rotvec_kernel(rotvec):
    return _exp(0.5 * check_finite(rotvec, "rotvec"))


def quat_multiply(q: Float[Array, "*batch 4"], r: Float[Array, "*batch 4"]) -> Quat:
    """The Hamilton product `q r` (rotate by `r` first, then by `q`)."""
    return _multiply_kernel(_quats(q, "q"), _quats(r, "r"))


@checked_jit
def _multiply_kernel(q, r):
    return _mul(*_finite({"q": q, "r": r}))


def quat_conjugate(q: Float[Array, "*batch 4"]) -> Quat:
    """`(w, -x, -y, -z)`: the inverse of a unit quaternion."""
    return _conjugate_kernel(_quats(q))


@checked_jit
def _conjugate_kernel(q):
    return _conj(check_finite(q, "q"))


def quat_normalize(q: Float[Array, "*batch 4"]) -> Quat:
    """`q / |q|` (the zero quaternion is rejected)."""
    return _normalize_kernel(_quats(q))


@checked_jit
def _normalize_kernel(q):
    q = check_finite(q, "q")
    q = value_error_if(q, safe_norm(q) == 0, "`q` must be non-zero quaternions")
    return safe_normalize(q)


def quat_to_matrix(q: Float[Array, "*batch 4"]) -> Float[Array, "*batch 3 3"]:
    """The 3x3 rotation matrix of unit quaternions (column-vector convention).

    Embed it in a 4x4 with `gfxlab.transforms.linear`.
    """
    return _matrix_kernel(_quats(q))


@checked_jit
def _matrix_kernel(q):
    # One owner for quaternion -> matrix: gfxlab.transforms (which also normalises).
    return rotation_from_quaternion(check_finite(q, "q"))


def quat_rotate(
    q: Float[Array, "*batch 4"], points: Float[Array, "*batch N 3"]
) -> Float[Array, "*batch N 3"]:
    """Rotate 3D `points` by unit quaternions `q` (`q` broadcasts over the point axis)."""
    return _rotate_kernel(_quats(q), _vectors(points, "points", 3, "3D points"))


@checked_jit
def _rotate_kernel(q, points):
    q, points = _finite({"q": q, "points": points})
    return jnp.einsum("...ij,...nj->...ni", rotation_from_quaternion(q), points)


def quat_log(q: Float[Array, "*batch 4"]) -> Float[Array, "*batch 3"]:
    """Logarithm of unit quaternions: the vector `(angle / 2) * axis`.

    **Arguments:**

    - `q`: `(..., 4)` non-zero quaternions (unit for a rotation; the zero quaternion
      has no logarithm and is an error).

    **Returns:** `(..., 3)` vectors.
    """
    return _log_kernel(_quats(q))


@checked_jit
def _log_kernel(q):
    return _log(_nonzero(check_finite(q, "q"), "q"))


def quat_exp(v: Float[Array, "*batch 3"]) -> Quat:
    """Exponential of pure quaternions `(0, v)`: `(cos|v|, sin|v| v/|v|)`."""
    return _exp_kernel(_vectors(v, "v", 3, "a 3-vector (pure quaternion)"))


@checked_jit
def _exp_kernel(v):
    return _exp(check_finite(v, "v"))


def slerp(
    q0: Float[Array, "*batch 4"],
    q1: Float[Array, "*batch 4"],
    u: Float[Array, "*batch"],
    *,
    shortest: bool = True,
) -> Quat:
    """Spherical linear interpolation between unit quaternions.

    `slerp(q0, q1, u) = (sin((1-u) W) q0 + sin(u W) q1) / sin W` with `cos W = q0 . q1`:
    constant angular speed along the great arc, unit length throughout.

    **Arguments:**

    - `q0`, `q1`: `(..., 4)` unit quaternions (broadcast together).
    - `u`: interpolation parameter, `0` gives `q0`, `1` gives `q1`; broadcast against
      the batch shape.
    - `shortest`: flip `q1` to `-q1` when that is closer (the shorter of the two arcs
      for the same pair of rotations). With `shortest=False` and antipodal keys
      (`q1 = -q0`: a full turn, no unique great circle) the path is the great circle
      through `q0` and the perpendicular `(-x, w, -z, y)` of `q0 = (w, x, y, z)`: unit
      length throughout, with finite gradients.

    **Returns:** `(..., 4)` unit quaternions.

    Called eagerly it is one compiled call; NaN/inf inputs raise `ValueError` naming
    the argument (under a user's `jax.jit`, through `equinox.error_if`).
    """
    q0, q1, u = _quats(q0, "q0"), _quats(q1, "q1"), as_float(u, "u")
    static_bool(shortest, "shortest")
    return _slerp_kernel(q0, q1, u, shortest=shortest)


@functools.partial(checked_jit, static_argnames=("shortest",))
def _slerp_kernel(q0, q1, u, *, shortest):
    return _slerp(*_finite({"q0": q0, "q1": q1, "u": u}), shortest=shortest)


def _slerp(q0, q1, u, *, shortest):
    dot = jnp.sum(q0 * q1, axis=-1, keepdims=True)
    if shortest:
        q1 = jnp.where(dot < 0, -q1, q1)
        dot = jnp.abs(dot)
    u = u[..., None]
    tol = 64 * jnp.finfo(dot.dtype).eps
    # Antipodal keys (q1 = -q0, the same rotation turned by a full turn) have no unique
    # great circle: take the one through `perp`, a unit quaternion perpendicular to
    # q0 chosen smoothly from it, in two quarter-turn arcs q0 -> perp -> q1.
    lengths = safe_norm(q0, keepdims=True) * safe_norm(q1, keepdims=True)
    anti = dot < (-1 + tol) * lengths  # scale-free, so a small perturbation keeps the branch
    w, x, y, z = jnp.moveaxis(q0, -1, 0)
    perp = jnp.stack([-x, w, -z, y], axis=-1)
    first = _arc(q0, perp, jnp.sum(q0 * perp, axis=-1, keepdims=True), 2 * u, tol)
    perp_dot = jnp.where(anti, jnp.sum(perp * q1, axis=-1, keepdims=True), 0.0)
    second = _arc(perp, q1, perp_dot, 2 * u - 1, tol)
    through_perp = jnp.where(u <= 0.5, first, second)
    return jnp.where(anti, through_perp, _arc(q0, q1, jnp.where(anti, 0.0, dot), u, tol))


def _arc(q0, q1, dot, u, tol):
    """Slerp on the great circle through `q0` and `q1` (not antipodal: `dot > -1`)."""
    near = dot > 1 - tol
    omega = jnp.arccos(jnp.clip(jnp.where(near, 0.5, dot), -1.0, 1.0))
    sin_omega = jnp.sin(omega)
    a = jnp.where(near, 1 - u, jnp.sin((1 - u) * omega) / sin_omega)
    b = jnp.where(near, u, jnp.sin(u * omega) / sin_omega)
    out = a * q0 + b * q1
    # The nearly-parallel branch is a lerp: renormalise it.
    return jnp.where(near, safe_normalize(out), out)


def squad_inner(
    q_prev: Float[Array, "*batch 4"], q: Float[Array, "*batch 4"], q_next: Float[Array, "*batch 4"]
) -> Quat:
    """The inner control quaternion of squad at key `q` with neighbours `q_prev`, `q_next`:
    `s = q exp(-(log(q^-1 q_next) + log(q^-1 q_prev)) / 4)`."""
    return _squad_inner_kernel(_quats(q_prev, "q_prev"), _quats(q, "q"), _quats(q_next, "q_next"))


@checked_jit
def _squad_inner_kernel(q_prev, q, q_next):
    q_prev, q, q_next = _finite({"q_prev": q_prev, "q": q, "q_next": q_next})
    q = _nonzero(q, "q")
    return _squad_inner(q_prev, q, q_next)


def _squad_inner(q_prev, q, q_next):
    inv = _conj(q)
    a = _log(_mul(inv, q_next))
    b = _log(_mul(inv, q_prev))
    return _mul(q, _exp(-(a + b) / 4))


def squad(
    q0: Float[Array, "*batch 4"],
    s0: Float[Array, "*batch 4"],
    s1: Float[Array, "*batch 4"],
    q1: Float[Array, "*batch 4"],
    u: Float[Array, "*batch"],
) -> Quat:
    """Spherical quadrangle interpolation (Shoemake's squad), a C1 curve through keys.

    `squad = slerp(slerp(q0, q1, u), slerp(s0, s1, u), 2u(1-u))`, with `s0`, `s1` the inner
    quaternions from `squad_inner`. Without shortest-arc flips inside, so the keys should
    already be sign-aligned (consecutive dot products >= 0), as `interpolate_rotations`
    does.
    """
    args = {n: _quats(x, n) for n, x in (("q0", q0), ("s0", s0), ("s1", s1), ("q1", q1))}
    return _squad_kernel(*args.values(), as_float(u, "u"))


@checked_jit
def _squad_kernel(q0, s0, s1, q1, u):
    return _squad(*_finite({"q0": q0, "s0": s0, "s1": s1, "q1": q1, "u": u}))


def _squad(q0, s0, s1, q1, u):
    outer = _slerp(q0, q1, u, shortest=False)
    inner = _slerp(s0, s1, u, shortest=False)
    return _slerp(outer, inner, 2 * u * (1 - u), shortest=False)
