"""Shading through `gfxlab.brdf`: point and directional lights, textures.

Outgoing radiance at a surface point with normal `n`, seen from direction `wo`:

    L = ambient * albedo + sum_lights pi * f(wi, wo, n) * albedo * E * max(n . wi, 0)

where `f` is any `gfxlab.brdf` model (`Lambert`, `Phong`, `BlinnPhong`,
`CookTorrance` = GGX) called as `f(wi, wo, n)`, `albedo` is the per-pixel colour
(vertex colours or a texture) and `E` the light's irradiance (a point light's intensity
falls off as `1 / d^2`). The factor `pi` makes a white Lambert surface facing a light of
intensity 1 exactly 1. Shading is two-sided: a normal facing away from the viewer is
flipped.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    check_shape,
    finite_float,
    follow_float,
    safe_norm,
    safe_normalize,
    value_error_if,
)
from .._pixels import row_to_y
from ..brdf import Lambert
from ..brdf._models import with_checked_fields

__all__ = ["PointLight", "DirectionalLight", "shade", "sample_texture"]


def _intensity(value, name="intensity"):
    value = as_float(value, name)
    if value.ndim > 1:
        raise ValueError(f"`{name}` must be a scalar or a colour (C,), got shape {value.shape}")
    return value_error_if(
        value, ~(value >= 0) | ~jnp.isfinite(value), f"`{name}` must be finite and >= 0"
    )


def _position(position):
    position = as_float(position, "position")
    check_shape(position, "position", (3,))
    return value_error_if(position, ~jnp.isfinite(position), "`position` must be finite")


def _direction(direction):
    direction = as_float(direction, "direction")
    check_shape(direction, "direction", (3,))
    return value_error_if(
        direction,
        ~(safe_norm(direction) > 0) | ~jnp.all(jnp.isfinite(direction)),
        "`direction` must be a finite non-zero vector",
    )


class PointLight(eqx.Module):
    """A point light at `position` (world space) of `intensity` (scalar or colour `(C,)`).

    `PointLight(position, intensity=1.0)`:

    - `position`: the light's `(3,)` position in world space, finite.
    - `intensity`: a scalar or a colour `(C,)`, finite and `>= 0`; default 1. The
      irradiance at a point falls off as `intensity / distance**2`.
    """

    position: Float[Array, "3"] = eqx.field(converter=_position)
    intensity: Float[Array, "*C"] = eqx.field(converter=_intensity)

    def __init__(self, position, intensity=1.0):
        """See the class doc; `intensity` takes `position`'s dtype unless it is an array."""
        self.position, self.intensity = follow_float(
            position, intensity, names=("position", "intensity")
        )

    def incident(self, points):
        """Unit directions towards the light and the irradiance `(..., 1 or C)`."""
        to_light = self.position.astype(points.dtype) - points
        d2 = jnp.sum(to_light * to_light, -1, keepdims=True)
        wi = _unit_or(to_light, jnp.array([0.0, 0.0, 1.0], points.dtype))
        return wi, self.intensity.astype(points.dtype) / jnp.maximum(d2, 1e-12)


class DirectionalLight(eqx.Module):
    """A light at infinity: `direction` points from the scene towards the light.

    `DirectionalLight(direction, intensity=1.0)`:

    - `direction`: `(3,)` vector from the scene towards the light, finite and non-zero
      (any length: it is normalized where used).
    - `intensity`: a scalar or a colour `(C,)`, finite and `>= 0`; default 1 (the same
      irradiance everywhere).
    """

    direction: Float[Array, "3"] = eqx.field(converter=_direction)
    intensity: Float[Array, "*C"] = eqx.field(converter=_intensity)

    def __init__(self, direction, intensity=1.0):
        """See the class doc; `intensity` takes `direction`'s dtype unless it is an array."""
        self.direction, self.intensity = follow_float(
            direction, intensity, names=("direction", "intensity")
        )

    def incident(self, points):
        """Unit directions towards the light and the irradiance scale at `points`."""
        d = self.direction.astype(points.dtype)
        wi = jnp.broadcast_to(d / safe_norm(d), points.shape)
        return wi, jnp.broadcast_to(
            self.intensity.astype(points.dtype), points.shape[:-1] + (self.intensity.shape or (1,))
        )


