"""Lattice noise: value noise (the one owner of it in gfxlab), gradient noise and their
fractal sums, in 1D or 2D, for textures (`synthetic_scene`) and secondary motion
(`gfxlab.animation`).

Randomness is a `jax.random` key (`key=`), as everywhere in gfxlab: the 32-bit seed of
the lattice hash is `jax.random.bits(key, dtype=uint32)`, so a key may be traced (split
keys under `vmap`, a key argument of a jitted function). The default key, `DEFAULT_KEY`,
is the data of `jax.random.key(0)`: the default noise is deterministic and equal to that
of `key=jax.random.key(0)`.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import check_key, check_last_dim, checked_jit, static_int
from ..raster._args import array_arg, finite_arg, float_dtype, float_scalar

__all__ = ["MAX_OCTAVES", "DEFAULT_KEY", "value_noise", "gradient_noise", "fractal_noise"]

#: The default `key` of the noise functions: the raw data of `jax.random.key(0)`
#: (a `uint32[2]` array, read-only), so that importing gfxlab creates no JAX array.
DEFAULT_KEY = np.zeros(2, np.uint32)
DEFAULT_KEY.flags.writeable = False

#: Most layers of `fractal_noise` (a documented size limit; with the default
#: lacunarity 2 the 32nd layer is already finer than float32 resolves).
MAX_OCTAVES = 32


def _hash(ints: jax.Array, seed) -> jax.Array:
    """A 32-bit integer hash of lattice coordinates `(..., k)` -> uniform floats in [0, 1).

    `seed` is a Python int or a traced `uint32` scalar (the same hash modulo 2^32).
    """
    if isinstance(seed, int):
        start = (seed * 0x9E3779B9 + 0x85EBCA6B) & 0xFFFFFFFF
        h = jnp.full(ints.shape[:-1], start, jnp.uint32)
    else:
        start = seed.astype(jnp.uint32) * jnp.uint32(0x9E3779B9) + jnp.uint32(0x85EBCA6B)
        h = jnp.broadcast_to(start, ints.shape[:-1])
    primes = (0x8DA6B343, 0xD8163841, 0xCB1AB31F)
    for j in range(ints.shape[-1]):
        h = h ^ (ints[..., j].astype(jnp.uint32) * jnp.uint32(primes[j]))
        h = (h ^ (h >> 16)) * jnp.uint32(0x7FEB352D)
        h = (h ^ (h >> 15)) * jnp.uint32(0x846CA68B)
        h = h ^ (h >> 16)
    return (h >> 8).astype(jnp.float32) / float(1 << 24)


def key_seed(key) -> jax.Array:
    """The lattice hash seed of a key: `jax.random.bits(key, dtype=uint32)` (traceable)."""
    return jax.random.bits(key, dtype=jnp.uint32)


def _fade(t):
    # Quintic fade 6t^5 - 15t^4 + 10t^3: C2 across lattice cells.
    return t * t * t * (t * (6 * t - 15) + 10)


def _noise_points(x, name: str = "x"):
    x = array_arg(x, name, "noise positions (..., 1) or (..., 2)")
    if x.ndim == 0:
        raise ValueError(f"`{name}` must be (..., 1) or (..., 2) positions")
    check_last_dim(x, name, (1, 2), "1D or 2D noise positions")
    return finite_arg(x, name)


def _corners(dim):
    return jnp.array([[(c >> j) & 1 for j in range(dim)] for c in range(2**dim)])


def _lattice_blend(x, corner_value):
    # Blend corner contributions of the cell containing x with the fade weights.
    cell = jnp.floor(jax.lax.stop_gradient(x))
    f = x - cell
    w = _fade(f)
    corners = _corners(x.shape[-1])
    total = 0.0
    for c in corners:
        weight = jnp.prod(jnp.where(c == 1, w, 1 - w), axis=-1)
        total = total + weight * corner_value(cell.astype(jnp.int32) + c, f - c)
    return total


def _value(x, seed):
    return _lattice_blend(x, lambda ij, _: 2 * _hash(ij, seed).astype(x.dtype) - 1)


def _gradient(x, seed):
    dim = x.shape[-1]

    def ramp(ij, offset):
        angle = 2 * jnp.pi * _hash(ij, seed).astype(x.dtype)
        if dim == 1:
            grad = (2 * _hash(ij, seed + 1).astype(x.dtype) - 1)[..., None]
            return 2 * jnp.sum(grad * offset, axis=-1)
        grad = jnp.stack([jnp.cos(angle), jnp.sin(angle)], axis=-1)
        return jnp.sqrt(2.0) * jnp.sum(grad * offset, axis=-1)

    return _lattice_blend(x, ramp)


def value_noise(
    x: Float[Array, "*batch dim"], *, key: jax.Array = DEFAULT_KEY
) -> Float[Array, "*batch"]:
    """Value noise in 1D or 2D: random values on the integer lattice, blended smoothly.

    **Arguments:**

    - `x`: `(..., 1)` or `(..., 2)` finite positions (use `t[..., None]` for a time
      signal); integer positions are taken as floats.
    - `key`: a `jax.random` key choosing the random lattice (may be traced; default
      `DEFAULT_KEY`, the data of `jax.random.key(0)`).

    **Returns:** values in `[-1, 1]`, shape `x.shape[:-1]`; equal to the lattice value at
    integer points, C2 smooth in between (quintic fade), differentiable in `x`.

    >>> v = value_noise(jnp.array([[0.0, 0.0], [0.5, 0.25]]), key=jax.random.key(3))
    >>> v.shape, bool(jnp.all(jnp.abs(v) <= 1))
    ((2,), True)
    """
    x = _noise_points(x)
    return _value_noise(x, check_key(key))


@checked_jit
def _value_noise(x, key):
    return _value(x.astype(float_dtype(x)), key_seed(key))


def gradient_noise(
    x: Float[Array, "*batch dim"], *, key: jax.Array = DEFAULT_KEY
) -> Float[Array, "*batch"]:
    """Gradient (Perlin-style) noise in 1D or 2D.

    Each lattice point holds a random unit gradient; the noise is the faded blend of the
    linear ramps `g . (x - corner)`, so it is zero at every lattice point and has no
    visible lattice-scale bumps.

    **Arguments:** as `value_noise`. **Returns:** values roughly in `[-1, 1]`.
    """
    x = _noise_points(x)
    return _gradient_noise(x, check_key(key))


@checked_jit
def _gradient_noise(x, key):
    return _gradient(x.astype(float_dtype(x)), key_seed(key))


def fractal_noise(
    x: Float[Array, "*batch dim"],
    *,
    octaves: int = 4,
    lacunarity: float = 2.0,
    gain: float = 0.5,
    kind: str = "gradient",
    key: jax.Array = DEFAULT_KEY,
) -> Float[Array, "*batch"]:
    """Sum of `octaves` noise layers, each `lacunarity` times finer and `gain` times weaker
    (fractional Brownian motion), normalised to the range of one layer.

    **Arguments:**

    - `x`: positions as in `value_noise`.
    - `octaves`: number of layers, a static int in `1..MAX_OCTAVES`.
    - `lacunarity`: frequency factor between layers (finite, > 0; may be traced).
    - `gain`: amplitude factor between layers (finite, > 0; may be traced).
    - `kind`: `"gradient"` or `"value"` noise layers.
    - `key`: a `jax.random` key (may be traced); layer `o` hashes with seed
      `s + 7919 o` (modulo 2^32), where `s = jax.random.bits(key, dtype=uint32)`.

    **Returns:** values roughly in `[-1, 1]`, shape `x.shape[:-1]`.
    """
    octaves = static_int(octaves, "octaves", minimum=1, maximum=MAX_OCTAVES)
    if kind not in ("gradient", "value"):
        raise ValueError(f"`kind` must be 'gradient' or 'value', got {kind!r}")
    x = _noise_points(x)
    lacunarity = float_scalar(lacunarity, "lacunarity", low=0)
    gain = float_scalar(gain, "gain", low=0)
    key = check_key(key)
    return _fractal_noise(x, lacunarity, gain, key, octaves=octaves, kind=kind)


@functools.partial(checked_jit, static_argnames=("octaves", "kind"))
def _fractal_noise(x, lacunarity, gain, key, *, octaves, kind):
    x = x.astype(float_dtype(x))
    seed = key_seed(key)
    noise = _gradient if kind == "gradient" else _value
    total, amplitude, norm, scale = 0.0, 1.0, 0.0, 1.0
    for o in range(octaves):
        total = total + amplitude * noise(x * scale, seed + jnp.uint32(7919 * o))
        norm = norm + amplitude
        amplitude = amplitude * gain
        scale = scale * lacunarity
    return total / norm
