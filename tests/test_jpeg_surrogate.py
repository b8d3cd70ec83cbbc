"""d/d(quality) of `compress` against central differences of the exact pipeline.

The forward value of `compress` is libjpeg's round trip, a staircase in `quality`;
its slope over a few quality steps is what a fit of `quality` needs. The default
surrogate must have that slope's sign and be within 2x of it."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import jpeg


def photo(height: int, width: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:height, :width]
    img = np.stack(
        [128 + 100 * np.sin(x / 5 + y / 7), 128 + 80 * np.cos(x / 3) * (x > width / 3), y / 2.0],
        -1,
    )
    return np.clip(img + rng.normal(0, 12, img.shape), 0, 255) / 255.0


IMAGES = [jnp.asarray(photo(64, 64, 1)), jnp.asarray(photo(64, 64, 2))]


def _loss(rounding):
    def loss(image, q):
        return jnp.mean((jpeg.compress(image, quality=q, rounding=rounding) - image) ** 2)

    return loss


# One compiled program each, shared by both images (same shape).
_VALUE_AND_GRAD = jax.jit(jax.value_and_grad(_loss("deadzone"), argnums=1))
_STE_GRAD = jax.jit(jax.grad(_loss("ste"), argnums=1))


@pytest.mark.parametrize("index", range(len(IMAGES)))
def test_default_quality_gradient_matches_central_differences(index):
    image = IMAGES[index]
    ratios = {}
    for q in (20.0, 50.0, 80.0):
        h = 5.0  # integer qualities either side: the staircase's slope
        above, below = (float(_VALUE_AND_GRAD(image, q + s)[0]) for s in (h, -h))
        central = (above - below) / (2 * h)
        assert central < 0  # higher quality, smaller error
        ratios["deadzone", q] = float(_VALUE_AND_GRAD(image, q)[1]) / central
        ratios["ste", q] = float(_STE_GRAD(image, q)) / central
    for q in (20.0, 50.0, 80.0):
        assert 0.5 <= ratios["deadzone", q] <= 2.0, ratios  # right sign, within 2x
        # ...and closer than straight-through, which overstates the slope.
        assert abs(np.log(ratios["deadzone", q])) < abs(np.log(ratios["ste", q])), ratios
    assert max(ratios["ste", q] for q in (50.0, 80.0)) > 2.0  # the finding


def test_quantize_deadzone_rounding():
    table = jnp.full((8, 8), 4.0)
    x = jnp.linspace(-10, 10, 64).reshape(8, 8)
    out = jpeg.quantize(x, table, rounding="deadzone")
    np.testing.assert_array_equal(out, jpeg.quantize(x, table))
    gx = jax.jit(jax.grad(lambda x: jpeg.quantize(x, table, rounding="deadzone").sum()))(x)
    np.testing.assert_allclose(gx, 0.25)  # straight-through w.r.t. the coefficients
    # d (q * t) / dt: (r - y) where r != 0, a quarter of it where r == 0.
    gt = jax.jit(jax.grad(lambda t: jnp.sum(jpeg.quantize(x, t, rounding="deadzone") * t)))(table)
    y = np.asarray(x) / 4.0
    r = np.sign(y) * np.floor(np.abs(y) + 0.5)
    np.testing.assert_allclose(gt, np.where(r == 0, 0.25, 1.0) * (r - y), atol=1e-12)
