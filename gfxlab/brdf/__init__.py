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

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab import brdf
    >>> n = jnp.array([0.0, 0.0, 1.0])
    >>> round(float(brdf.cook_torrance(n, n, n, roughness=0.5, f0=0.04)), 4)
    0.0509
    >>> round(float(brdf.directional_albedo(brdf.Lambert(0.8), n)), 4)
    0.8

Low roughness: GGX's lobe narrows to a delta (a perfect mirror) as the roughness goes
to 0, which no function can represent. `roughness` must be at least `MIN_ROUGHNESS`
(GGX `alpha` at least `MIN_ALPHA = MIN_ROUGHNESS**2`); smaller values raise a clear
error. Down to that limit the values and gradients are finite in float32 and float64:
GGX's denominator is evaluated as `sin^2(theta_h) + alpha^2 cos^2(theta_h)`, with
`sin^2(theta_h) = |n x h|^2`, so it never cancels at the mirror direction.
"""

from ._common import MAX_PIXELS, MAX_QUADRATURE, MAX_SAMPLES, MIN_ALPHA, MIN_ROUGHNESS, reflect
from ._models import (
    BlinnPhong,
    CookTorrance,
    Lambert,
    Phong,
    blinn_phong,
    cook_torrance,
    ggx_distribution,
    lambert,
    phong,
    schlick_fresnel,
    smith_visibility,
)
from ._properties import (
    directional_albedo,
    half_diff_to_directions,
    reciprocity_error,
    shade_sphere,
)

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
    "MIN_ROUGHNESS",
    "MIN_ALPHA",
    "MAX_SAMPLES",
    "MAX_QUADRATURE",
    "MAX_PIXELS",
]
