"""The BRDF models: functions and the `equinox.Module`s that hold their parameters."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import as_float, check_finite, checked_jit, is_traced, safe_normalize, static_bool
from ._common import (
    _ALPHA_WHY,
    _ROUGHNESS_WHY,
    MIN_ALPHA,
    MIN_ROUGHNESS,
    _batch,
    _check_directions,
    _check_param,
    _diffuse,
    _directions,
    _dot,
    _param,
    _reflect,
    _safe_power,
    _static,
)


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
    return _lambert(*_directions(wi, wo, n, albedo=albedo))


@checked_jit
def _lambert(wi, wo, n, albedo):
    wi, wo, n, albedo = _check_directions(wi, wo, n, albedo)
    albedo = _check_param(albedo, "albedo", high=1.0)
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
    static_bool(normalized, "normalized")
    args = _directions(wi, wo, n, ks=ks, shininess=shininess, kd=kd)
    return _phong(*args, bool(normalized))


@functools.partial(checked_jit, static_argnums=6)
def _phong(wi, wo, n, ks, shininess, kd, normalized):
    wi, wo, n, ks, shininess, kd = _check_directions(wi, wo, n, ks, shininess, kd)
    ks, shininess = _check_param(ks, "ks"), _check_param(shininess, "shininess")
    kd = _check_param(kd, "kd", high=1.0)
    cos_i, cos_o = _dot(n, wi), _dot(n, wo)
    valid = (cos_i > 0) & (cos_o > 0)
    lobe = _safe_power(_dot(_reflect(wi, n), wo), shininess)
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
    return _blinn_phong(*_directions(wi, wo, n, ks=ks, shininess=shininess, kd=kd))


@checked_jit
def _blinn_phong(wi, wo, n, ks, shininess, kd):
    wi, wo, n, ks, shininess, kd = _check_directions(wi, wo, n, ks, shininess, kd)
    ks, shininess = _check_param(ks, "ks"), _check_param(shininess, "shininess")
    kd = _check_param(kd, "kd", high=1.0)
    valid = (_dot(n, wi) > 0) & (_dot(n, wo) > 0)
    half = safe_normalize(wi + wo)
    norm = (
        (shininess + 2.0)
        * (shininess + 4.0)
        / (8.0 * jnp.pi * (2.0 ** (-shininess / 2) + shininess))
    )
    specular = ks * norm * _safe_power(_dot(n, half), shininess)
    return _diffuse(kd, valid, wi.dtype) + jnp.where(valid, specular, 0.0)


def _scalars(**values) -> list[jax.Array]:
    """Static checks of the microfacet terms' arguments: float arrays that broadcast."""
    arrays = {name: _static(v, name) for name, v in values.items()}
    _batch(arrays, {})
    return list(arrays.values())


def _ggx(cos_h, sin2_h, a2):
    """GGX `D` from `cos(theta_h)` and `sin^2(theta_h)` given separately (no cancellation).

    `c^2 (a^2 - 1) + 1 = sin^2 + a^2 c^2`: both terms are non-negative, so the
    denominator is never a difference of nearly equal numbers, and it is at least
    `a^2 c^2 > 0` wherever `c > 0`.
    """
    positive = cos_h > 0
    denom = sin2_h + a2 * cos_h * cos_h
    denom = jnp.where(positive, denom, 1.0)
    return jnp.where(positive, a2 / (jnp.pi * denom * denom), 0.0)


def ggx_distribution(cos_h: Float[Array, "..."], alpha: Float[Array, "..."]) -> Float[Array, "..."]:
    """GGX (Trowbridge-Reitz) normal distribution `D = a^2 / (pi (c^2 (a^2 - 1) + 1)^2)`.

    `cos_h = n . h`; `D(h) cos_h` integrates to 1 over the hemisphere of `h`. The
    denominator is evaluated as `(1 - c)(1 + c) + a^2 c^2`, free of cancellation, so
    `D(1, a) = 1 / (pi a^2)` is exact even for the smallest `alpha`.

    **Arguments:**

    - `cos_h`: cosines of the half vector's polar angle (clipped to [0, 1]; 0 below
      the horizon).
    - `alpha`: GGX width, `>= MIN_ALPHA` (`roughness**2`).

    **Returns:** `D` in 1/sr, broadcast over both arguments.
    """
    cos_h, alpha = _scalars(cos_h=cos_h, alpha=alpha)
    return _ggx_public(cos_h, alpha)


@checked_jit
def _ggx_public(cos_h, alpha):
    cos_h = check_finite(cos_h, "cos_h")
    alpha = _check_param(alpha, "alpha", low=MIN_ALPHA, why=_ALPHA_WHY)
    c = jnp.clip(cos_h, 0.0, 1.0)
    return jnp.where(cos_h > 0, _ggx(c, (1.0 - c) * (1.0 + c), alpha * alpha), 0.0)