def _unit_or(v, fallback):
    """`v / |v|`, or `fallback` where `v` is zero (finite gradients)."""
    return jnp.where(safe_norm(v, keepdims=True) > 0, safe_normalize(v), fallback)


def _check_lights(lights, channels: int | None = None):
    """The lights as a tuple (None stays None: `render`'s "no shading"), each with an
    intensity of 1 or `channels` colour channels (when given)."""
    if lights is None:
        return None
    if isinstance(lights, PointLight | DirectionalLight):
        lights = (lights,)
    if isinstance(lights, str) or not hasattr(lights, "__iter__"):
        raise TypeError(
            "`lights` must be a PointLight, a DirectionalLight or a sequence of them, got "
            f"{type(lights).__name__}"
        )
    lights = tuple(lights)
    for k, light in enumerate(lights):
        if not isinstance(light, PointLight | DirectionalLight):
            raise TypeError(
                f"`lights[{k}]` must be a PointLight or DirectionalLight, got "
                f"{type(light).__name__}"
            )
        size = light.intensity.size
        if channels is not None and size not in (1, channels):
            raise ValueError(
                f"`lights[{k}].intensity` has {size} colour channels; the surface has "
                f"{channels}: give a scalar or a ({channels},) colour"
            )
    return lights


#: The `gfxlab.brdf` models, for the message that names them.
_MODELS = "Lambert(), Phong(...), BlinnPhong(...), CookTorrance(...) (GGX)"


def check_brdf(brdf):
    """`brdf`, or `Lambert()` for `None`, after checking it is a model: a `gfxlab.brdf`
    model or any callable `eqx.Module` `f(wi, wo, n)` (a pytree, so it can be fitted)."""
    if brdf is None:
        return Lambert()
    if not (isinstance(brdf, eqx.Module) and callable(brdf)):
        raise TypeError(
            f"`brdf` must be a gfxlab.brdf model ({_MODELS}) or a callable eqx.Module "
            f"f(wi, wo, n), got {brdf!r:.40}"
        )
    # traced parameters carry their range checks from here: `render`'s core drops its own
    return with_checked_fields(brdf)


def check_ambient(ambient, channels: int, dtype):
    """`ambient` as a `dtype` array, finite and >= 0, a scalar or a `(channels,)` colour.
    A NumPy value (as `render` passes its options) is checked on the host, without a
    JAX dispatch; a traced one under `jit`, through the returned value."""
    if isinstance(ambient, np.ndarray) and ambient.dtype.kind in "iuf":
        ambient = ambient.astype(dtype)
    else:
        ambient = as_float(ambient, "ambient").astype(dtype)
    if ambient.ndim > 1 or ambient.size not in (1, channels):
        raise ValueError(
            f"`ambient` must be a scalar or a colour ({channels},), got shape {ambient.shape}"
        )
    xp = np if isinstance(ambient, np.ndarray) else jnp
    bad = ~(xp.isfinite(ambient) & (ambient >= 0))
    return value_error_if(ambient, bad, "`ambient` must be finite and >= 0")


def shade(
    albedo: Float[Array, "*batch C"],
    normal: Float[Array, "*batch 3"],
    position: Float[Array, "*batch 3"],
    eye: Float[Array, "3"],
    *,
    lights,
    brdf=None,
    ambient=0.0,
) -> Float[Array, "*batch C"]:
    """Radiance of surface points (see the module docstring for the formula).

    **Arguments:**

    - `albedo`: `(..., C)` colours, `C` in 1..4; `normal` `(..., 3)` (normalised here; zero normals
      face the viewer); `position` `(..., 3)` world positions; `eye` the camera position.
    - `lights`: a light or a sequence of `PointLight` / `DirectionalLight` (`()`: none).
    - `brdf`: a `gfxlab.brdf` model (default `Lambert()`).
    - `ambient`: ambient term (scalar or `(C,)`).

    **Returns:** `(..., C)` radiance.
    """
    albedo, normal, position = (
        finite_float(a, n)
        for a, n in ((albedo, "albedo"), (normal, "normal"), (position, "position"))
    )
    check_last_dim(albedo, "albedo", (1, 2, 3, 4), "1 to 4 colour channels")
    check_last_dim(normal, "normal", (3,))
    check_last_dim(position, "position", (3,))
    try:
        jnp.broadcast_shapes(albedo.shape[:-1], normal.shape[:-1], position.shape[:-1])
    except ValueError:
        raise ValueError(
            "`albedo`, `normal` and `position` must have one batch shape (or broadcast), got "
            f"{albedo.shape[:-1]}, {normal.shape[:-1]} and {position.shape[:-1]}"
        ) from None
    if lights is None:
        raise TypeError(
            "`lights` must be a PointLight, a DirectionalLight or a sequence of them (`()` for "
            "none), got None"
        )
    lights = _check_lights(lights, albedo.shape[-1])
    brdf = check_brdf(brdf)
    dtype = albedo.dtype
    eye = finite_float(eye, "eye").astype(dtype)
    check_shape(eye, "eye", (3,))
    ambient = check_ambient(ambient, albedo.shape[-1], dtype)
    return _shade(albedo, normal.astype(dtype), position.astype(dtype), eye, ambient, lights, brdf)


