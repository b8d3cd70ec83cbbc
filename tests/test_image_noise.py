"""gfxlab.image noise: value noise (gfxlab's one owner), gradient noise, fractal sums."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.stats
from jax.test_util import check_grads

from gfxlab import image as gi

K = jax.random.key


def lattice(n, dim):
    grids = np.meshgrid(*[np.arange(-n, n, dtype=float)] * dim, indexing="ij")
    return jnp.asarray(np.stack([g.ravel() for g in grids], -1))


@pytest.mark.parametrize("dim", [1, 2])
def test_value_noise_lattice_values_are_uniform_in_minus_one_one(dim):
    # At lattice points the noise is the hashed lattice value: uniform on [-1, 1).
    values = np.asarray(gi.value_noise(lattice(2000 if dim == 1 else 45, dim), key=K(11)))
    assert values.min() >= -1 and values.max() < 1
    assert scipy.stats.kstest(values, scipy.stats.uniform(-1, 2).cdf).pvalue > 1e-3
    # Neighbouring lattice values are independent (no visible correlation).
    assert abs(np.corrcoef(values[:-1], values[1:])[0, 1]) < 0.1


def test_value_noise_interpolates_between_lattice_values_with_a_quintic_fade():
    # In 1D between lattice points i and i + 1: v = a + (b - a) * fade(t).
    t = np.linspace(0.0, 1.0, 17)
    x = 3.0 + t
    ends = np.asarray(gi.value_noise(jnp.array([[3.0], [4.0]]), key=K(4)))
    fade = t**3 * (t * (6 * t - 15) + 10)
    expected = ends[0] + (ends[1] - ends[0]) * fade
    np.testing.assert_allclose(
        gi.value_noise(jnp.asarray(x)[:, None], key=K(4)), expected, rtol=1e-6, atol=1e-6
    )


def test_value_noise_is_smooth_and_differentiable():
    x = jnp.array([[0.3, 1.7], [2.25, -0.6], [5.5, 5.5]])
    check_grads(
        lambda p: gi.value_noise(p, key=K(2)), (x,), order=2, modes=["rev"], atol=1e-4, rtol=1e-4
    )
    check_grads(
        lambda p: gi.gradient_noise(p, key=K(2)), (x,), order=1, modes=["rev"], atol=1e-4, rtol=1e-4
    )


def test_gradient_noise_vanishes_on_the_lattice_and_keys_differ():
    points = lattice(6, 2)
    np.testing.assert_allclose(gi.gradient_noise(points, key=K(5)), 0.0, atol=1e-12)
    x = jnp.array([[0.5, 0.5], [1.3, 2.7]])
    assert not np.allclose(gi.value_noise(x, key=K(1)), gi.value_noise(x, key=K(2)))
    np.testing.assert_array_equal(gi.value_noise(x, key=K(1)), gi.value_noise(x, key=K(1)))


def test_fractal_noise_is_the_normalised_sum_of_its_layers():
    # (1 + g + g^2) fractal(g) = n0 + g n1 + g^2 n2: a quadratic in the gain g whose
    # constant term is the first layer, the noise of the same key.
    x = jnp.array([[0.3, 1.7], [2.25, -0.6]])
    gains = np.array([0.3, 0.6, 0.9, 1.4])
    sums = np.stack(
        [
            (1 + g + g * g)
            * np.asarray(
                gi.fractal_noise(x, octaves=3, lacunarity=1.5, gain=g, kind="value", key=K(9))
            )
            for g in gains
        ]
    )
    coefficients = np.polyfit(gains, sums, 3)
    np.testing.assert_allclose(coefficients[0], 0.0, atol=1e-10)  # no cubic term
    np.testing.assert_allclose(coefficients[-1], gi.value_noise(x, key=K(9)), atol=1e-10)
    np.testing.assert_array_equal(
        gi.fractal_noise(x, octaves=1, key=K(3)), gi.gradient_noise(x, key=K(3))
    )
    check_grads(lambda g: gi.fractal_noise(x, octaves=3, gain=g), (0.5,), order=1, modes=["rev"])


def test_noise_key_default_raw_keys_and_traced_keys():
    x = jnp.array([[0.5, 0.5], [1.3, 2.7]])
    for fn in (gi.value_noise, gi.gradient_noise, gi.fractal_noise):
        default = np.asarray(fn(x))
        np.testing.assert_array_equal(default, fn(x, key=K(0)))  # documented default
        np.testing.assert_array_equal(default, fn(x, key=jax.random.PRNGKey(0)))
        traced = jax.jit(lambda k, fn=fn: fn(x, key=k))(K(7))
        np.testing.assert_allclose(traced, fn(x, key=K(7)), rtol=1e-13, atol=1e-15)
    # split keys under vmap: one noise per key, each equal to its own call
    keys = jax.random.split(K(1), 3)
    batched = jax.vmap(lambda k: gi.value_noise(x, key=k))(keys)
    for k, row in zip(keys, batched, strict=True):
        np.testing.assert_allclose(row, gi.value_noise(x, key=k), rtol=1e-13, atol=1e-15)


def test_noise_bad_inputs():
    with pytest.raises(ValueError, match="x"):
        gi.value_noise(jnp.zeros((4, 3)))
    with pytest.raises(ValueError, match="x"):
        gi.value_noise(jnp.asarray(1.0))
    with pytest.raises(TypeError, match="key"):
        gi.value_noise(jnp.zeros((4, 2)), key=1)
    with pytest.raises(TypeError, match="key"):
        gi.gradient_noise(jnp.zeros((4, 2)), key=None)
    with pytest.raises(TypeError, match="key"):
        gi.fractal_noise(jnp.zeros((4, 2)), key=jax.random.split(K(0), 2))
    with pytest.raises(ValueError, match="kind"):
        gi.fractal_noise(jnp.zeros((4, 2)), kind="perlin")
    with pytest.raises(ValueError, match="octaves"):
        gi.fractal_noise(jnp.zeros((4, 2)), octaves=0)
    with pytest.raises(ValueError, match="octaves"):
        gi.fractal_noise(jnp.zeros((4, 2)), octaves=10**9)


def test_synthetic_scene_is_the_same_with_and_without_x64():
    a = gi.synthetic_scene((20, 24), key=K(1))
    with jax.enable_x64(False):
        b = gi.synthetic_scene((20, 24), key=K(1))
        c = gi.synthetic_scene((20, 24), key=jax.random.PRNGKey(1))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
