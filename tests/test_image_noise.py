"""gfxlab.image noise: value noise (gfxlab's one owner), gradient noise, fractal sums."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.stats
from jax.test_util import check_grads

from gfxlab import image as gi


def lattice(n, dim):
    grids = np.meshgrid(*[np.arange(-n, n, dtype=float)] * dim, indexing="ij")
    return jnp.asarray(np.stack([g.ravel() for g in grids], -1))


@pytest.mark.parametrize("dim", [1, 2])
def test_value_noise_lattice_values_are_uniform_in_minus_one_one(dim):
    # At lattice points the noise is the hashed lattice value: uniform on [-1, 1).
    values = np.asarray(gi.value_noise(lattice(2000 if dim == 1 else 45, dim), seed=11))
    assert values.min() >= -1 and values.max() < 1
    assert scipy.stats.kstest(values, scipy.stats.uniform(-1, 2).cdf).pvalue > 1e-3
    # Neighbouring lattice values are independent (no visible correlation).
    assert abs(np.corrcoef(values[:-1], values[1:])[0, 1]) < 0.1


def test_value_noise_interpolates_between_lattice_values_with_a_quintic_fade():
    # In 1D between lattice points i and i + 1: v = a + (b - a) * fade(t).
    t = np.linspace(0.0, 1.0, 17)
    x = 3.0 + t
    ends = np.asarray(gi.value_noise(jnp.array([[3.0], [4.0]]), seed=4))
    fade = t**3 * (t * (6 * t - 15) + 10)
    expected = ends[0] + (ends[1] - ends[0]) * fade
    np.testing.assert_allclose(
        gi.value_noise(jnp.asarray(x)[:, None], seed=4), expected, rtol=1e-6, atol=1e-6
    )


def test_value_noise_is_smooth_and_differentiable():
    x = jnp.array([[0.3, 1.7], [2.25, -0.6], [5.5, 5.5]])
    check_grads(
        lambda p: gi.value_noise(p, seed=2), (x,), order=2, modes=["rev"], atol=1e-4, rtol=1e-4
    )
    check_grads(
        lambda p: gi.gradient_noise(p, seed=2), (x,), order=1, modes=["rev"], atol=1e-4, rtol=1e-4
    )


def test_gradient_noise_vanishes_on_the_lattice_and_seeds_differ():
    points = lattice(6, 2)
    np.testing.assert_allclose(gi.gradient_noise(points, seed=5), 0.0, atol=1e-12)
    x = jnp.array([[0.5, 0.5], [1.3, 2.7]])
    assert not np.allclose(gi.value_noise(x, seed=1), gi.value_noise(x, seed=2))
    np.testing.assert_array_equal(gi.value_noise(x, seed=1), gi.value_noise(x, seed=1))


def test_fractal_noise_is_the_normalised_sum_of_its_layers():
    x = jnp.array([[0.3, 1.7], [2.25, -0.6]])
    layers = [gi.value_noise(x * 1.5**o, seed=9 + 7919 * o) for o in range(3)]
    weights = [1.0, 0.6, 0.36]
    expected = sum(w * v for w, v in zip(weights, layers, strict=True)) / sum(weights)
    ours = gi.fractal_noise(x, octaves=3, lacunarity=1.5, gain=0.6, kind="value", seed=9)
    np.testing.assert_allclose(ours, expected, rtol=1e-12)
    np.testing.assert_array_equal(
        gi.fractal_noise(x, octaves=1, seed=3), gi.gradient_noise(x, seed=3)
    )
    check_grads(lambda g: gi.fractal_noise(x, octaves=3, gain=g), (0.5,), order=1, modes=["rev"])


def test_noise_bad_inputs():
    with pytest.raises(ValueError, match="x"):
        gi.value_noise(jnp.zeros((4, 3)))
    with pytest.raises(ValueError, match="x"):
        gi.value_noise(jnp.asarray(1.0))
    with pytest.raises(TypeError, match="seed"):
        gi.value_noise(jnp.zeros((4, 2)), seed=1.5)
    with pytest.raises(ValueError, match="kind"):
        gi.fractal_noise(jnp.zeros((4, 2)), kind="perlin")
    with pytest.raises(ValueError, match="octaves"):
        gi.fractal_noise(jnp.zeros((4, 2)), octaves=0)
    with pytest.raises(TypeError, match="seed"):
        jax.jit(lambda s: gi.value_noise(jnp.zeros((1, 2)), seed=s))(3)


def test_synthetic_scene_is_the_same_with_and_without_x64():
    a = gi.synthetic_scene((20, 24), seed=1)
    with jax.enable_x64(False):
        b = gi.synthetic_scene((20, 24), seed=1)
    np.testing.assert_array_equal(a, b)