def _smith(ci, co, a2):
    lam_i = co * jnp.sqrt(a2 + (1.0 - a2) * ci * ci)
    lam_o = ci * jnp.sqrt(a2 + (1.0 - a2) * co * co)
    total = lam_i + lam_o
    positive = total > 0
    return jnp.where(positive, 0.5 / jnp.where(positive, total, 1.0), 0.0)


def smith_visibility(
    cos_i: Float[Array, "..."], cos_o: Float[Array, "..."], alpha: Float[Array, "..."]
) -> Float[Array, "..."]:
    """Height-correlated Smith masking-shadowing for GGX, divided by `4 cos_i cos_o`.

    `V = G2 / (4 cos_i cos_o) = 0.5 / (cos_o sqrt(a^2 + (1 - a^2) cos_i^2)
    + cos_i sqrt(a^2 + (1 - a^2) cos_o^2))`, finite at grazing angles; symmetric in
    `cos_i` and `cos_o`.

    **Arguments:**

    - `cos_i`, `cos_o`: cosines of the light and view directions with the normal
      (clipped to [0, 1]).
    - `alpha`: GGX width, `>= MIN_ALPHA`.

    **Returns:** `V`, broadcast over the arguments.
    """
    return _smith_public(*_scalars(cos_i=cos_i, cos_o=cos_o, alpha=alpha))


@checked_jit
def _smith_public(cos_i, cos_o, alpha):
    cos_i, cos_o = check_finite(cos_i, "cos_i"), check_finite(cos_o, "cos_o")
    alpha = _check_param(alpha, "alpha", low=MIN_ALPHA, why=_ALPHA_WHY)
    return _smith(jnp.clip(cos_i, 0.0, 1.0), jnp.clip(cos_o, 0.0, 1.0), alpha * alpha)


def schlick_fresnel(cos_d: Float[Array, "..."], f0: Float[Array, "..."]) -> Float[Array, "..."]:
    """Schlick's Fresnel approximation `F = f0 + (1 - f0) (1 - cos_d)^5`, `cos_d = wi . h`.

    **Arguments:**

    - `cos_d`: cosines between the light direction and the half vector (clipped to
      [0, 1]).
    - `f0`: reflectance at normal incidence, in [0, 1].

    **Returns:** `F`, broadcast over both arguments.
    """
    return _schlick(*_scalars(cos_d=cos_d, f0=f0))


