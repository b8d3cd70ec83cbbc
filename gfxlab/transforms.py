"""Homogeneous 2D and 3D transforms.

Column-vector convention: a transform is a matrix `M` applied as `M @ p`, so 2D
transforms are 3x3 and 3D transforms are 4x4. Point sets are arrays `(..., N, d)`.
The size of a matrix is inferred from its arguments: a 2-vector offset gives a 3x3
translation, a 3-vector a 4x4 one. Every constructor broadcasts over leading batch
dimensions of its arguments, so `translate(offsets)` with `offsets` of shape `(K, 2)`
gives `K` matrices of shape `(K, 3, 3)`.

The textbook's row-vector form `p' = p . T` uses the transpose: `T = M.T`.
`compose(A, B, C)` means "A first, then B, then C", i.e. `C @ B @ A`.

Example:
    >>> import jax.numpy as jnp
    >>> from gfxlab import transforms as tf
    >>> square = jnp.array([[-.5, -.5], [.5, -.5], [.5, .5], [-.5, .5]])
    >>> M = tf.compose(tf.translate([1.0, 1.0]), tf.rotate(jnp.pi / 2))
    >>> tf.apply(M, square).round(6).tolist()  # the seed's Q2b: A'(-1/2, 1/2), B'(-1/2, 3/2)
    [[-0.5, 0.5], [-0.5, 1.5], [-1.5, 1.5], [-1.5, 0.5]]
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._checks import (
    check_last_dim,
    check_rect,
    check_shape,
    checked_jit,
    common_finite,
    finite_float,
    safe_divide,
    safe_norm,
    safe_normalize,
    value_error_if,
)

__all__ = [
    "translate",
    "rotate",
    "rotate_x",
    "rotate_y",
    "rotate_z",
    "rotate_axis",
    "scale",
    "shear",
    "linear",
    "reflect",
    "compose",
    "apply",
    "to_homogeneous",
    "from_homogeneous",
    "window_to_viewport",
    "ROTATION_REPRESENTATIONS",
    "rotation",
    "rotation_matrix",
    "rotation_from_axis_angle",
    "rotation_from_quaternion",
    "rotation_from_6d",
    "rotation_to_axis_angle",
    "rotation_to_quaternion",
    "rotation_to_6d",
]

Matrix = Float[Array, "*batch n n"]


def _embed(linear_part: jax.Array, offset: jax.Array | None = None) -> jax.Array:
    """The homogeneous matrix `[[L, t], [0, 1]]` for linear part `(..., d, d)`."""
    d = linear_part.shape[-1]
    batch = linear_part.shape[:-2]
    if offset is None:
        offset = jnp.zeros(batch + (d,), linear_part.dtype)
    batch = jnp.broadcast_shapes(batch, offset.shape[:-1])
    linear_part = jnp.broadcast_to(linear_part, batch + (d, d))
    offset = jnp.broadcast_to(offset, batch + (d,)).astype(linear_part.dtype)
    top = jnp.concatenate([linear_part, offset[..., :, None]], axis=-1)
    bottom = jnp.broadcast_to(jnp.eye(1, d + 1, d, dtype=linear_part.dtype), batch + (1, d + 1))
    return jnp.concatenate([top, bottom], axis=-2)


def translate(offset: Float[Array, "*batch d"]) -> Matrix:
    """Translation by `offset`.

    **Arguments:**

    - `offset`: `(..., 2)` for a 3x3 (2D) matrix or `(..., 3)` for a 4x4 (3D) matrix.

    **Returns:** the homogeneous matrix `(..., d+1, d+1)`.
    """
    offset = finite_float(offset, "offset")
    check_last_dim(offset, "offset", (2, 3), "a 2D or 3D offset")
    return _translate(offset)


# Each public function checks its arguments in Python and runs its array work as one
# compiled call (`checked_jit`: a failed value check is the same ValueError as eagerly).
@checked_jit
def _translate(offset):
    return _embed(jnp.eye(offset.shape[-1], dtype=offset.dtype), offset)


def _rotation_2d(angle: jax.Array) -> jax.Array:
    c, s = jnp.cos(angle), jnp.sin(angle)
    return jnp.stack([jnp.stack([c, -s], -1), jnp.stack([s, c], -1)], -2)


def rotate(angle: Float[Array, "*batch"]) -> Matrix:
    """2D rotation about the origin, counter-clockwise by `angle` radians (3x3)."""
    return _rotate(finite_float(angle, "angle"))


@checked_jit
def _rotate(angle):
    return _embed(_rotation_2d(angle))


def _rotation_about(axis_index: int, angle: jax.Array) -> jax.Array:
    return _rotation_about_core(finite_float(angle, "angle"), axis_index)


@functools.partial(checked_jit, static_argnums=1)
def _rotation_about_core(angle: jax.Array, axis_index: int) -> jax.Array:
    # Rotation in the plane of the two other axes, right-handed about `axis_index`.
    i, j = [(1, 2), (2, 0), (0, 1)][axis_index]
    c, s = jnp.cos(angle), jnp.sin(angle)
    m = jnp.broadcast_to(jnp.eye(3, dtype=angle.dtype), angle.shape + (3, 3))
    m = m.at[..., i, i].set(c).at[..., j, j].set(c)
    m = m.at[..., i, j].set(-s).at[..., j, i].set(s)
    return _embed(m)


def rotate_x(angle: Float[Array, "*batch"]) -> Matrix:
    """3D rotation by `angle` radians about the x axis (right-handed: y towards z), 4x4."""
    return _rotation_about(0, angle)


def rotate_y(angle: Float[Array, "*batch"]) -> Matrix:
    """3D rotation by `angle` radians about the y axis (right-handed: z towards x), 4x4."""
    return _rotation_about(1, angle)


def rotate_z(angle: Float[Array, "*batch"]) -> Matrix:
    """3D rotation by `angle` radians about the z axis (right-handed: x towards y), 4x4."""
    return _rotation_about(2, angle)


def rotate_axis(axis: Float[Array, "*batch 3"], angle: Float[Array, "*batch"]) -> Matrix:
    """3D rotation by `angle` radians about `axis` through the origin (Rodrigues), 4x4.

    **Arguments:**

    - `axis`: `(..., 3)`, any non-zero length (it is normalised).
    - `angle`: radians, right-handed about `axis`.
    """
    axis, angle = common_finite(axis, angle, names=("axis", "angle"))
    check_last_dim(axis, "axis", (3,), "a 3D direction")
    return _rotate_axis(axis, angle)


@checked_jit
def _rotate_axis(axis, angle):
    length = safe_norm(axis, keepdims=True)
    axis = value_error_if(axis, length == 0, "`axis` must be a non-zero 3-vector")
    k = axis / jnp.where(length == 0, 1.0, length)
    zero = jnp.zeros_like(k[..., 0])
    cross = jnp.stack(
        [
            jnp.stack([zero, -k[..., 2], k[..., 1]], -1),
            jnp.stack([k[..., 2], zero, -k[..., 0]], -1),
            jnp.stack([-k[..., 1], k[..., 0], zero], -1),
        ],
        -2,
    )
    c, s = jnp.cos(angle)[..., None, None], jnp.sin(angle)[..., None, None]
    outer = k[..., :, None] * k[..., None, :]
    return _embed(c * jnp.eye(3, dtype=k.dtype) + s * cross + (1 - c) * outer)


def scale(
    factors: Float[Array, "*batch d"], *, center: Float[Array, "*batch d"] | None = None
) -> Matrix:
    """Scaling by `factors` about the origin, or about the fixed point `center`.

    About a fixed point this is `T(center) @ S(factors) @ T(-center)`, i.e.
    `[[s, center * (1 - s)], [0, 1]]` (the seed's Q2c).

    **Arguments:**

    - `factors`: `(..., 2)` or `(..., 3)` scale factors per axis.
    - `center`: the fixed point, same size as `factors`; default the origin.
    """
    factors = finite_float(factors, "factors")
    d = check_last_dim(factors, "factors", (2, 3), "one scale factor per axis")
    if center is not None:
        factors, center = common_finite(factors, center, names=("factors", "center"))
        if center.shape[-1:] != (d,):
            raise ValueError(
                f"`center` must have shape (..., {d}) like `factors`, got {center.shape}"
            )
    return _scale(factors, center)


@checked_jit
def _scale(factors, center):
    linear_part = factors[..., :, None] * jnp.eye(factors.shape[-1], dtype=factors.dtype)
    return _embed(linear_part, None if center is None else center * (1 - factors))


_SHEAR_3D = ("xz", "yz", "zx", "zy")


def shear(
    *,
    xy: float | jax.Array = 0.0,
    yx: float | jax.Array = 0.0,
    xz: float | jax.Array | None = None,
    yz: float | jax.Array | None = None,
    zx: float | jax.Array | None = None,
    zy: float | jax.Array | None = None,
) -> Matrix:
    """Shear: each coordinate gains a multiple of the others.

    A factor named `ab` adds `ab * b` to coordinate `a`; e.g. `shear(xy=k)` is the 2D
    x-shear `x' = x + k y`. With only `xy`/`yx` the result is 2D (3x3); giving any of
    `xz, yz, zx, zy` makes it 3D (4x4). For a general linear part (such as the seed's
    Q2f matrix, which is not a pure shear) use `linear`.

    **Returns:** the homogeneous shear matrix.
    """
    three_d = any(v is not None for v in (xz, yz, zx, zy))
    named = {"xy": xy, "yx": yx, "xz": xz, "yz": yz, "zx": zx, "zy": zy}
    values = {  # None means "absent" only for the 3D factors
        k: finite_float(0.0 if v is None and k in _SHEAR_3D else v, k) for k, v in named.items()
    }
    return _shear(values, three_d)


@functools.partial(checked_jit, static_argnums=1)
def _shear(values: dict, three_d: bool):
    dtype = jnp.result_type(*values.values())
    batch = jnp.broadcast_shapes(*(v.shape for v in values.values()))
    d = 3 if three_d else 2
    m = jnp.broadcast_to(jnp.eye(d, dtype=dtype), batch + (d, d))
    axes = "xyz"
    for key, value in values.items():
        if d == 2 and key in _SHEAR_3D:
            continue
        m = m.at[..., axes.index(key[0]), axes.index(key[1])].set(
            jnp.broadcast_to(value.astype(dtype), batch)
        )
    return _embed(m)


def linear(matrix: Float[Array, "*batch d d"]) -> Matrix:
    """A general linear map `(..., d, d)` (d = 2 or 3) as a homogeneous matrix.

    In the column convention. A textbook matrix `T` written for row vectors
    (`p' = p . T`) becomes `linear(T.T)`.
    """
    matrix = finite_float(matrix, "matrix")
    if matrix.ndim < 2 or matrix.shape[-1] != matrix.shape[-2] or matrix.shape[-1] not in (2, 3):
        raise ValueError(f"`matrix` must have shape (..., 2, 2) or (..., 3, 3), got {matrix.shape}")
    return _linear(matrix)


_linear = checked_jit(lambda matrix: _embed(matrix))


def reflect(
    normal: Float[Array, "*batch d"], *, point: Float[Array, "*batch d"] | None = None
) -> Matrix:
    """Reflection about the line (2D) or plane (3D) with the given `normal`.

    The mirror passes through `point` (default the origin). For example
    `reflect([0, 1])` mirrors about the x axis (y -> -y), `reflect([1, -1])` about
    the line y = x, and `reflect([0, 0, 1])` about the xy plane.

    **Arguments:**

    - `normal`: `(..., 2)` or `(..., 3)`, non-zero (it is normalised).
    - `point`: a point on the mirror, same size as `normal`.
    """
    normal = finite_float(normal, "normal")
    d = check_last_dim(normal, "normal", (2, 3), "a 2D or 3D normal")
    if point is not None:
        normal, point = common_finite(normal, point, names=("normal", "point"))
        if point.shape[-1:] != (d,):
            raise ValueError(f"`point` must have shape (..., {d}) like `normal`, got {point.shape}")
    return _reflect(normal, point)


@checked_jit
def _reflect(normal, point):
    length = safe_norm(normal, keepdims=True)
    normal = value_error_if(normal, length == 0, "`normal` must be a non-zero vector")
    n = normal / jnp.where(length == 0, 1.0, length)
    householder = jnp.eye(n.shape[-1], dtype=n.dtype) - 2 * n[..., :, None] * n[..., None, :]
    if point is None:
        return _embed(householder)
    # p' = H (p - q) + q  =>  offset = q - H q = 2 n (n . q)
    offset = 2 * n * jnp.sum(n * point, axis=-1, keepdims=True)
    return _embed(householder, offset)


def compose(*matrices: Matrix) -> Matrix:
    """Chain transforms in the order they are applied: `compose(A, B, C) == C @ B @ A`.

    All matrices must have the same size (all 3x3 or all 4x4); leading batch
    dimensions broadcast.
    """
    if not matrices:
        raise ValueError("`compose` needs at least one matrix")
    mats = [finite_float(m, f"matrices[{i}]") for i, m in enumerate(matrices)]
    size = mats[0].shape[-2:]
    for i, m in enumerate(mats):
        if m.ndim < 2 or m.shape[-1] != m.shape[-2] or m.shape[-1] not in (3, 4):
            raise ValueError(f"`matrices[{i}]` must be (..., 3, 3) or (..., 4, 4), got {m.shape}")
        if m.shape[-2:] != size:
            raise ValueError(
                f"cannot compose a {size[0]}x{size[1]} matrix with a "
                f"{m.shape[-2]}x{m.shape[-1]} one (`matrices[{i}]`): mix of 2D and 3D transforms"
            )
    return _compose(mats)


@checked_jit
def _compose(mats):
    out = mats[0]
    for m in mats[1:]:
        out = m @ out
    return out


def to_homogeneous(points: Float[Array, "*batch N d"]) -> Float[Array, "*batch N d+1"]:
    """Append a homogeneous coordinate `w = 1`."""
    return _to_homogeneous(finite_float(points, "points"))


@checked_jit
def _to_homogeneous(points):
    return jnp.concatenate([points, jnp.ones_like(points[..., :1])], axis=-1)


def from_homogeneous(points: Float[Array, "*batch N d+1"]) -> Float[Array, "*batch N d"]:
    """Divide by the last coordinate and drop it (the perspective divide).

    A point with `w = 0` lies at infinity; it comes back large but finite, with
    finite gradients, rather than as inf or NaN.
    """
    return _from_homogeneous(finite_float(points, "points"))


@checked_jit
def _from_homogeneous(points):
    return safe_divide(points[..., :-1], points[..., -1:])


def apply(matrix: Matrix, points: Float[Array, "*batch N d"]) -> Float[Array, "*batch N d"]:
    """Apply a homogeneous transform to a set of points, with the perspective divide.

    **Arguments:**

    - `matrix`: `(..., d+1, d+1)`.
    - `points`: `(..., N, d)` (a single point `(d,)` is accepted too).

    **Returns:** the transformed points, same shape as `points`.
    """
    matrix, points = common_finite(matrix, points, names=("matrix", "points"))
    if matrix.ndim < 2 or matrix.shape[-1] != matrix.shape[-2]:
        raise ValueError(f"`matrix` must be square (..., n, n), got shape {matrix.shape}")
    d = matrix.shape[-1] - 1
    check_last_dim(points, "points", (d,), f"{d}D points for a {d + 1}x{d + 1} matrix")
    return _apply(matrix, points)


@checked_jit
def _apply(matrix, points):
    single = points.ndim == 1
    pts = points[None] if single else points
    moved = jnp.einsum("...ij,...nj->...ni", matrix, _to_homogeneous(pts))
    out = _from_homogeneous(moved)
    return out[..., 0, :] if single else out


def window_to_viewport(
    window: Float[Array, "4"], viewport: Float[Array, "4"]
) -> Float[Array, "3 3"]:
    """The 2D window-to-viewport (workstation) transform (the seed's Q2a).

    Translate the window's lower-left corner to the origin, scale by
    `s = viewport size / window size`, translate to the viewport's lower-left corner:
    `T(v_min) @ S(s) @ T(-w_min)`.

    **Arguments:**

    - `window`: `(xmin, ymin, xmax, ymax)` in world coordinates, positive width and height.
    - `viewport`: `(xmin, ymin, xmax, ymax)` in device coordinates, positive width and
      height (to flip y for a y-down device, swap the result with `reflect`).

    **Returns:** the 3x3 matrix.
    """
    window = check_rect(window, "window")
    viewport = check_rect(viewport, "viewport")
    window, viewport = common_finite(window, viewport, names=("window", "viewport"))
    check_shape(viewport, "viewport", (4,))
    return _window_to_viewport(window, viewport)


@checked_jit
def _window_to_viewport(window, viewport):
    s = (viewport[2:] - viewport[:2]) / (window[2:] - window[:2])
    return _embed(jnp.diag(s), viewport[:2] - s * window[:2])


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
    gram = jnp.swapaxes(matrix, -1, -2) @ matrix
    tol = 1e-5 if matrix.dtype == jnp.float64 else 1e-3
    bad = (jnp.max(jnp.abs(gram - jnp.eye(3)), axis=(-2, -1)) > tol) | (jnp.linalg.det(matrix) <= 0)
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


def rotation(
    values: Float[Array, "*batch k"], *, representation: str = "axis_angle"
) -> Float[Array, "*batch 4 4"]:
    """The homogeneous 4x4 rotation of `rotation_matrix(values, representation)`."""
    return _linear(rotation_matrix(values, representation))
