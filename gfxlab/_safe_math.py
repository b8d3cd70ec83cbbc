"""Norms, divides and normalizations whose values and gradients stay finite where the
textbook formula divides by zero (layer 0, beside `gfxlab._checks`, which re-exports them)."""

import jax
import jax.numpy as jnp


def safe_norm(x: jax.Array, axis: int = -1, keepdims: bool = False) -> jax.Array:
    """Euclidean norm whose gradient is zero, not NaN, at the zero vector."""
    sq = jnp.sum(x * x, axis=axis, keepdims=keepdims)
    positive_sq = sq > 0
    return jnp.where(positive_sq, jnp.sqrt(jnp.where(positive_sq, sq, 1.0)), 0.0)


def safe_divide(numerator: jax.Array, denominator: jax.Array) -> jax.Array:
    """`numerator / denominator` with `|denominator|` clamped to at least machine epsilon.

    Keeps values and gradients finite (large, not infinite or NaN) where the
    denominator vanishes, e.g. the perspective divide of a point on the camera plane.
    """
    eps = jnp.finfo(jnp.result_type(denominator, float)).eps
    small = jnp.abs(denominator) < eps
    sign = jnp.where(denominator < 0, -1.0, 1.0).astype(jnp.result_type(denominator, float))
    return numerator / jnp.where(small, sign * eps, denominator)


def safe_normalize(x: jax.Array, axis: int = -1) -> jax.Array:
    """`x / |x|` along `axis`; the zero vector stays zero with finite gradients."""
    length = safe_norm(x, axis=axis, keepdims=True)
    return x / jnp.where(length > 0, length, 1.0)
