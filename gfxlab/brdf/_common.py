"""Shared pieces of `gfxlab.brdf`: limits, argument checks, small vector helpers."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    checked_jit,
    value_error_if,
)

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
    """Value checks (traceable) of 3D unit vectors: finite, length 1 within a tolerance."""
    v = check_finite(v, name)
    length = jnp.sqrt(jnp.sum(v * v, axis=-1))
    tol = _unit_tolerance(v.dtype)
    return value_error_if(
        v,
        jnp.abs(length - 1.0) > tol,
        f"`{name}` must contain unit vectors (length 1 within {tol:g}); normalise it",
    )


def _static(x, name: str):
    """Static checks of a float argument: `None`, text and non-numbers raise `TypeError`
    naming it. Python numbers and float JAX arrays pass through unchanged (the jitted
    function converts them, with no eager operation); anything else becomes a float
    JAX array (`as_float`)."""
    if type(x) is float or (isinstance(x, jax.Array) and jnp.issubdtype(x.dtype, jnp.floating)):
        return x
    if type(x) is int:
        return float(x)
    return as_float(x, name)


def _broadcast(shapes: list[tuple[int, ...]]) -> tuple[int, ...] | None:
    """The broadcast of `shapes` (NumPy rules), or None if they do not broadcast."""
    out = [1] * max(map(len, shapes), default=0)
    for shape in shapes:
        for i, size in enumerate(shape, len(out) - len(shape)):
            if size != 1:
                if out[i] not in (1, size):
                    return None
                out[i] = size
    return tuple(out)


def _batch(named: dict, core: dict[str, int]) -> tuple[int, ...]:
    """The broadcast batch shape of arrays whose last `core[name]` axes are not batch
    axes; a `ValueError` naming the arguments if they do not broadcast."""
    shapes = {k: np.shape(v) for k, v in named.items()}
    shapes = {k: s[: len(s) - core.get(k, 0)] for k, s in shapes.items()}
    batch = _broadcast(list(shapes.values()))
    if batch is None:
        listed = ", ".join(f"`{k}` {s}" for k, s in shapes.items())
        raise ValueError(f"the batch shapes do not broadcast together: {listed}")
    return batch


def _directions(wi, wo, n, **params) -> tuple:
    """Static checks: the three directions `(..., 3)` and the parameters as floats
    whose batch shapes broadcast. Values and dtypes are handled by `_check_directions`
    and `_check_param` inside the jitted function."""
    arrays = {"wi": _static(wi, "wi"), "wo": _static(wo, "wo"), "n": _static(n, "n")}
    for name, v in arrays.items():
        if np.ndim(v) == 0 or np.shape(v)[-1] != 3:
            check_last_dim(jnp.asarray(v), name, (3,), "3D direction vectors")
    arrays |= {name: _static(value, name) for name, value in params.items()}
    _batch(arrays, {"wi": 1, "wo": 1, "n": 1})
    return tuple(arrays.values())


def _check_directions(wi, wo, n, *params) -> tuple[jax.Array, ...]:
    """Inside the jitted function: the directions in their common dtype, checked to be
    finite unit vectors, then the parameters cast to that dtype."""
    dtype = jnp.result_type(wi, wo, n)
    wi, wo, n = (
        _unit_vectors(jnp.asarray(v, dtype), name) for v, name in ((wi, "wi"), (wo, "wo"), (n, "n"))
    )
    return (wi, wo, n, *(jnp.asarray(p, dtype) for p in params))


def _range_message(name: str, low: float, high: float | None, why: str = "") -> str:
    allowed = f">= {low:g}" if high is None else f"in [{low:g}, {high:g}]"
    return f"`{name}` must be {allowed}{why}"


def _check_param(p, name: str, *, low: float = 0.0, high: float | None = None, why=""):
    """Value checks (traceable) of a model parameter: finite and in `[low, high]`."""
    p = check_finite(p, name)
    bad = p < low if high is None else (p < low) | (p > high)
    return value_error_if(p, bad, _range_message(name, low, high, why))


def _param(value, name: str, dtype=None, *, low: float = 0.0, high: float | None = None, why=""):
    """A model parameter as a finite float array, checked to lie in `[low, high]`."""
    p = as_float(value, name)
    p = p if dtype is None else p.astype(dtype)
    return _check_param(p, name, low=low, high=high, why=why)


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
    w, n = as_float(w, "w"), as_float(n, "n")
    check_last_dim(w, "w", (3,), "3D direction vectors")
    check_last_dim(n, "n", (3,), "3D direction vectors")
    _batch({"w": w, "n": n}, {"w": 1, "n": 1})
    return _reflect_checked(w, n)


@checked_jit
def _reflect_checked(w, n):
    dtype = jnp.result_type(w, n)
    return _reflect(check_finite(w.astype(dtype), "w"), check_finite(n.astype(dtype), "n"))


def _diffuse(kd, valid, dtype):
    return jnp.where(valid, kd / jnp.pi, 0.0).astype(dtype)


def check_brdf(brdf) -> None:
    """A `TypeError` naming `brdf` unless it is callable."""
    if not callable(brdf):
        raise TypeError(
            f"`brdf` must be a callable brdf(wi, wo, n) such as brdf.Lambert(), got {brdf!r}"
        )
