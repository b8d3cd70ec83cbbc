"""Cameras and projections, in OpenGL conventions.

Right-handed eye space, the camera at the origin looking down -z with y up; the
projection maps the view volume onto the canonical view volume `[-1, 1]^3` (NDC),
the near plane to z = -1 and the far plane to z = +1. All matrices are 4x4 and act
on column vectors (see `gfxlab.transforms`).

Pixel coordinates follow the project convention (y up, the centre of pixel column x,
row H-1-y at integer (x, y)); `ndc_to_pixels` maps NDC x, y onto them.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab.viewing import Camera
    >>> camera = Camera(jnp.array([0.0, 0.0, 5.0]), near=1.0, far=10.0)  # looks at the origin
    >>> on_near_and_far = jnp.array([[0.0, 0.0, 4.0], [0.0, 0.0, -5.0]])
    >>> camera.project(on_near_and_far).round(4).tolist()  # NDC z = -1 and +1
    [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from . import transforms as tf
from ._checks import (
    check_last_dim,
    check_range,
    checked_jit,
    checked_unit,
    common_finite,
    finite_float,
    follow_float,
    is_traced,
    safe_norm,
    static_shape,
    value_error_if,
)
from ._rotations import _rotation_matrix

__all__ = [
    "look_at",
    "orthographic",
    "frustum",
    "perspective",
    "project",
    "in_view_volume",
    "ndc_to_pixels",
    "plane_projection",
    "orthographic_view",
    "ORTHOGRAPHIC_VIEWS",
    "Camera",
]


def _unit(v: jax.Array, message: str, scale=None) -> jax.Array:
    return checked_unit(v, message, tiny=0.0 if scale is None else 1e-12 * scale)


def look_at(
    eye: Float[Array, "3"], target: Float[Array, "3"], up: Float[Array, "3"]
) -> Float[Array, "4 4"]:
    """The view matrix of a camera at `eye` looking at `target` (gluLookAt).

    It sends `eye` to the origin and `target` onto the negative z axis, with `up`
    projected to +y.

    **Arguments:**

    - `eye`, `target`, `up`: 3-vectors; `target != eye` and `up` not parallel to the
      viewing direction.
    """
    eye, target, up = common_finite(eye, target, up, names=("eye", "target", "up"))
    for name, v in (("eye", eye), ("target", target), ("up", up)):
        check_last_dim(v, name, (3,), "a 3D point or direction")
    return _look_at(eye, target, up)


# Each public function checks its arguments in Python and runs its array work (value
# checks included) as one compiled call; `checked_jit` raises a failed check's ValueError.
@checked_jit
def _look_at(eye, target, up):
    forward = _unit(target - eye, "`target` equals `eye`: the viewing direction is undefined")
    up_length = safe_norm(up, keepdims=True)
    right = _unit(
        jnp.cross(forward, up),
        "`up` must be non-zero and not parallel to the viewing direction `target - eye`",
        scale=up_length,
    )
    true_up = jnp.cross(right, forward)
    rotation = jnp.stack([right, true_up, -forward], axis=-2)
    offset = -jnp.einsum("...ij,...j->...i", rotation, eye)
    return tf._embed(rotation, offset)


def _check_range(lo, hi, name_lo, name_hi):
    return value_error_if(lo, hi <= lo, f"`{name_hi}` must be greater than `{name_lo}`")


_SIDES = ("left", "right", "bottom", "top", "near", "far")


def orthographic(left, right, bottom, top, near, far) -> Float[Array, "4 4"]:
    """Orthographic projection of the box `[left, right] x [bottom, top] x [-far, -near]`
    (eye space) onto the canonical view volume (glOrtho).

    All six finite, with `right > left`, `top > bottom`, `far > near`.
    """
    return _orthographic(*common_finite(left, right, bottom, top, near, far, names=_SIDES))


@checked_jit
def _orthographic(left, right, bottom, top, near, far):
    left = _check_range(left, right, "left", "right")
    bottom = _check_range(bottom, top, "bottom", "top")
    near = _check_range(near, far, "near", "far")
    zero = jnp.zeros_like(left)
    one = jnp.ones_like(left)
    rows = [
        [2 / (right - left), zero, zero, -(right + left) / (right - left)],
        [zero, 2 / (top - bottom), zero, -(top + bottom) / (top - bottom)],
        [zero, zero, -2 / (far - near), -(far + near) / (far - near)],
        [zero, zero, zero, one],
    ]
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def frustum(left, right, bottom, top, near, far) -> Float[Array, "4 4"]:
    """Perspective projection of the truncated viewing pyramid whose near-plane window
    is `[left, right] x [bottom, top]` at distance `near` (glFrustum).

    All six finite, `right > left`, `top > bottom` and `0 < near < far`.
    """
    return _frustum(*common_finite(left, right, bottom, top, near, far, names=_SIDES))


@checked_jit
def _frustum(left, right, bottom, top, near, far):
    near = value_error_if(near, near <= 0, "`near` must be positive for a perspective projection")
    near = _check_range(near, far, "near", "far")
    left = _check_range(left, right, "left", "right")
    bottom = _check_range(bottom, top, "bottom", "top")
    zero = jnp.zeros_like(left)
    rows = [
        [2 * near / (right - left), zero, (right + left) / (right - left), zero],
        [zero, 2 * near / (top - bottom), (top + bottom) / (top - bottom), zero],
        [zero, zero, -(far + near) / (far - near), -2 * far * near / (far - near)],
        [zero, zero, -jnp.ones_like(left), zero],
    ]
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def _lens_checks(fov_y, aspect, near, far):
    fov_y, aspect, near = _check_fov_y(fov_y), _check_aspect(aspect), _check_near(near)
    return fov_y, aspect, _check_range(near, far, "near", "far"), far


def _check_fov_y(fov_y):
    return check_range(
        fov_y, "fov_y", minimum=0, maximum=jnp.pi, lower_open=True, upper_open=True, what="radians"
    )


def _check_aspect(aspect):
    return check_range(aspect, "aspect", minimum=0, lower_open=True, what="width / height")


def _check_near(near):
    return value_error_if(near, near <= 0, "`near` must be positive for a perspective projection")


def perspective(fov_y, aspect, near, far) -> Float[Array, "4 4"]:
    """Symmetric perspective projection (gluPerspective).

    **Arguments:**

    - `fov_y`: vertical field of view in radians, in (0, pi).
    - `aspect`: width / height, > 0.
    - `near`, `far`: distances to the clipping planes, `0 < near < far`.
    """
    fov_y, aspect, near, far = common_finite(
        fov_y, aspect, near, far, names=("fov_y", "aspect", "near", "far")
    )
    return _perspective(fov_y, aspect, near, far)


@checked_jit
def _perspective(fov_y, aspect, near, far):
    fov_y, aspect, near, far = _lens_checks(fov_y, aspect, near, far)
    top = near * jnp.tan(fov_y / 2)
    right = top * aspect
    return _frustum(-right, right, -top, top, near, far)


def project(
    matrix: Float[Array, "4 4"], points: Float[Array, "*batch N 3"]
) -> Float[Array, "*batch N 3"]:
    """Project 3D points to normalised device coordinates (with the perspective divide).

    **Arguments:**

    - `matrix`: a `(4, 4)` projection (or projection times view) matrix, e.g.
      `perspective(...) @ look_at(...)`; a batch `(*batch, 4, 4)` projects per batch.
    - `points`: `(*batch, N, 3)` 3D points.

    **Returns:** `(*batch, N, 3)` NDC points; inside the view volume they lie in
    `[-1, 1]^3` (`in_view_volume`).

    **Raises:** `ValueError` for a matrix that is not 4x4, points that are not 3D, or
    values that are not finite.
    """
    matrix = finite_float(matrix, "matrix")
    if matrix.ndim < 2 or matrix.shape[-2:] != (4, 4):
        raise ValueError(
            f"`matrix` must be a 4x4 projection matrix (shape (..., 4, 4)), got shape "
            f"{tuple(matrix.shape)}"
        )
    points = finite_float(points, "points")
    check_last_dim(points, "points", (3,), "3D points")
    return tf.apply(matrix, points)


def in_view_volume(
    ndc_points: Float[Array, "*batch 3"], *, tol: float = 0.0
) -> Bool[Array, "*batch"]:
    """Whether NDC points lie inside the canonical view volume `[-1, 1]^3`, widened by
    `tol >= 0` on every side."""
    ndc_points = finite_float(ndc_points, "ndc_points")
    check_last_dim(ndc_points, "ndc_points", (3,), "NDC points")
    tol = check_range(finite_float(tol, "tol"), "tol", minimum=0)
    return _in_view_volume(ndc_points, tol)


_in_view_volume = checked_jit(lambda p, tol: jnp.all(jnp.abs(p) <= 1 + tol, axis=-1))


def ndc_to_pixels(
    ndc_points: Float[Array, "*batch d"], shape: tuple[int, int]
) -> Float[Array, "*batch 2"]:
    """Map NDC x, y in [-1, 1] to pixel coordinates of an image of `shape = (H, W)`.

    NDC -1 is the outer edge of the first pixel and +1 the outer edge of the last, so
    pixel centres sit at integers 0..W-1 (x) and 0..H-1 (y, up).
    """
    height, width = static_shape(shape)
    ndc_points = finite_float(ndc_points, "ndc_points")
    check_last_dim(ndc_points, "ndc_points", (2, 3, 4), "NDC points")
    return _ndc_to_pixels(ndc_points, (height, width))


@functools.partial(checked_jit, static_argnums=1)
def _ndc_to_pixels(ndc_points, shape):
    size = jnp.array(shape[::-1], ndc_points.dtype)
    return (ndc_points[..., :2] + 1) / 2 * size - 0.5


_AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


def plane_projection(axis: str) -> Float[Array, "4 4"]:
    """The exam's orthographic projection matrix that zeroes one coordinate.

    `plane_projection("z")` is the exam's `[T_z]` (projection onto the plane z = 0,
    the front view), `"y"` gives `[T_y]` (top view, onto y = 0) and `"x"` gives
    `[T_x]` (side view, onto x = 0).
    """
    if not isinstance(axis, str) or axis not in _AXIS_INDEX:
        raise ValueError(f"`axis` must be 'x', 'y' or 'z', got {axis!r}")
    return jnp.diag(jnp.ones(4).at[_AXIS_INDEX[axis]].set(0.0))


# name: (direction from the object to the centre of projection, up on the drawing)
ORTHOGRAPHIC_VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "front": ((0, 0, 1), (0, 1, 0)),
    "rear": ((0, 0, -1), (0, 1, 0)),
    "right": ((1, 0, 0), (0, 1, 0)),
    "left": ((-1, 0, 0), (0, 1, 0)),
    "top": ((0, 1, 0), (0, 0, -1)),
    "bottom": ((0, -1, 0), (0, 0, 1)),
}


def orthographic_view(name: str) -> Float[Array, "4 4"]:
    """One of the six orthographic views of the exam's table, as a 4x4 matrix.

    The result maps a point to its drawing coordinates `(u, v, 0)`: `u` to the right
    and `v` up as seen from the centre of projection (e.g. the front view keeps x, y;
    the rear view mirrors x; the top view has u = x and v = -z). It is the exam's
    zeroing matrix applied after turning the object to face the viewer.

    **Arguments:**

    - `name`: one of `"front"`, `"rear"`, `"right"`, `"left"`, `"top"`, `"bottom"`.
    """
    if not isinstance(name, str) or name not in ORTHOGRAPHIC_VIEWS:
        raise ValueError(f"`name` must be one of {sorted(ORTHOGRAPHIC_VIEWS)}, got {name!r}")
    toward_viewer, up = ORTHOGRAPHIC_VIEWS[name]
    view = look_at(jnp.array(toward_viewer, float), jnp.zeros(3), jnp.array(up, float))
    return plane_projection("z") @ view


def _vector_field(name: str):
    def convert(v):
        v = finite_float(v, name)
        check_last_dim(v, name, (3,), "a 3-vector")
        return v

    convert.__name__ = f"_as_{name}"
    return convert


def _scalar_field(name: str, check):
    def convert(x):
        x = finite_float(x, name)
        return x if check is None else check(x)

    convert.__name__ = f"_as_{name}"
    return convert


def _rotation_field(rotation):
    return None if rotation is None else finite_float(rotation, "rotation")


def _representation_field(representation: str) -> str:
    if not isinstance(representation, str) or representation not in tf.ROTATION_REPRESENTATIONS:
        raise ValueError(
            f"`representation` must be one of {sorted(tf.ROTATION_REPRESENTATIONS)}, "
            f"got {representation!r:.40}"
        )
    return representation


class Camera(eqx.Module):
    """A pinhole camera: pose (`eye`, `target`, `up`) and a perspective lens.

    A pytree, so `gfxlab.fit` can fit any of its fields (all are traced arrays). The
    pose can instead be given by a rotation parametrisation (`Camera.from_rotation`,
    or `rotation=` here), which is the better choice to fit an orientation: then
    `view_matrix` uses `rotation`, `target`/`up` are derived from it for reference, and
    `fixed_fields()` tells `gfxlab.fit` to hold them fixed.

    Its fields are the constructor's arguments (`representation` static), checked at
    construction.
    """

    eye: Float[Array, "3"] = eqx.field(converter=_vector_field("eye"))
    target: Float[Array, "3"] = eqx.field(converter=_vector_field("target"))
    up: Float[Array, "3"] = eqx.field(converter=_vector_field("up"))
    fov_y: Float[Array, ""] = eqx.field(converter=_scalar_field("fov_y", _check_fov_y))
    aspect: Float[Array, ""] = eqx.field(converter=_scalar_field("aspect", _check_aspect))
    near: Float[Array, ""] = eqx.field(converter=_scalar_field("near", _check_near))
    far: Float[Array, ""] = eqx.field(converter=_scalar_field("far", None))
    rotation: Float[Array, " k"] | None = eqx.field(default=None, converter=_rotation_field)
    representation: str = eqx.field(
        static=True, default="axis_angle", converter=_representation_field
    )

    def __init__(
        self,
        eye,
        target=(0.0, 0.0, 0.0),
        up=(0.0, 1.0, 0.0),
        *,
        fov_y=jnp.pi / 4,
        aspect=1.0,
        near=0.1,
        far=100.0,
        rotation=None,
        representation: str = "axis_angle",
    ):
        """**Arguments:**

        - `eye`, `target`, `up`: 3-vectors (world space); `target` defaults to the
          origin, `up` to `(0, 1, 0)`. With `rotation`, `target` and `up` are ignored
          (derived from the rotation instead).
        - `fov_y`: vertical field of view, radians; default `pi / 4`.
        - `aspect`: width / height; default 1.
        - `near`, `far`: clipping distances; default 0.1 and 100.
        - `rotation`: `None` (default), or the camera-to-world rotation in
          `representation`: the camera's x (right), y (up) and z (backwards: it looks
          down -z) axes are the columns of its matrix.
        - `representation`: one of `gfxlab.transforms.ROTATION_REPRESENTATIONS`; default
          `"axis_angle"`.

        Every argument is checked (eagerly and under jit): finite values,
        `0 < fov_y < pi`, `aspect > 0`, `0 < near < far`, `target != eye`, `up` not
        parallel to the viewing direction; each error names its argument (the relations
        between traced arguments where the camera's matrices are made, `look_at` and
        `perspective`).
        """
        # Only what depends on several arguments is made here (the converters and
        # `__check_init__` check the fields): one dtype for the pose, led by its array
        # arguments, one for the lens (the pose's when the lens is Python numbers, so that
        # the float defaults keep float32 arrays float32 under x64), and with `rotation`,
        # `target` and `up` from its frame.
        if rotation is None:
            pose = follow_float(eye, target, up, names=("eye", "target", "up"))
        else:
            pose = follow_float(eye, rotation, names=("eye", "rotation"))
        self.fov_y, self.aspect, self.near, self.far = follow_float(
            fov_y,
            aspect,
            near,
            far,
            names=("fov_y", "aspect", "near", "far"),
            default=pose[0].dtype,
        )
        self.representation, self.rotation = representation, rotation
        if rotation is None:
            self.eye, self.target, self.up = pose
            return
        eye, rotation = _vector_field("eye")(pose[0]), _rotation_field(pose[1])
        self.rotation = rotation
        frame = _rotation_matrix(rotation, _representation_field(representation), "rotation")
        frame = frame.astype(eye.dtype)
        self.eye, self.target, self.up = eye, eye - frame[..., :, 2], frame[..., :, 1]

    def __check_init__(self):
        """Relations between fields, for concrete values: `near < far`, and a pose with a
        viewing direction and an `up` off it."""
        if not is_traced((self.near, self.far)):
            _check_range(self.near, self.far, "near", "far")
        if self.rotation is None and not is_traced((self.eye, self.target, self.up)):
            _pose_checked(self.target, self.eye, self.target, self.up)

    @classmethod
    def from_rotation(cls, eye, rotation, representation: str = "axis_angle", **lens) -> Camera:
        """A camera at `eye` oriented by a rotation parametrisation (see the class doc);
        `lens` takes `fov_y`, `aspect`, `near`, `far`. A zero rotation looks down -z."""
        return cls(eye, rotation=rotation, representation=representation, **lens)

    def fixed_fields(self) -> tuple[str, ...]:
        """Fields `gfxlab.fit` holds fixed: `target` and `up` when `rotation` sets the pose."""
        return () if self.rotation is None else ("target", "up")

    def view_matrix(self) -> Float[Array, "4 4"]:
        """World to eye space (`look_at`, or the inverse of the rotation's frame)."""
        if self.rotation is None:
            return look_at(self.eye, self.target, self.up)
        frame = _rotation_matrix(self.rotation, self.representation, "rotation")
        to_eye = jnp.swapaxes(frame, -1, -2)
        eye = finite_float(self.eye, "eye")
        return tf._embed(to_eye, -jnp.einsum("...ij,...j->...i", to_eye, eye))

    def projection_matrix(self) -> Float[Array, "4 4"]:
        """Eye space to clip space (`perspective`)."""
        return perspective(self.fov_y, self.aspect, self.near, self.far)

    def matrix(self) -> Float[Array, "4 4"]:
        """World to clip space: projection after view."""
        return _camera_matrix(self)

    def project(self, points: Float[Array, "*batch N 3"]) -> Float[Array, "*batch N 3"]:
        """World points to NDC."""
        points = finite_float(points, "points")
        check_last_dim(points, "points", (3,), "3D world points")
        return _camera_project(self, points)

    def to_pixels(
        self, points: Float[Array, "*batch N 3"], shape: tuple[int, int]
    ) -> Float[Array, "*batch N 2"]:
        """World points to pixel coordinates of an image of `shape` (y up)."""
        return ndc_to_pixels(self.project(points), shape)

    def depth(self, points: Float[Array, "*batch N 3"]) -> Float[Array, "*batch N"]:
        """Distance in front of the camera along the viewing axis (eye-space -z)."""
        points = finite_float(points, "points")
        check_last_dim(points, "points", (3,), "3D world points")
        return _camera_depth(self, points)


# A camera's matrices and projections as one compiled call each.
_camera_matrix = checked_jit(
    lambda camera: tf.compose(camera.view_matrix(), camera.projection_matrix())
)
_camera_project = checked_jit(lambda camera, points: tf.apply(camera.matrix(), points))
_camera_depth = checked_jit(lambda camera, points: -tf.apply(camera.view_matrix(), points)[..., 2])


def _pose_checked(x, eye, target, up, *, prefix: str = ""):
    """`x`, tied to the checks of a camera frame `look_at(eye, target, up)`: a viewing
    direction exists and `up` is off it (any batch shape; concrete values raise at once).

    `prefix` names the fields' owner in the messages (`"camera."` in `render`, whose
    compiled core skips the camera's own checks).
    """
    shapes = [jnp.shape(v) for v in (eye, target, up)]
    try:
        jnp.broadcast_shapes(*shapes)
    except ValueError:
        names = ", ".join(f"`{prefix}{n}`" for n in ("eye", "target", "up"))
        raise ValueError(
            f"{names} must be (3,) vectors or batches of one size (B, 3), got shapes "
            f"{shapes[0]}, {shapes[1]} and {shapes[2]}"
        ) from None
    forward, up = jnp.broadcast_arrays(target - eye, up)
    x = value_error_if(
        x,
        jnp.any(safe_norm(forward) == 0),
        f"`{prefix}target` equals `{prefix}eye`: the viewing direction is undefined",
    )
    return value_error_if(
        x,
        jnp.any(safe_norm(jnp.cross(forward, up)) <= 1e-12 * safe_norm(up) * safe_norm(forward)),
        f"`{prefix}up` must be non-zero and not parallel to the viewing direction `target - eye`",
    )
