"""Rotation parametrisations (private; public through `gfxlab.transforms`).

Axis-angle (rotation vector), unit quaternion `(w, x, y, z)` and the continuous 6D
representation, each to and from 3x3 rotation matrices, with finite gradients everywhere
(the identity included). Each function checks its argument in Python and runs its array
work as one compiled call.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._checks import (
    check_last_dim,
    check_shape,
    checked_jit,
    finite_float,
    safe_norm,
    safe_normalize,
    value_error_if,
)

# --------------------------------------------------------------------------------------
# Rotation parametrisations: axis-angle (rotation vector), unit quaternion (w, x, y, z),
# and the continuous 6D representation of Zhou et al. (CVPR 2019). All map to 3x3
# rotation matrices with finite gradients everywhere, the identity included.

#: Names accepted by `rotation_matrix` and `rotation`, with the size of their last axis.
ROTATION_REPRESENTATIONS = {"axis_angle": 3, "quaternion": 4, "6d": 6, "matrix": 9}

_SMALL_ANGLE_SQ = 1e-4  # below this squared angle the Taylor series are exact to ~1e-17


def _skew(v: jax.Array) -> jax.Array:
    zero = jnp.zeros_like(v[..., 0])
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    rows = [[zero, -z, y], [z, zero, -x], [-y, x, zero]]
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def _from_axis_angle(rotvec, _name: str) -> jax.Array:
    rotvec = finite_float(rotvec, _name)
    check_last_dim(rotvec, _name, (3,), "a rotation vector angle * axis")
    return _axis_angle_matrix(rotvec)


@checked_jit
def _axis_angle_matrix(rotvec):
    t2 = jnp.sum(rotvec * rotvec, axis=-1)[..., None, None]
    small = t2 < _SMALL_ANGLE_SQ
    t = jnp.sqrt(jnp.where(small, 1.0, t2))
    sinc = jnp.where(small, 1 - t2 / 6 + t2 * t2 / 120, jnp.sin(t) / t)
    half = jnp.where(small, 0.5 - t2 / 24 + t2 * t2 / 720, 2 * jnp.sin(t / 2) ** 2 / (t * t))
    k = _skew(rotvec)
    return jnp.eye(3, dtype=rotvec.dtype) + sinc * k + half * (k @ k)


def rotation_from_axis_angle(rotvec: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3 3"]:
    """The 3x3 rotation by the rotation vector `rotvec = angle * unit_axis` (Rodrigues).

    `R = I + (sin t / t) K + ((1 - cos t) / t^2) K^2` with `K` the cross-product matrix of
    `rotvec` and `t = |rotvec|`; near `t = 0` both coefficients use their Taylor series
    (double `where`), so values and gradients are exact and finite at the identity.

    **Arguments:**

    - `rotvec`: `(..., 3)` finite rotation vectors (radians).

    **Returns:** `(..., 3, 3)` rotation matrices.
    """
    return _from_axis_angle(rotvec, "rotvec")


def _from_quaternion(q, _name: str) -> jax.Array:
    q = finite_float(q, _name)
    check_last_dim(q, _name, (4,), "a quaternion (w, x, y, z)")
    return _quaternion_matrix(q, _name)


@functools.partial(checked_jit, static_argnums=1)
def _quaternion_matrix(q, _name: str):
    n2 = jnp.sum(q * q, axis=-1)
    q = value_error_if(q, n2 == 0, f"`{_name}` must be a non-zero quaternion")
    s = 2 / jnp.where(n2 == 0, 1.0, n2)
    w, x, y, z = jnp.moveaxis(q, -1, 0)
    rows = [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def rotation_from_quaternion(q: Float[Array, "*batch 4"]) -> Float[Array, "*batch 3 3"]:
    """The 3x3 rotation of the quaternion `q = (w, x, y, z)` (scalar first, as in
    `gfxlab.animation`); `q` need not be unit length (it is normalised), so it can be
    fitted freely, but it must not be zero. `q` and `-q` give the same rotation.

    **Arguments:**

    - `q`: `(..., 4)` finite, non-zero quaternions.

    **Returns:** `(..., 3, 3)` rotation matrices.
    """
    return _from_quaternion(q, "q")


def _from_6d(r6, _name: str) -> jax.Array:
    r6 = finite_float(r6, _name)
    check_last_dim(r6, _name, (6,), "two 3-vectors (a1, a2)")
    return _6d_matrix(r6, _name)


@functools.partial(checked_jit, static_argnums=1)
def _6d_matrix(r6, _name: str):
    a1, a2 = r6[..., :3], r6[..., 3:]
    b1 = safe_normalize(a1)
    rest = a2 - jnp.sum(b1 * a2, axis=-1, keepdims=True) * b1
    scale_ = jnp.maximum(safe_norm(a1), safe_norm(a2))
    degenerate = safe_norm(rest) <= 1e-12 * jnp.where(scale_ > 0, scale_, 1.0)
    b2 = safe_normalize(
        value_error_if(
            rest, degenerate, f"`{_name}` must hold two linearly independent 3-vectors (a1, a2)"
        )
    )
    return jnp.stack([b1, b2, jnp.cross(b1, b2)], axis=-1)


def rotation_from_6d(r6: Float[Array, "*batch 6"]) -> Float[Array, "*batch 3 3"]:
    """The 3x3 rotation of the continuous 6D representation (Zhou et al., 2019).

    `r6 = (a1, a2)`, two 3-vectors, is turned into the first two columns of `R` by
    Gram-Schmidt: `b1 = a1 / |a1|`, `b2 = normalize(a2 - (b1 . a2) b1)`, and the third
    column is `b3 = b1 x b2`. Continuous and surjective onto rotations, so it is the
    representation of choice to fit (`rotation_to_6d` gives the first two columns).

    **Arguments:**

    - `r6`: `(..., 6)` finite, with `a1` and `a2` linearly independent.

    **Returns:** `(..., 3, 3)` rotation matrices.
    """
    return _from_6d(r6, "r6")


def _check_rotation(matrix: jax.Array, name: str) -> jax.Array:
    matrix = finite_float(matrix, name)
    check_shape(matrix, name, (..., 3, 3))
    return _rotation_checked(matrix, name)


@functools.partial(checked_jit, static_argnums=1)
def _rotation_checked(matrix, name: str):
    # The check needs no derivative; the triple product is the 3x3 determinant without
    # an LU factorisation (which would make every gradient program much larger).
    m = jax.lax.stop_gradient(matrix)
    gram = jnp.swapaxes(m, -1, -2) @ m
    tol = 1e-5 if matrix.dtype == jnp.float64 else 1e-3
    det = jnp.sum(m[..., 0, :] * jnp.cross(m[..., 1, :], m[..., 2, :]), axis=-1)
    bad = (jnp.max(jnp.abs(gram - jnp.eye(3)), axis=(-2, -1)) > tol) | (det <= 0)
    return value_error_if(matrix, bad, f"`{name}` must be a rotation matrix (orthonormal, det +1)")


def rotation_to_quaternion(matrix: Float[Array, "*batch 3 3"]) -> Float[Array, "*batch 4"]:
    """The unit quaternion `(w, x, y, z)` with `w >= 0` of a 3x3 rotation matrix
    (Shepperd's method: the best-conditioned of four formulas, chosen per matrix)."""
    return _quaternion_of(_check_rotation(matrix, "matrix"))


@checked_jit
def _quaternion_of(r):
    d0, d1, d2 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    t = jnp.stack([1 + d0 + d1 + d2, 1 + d0 - d1 - d2, 1 - d0 + d1 - d2, 1 - d0 - d1 + d2], -1)
    half = 0.5 * jnp.sqrt(jnp.maximum(t, 1e-6))  # the chosen one has t >= 1
    a, b = r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0]
    c, e = r[..., 1, 0] - r[..., 0, 1], r[..., 0, 1] + r[..., 1, 0]
    f, g = r[..., 0, 2] + r[..., 2, 0], r[..., 1, 2] + r[..., 2, 1]
    h0, h1, h2, h3 = (half[..., k] for k in range(4))
    candidates = jnp.stack(
        [
            jnp.stack([h0, a / (4 * h0), b / (4 * h0), c / (4 * h0)], -1),
            jnp.stack([a / (4 * h1), h1, e / (4 * h1), f / (4 * h1)], -1),
            jnp.stack([b / (4 * h2), e / (4 * h2), h2, g / (4 * h2)], -1),
            jnp.stack([c / (4 * h3), f / (4 * h3), g / (4 * h3), h3], -1),
        ],
        -2,
    )
    choice = jax.nn.one_hot(jnp.argmax(t, axis=-1), 4, dtype=r.dtype)
    q = jnp.sum(choice[..., :, None] * candidates, axis=-2)
    q = q * jnp.where(q[..., :1] < 0, -1.0, 1.0)
    return safe_normalize(q)


