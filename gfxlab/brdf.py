"""BRDF models and their properties: domain, range, reciprocity, energy conservation.

A BRDF `f(wi, wo, n)` says how much of the light arriving from direction `wi` leaves
towards `wo` at a surface with normal `n`: `L_o = f * E * cos(theta_i)` for a light
of irradiance `E` (measured normal to the light). All three are unit vectors of
shape `(..., 3)` pointing *away* from the surface (`wi` towards the light, `wo`
towards the viewer); model parameters are keyword arguments that broadcast with the
batch shape `...`, or fields of the matching `equinox.Module` (`Lambert`, `Phong`,
`BlinnPhong`, `CookTorrance`), which `gfxlab.fit.fit` can fit.

The three properties of a BRDF (seed Q3c):

- **Domain.** Pairs of directions in the upper hemisphere (`n . wi > 0` and
  `n . wo > 0`). Every model here returns exactly 0 outside it, and its gradients
  there are 0 too (no NaN), so light from below the surface never contributes.
- **Range.** Non-negative, with units 1/sr, and unbounded above (a mirror is a
  delta function).
- **Reciprocity** (Helmholtz): `f(wi, wo) == f(wo, wi)`. All models obey it except
  Phong's original model read as a BRDF, whose `1 / cos(theta_i)` breaks the symmetry
  (`reciprocity_error` measures it).

Energy conservation: the directional albedo `integral f cos(theta_i) dwi` must not
exceed 1 (`directional_albedo`; with a white surface in a uniformly white
environment this is the "white furnace" test). Single-scattering microfacet models
such as GGX lose energy at high roughness (light that would bounce more than once
between microfacets is dropped), so their albedo falls visibly below `f0 = 1`.

Example:
    >>> import jax.numpy as jnp
    >>> from gfxlab import brdf
    >>> n = jnp.array([0.0, 0.0, 1.0])
    >>> brdf.cook_torrance(n, n, n, roughness=0.5, f0=0.04)
    >>> brdf.directional_albedo(brdf.Lambert(0.8), n)  # 0.8
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._checks import as_float, check_last_dim, safe_norm, static_int, static_shape, value_error_if

__all__ = [
    "lambert",
    "phong",
    "blinn_phong",
    "cook_torrance",
    "ggx_distribution",
    "smith_visibility",
    "schlick_fresnel",
    "Lambert",
    "Phong",
    "BlinnPhong",
    "CookTorrance",
    "reciprocity_error",
    "directional_albedo",
    "shade_sphere",
    "half_diff_to_directions",
    "reflect",
]

BRDF = Callable[[jax.Array, jax.Array, jax.Array], jax.Array]

#: Smallest GGX alpha used: a perfect mirror (alpha = 0) is a delta, not a function.
MIN_ALPHA = 1e-4


# --------------------------------------------------------------------------- helpers


def _unit_tolerance(dtype) -> float:
    return max(1e-6, 1000.0 * float(jnp.finfo(dtype).eps))


def _unit_vectors(v: jax.Array, name: str) -> jax.Array:
    """Check that `v` holds 3D unit vectors (last axis 3, length 1 within a tolerance)."""
    check_last_dim(v, name, (3,), "3D direction vectors")
    length = jnp.sqrt(jnp.sum(v * v, axis=-1))
    tol = _unit_tolerance(v.dtype)
    return value_error_if(
        v,
        jnp.abs(length - 1.0) > tol,
        f"`{name}` must contain unit vectors (length 1 within {tol:g}); normalise it",
    )


def _directions(wi, wo, n) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Check and promote the three direction arrays (unit vectors, last axis 3)."""
    arrays = [as_float(v, name) for v, name in ((wi, "wi"), (wo, "wo"), (n, "n"))]
    dtype = jnp.result_type(*arrays)
    wi, wo, n = (
        _unit_vectors(v.astype(dtype), name)
        for v, name in zip(arrays, ("wi", "wo", "n"), strict=True)
    )
    return wi, wo, n


def _param(value, name: str, dtype, *, low: float = 0.0, high: float | None = None):
    """A model parameter as an array, checked to lie in `[low, high]`."""
    p = as_float(value, name).astype(dtype)
    bad = p < low if high is None else (p < low) | (p > high)
    allowed = f">= {low:g}" if high is None else f"in [{low:g}, {high:g}]"
    return value_error_if(p, bad, f"`{name}` must be {allowed}")


