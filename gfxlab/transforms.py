"""Homogeneous 2D and 3D transforms.

Column-vector convention: a transform is a matrix `M` applied as `M @ p`, so 2D
transforms are 3x3 and 3D transforms are 4x4. Point sets are arrays `(..., N, d)`.
The size of a matrix is inferred from its arguments: a 2-vector offset gives a 3x3
translation, a 3-vector a 4x4 one. Every constructor broadcasts over leading batch
dimensions of its arguments, so `translate(offsets)` with `offsets` of shape `(K, 2)`
gives `K` matrices of shape `(K, 3, 3)`.

The textbook's row-vector form `p' = p . T` uses the transpose: `T = M.T`.
`compose(A, B, C)` means "A first, then B, then C", i.e. `C @ B @ A`.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab import transforms as tf
    >>> square = jnp.array([[-.5, -.5], [.5, -.5], [.5, .5], [-.5, .5]])
    >>> M = tf.compose(tf.translate([1.0, 1.0]), tf.rotate(jnp.pi / 2))
    >>> tf.apply(M, square).round(6).tolist()  # the exam's Q2b: A'(-1/2, 1/2), B'(-1/2, 3/2)
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
    checked_unit,
    common_finite,
    finite_float,
    safe_divide,
)
from ._rotations import (
    ROTATION_REPRESENTATIONS,
    rotation_from_6d,
    rotation_from_axis_angle,
    rotation_from_quaternion,
    rotation_matrix,
    rotation_to_6d,
    rotation_to_axis_angle,
    rotation_to_quaternion,
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
    "reflection",
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
    k = checked_unit(axis, "`axis` must be a non-zero 3-vector")
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
    `[[s, center * (1 - s)], [0, 1]]` (the exam's Q2c).

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
    `xz, yz, zx, zy` makes it 3D (4x4). For a general linear part (such as the exam's
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


def reflection(
    normal: Float[Array, "*batch d"], *, point: Float[Array, "*batch d"] | None = None
) -> Matrix:
    """Reflection about the line (2D) or plane (3D) with the given `normal`.

    The mirror passes through `point` (default the origin). For example
    `reflection([0, 1])` mirrors about the x axis (y -> -y), `reflection([1, -1])` about
    the line y = x, and `reflection([0, 0, 1])` about the xy plane.

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
    n = checked_unit(normal, "`normal` must be a non-zero vector")
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

    **Returns:** the transformed points, same shape as `points`. A point that maps to
    `w = 0` (at infinity, e.g. on the camera plane of a perspective matrix) comes back
    large but finite: `|w|` is clamped to machine epsilon, so values and gradients stay
    finite in a fit. Test `w` yourself (the last row of `matrix`) where that matters.
    """
    matrix, points = common_finite(matrix, points, names=("matrix", "points"))
    if matrix.ndim < 2 or matrix.shape[-1] != matrix.shape[-2] or matrix.shape[-1] < 2:
        raise ValueError(
            "`matrix` must be a square homogeneous matrix, 3x3 for 2D points or 4x4 for 3D "
            f"(or a batch of them, shape (..., d+1, d+1)), got shape {matrix.shape}"
        )
    d = matrix.shape[-1] - 1
    check_last_dim(points, "points", (d,), f"{d}D points for a {d + 1}x{d + 1} matrix")
    matrix_batch = matrix.shape[:-2]
    points_batch = points.shape[:-2]
    try:
        jnp.broadcast_shapes(matrix_batch, points_batch)
    except ValueError:
        raise ValueError(
            f"the batch shapes of `matrix` {matrix_batch} and `points` {points_batch} (all "
            f"but the last two axes; shapes {matrix.shape} and {points.shape}) do not broadcast"
        ) from None
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
    """The 2D window-to-viewport (workstation) transform (the exam's Q2a).

    Translate the window's lower-left corner to the origin, scale by
    `s = viewport size / window size`, translate to the viewport's lower-left corner:
    `T(v_min) @ S(s) @ T(-w_min)`.

    **Arguments:**

    - `window`: `(xmin, ymin, xmax, ymax)` in world coordinates, positive width and height.
    - `viewport`: `(xmin, ymin, xmax, ymax)` in device coordinates, positive width and
      height (to flip y for a y-down device, compose the result with `reflection`).

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


def rotation(
    values: Float[Array, "*batch k"], *, representation: str = "axis_angle"
) -> Float[Array, "*batch 4 4"]:
    """The homogeneous 4x4 rotation of `rotation_matrix(values, representation)`."""
    return _linear(rotation_matrix(values, representation))