def rotation_to_axis_angle(matrix: Float[Array, "*batch 3 3"]) -> Float[Array, "*batch 3"]:
    """The rotation vector `angle * unit_axis` (angle in [0, pi]) of a rotation matrix;
    the inverse of `rotation_from_axis_angle`, with finite gradients at the identity."""
    return _axis_angle_of(_check_rotation(matrix, "matrix"))


@checked_jit
def _axis_angle_of(r):
    q = _quaternion_of(r)
    w, v = q[..., :1], q[..., 1:]
    n2 = jnp.sum(v * v, axis=-1, keepdims=True)
    small = n2 < _SMALL_ANGLE_SQ
    n = jnp.sqrt(jnp.where(small, 1.0, n2))
    # angle / n with angle = 2 atan2(n, w); near n = 0 its series in n (w ~ 1 there)
    w_small = jnp.where(small, w, 1.0)
    series = 2 / w_small * (1 - n2 / (3 * w_small * w_small))
    factor = jnp.where(small, series, 2 * jnp.arctan2(n, w) / n)
    return factor * v


def rotation_to_6d(matrix: Float[Array, "*batch 3 3"]) -> Float[Array, "*batch 6"]:
    """The 6D representation of a rotation matrix: its first two columns `(a1, a2)`."""
    return _6d_of(_check_rotation(matrix, "matrix"))


_6d_of = checked_jit(lambda r: jnp.concatenate([r[..., :, 0], r[..., :, 1]], axis=-1))


def rotation_matrix(
    values: Float[Array, "*batch k"], representation: str = "axis_angle"
) -> Float[Array, "*batch 3 3"]:
    """A 3x3 rotation matrix from any parametrisation in `ROTATION_REPRESENTATIONS`:
    `"axis_angle"` (3), `"quaternion"` (4, `(w, x, y, z)`), `"6d"` (6) or `"matrix"`
    (a `(..., 3, 3)` rotation, checked and returned)."""
    return _rotation_matrix(values, representation, "values")


def _rotation_matrix(values, representation, name: str) -> jax.Array:
    """`rotation_matrix` whose errors name the argument `name`."""
    if not isinstance(representation, str) or representation not in ROTATION_REPRESENTATIONS:
        raise ValueError(
            f"`representation` must be one of {sorted(ROTATION_REPRESENTATIONS)}, "
            f"got {representation!r:.40}"
        )
    if representation == "matrix":
        return _check_rotation(values, name)
    convert = {"axis_angle": _from_axis_angle, "quaternion": _from_quaternion, "6d": _from_6d}
    return convert[representation](values, name)