@checked_jit
def _schlick(cos_d, f0):
    cos_d, f0 = check_finite(cos_d, "cos_d"), _check_param(f0, "f0", high=1.0)
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
    `alpha = roughness^2`, `D` = `ggx_distribution` (its denominator from
    `|n x h|^2`, stable at the mirror direction), `G` the height-correlated Smith
    term (`smith_visibility` folds in the denominator) and `F` = `schlick_fresnel`.
    Single scattering only, so energy is lost at high roughness.

    The optional diffuse base is Ashikhmin and Shirley's coupled term
    `f_d = kd 28 / (23 pi) (1 - f0) (1 - (1 - cos_i / 2)^5) (1 - (1 - cos_o / 2)^5)`,
    which takes out what the specular layer reflects (a plain `kd / pi` added to it
    would reflect more than all the light at grazing angles). Both terms are
    reciprocal.

    **Arguments:**

    - `wi`, `wo`, `n`: `(..., 3)` unit vectors (light, view, normal).
    - `roughness`: perceptual roughness, `>= MIN_ROUGHNESS` (about 0.05 polished ..
      1 rough); a smaller value is an error (a mirror is not a function).
    - `f0`: reflectance at normal incidence in [0, 1] (0.04 for most dielectrics).
    - `kd`: diffuse albedo in [0, 1] of the coupled diffuse base.

    **Returns:** `(...)` BRDF values in 1/sr, 0 outside the upper hemisphere.
    """
    return _cook_torrance(*_directions(wi, wo, n, roughness=roughness, f0=f0, kd=kd))


@checked_jit
def _cook_torrance(wi, wo, n, roughness, f0, kd):
    wi, wo, n, roughness, f0, kd = _check_directions(wi, wo, n, roughness, f0, kd)
    roughness = _check_param(roughness, "roughness", low=MIN_ROUGHNESS, why=_ROUGHNESS_WHY)
    f0, kd = _check_param(f0, "f0", high=1.0), _check_param(kd, "kd", high=1.0)
    a2 = (roughness * roughness) ** 2
    cos_i, cos_o = _dot(n, wi), _dot(n, wo)
    valid = (cos_i > 0) & (cos_o > 0)
    ci, co = jnp.clip(cos_i, 0.0, 1.0), jnp.clip(cos_o, 0.0, 1.0)
    half = safe_normalize(wi + wo)
    cross = jnp.cross(jnp.broadcast_to(n, half.shape), half)
    specular = (
        _ggx(jnp.clip(_dot(n, half), 0.0, 1.0), _dot(cross, cross), a2)
        * _smith(ci, co, a2)
        * (f0 + (1.0 - f0) * (1.0 - jnp.clip(_dot(wi, half), 0.0, 1.0)) ** 5)
    )
    diffuse = (
        kd * 28.0 / (23.0 * jnp.pi) * (1.0 - f0)
        * (1.0 - (1.0 - 0.5 * ci) ** 5) * (1.0 - (1.0 - 0.5 * co) ** 5)
    )  # fmt: skip
    return jnp.where(valid, diffuse + specular, 0.0)


# --------------------------------------------------------------------------- containers
#
# One way to validate a module: converters turn each field into a float array (a
# `TypeError` naming the field for None or text) and `__check_init__` checks the values
# eagerly (a `ValueError` naming the field). Traced values are checked when the model is
# called, through the function it wraps.


def _converter(name: str):
    def convert(x):
        return x if is_traced(x) else as_float(x, name)

    convert.__name__ = f"_as_{name}"
    return convert


def _check_fields(module) -> None:
    """The concrete fields of a model, checked against its `_RANGES` at construction."""
    for name, (low, high, why) in module._RANGES.items():
        value = getattr(module, name)
        if not is_traced(value):
            _param(value, name, low=low, high=high, why=why)


def with_checked_fields(model):
    """`model` whose fields carry their range checks (`eqx.error_if`) for traced values
    too: construction checks only concrete ones, and a caller that runs the model
    inside a core whose own checks are dropped (`render`) ties them on first. Other
    modules (a user's own model) come back unchanged."""
    ranges = getattr(model, "_RANGES", None)
    if not ranges or not is_traced([getattr(model, n) for n in ranges]):
        return model
    names = list(ranges)
    checked = [_check_param(getattr(model, n), n, low=lo, high=hi, why=why)
               for n, (lo, hi, why) in ranges.items()]  # fmt: skip
    return eqx.tree_at(lambda m: [getattr(m, n) for n in names], model, checked)


class Lambert(eqx.Module):
    """Parameters of `lambert`; call it as `model(wi, wo, n)`."""

    albedo: Float[Array, "..."] = eqx.field(converter=_converter("albedo"), default=1.0)
    _RANGES = {"albedo": (0.0, 1.0, "")}

    def __check_init__(self):
        _check_fields(self)

    def __call__(self, wi, wo, n):
        return lambert(wi, wo, n, albedo=self.albedo)


class Phong(eqx.Module):
    """Parameters of `phong` (`normalized` is static); call as `model(wi, wo, n)`."""

    ks: Float[Array, "..."] = eqx.field(converter=_converter("ks"), default=1.0)
    shininess: Float[Array, "..."] = eqx.field(converter=_converter("shininess"), default=10.0)
    kd: Float[Array, "..."] = eqx.field(converter=_converter("kd"), default=0.0)
    normalized: bool = eqx.field(static=True, default=True)
    _RANGES = {"ks": (0.0, None, ""), "shininess": (0.0, None, ""), "kd": (0.0, 1.0, "")}

    def __check_init__(self):
        _check_fields(self)
        static_bool(self.normalized, "normalized")

    def __call__(self, wi, wo, n):
        return phong(
            wi, wo, n, ks=self.ks, shininess=self.shininess, kd=self.kd,
            normalized=self.normalized,
        )  # fmt: skip


class BlinnPhong(eqx.Module):
    """Parameters of `blinn_phong`; call as `model(wi, wo, n)`."""

    ks: Float[Array, "..."] = eqx.field(converter=_converter("ks"), default=1.0)
    shininess: Float[Array, "..."] = eqx.field(converter=_converter("shininess"), default=10.0)
    kd: Float[Array, "..."] = eqx.field(converter=_converter("kd"), default=0.0)
    _RANGES = Phong._RANGES

    def __check_init__(self):
        _check_fields(self)

    def __call__(self, wi, wo, n):
        return blinn_phong(wi, wo, n, ks=self.ks, shininess=self.shininess, kd=self.kd)


class CookTorrance(eqx.Module):
    """Parameters of `cook_torrance`; call as `model(wi, wo, n)`.

    `roughness` below `MIN_ROUGHNESS` (0 included) is an error at construction.
    """

    roughness: Float[Array, "..."] = eqx.field(converter=_converter("roughness"), default=0.5)
    f0: Float[Array, "..."] = eqx.field(converter=_converter("f0"), default=0.04)
    kd: Float[Array, "..."] = eqx.field(converter=_converter("kd"), default=0.0)
    _RANGES = {
        "roughness": (MIN_ROUGHNESS, None, _ROUGHNESS_WHY),
        "f0": (0.0, 1.0, ""),
        "kd": (0.0, 1.0, ""),
    }

    def __check_init__(self):
        _check_fields(self)

    def __call__(self, wi, wo, n):
        return cook_torrance(wi, wo, n, roughness=self.roughness, f0=self.f0, kd=self.kd)
