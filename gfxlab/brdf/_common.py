"""Shared pieces of `gfxlab.brdf`: limits, argument checks, small vector helpers."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import as_float, check_finite, check_last_dim, finite_float, value_error_if

BRDF = Callable[[jax.Array, jax.Array, jax.Array], jax.Array]

#: Smallest Cook-Torrance `roughness` accepted. Below it the GGX lobe is narrower than
#: float32 can resolve (a perfect mirror, roughness 0, is a delta, not a function).
MIN_ROUGHNESS = 0.02

#: Smallest GGX `alpha` accepted (`alpha = roughness**2`).
MIN_ALPHA = MIN_ROUGHNESS**2

#: Size limits (refused before allocating): random pairs in `reciprocity_error`,
#: quadrature points per axis in `directional_albedo`, pixels in `shade_sphere`.
MAX_SAMPLES = 1 << 22
MAX_QUADRATURE = 2048
MAX_PIXELS = 1 << 24


# --------------------------------------------------------------------------- helpers


def _unit_tolerance(dtype) -> float:
    return max(1e-6, 1000.0 * float(jnp.finfo(dtype).eps))


def _unit_vectors(v: jax.Array, name: str) -> jax.Array:
    """Check that `v` holds finite 3D unit vectors (last axis 3, length 1 within a tolerance)."""
    check_last_dim(v, name, (3,), "3D direction vectors")
    v = check_finite(v, name)
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


def _range_message(name: str, low: float, high: float | None, why: str = "") -> str:
    allowed = f">= {low:g}" if high is None else f"in [{low:g}, {high:g}]"
    return f"`{name}` must be {allowed}{why}"


def _param(value, name: str, dtype=None, *, low: float = 0.0, high: float | None = None, why=""):
    """A model parameter as a finite float array, checked to lie in `[low, high]`."""
    p = finite_float(value, name)
    p = p if dtype is None else p.astype(dtype)
    bad = p < low if high is None else (p < low) | (p > high)
    return value_error_if(p, bad, _range_message(name, low, high, why))


_ROUGHNESS_WHY = (
    f" (MIN_ROUGHNESS = {MIN_ROUGHNESS:g}: a smoother surface is a mirror, a delta, not a function)"
)
_ALPHA_WHY = f" (MIN_ALPHA = {MIN_ALPHA:g}, i.e. roughness >= MIN_ROUGHNESS = {MIN_ROUGHNESS:g})"


def _dot(a: jax.Array, b: jax.Array) -> jax.Array:
    return jnp.sum(a * b, axis=-1)


def _safe_power(base: jax.Array, exponent: jax.Array) -> jax.Array:
    """`max(base, 0) ** exponent` with finite gradients at and below 0."""
    positive = base > 0
    return jnp.where(positive, jnp.where(positive, base, 1.0) ** exponent, 0.0)


def _reflect(w: jax.Array, n: jax.Array) -> jax.Array:
    return 2.0 * _dot(n, w)[..., None] * n - w


def reflect(w: Float[Array, "*batch 3"], n: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """The mirror direction `2 (n . w) n - w` of the vector `w` about the normal `n`.

    **Arguments:**

    - `w`: `(..., 3)` directions (pointing away from the surface).
    - `n`: `(..., 3)` unit normals.

    **Returns:** `(..., 3)` mirrored directions.
    """
    w, n = finite_float(w, "w"), finite_float(n, "n")
    check_last_dim(w, "w", (3,), "3D direction vectors")
    check_last_dim(n, "n", (3,), "3D direction vectors")
    return _reflect(w, n)


def _diffuse(kd, valid, dtype):
    return jnp.where(valid, kd / jnp.pi, 0.0).astype(dtype)


def check_brdf(brdf) -> None:
    """A `TypeError` naming `brdf` unless it is callable."""
    if not callable(brdf):
        raise TypeError(
            f"`brdf` must be a callable brdf(wi, wo, n) such as brdf.Lambert(), got {brdf!r}"
        )
