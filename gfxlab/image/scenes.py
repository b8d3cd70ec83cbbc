"""Test pictures: impulse noise for the filters and a procedural photograph-like scene."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import check_key, checked_jit
from .._pixels import checked_shape, row_to_y
from ..raster._args import float_dtype, float_scalar
from .filters import _check_filter_image
from .networks import guard_finite
from .noise import DEFAULT_KEY, _value

__all__ = ["add_salt_and_pepper", "synthetic_scene"]


def add_salt_and_pepper(
    image: Float[Array, "H W *C"], *, amount: float = 0.05, key: jax.Array
) -> Float[Array, "H W *C"]:
    """Impulse noise: a fraction `amount` of pixels set to 0 or 1 (half each), all
    channels of a pixel together.

    **Arguments:**

    - `image`: float image in [0, 1], `(H, W)` or `(H, W, C)`.
    - `amount`: the expected fraction of corrupted pixels, in [0, 1].
    - `key`: a `jax.random` key.

    **Returns:**

    The noisy image (same shape and dtype).
    """
    image = _check_filter_image(image)
    amount = float_scalar(amount, "amount", low=0, high=1, low_open=False)
    return _salt_and_pepper(image, amount, check_key(key))


@checked_jit
def _salt_and_pepper(image, amount, key):
    image = guard_finite(image, image, "image")
    image = image.astype(float_dtype(image))
    k1, k2 = jax.random.split(key)
    u = jax.random.uniform(k1, image.shape[:2], dtype=image.dtype)
    salt = jax.random.bernoulli(k2, 0.5, image.shape[:2])
    hit, salt = u < amount, salt
    if image.ndim == 3:
        hit, salt = hit[..., None], salt[..., None]
    return jnp.where(hit, jnp.where(salt, 1.0, 0.0).astype(image.dtype), image)


def _scene_number(key) -> int:
    """A concrete key's data as one non-negative integer (`jax.random.key(n)` -> `n`)."""
    if isinstance(key, jax.core.Tracer):
        raise TypeError("`key` must be a concrete jax.random key (the scene is NumPy), not traced")
    data = (
        np.asarray(
            jax.random.key_data(key) if jnp.issubdtype(key.dtype, jax.dtypes.prng_key) else key
        )
        .astype(np.uint64)
        .ravel()
    )
    number = 0
    for word in data:
        number = (number << 32) | int(word)
    return number


@jax.jit
def _scene_noise(uv, cells, seeds):
    return jax.vmap(lambda c, s: _value(uv * c, s))(cells, seeds)


