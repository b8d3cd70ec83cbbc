"""Conics: the parametric ellipse and circle, `Ellipse`."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_finite, check_last_dim, check_shape, common_float
from ._common import _flat_parameters, _floats, _not_finite, _require, _unflatten


def ellipse(
    center: Float[ArrayLike, "*batch 2"],
    radii: Float[ArrayLike, "*batch 2"],
    angle: Float[ArrayLike, "*batch"],
    t: Float[ArrayLike, " N"],
) -> Float[Array, "*batch N 2"]:
    """The parametric ellipse `x = h + a cos t, y = k + b sin t`, rotated by `angle`
    about its centre `(h, k)`:
    `(x, y) = (h, k) + R(angle) (a cos t, b sin t)`.

    **Arguments:**

    - `center`: `(h, k)`, `(..., 2)`.
    - `radii`: `(rx, ry)`, the semi-axes along the (rotated) x and y axes (the exam's
      `a`, `b`), `(..., 2)`.
    - `angle`: rotation in radians, `(...)`.
    - `t`: parameters `(N,)`; `0 <= t < 2 pi` traces the ellipse once.

    **Returns:** `(..., N, 2)`.
    """
    center, radii, angle, t = _floats(
        center, radii, angle, t, names=("center", "radii", "angle", "t")
    )
    check_last_dim(center, "center", (2,), "the centre (h, k)")
    check_last_dim(radii, "radii", (2,), "the semi-axes (rx, ry)")
    center, radii, angle, t = (
        _require(x, f"`{name}` must be finite (no NaN or inf)", _not_finite)
        for x, name in zip(
            (center, radii, angle, t), ("center", "radii", "angle", "t"), strict=True
        )
    )
    return _ellipse_kernel(center, radii, angle, t)


@jax.jit
def _ellipse_kernel(center, radii, angle, t) -> jax.Array:
    flat, shape = _flat_parameters(t)
    local_x = radii[..., None, 0] * jnp.cos(flat)
    local_y = radii[..., None, 1] * jnp.sin(flat)
    c, s = jnp.cos(angle)[..., None], jnp.sin(angle)[..., None]
    x = center[..., None, 0] + c * local_x - s * local_y
    y = center[..., None, 1] + s * local_x + c * local_y
    return _unflatten(jnp.stack([x, y], axis=-1), shape, -2)


def circle(
    center: Float[ArrayLike, "*batch 2"],
    radius: Float[ArrayLike, "*batch"],
    t: Float[ArrayLike, " N"],
) -> Float[Array, "*batch N 2"]:
    """The parametric circle `(h + r cos t, k + r sin t)`: an ellipse with `a = b = r`."""
    center, radius, t = _floats(center, radius, t, names=("center", "radius", "t"))
    check_last_dim(center, "center", (2,), "the centre (h, k)")
    center, radius, t = (
        _require(x, f"`{name}` must be finite (no NaN or inf)", _not_finite)
        for x, name in zip((center, radius, t), ("center", "radius", "t"), strict=True)
    )
    return _circle_kernel(center, radius, t)


@jax.jit
def _circle_kernel(center, radius, t) -> jax.Array:
    radii = jnp.stack([radius, radius], axis=-1)
    return _ellipse_kernel(center, radii, jnp.zeros_like(radius), t)


def _finite_field(name: str, shape: tuple):
    def convert(x):
        x = as_float(x, name)
        check_shape(x, name, shape)
        return _require(x, f"`{name}` must be finite (no NaN or inf)", _not_finite)

    convert.__name__ = f"_as_{name}"
    return convert


class Ellipse(eqx.Module):
    """The parametric ellipse of `ellipse` as a pytree.

    **Fields:** `center` `(2,)`, `radii` `(2,)` (semi-axes `rx`, `ry`), `angle` (radians),
    all finite and of one float dtype. Call with `t` `(N,)` to get `(N, 2)` points.
    """

    center: Float[Array, "2"] = eqx.field(converter=_finite_field("center", (2,)))
    radii: Float[Array, "2"] = eqx.field(converter=_finite_field("radii", (2,)))
    angle: Float[Array, ""] = eqx.field(converter=_finite_field("angle", ()))

    def __init__(self, center, radii, angle=0.0):
        # Only the common dtype is made here (it depends on all three arguments); the
        # converters check each field.
        self.center, self.radii, self.angle = common_float(
            center, radii, angle, names=("center", "radii", "angle")
        )  # JAX arrays: the fields are the leaves `gfxlab.fit` fits

    def __call__(self, t: Float[ArrayLike, " N"]) -> Float[Array, "N 2"]:
        # The fields were checked at construction; inside a fit (where they are traced)
        # only `t` is checked, so the compiled solver stays small.
        t = check_finite(as_float(t, "t"), "t")
        return _ellipse_kernel(self.center, self.radii, self.angle, t)

    def normalized(self) -> Ellipse:
        """The same point set with `rx >= ry >= 0` and `angle` in `[0, pi)`."""
        return Ellipse(self.center, *_normalized_axes(self.radii, self.angle))


@jax.jit
def _normalized_axes(radii: jax.Array, angle: jax.Array) -> tuple[jax.Array, jax.Array]:
    a, b = jnp.abs(radii[0]), jnp.abs(radii[1])
    swap = b > a
    radii = jnp.where(swap, jnp.stack([b, a]), jnp.stack([a, b]))
    return radii, jnp.mod(angle + jnp.where(swap, jnp.pi / 2, 0.0), jnp.pi)