@eqx.filter_jit
def _shade(albedo, normal, position, eye, ambient, lights, brdf):
    """The radiance of `shade` on checked arrays (no checks: for use inside a trace)."""
    dtype = albedo.dtype
    up = jnp.array([0.0, 0.0, 1.0], dtype)
    wo = _unit_or(eye - position, up)
    n = _unit_or(normal, wo)
    n = jnp.where(jnp.sum(n * wo, -1, keepdims=True) < 0, -n, n)  # two-sided
    radiance = ambient * albedo
    for light in lights:
        wi, irradiance = light.incident(position)
        f = brdf(wi, wo, n)
        cos = jnp.maximum(jnp.sum(n * wi, -1), 0.0)
        radiance = radiance + (jnp.pi * f * cos)[..., None] * albedo * irradiance
    return radiance


def sample_texture(
    texture: Float[Array, "Ht Wt C"], uv: Float[Array, "*batch 2"]
) -> Float[Array, "*batch C"]:
    """Bilinear texture lookup, differentiable in the texture and in `uv`.

    `uv = (0, 0)` is the lower-left corner of the image and `(1, 1)` the upper-right
    (OBJ `vt` convention; row 0 of `texture` is the top). Texel centres sit at
    `((col + 1/2) / Wt, 1 - (row + 1/2) / Ht)`; outside the image the edge texels repeat
    (clamp to edge).

    **Arguments:** `texture` `(Ht, Wt, C)`, finite, 1 to 4 channels; `uv` `(..., 2)` finite.

    **Returns:** `(..., C)` colours.
    """
    texture = as_float(texture, "texture")
    check_shape(texture, "texture", (None, None, None))
    if 0 in texture.shape[:2] or not 1 <= texture.shape[2] <= 4:
        raise ValueError(
            "`texture` must have shape (Ht, Wt, C) with Ht, Wt >= 1 and 1 to 4 channels, got "
            f"shape {tuple(texture.shape)}"
        )
    uv = as_float(uv, "uv").astype(texture.dtype)
    check_last_dim(uv, "uv", (2,), "texture coordinates (u, v)")
    return _sample_texture(check_finite(texture, "texture"), check_finite(uv, "uv"))


@jax.jit
def _sample_texture(texture, uv):
    """The lookup of `sample_texture` on checked arrays (no checks: for use in a trace)."""
    height, width = texture.shape[:2]
    # texel space, y up (the pixel convention of gfxlab._pixels), then array rows
    x = jnp.clip(uv[..., 0] * width - 0.5, 0.0, width - 1.0)
    y = jnp.clip(uv[..., 1] * height - 0.5, 0.0, height - 1.0)
    x0 = jnp.clip(jnp.floor(jax.lax.stop_gradient(x)), 0, max(width - 2, 0)).astype(jnp.int32)
    y0 = jnp.clip(jnp.floor(jax.lax.stop_gradient(y)), 0, max(height - 2, 0)).astype(jnp.int32)
    x1, y1 = jnp.minimum(x0 + 1, width - 1), jnp.minimum(y0 + 1, height - 1)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]

    def at(xi, yi):
        return texture[row_to_y(yi, height), xi]

    bottom = at(x0, y0) * (1 - fx) + at(x1, y0) * fx
    top = at(x0, y1) * (1 - fx) + at(x1, y1) * fx
    return bottom * (1 - fy) + top * fy
