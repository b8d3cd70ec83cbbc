"""gfxlab.curves: least-squares fitting of Bezier and B-spline control points, parameter
correction, and ellipse fitting, all through gfxlab.fit."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate as si

from gfxlab import curves
from gfxlab.fit import fit


def noisy_curve(rng, count=60, noise=0.01):
    s = np.linspace(0, 1, count)
    clean = np.stack([s * 3 + 0.3 * np.sin(5 * s), np.sin(2 * np.pi * s) + 0.2 * s], axis=1)
    return clean + noise * rng.normal(size=clean.shape)


def test_gauss_newton_fit_matches_make_lsq_spline():
    rng = np.random.default_rng(0)
    points = noisy_curve(rng)
    degree, count = 3, 9
    knots = np.asarray(curves.clamped_knots(count, degree))
    u = np.asarray(curves.chord_length_parameters(points))
    reference = si.make_lsq_spline(u, points, knots, k=degree).c
    curve, parameters, result = curves.fit_bspline(points, degree, count, full_output=True)
    np.testing.assert_allclose(parameters, u, atol=1e-15)
    np.testing.assert_allclose(curve.control_points, reference, rtol=0, atol=1e-9)
    assert result.method == "gauss_newton"
    assert result.num_steps <= 5
    np.testing.assert_allclose(curve.knots, knots)


def test_fit_bspline_with_given_knots_and_parameters():
    rng = np.random.default_rng(1)
    points = noisy_curve(rng, count=40)
    knots = np.array([0, 0, 0, 0.2, 0.5, 0.6, 1, 1, 1.0]) * 2 + 1  # range [1, 3]
    u = 1 + 2 * np.linspace(0, 1, 40) ** 1.2
    reference = si.make_lsq_spline(u, points, knots, k=2).c
    curve = curves.fit_bspline(
        points, 2, 6, knots=knots, parameters=u, method="levenberg_marquardt"
    )
    np.testing.assert_allclose(curve.control_points, reference, atol=1e-7)


def test_parameter_correction_reduces_the_error():
    rng = np.random.default_rng(2)
    s = np.sort(rng.uniform(0, 1, 50)) ** 2  # uneven sampling: chord length is off
    true = curves.bezier(jnp.array([[0, 0], [1, 2], [3, -1], [4, 1.0]]), s)
    points = np.asarray(true) + 1e-4 * rng.normal(size=(50, 2))
    corrected, parameters, result = curves.fit_bezier(
        points, 3, correct_parameters=True, full_output=True
    )
    # The chord-length least-squares fit it starts from, by NumPy.
    basis = np.asarray(curves.bernstein(3, curves.chord_length_parameters(points)))
    plain = basis @ np.linalg.lstsq(basis, points, rcond=None)[0]
    error_plain = np.abs(plain - points).max()
    error_corrected = np.abs(corrected(parameters) - points).max()
    assert error_corrected < error_plain / 10
    assert error_corrected < 1e-3
    assert np.all((parameters >= 0) & (parameters <= 1))
    assert result.method == "levenberg_marquardt"


def test_fit_ellipse_recovers_noisy_ellipse():
    rng = np.random.default_rng(4)
    truth = curves.Ellipse([1.0, -0.5], [3.0, 1.2], 0.6)
    t = rng.uniform(0, 2 * np.pi, 80)
    points = np.asarray(truth(t)) + 0.02 * rng.normal(size=(80, 2))
    fitted, _, result = curves.fit_ellipse(points, max_steps=30, full_output=True)
    np.testing.assert_allclose(fitted.center, truth.center, atol=0.02)
    np.testing.assert_allclose(fitted.radii, truth.radii, atol=0.02)
    np.testing.assert_allclose(fitted.angle, 0.6, atol=0.02)
    assert result.loss < result.loss_history[0]
    # Geometric optimum: the mean squared residual is about the noise variance.
    assert result.loss / 80 < 2 * 2 * 0.02**2


def test_modules_fit_directly_with_gfxlab_fit():
    """A `Bezier` is a pytree: `gfxlab.fit.fit` fits it as is."""
    u = jnp.linspace(0, 1, 20)
    target = curves.bezier(jnp.array([[0, 0], [1, 2], [2, 0.0]]), u)
    start = curves.Bezier(jnp.zeros((3, 2)))
    result = fit(lambda c: c(u) - target, start, method="gauss_newton")
    np.testing.assert_allclose(result.params.control_points, [[0, 0], [1, 2], [2, 0]], atol=1e-9)
    # A BSpline fits its control points; its knots stay where they are.
    spline = curves.BSpline(jnp.zeros((5, 2)), 2)
    target = curves.bspline(jnp.arange(10.0).reshape(5, 2), 2, u)
    fitted = fit(lambda c: c(u) - target, spline).params
    np.testing.assert_allclose(fitted.knots, spline.knots)
    np.testing.assert_allclose(fitted.control_points, np.arange(10.0).reshape(5, 2), atol=1e-6)


def test_fit_bad_input():
    points = jnp.zeros((3, 2))
    with pytest.raises(ValueError, match="at least degree \\+ 1 = 4 points"):
        curves.fit_bezier(points, 3)
    with pytest.raises(ValueError, match="at least num_control_points = 5"):
        curves.fit_bspline(points, 2, 5)
    with pytest.raises(ValueError, match="too high"):
        curves.fit_bspline(jnp.zeros((10, 2)), 4, 4)
    with pytest.raises(ValueError, match="`parameters` must lie in \\[0, 1\\]"):
        curves.fit_bezier(jnp.zeros((5, 2)), 2, parameters=jnp.linspace(0, 2, 5))
    with pytest.raises(ValueError, match="`parameters` must lie in the B-spline"):
        curves.fit_bspline(jnp.zeros((5, 2)), 2, 4, parameters=jnp.linspace(-1, 1, 5))
    with pytest.raises(ValueError, match="at least 5 points"):
        curves.fit_ellipse(jnp.zeros((4, 2)))
    with pytest.raises(ValueError, match="`points` must have shape"):
        curves.fit_ellipse(jnp.zeros((8, 3)))
    with pytest.raises(ValueError, match="at least 2 points"):
        curves.chord_length_parameters(jnp.zeros((1, 2)))
    # Coincident points fall back to uniform parameters.
    np.testing.assert_allclose(curves.chord_length_parameters(jnp.ones((3, 2))), [0, 0.5, 1])
    assert jax.numpy.all(
        jnp.isfinite(jax.grad(lambda p: curves.chord_length_parameters(p).sum())(jnp.ones((3, 2))))
    )


def test_fitting_functions_are_documented_drivers():
    """Issue 17: the fitting functions are drivers (they run `gfxlab.fit.fit`'s loop):
    under `jax.jit`/`jax.grad` they raise a clear `TypeError`, and their solver settings
    are checked before any work."""
    points = jnp.array([[0.0, 0], [1, 2], [2, -1], [3, 3], [4, 0], [5, 1]])
    for fn, args in [
        (curves.fit_bezier, (2,)),
        (curves.fit_bspline, (2, 4)),
        (curves.fit_ellipse, ()),
    ]:
        assert "driver" in fn.__doc__
        with pytest.raises(TypeError, match=f"`{fn.__name__}` is a driver"):
            jax.jit(lambda p, fn=fn, args=args: jax.tree_util.tree_leaves(fn(p, *args)))(points)
        with pytest.raises(TypeError, match=f"`{fn.__name__}` is a driver"):
            jax.grad(lambda p, fn=fn, args=args: jax.tree_util.tree_leaves(fn(p, *args))[0].sum())(
                points
            )
        with pytest.raises(TypeError, match="`method`"):
            fn(points, *args, method=None)
        with pytest.raises(ValueError, match="`method`"):
            fn(points, *args, method="newton")
        with pytest.raises(ValueError, match="`max_steps`"):
            fn(points, *args, max_steps=10**12)