def _dot(a: jax.Array, b: jax.Array) -> jax.Array:
    return jnp.sum(a * b, axis=-1)


def _safe_power(base: jax.Array, exponent: jax.Array) -> jax.Array:
    """`max(base, 0) ** exponent` with finite gradients at and below 0."""
    positive = base > 0
    return jnp.where(positive, jnp.where(positive, base, 1.0) ** exponent, 0.0)


def _normalize(v: jax.Array) -> jax.Array:
    length = safe_norm(v, keepdims=True)
    return v / jnp.where(length > 0, length, 1.0)


def reflect(w: Float[Array, "*batch 3"], n: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """The mirror direction `2 (n . w) n - w` of `w` about the normal `n`."""
    w, n = as_float(w, "w"), as_float(n, "n")
    check_last_dim(w, "w", (3,), "3D direction vectors")
    check_last_dim(n, "n", (3,), "3D direction vectors")
    return 2.0 * _dot(n, w)[..., None] * n - w


def _diffuse(kd, valid, dtype):
    return jnp.where(valid, kd / jnp.pi, 0.0).astype(dtype)


# --------------------------------------------------------------------------- models


def lambert(
    wi: Float[Array, "*batch 3"],
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"],
    *,
    albedo=1.0,
) -> Float[Array, "*batch"]:
    """The ideal diffuse BRDF `albedo / pi` (directional albedo = `albedo`).

    **Arguments:**

    - `wi`, `wo`, `n`: `(..., 3)` unit vectors (light, view, normal).
    - `albedo`: reflectance in [0, 1].

    **Returns:** `(...)` BRDF values in 1/sr, 0 outside the upper hemisphere.
    """
    wi, wo, n = _directions(wi, wo, n)
    albedo = _param(albedo, "albedo", wi.dtype, high=1.0)
    valid = (_dot(n, wi) > 0) & (_dot(n, wo) > 0)
    return _diffuse(albedo, valid, wi.dtype)


def phong(
    wi: Float[Array, "*batch 3"],
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"],
    *,
    ks=1.0,
    shininess=10.0,
    kd=0.0,
    normalized: bool = True,
) -> Float[Array, "*batch"]:
    """Phong's specular lobe around the mirror direction, plus an optional diffuse term.

    With `cos_a = max(reflect(wi, n) . wo, 0)`:

    - `normalized=True` (Lafortune and Willems' modified Phong):
      `f = kd / pi + ks (s + 2) / (2 pi) cos_a^s`. Reciprocal; its directional albedo
      is at most `kd + ks` (equal at normal incidence), so `kd + ks <= 1` conserves
      energy.
    - `normalized=False` (Phong 1975 read as a BRDF: his shading
      `kd cos_i + ks cos_a^s` divided by `cos_i`): `f = kd / pi + ks cos_a^s / cos_i`.
      Not reciprocal, and not energy conserving (its albedo is about
      `ks 2 pi / (s + 1)`).

    **Arguments:**

    - `wi`, `wo`, `n`: `(..., 3)` unit vectors (light, view, normal).
    - `ks`: specular reflectance, >= 0.
    - `shininess`: the exponent `s`, >= 0.
    - `kd`: diffuse albedo in [0, 1].
    - `normalized`: which of the two forms (static).

    **Returns:** `(...)` BRDF values in 1/sr, 0 outside the upper hemisphere.
    """
    wi, wo, n = _directions(wi, wo, n)
    ks = _param(ks, "ks", wi.dtype)
    shininess = _param(shininess, "shininess", wi.dtype)
    kd = _param(kd, "kd", wi.dtype, high=1.0)
    cos_i, cos_o = _dot(n, wi), _dot(n, wo)
    valid = (cos_i > 0) & (cos_o > 0)
    lobe = _safe_power(_dot(reflect(wi, n), wo), shininess)
    if normalized:
        specular = ks * (shininess + 2.0) / (2.0 * jnp.pi) * lobe
    else:
        specular = ks * lobe / jnp.where(valid, cos_i, 1.0)
    return _diffuse(kd, valid, wi.dtype) + jnp.where(valid, specular, 0.0)


def blinn_phong(
    wi: Float[Array, "*batch 3"],
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"],
    *,
    ks=1.0,
    shininess=10.0,
    kd=0.0,
) -> Float[Array, "*batch"]:
    """Normalised Blinn-Phong: `f = kd / pi + ks c(s) (n . h)^s`.

    `h = normalize(wi + wo)` is the half vector and
    `c(s) = (s + 2) (s + 4) / (8 pi (2^(-s/2) + s))` the exact normalisation that
    makes the directional albedo at normal incidence (its maximum) equal to `ks`
    (the popular `(s + 8) / (8 pi)` overshoots by up to 8%). Reciprocal.

    **Arguments:**

    - `wi`, `wo`, `n`: `(..., 3)` unit vectors (light, view, normal).
    - `ks`: specular reflectance, >= 0; `shininess`: exponent `s`, >= 0.
    - `kd`: diffuse albedo in [0, 1].

    **Returns:** `(...)` BRDF values in 1/sr, 0 outside the upper hemisphere.
    """
    wi, wo, n = _directions(wi, wo, n)
    ks = _param(ks, "ks", wi.dtype)
    shininess = _param(shininess, "shininess", wi.dtype)
    kd = _param(kd, "kd", wi.dtype, high=1.0)
    valid = (_dot(n, wi) > 0) & (_dot(n, wo) > 0)
    half = _normalize(wi + wo)
    norm = (shininess + 2.0) * (shininess + 4.0) / (
        8.0 * jnp.pi * (2.0 ** (-shininess / 2) + shininess)
    )
    specular = ks * norm * _safe_power(_dot(n, half), shininess)
    return _diffuse(kd, valid, wi.dtype) + jnp.where(valid, specular, 0.0)


def ggx_distribution(cos_h: Float[Array, "..."], alpha: Float[Array, "..."]) -> Float[Array, "..."]:
    """GGX (Trowbridge-Reitz) normal distribution `D = a^2 / (pi (c^2 (a^2 - 1) + 1)^2)`.

    `cos_h = n . h`; `D(h) cos_h` integrates to 1 over the hemisphere of `h`.
    """
    cos_h, alpha = as_float(cos_h, "cos_h"), as_float(alpha, "alpha")
    a2 = alpha * alpha
    c = jnp.clip(cos_h, 0.0, 1.0)
    denom = c * c * (a2 - 1.0) + 1.0
    return jnp.where(cos_h > 0, a2 / (jnp.pi * denom * denom), 0.0)


def smith_visibility(
    cos_i: Float[Array, "..."], cos_o: Float[Array, "..."], alpha: Float[Array, "..."]
) -> Float[Array, "..."]:
    """Height-correlated Smith masking-shadowing for GGX, divided by `4 cos_i cos_o`.

    `V = G2 / (4 cos_i cos_o) = 0.5 / (cos_o sqrt(a^2 + (1 - a^2) cos_i^2)
    + cos_i sqrt(a^2 + (1 - a^2) cos_o^2))`, finite at grazing angles; symmetric in
    `cos_i` and `cos_o`.
    """
    cos_i, cos_o = as_float(cos_i, "cos_i"), as_float(cos_o, "cos_o")
    alpha = as_float(alpha, "alpha")
    a2 = alpha * alpha
    ci = jnp.clip(cos_i, 0.0, 1.0)
    co = jnp.clip(cos_o, 0.0, 1.0)
    lam_i = co * jnp.sqrt(a2 + (1.0 - a2) * ci * ci)
    lam_o = ci * jnp.sqrt(a2 + (1.0 - a2) * co * co)
    total = lam_i + lam_o
    positive = total > 0
    return jnp.where(positive, 0.5 / jnp.where(positive, total, 1.0), 0.0)


def schlick_fresnel(cos_d: Float[Array, "..."], f0: Float[Array, "..."]) -> Float[Array, "..."]:
    """Schlick's Fresnel approximation `F = f0 + (1 - f0) (1 - cos_d)^5`, `cos_d = wi . h`."""
    cos_d, f0 = as_float(cos_d, "cos_d"), as_float(f0, "f0")
    return f0 + (1.0 - f0) * (1.0 - jnp.clip(cos_d, 0.0, 1.0)) ** 5


def cook_torrance(
    wi: Float[Array, "*batch 3"],
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"],
    *,
    roughness=0.5,
    f0=0.04,
    kd=0.0,
) -> Float[Array, "*batch"]:
    """Cook-Torrance microfacet BRDF with GGX, Smith masking and Schlick Fresnel.

    `f = f_d + D(h) G(wi, wo) F(wi . h) / (4 cos_i cos_o)` with
    `alpha = roughness^2` (clamped to at least `MIN_ALPHA`), `D` = `ggx_distribution`,
    `G` the height-correlated Smith term (`smith_visibility` folds in the
    denominator) and `F` = `schlick_fresnel`. Single scattering only, so energy is
    lost at high roughness.

    The optional diffuse base is Ashikhmin and Shirley's coupled term
    `f_d = kd 28 / (23 pi) (1 - f0) (1 - (1 - cos_i / 2)^5) (1 - (1 - cos_o / 2)^5)`,
    which takes out what the specular layer reflects (a plain `kd / pi` added to it
    would reflect more than all the light at grazing angles). Both terms are
    reciprocal.

    **Arguments:**

    - `wi`, `wo`, `n`: `(..., 3)` unit vectors (light, view, normal).
    - `roughness`: perceptual roughness, >= 0 (about 0.05 polished .. 1 rough).
    - `f0`: reflectance at normal incidence in [0, 1] (0.04 for most dielectrics).
    - `kd`: diffuse albedo in [0, 1] of the coupled diffuse base.

    **Returns:** `(...)` BRDF values in 1/sr, 0 outside the upper hemisphere.
    """
    wi, wo, n = _directions(wi, wo, n)
    roughness = _param(roughness, "roughness", wi.dtype)
    f0 = _param(f0, "f0", wi.dtype, high=1.0)
    kd = _param(kd, "kd", wi.dtype, high=1.0)
    alpha = jnp.maximum(roughness * roughness, MIN_ALPHA)
    cos_i, cos_o = _dot(n, wi), _dot(n, wo)
    valid = (cos_i > 0) & (cos_o > 0)
    half = _normalize(wi + wo)
    specular = (
        ggx_distribution(_dot(n, half), alpha)
        * smith_visibility(cos_i, cos_o, alpha)
        * schlick_fresnel(_dot(wi, half), f0)
    )
    ci, co = jnp.clip(cos_i, 0.0, 1.0), jnp.clip(cos_o, 0.0, 1.0)
    diffuse = (
        kd * 28.0 / (23.0 * jnp.pi) * (1.0 - f0)
        * (1.0 - (1.0 - 0.5 * ci) ** 5) * (1.0 - (1.0 - 0.5 * co) ** 5)
    )
    return jnp.where(valid, diffuse + specular, 0.0)


# --------------------------------------------------------------------------- containers


def _as_param(x):
    return jnp.asarray(x, dtype=jnp.result_type(x, float)) if not isinstance(x, jax.Array) else x


class Lambert(eqx.Module):
    """Parameters of `lambert`; call it as `model(wi, wo, n)`."""

    albedo: Float[Array, "..."] = eqx.field(converter=_as_param, default=1.0)

    def __call__(self, wi, wo, n):
        return lambert(wi, wo, n, albedo=self.albedo)


class Phong(eqx.Module):
    """Parameters of `phong` (`normalized` is static); call as `model(wi, wo, n)`."""

    ks: Float[Array, "..."] = eqx.field(converter=_as_param, default=1.0)
    shininess: Float[Array, "..."] = eqx.field(converter=_as_param, default=10.0)
    kd: Float[Array, "..."] = eqx.field(converter=_as_param, default=0.0)
    normalized: bool = eqx.field(static=True, default=True)

    def __call__(self, wi, wo, n):
        return phong(
            wi, wo, n, ks=self.ks, shininess=self.shininess, kd=self.kd,
            normalized=self.normalized,
        )


class BlinnPhong(eqx.Module):
    """Parameters of `blinn_phong`; call as `model(wi, wo, n)`."""

    ks: Float[Array, "..."] = eqx.field(converter=_as_param, default=1.0)
    shininess: Float[Array, "..."] = eqx.field(converter=_as_param, default=10.0)
    kd: Float[Array, "..."] = eqx.field(converter=_as_param, default=0.0)

    def __call__(self, wi, wo, n):
        return blinn_phong(wi, wo, n, ks=self.ks, shininess=self.shininess, kd=self.kd)


class CookTorrance(eqx.Module):
    """Parameters of `cook_torrance`; call as `model(wi, wo, n)`."""

    roughness: Float[Array, "..."] = eqx.field(converter=_as_param, default=0.5)
    f0: Float[Array, "..."] = eqx.field(converter=_as_param, default=0.04)
    kd: Float[Array, "..."] = eqx.field(converter=_as_param, default=0.0)

    def __call__(self, wi, wo, n):
        return cook_torrance(wi, wo, n, roughness=self.roughness, f0=self.f0, kd=self.kd)


# --------------------------------------------------------------------------- properties


def _frame(axis: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Two unit vectors completing the unit `axis` to a right-handed orthonormal frame."""
    helper = jnp.where(
        (jnp.abs(axis[..., 2]) < 0.9)[..., None],
        jnp.array([0.0, 0.0, 1.0], axis.dtype),
        jnp.array([1.0, 0.0, 0.0], axis.dtype),
    )
    tangent = _normalize(jnp.cross(helper, axis))
    return tangent, jnp.cross(axis, tangent)


def _hemisphere_samples(key, count: int, n: jax.Array, dtype) -> jax.Array:
    """`count` directions uniform on the hemisphere around each normal `n`."""
    u = jax.random.uniform(key, (count, 2), dtype=dtype)
    cos_t = u[:, 0]
    sin_t = jnp.sqrt(jnp.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * jnp.pi * u[:, 1]
    t, b = _frame(n)
    local = jnp.stack([sin_t * jnp.cos(phi), sin_t * jnp.sin(phi), cos_t], axis=-1)
    return _normalize(local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n)


def reciprocity_error(
    brdf: BRDF,
    wi: Float[Array, "*batch 3"] | None = None,
    wo: Float[Array, "*batch 3"] | None = None,
    n: Float[Array, "*batch 3"] | None = None,
    *,
    num_samples: int = 512,
    seed: int = 0,
) -> Float[Array, ""]:
    """The largest relative asymmetry `|f(wi, wo) - f(wo, wi)| / max(f(wi, wo), f(wo, wi))`.

    0 (to rounding) for a reciprocal BRDF.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)`, e.g. a `CookTorrance` module or
      `functools.partial(phong, normalized=False)`.
    - `wi`, `wo`, `n`: directions to test; by default `num_samples` random pairs,
      uniform on the upper hemisphere about `n = (0, 0, 1)`.
    - `num_samples`, `seed`: the random pairs' count (static) and seed.

    **Returns:** a scalar in [0, 1] (0/0 counts as 0).
    """
    num_samples = static_int(num_samples, "num_samples", minimum=1)
    if n is None:
        n = jnp.array([0.0, 0.0, 1.0], jnp.result_type(float))
    n = as_float(n, "n")
    if wi is None or wo is None:
        key_i, key_o = jax.random.split(jax.random.PRNGKey(seed))
        sample_wi = _hemisphere_samples(key_i, num_samples, n, n.dtype)
        sample_wo = _hemisphere_samples(key_o, num_samples, n, n.dtype)
        wi = sample_wi if wi is None else wi
        wo = sample_wo if wo is None else wo
    return _reciprocity(brdf, as_float(wi, "wi"), as_float(wo, "wo"), n)


@eqx.filter_jit
def _reciprocity(brdf, wi, wo, n):
    forward = brdf(wi, wo, n)
    backward = brdf(wo, wi, n)
    scale = jnp.maximum(jnp.abs(forward), jnp.abs(backward))
    positive = scale > 0
    rel = jnp.where(positive, jnp.abs(forward - backward) / jnp.where(positive, scale, 1.0), 0.0)
    return jnp.max(rel)


def _albedo_grid(num_theta: int, num_phi: int, dtype) -> tuple[np.ndarray, ...]:
    """Quadrature on the sphere around a pole: Gauss-Legendre in `u` with
    `theta = pi u^2` (nodes crowd towards the pole, where the lobes peak) and the
    midpoint rule in `phi` (exact for trigonometric polynomials)."""
    x, w = np.polynomial.legendre.leggauss(num_theta)
    u, wu = 0.5 * (x + 1.0), 0.5 * w
    theta = np.pi * u * u
    weight_theta = wu * 2.0 * np.pi * u * np.sin(theta)  # d(theta)/du * sin(theta)
    phi = 2.0 * np.pi * (np.arange(num_phi) + 0.5) / num_phi
    weights = weight_theta[:, None] * np.full(num_phi, 2.0 * np.pi / num_phi)[None, :]
    local = np.stack(
        [
            np.sin(theta)[:, None] * np.cos(phi)[None, :],
            np.sin(theta)[:, None] * np.sin(phi)[None, :],
            np.broadcast_to(np.cos(theta)[:, None], (num_theta, num_phi)),
        ],
        axis=-1,
    )
    return local.reshape(-1, 3).astype(dtype), weights.reshape(-1).astype(dtype)


def directional_albedo(
    brdf: BRDF,
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"] | None = None,
    *,
    num_theta: int = 256,
    num_phi: int = 128,
) -> Float[Array, "*batch"]:
    """Directional albedo `rho(wo) = integral over wi of f(wi, wo, n) cos(theta_i)`.

    The fraction of light arriving uniformly from all directions that leaves towards
    `wo` (the white-furnace test: a surface in a uniformly white environment looks
    exactly `rho` bright). Energy conservation requires `rho <= 1` for every `wo`.

    Deterministic quadrature over the whole sphere centred on the mirror direction of
    `wo`, where specular lobes peak (`num_theta * num_phi` BRDF evaluations per `wo`,
    one `wo` at a time). The default 256 x 128 is accurate to about 1e-4 for
    Lambert, and to 1e-3 for lobes down to GGX roughness 0.2 or Phong shininess 1000;
    sharper lobes at grazing angles need more points.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)` (whose parameters broadcast with the
      directions' batch shape; for a batch of parameters, `jax.vmap` over them).
    - `wo`: `(..., 3)` unit view directions.
    - `n`: `(..., 3)` unit normals (default `(0, 0, 1)`).
    - `num_theta`, `num_phi`: quadrature points (static).

    **Returns:** `(...)` albedo values.
    """
    num_theta = static_int(num_theta, "num_theta", minimum=2)
    num_phi = static_int(num_phi, "num_phi", minimum=2)
    wo = as_float(wo, "wo")
    if n is None:
        n = jnp.array([0.0, 0.0, 1.0], wo.dtype)
    n = as_float(n, "n")
    dtype = jnp.result_type(wo, n)
    wo, n = wo.astype(dtype), n.astype(dtype)
    wo, n = _unit_vectors(wo, "wo"), _unit_vectors(n, "n")
    batch = jnp.broadcast_shapes(wo.shape, n.shape)
    wo_flat = jnp.broadcast_to(wo, batch).reshape(-1, 3)
    n_flat = jnp.broadcast_to(n, batch).reshape(-1, 3)
    local, weights = _albedo_grid(num_theta, num_phi, np.dtype(dtype))
    albedo = _albedo_quadrature(brdf, wo_flat, n_flat, jnp.asarray(local), jnp.asarray(weights))
    return albedo.reshape(batch[:-1])


@eqx.filter_jit
def _albedo_quadrature(brdf, wo, n, local, weights):
    # Compiled once per BRDF structure (a model's parameters are traced leaves), and
    # mapped over the view directions to keep memory at one quadrature grid.
    def one(pair):
        w_o, normal = pair
        axis = _normalize(reflect(w_o, normal))
        t, b = _frame(axis)
        wi = _normalize(local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * axis)
        cos_i = jnp.maximum(wi @ normal, 0.0)
        values = brdf(wi, jnp.broadcast_to(w_o, wi.shape), jnp.broadcast_to(normal, wi.shape))
        return jnp.sum(values * cos_i * weights)

    return jax.lax.map(one, (wo, n))


# --------------------------------------------------------------------------- rendering


def shade_sphere(
    brdf: BRDF,
    shape: tuple[int, int],
    *,
    light: Float[Array, "3"] = (1.0, 1.0, 1.0),
    point_light: bool = False,
    intensity=1.0,
    radius: float = 0.9,
    background=0.0,
) -> Float[Array, "H W"]:
    """Render a unit sphere with any BRDF under one light, seen orthographically.

    The viewer looks down the -z axis (`wo = (0, 0, 1)` at every pixel); x points
    right and y up, following the pixel convention (pixel `(row, col)` has its centre
    at `(col, H - 1 - row)`). Each pixel gets the outgoing radiance
    `L = f(wi, wo, n) * E * max(n . wi, 0)`, no shadows or ambient term.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)` on `(H, W, 3)` arrays (for colour, vmap
      over a model with per-channel parameters).
    - `shape`: image shape `(H, W)` (static).
    - `light`: a direction towards the light (normalised here), or with
      `point_light=True` the light's position, in units of the sphere radius with the
      sphere centred at the origin.
    - `point_light`: use a point light (inverse-square falloff) instead of a
      directional one.
    - `intensity`: the directional light's irradiance (normal to the light), or the
      point light's intensity (power per steradian).
    - `radius`: the sphere's radius as a fraction of half the smaller image side.
    - `background`: value of pixels that miss the sphere.

    **Returns:** `(H, W)` linear radiance (not clipped; highlights may exceed 1).
    """
    height, width = static_shape(shape)
    light = as_float(light, "light")
    check_last_dim(light, "light", (3,), "a 3D direction or position")
    if light.ndim != 1:
        raise ValueError(f"`light` must be a single 3-vector, got shape {tuple(light.shape)}")
    radius = float(radius)
    if not 0 < radius:
        raise ValueError(f"`radius` must be positive, got {radius}")
    dtype = jnp.result_type(light.dtype, float)
    light = light.astype(dtype)
    light = value_error_if(light, jnp.all(light == 0), "`light` must not be the zero vector")
    rows, cols = np.mgrid[0:height, 0:width]
    pixel_r = radius * 0.5 * min(height, width)
    x = jnp.asarray((cols - (width - 1) / 2) / pixel_r, dtype)
    y = jnp.asarray(((height - 1 - rows) - (height - 1) / 2) / pixel_r, dtype)
    intensity = as_float(intensity, "intensity").astype(dtype)
    background = as_float(background, "background").astype(dtype)
    return _shade(brdf, x, y, light, intensity, background, point_light)


@eqx.filter_jit
def _shade(brdf, x, y, light, intensity, background, point_light):
    # Compiled once per BRDF structure and image size.
    r2 = x * x + y * y
    inside = r2 < 1.0
    z = jnp.sqrt(jnp.where(inside, 1.0 - r2, 1.0))
    up = jnp.array([0.0, 0.0, 1.0], x.dtype)
    normal = jnp.where(inside[..., None], jnp.stack([x, y, z], axis=-1), up)
    normal = _normalize(normal)
    wo = jnp.broadcast_to(up, normal.shape)
    if point_light:
        to_light = light - normal
        dist2 = jnp.sum(to_light * to_light, axis=-1)
        wi = _normalize(to_light)
        irradiance = intensity / jnp.where(dist2 > 0, dist2, 1.0)
    else:
        wi = jnp.broadcast_to(_normalize(light), normal.shape)
        irradiance = intensity
    cos_i = jnp.maximum(_dot(normal, wi), 0.0)
    radiance = brdf(wi, wo, normal) * irradiance * cos_i
    return jnp.where(inside, radiance, background)


def half_diff_to_directions(
    theta_h: Float[Array, "..."],
    theta_d: Float[Array, "..."],
    phi_d: Float[Array, "..."],
    phi_h=0.0,
) -> tuple[Float[Array, "... 3"], Float[Array, "... 3"]]:
    """Directions `(wi, wo)` from Rusinkiewicz's half/difference angles (n = +z).

    Measured-BRDF datasets (e.g. MERL) tabulate isotropic BRDFs over
    `(theta_h, theta_d, phi_d)`: the half vector's polar angle, and the incoming
    direction's polar and azimuth angles in a frame whose pole is the half vector.

    **Returns:** `wi`, `wo` as `(..., 3)` unit vectors (possibly below the horizon).
    """
    names = ("theta_h", "theta_d", "phi_d", "phi_h")
    th, td, pd, ph = (
        as_float(a, name) for a, name in zip((theta_h, theta_d, phi_d, phi_h), names, strict=True)
    )
    th, td, pd, ph = jnp.broadcast_arrays(th, td, pd, ph)
    d = jnp.stack([jnp.sin(td) * jnp.cos(pd), jnp.sin(td) * jnp.sin(pd), jnp.cos(td)], axis=-1)
    d_mirror = d * jnp.array([-1.0, -1.0, 1.0], d.dtype)

    def to_world(v):
        # rotate about y by theta_h, then about z by phi_h
        x1 = jnp.cos(th) * v[..., 0] + jnp.sin(th) * v[..., 2]
        z1 = -jnp.sin(th) * v[..., 0] + jnp.cos(th) * v[..., 2]
        y1 = v[..., 1]
        return jnp.stack(
            [jnp.cos(ph) * x1 - jnp.sin(ph) * y1, jnp.sin(ph) * x1 + jnp.cos(ph) * y1, z1], axis=-1
        )

    return to_world(d), to_world(d_mirror)