def synthetic_scene(
    shape: tuple[int, int] = (256, 256), *, key: jax.Array = DEFAULT_KEY
) -> np.ndarray:
    """A procedural, photograph-like RGB scene: sky, sun, hills, a house, a tree, grass
    texture (`value_noise`) and sensor noise. Deterministic for a given `shape` and
    `key`, with and without `jax_enable_x64`.

    **Arguments:**

    - `shape`: `(H, W)` (static).
    - `key`: a concrete `jax.random` key. The scene's number is the key's data read as
      one 64-bit integer, so `jax.random.key(n)` gives scene `n`; the default
      (`DEFAULT_KEY`, the data of `jax.random.key(0)`) gives scene 0, which is
      `data/images/scene.png` (written by `write_image`).

    **Returns:**

    A float64 NumPy array `(H, W, 3)` in [0, 1].
    """
    height, width = checked_shape(shape)
    seed = _scene_number(check_key(key))
    rng = np.random.default_rng(seed)
    # Picture coordinates in [0, 1] of the pixel centres: u right, v up (`_pixels`' y).
    heights = row_to_y(np.arange(height), height) / (height - 1) if height > 1 else np.ones(1)
    v, u = np.meshgrid(heights, np.linspace(0, 1, width), indexing="ij")
    # Value noise on `cells x cells` lattices over the picture, one layer per size,
    # in float32 so that the scene is the same with and without `jax_enable_x64`.
    sizes = (6, 14, 30, 10, 8, 40, 50, 60, 35, 12)
    layers = _scene_noise(
        np.stack([u, v], axis=-1).astype(np.float32),
        np.asarray(sizes, np.float32),
        np.asarray([(seed * 1009 + c) % 2**32 for c in sizes], np.uint32),
    )
    layers = dict(zip(sizes, 0.5 + 0.5 * np.asarray(layers, dtype=np.float64), strict=True))

    def smooth_noise(cells):
        return layers[cells]

    clouds = 0.5 * smooth_noise(6) + 0.3 * smooth_noise(14) + 0.2 * smooth_noise(30)
    sky = np.stack([0.35 + 0.45 * (1 - v), 0.55 + 0.35 * (1 - v), 0.95 - 0.1 * (1 - v)], -1)
    img = sky + 0.35 * np.clip(clouds - 0.5, 0, 1)[..., None]
    sun_d = np.hypot((u - 0.78) * width / height, v - 0.82)
    img += np.clip(1.0 - sun_d / 0.08, 0, 1)[..., None] ** 0.5 * np.array([0.6, 0.5, 0.2])
    img += 0.25 * np.exp(-((sun_d / 0.2) ** 2))[..., None] * np.array([1.0, 0.8, 0.4])
    far = 0.45 + 0.06 * np.sin(7 * u + 1) + 0.03 * np.sin(23 * u) + 0.03 * smooth_noise(10)
    img = np.where((v < far)[..., None], np.array([0.35, 0.45, 0.6]) + 0.1 * v[..., None], img)
    near = 0.3 + 0.08 * np.sin(4 * u + 2) + 0.04 * smooth_noise(8)
    texture = 0.6 * smooth_noise(40) + 0.4 * rng.random((height, width))
    grass = np.stack([0.2 + 0.15 * texture, 0.45 + 0.25 * texture, 0.12 + 0.08 * texture], -1)
    img = np.where((v < near)[..., None], grass * (0.7 + 0.6 * v[..., None]), img)
    # A house: wall, roof, door and window.
    wall = (u > 0.18) & (u < 0.42) & (v > 0.22) & (v < 0.4)
    roof = (v >= 0.4) & (v < 0.4 + 0.16 - np.abs(u - 0.3) * 1.1) & (u > 0.15) & (u < 0.45)
    img = np.where(
        wall[..., None], np.array([0.85, 0.78, 0.65]) - 0.05 * smooth_noise(50)[..., None], img
    )
    img = np.where(
        roof[..., None], np.array([0.6, 0.15, 0.1]) + 0.08 * smooth_noise(60)[..., None], img
    )
    door = (u > 0.27) & (u < 0.32) & (v > 0.22) & (v < 0.33)
    window = (u > 0.35) & (u < 0.4) & (v > 0.3) & (v < 0.36)
    img = np.where(door[..., None], np.array([0.35, 0.2, 0.1]), img)
    img = np.where(window[..., None], np.array([0.9, 0.85, 0.4]), img)
    # A tree: trunk and a textured round crown.
    trunk = (np.abs(u - 0.7) < 0.015) & (v > 0.2) & (v < 0.36)
    crown_d = np.hypot((u - 0.7) * width / height, v - 0.42)
    leaves = 0.5 * smooth_noise(35) + 0.5 * rng.random((height, width))
    img = np.where(trunk[..., None], np.array([0.3, 0.2, 0.1]), img)
    crown = crown_d < 0.1 + 0.015 * smooth_noise(12)
    img = np.where(
        crown[..., None],
        np.stack([0.1 + 0.1 * leaves, 0.3 + 0.3 * leaves, 0.08 + 0.05 * leaves], -1),
        img,
    )
    img += 0.012 * rng.standard_normal((height, width, 3))
    return np.clip(img, 0.0, 1.0)
