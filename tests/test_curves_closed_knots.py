"""gfxlab.curves: closed (periodic) B-splines, fitted knots kept ordered by construction,
the fields `gfxlab.fit` holds fixed, and bad input (None, NaN/inf, huge sizes)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate as si
from jax.test_util import check_grads

from gfxlab import checked_jit, curves
from gfxlab.fit import fit


def periodic_reference(cp, breaks, degree):
    """SciPy's periodic B-spline for the closed curve: wrapped control points on the
    periodically extended knots, evaluated with `extrapolate="periodic"`."""
    n = len(cp)
    period = breaks[-1] - breaks[0]
    knots = np.concatenate(
        [breaks[n - degree : n] - period, breaks, breaks[1 : degree + 1] + period]
    )
    wrapped = np.concatenate([cp, cp[:degree]])
    return si.BSpline(knots, wrapped, degree, extrapolate="periodic")


def test_closed_bspline_matches_scipy_periodic():
    rng = np.random.default_rng(0)
    for degree in (1, 2, 3, 4):
        cp = rng.normal(size=(7, 2))
        breaks = np.sort(rng.uniform(-1, 3, 8))
        # Inside the period, at its ends, and far outside (wrapped).
        u = np.concatenate([breaks, rng.uniform(-7, 9, 40)])
        ours = curves.bspline(cp, degree, u, knots=breaks, closed=True)
        np.testing.assert_allclose(
            ours, periodic_reference(cp, breaks, degree)(u), rtol=0, atol=1e-12
        )
    # Default breakpoints: uniform on [0, 1].
    cp = rng.normal(size=(5, 3))
    u = np.linspace(0, 1, 11)
    reference = periodic_reference(cp, np.linspace(0, 1, 6), 3)(u)
    np.testing.assert_allclose(curves.bspline(cp, 3, u, closed=True), reference, atol=1e-12)
    np.testing.assert_allclose(curves.BSpline(cp, 3, closed=True)(u), reference, atol=1e-12)


def test_closed_bspline_is_smooth_where_it_closes():
    cp = jnp.asarray(np.random.default_rng(1).normal(size=(6, 2)))
    curve = curves.BSpline(cp, 3, closed=True)
    point = lambda u: curve(u)  # noqa: E731
    first = jax.jacfwd(point)
    second = jax.jacfwd(first)
    for f in (point, first, second):  # C^2 for a cubic: value, tangent, curvature
        np.testing.assert_allclose(f(0.0), f(1.0), atol=1e-12)
    # Gradients with respect to the control points, under jit.
    check_grads(
        jax.jit(lambda c: curves.bspline(c, 3, jnp.array([0.05, 0.5, 0.97]), closed=True)),
        (cp,),
        order=1,
        modes=["rev"],
    )


def test_fixed_knots_are_named_for_fit_and_have_no_gradient():
    curve = curves.BSpline(jnp.zeros((5, 2)), 2)
    assert curve.fixed_fields() == ("base_knots",)
    assert curve.knot_logits is None
    np.testing.assert_array_equal(curve.knots, curves.clamped_knots(5, 2))
    # Every name is a field holding the knots (what `fit` partitions out).
    for name in curve.fixed_fields():
        np.testing.assert_array_equal(getattr(curve, name), curve.knots)
    grads = eqx.filter_grad(lambda c: jnp.sum(c(jnp.linspace(0, 1, 9)) ** 2))(
        eqx.tree_at(lambda c: c.control_points, curve, jnp.ones((5, 2)))
    )
    np.testing.assert_array_equal(grads.base_knots, 0)
    assert float(jnp.abs(grads.control_points).sum()) > 0
    nurbs = curves.NURBS(jnp.zeros((5, 2)), jnp.ones(5), 2)
    assert nurbs.fixed_fields() == ("base_knots",) and nurbs.knot_logits is None
    np.testing.assert_array_equal(nurbs.knots, curves.clamped_knots(5, 2))
    free = curves.NURBS(jnp.zeros((5, 2)), jnp.ones(5), 2, fit_knots=True)
    assert free.knot_logits.shape == (3,)


@pytest.mark.parametrize("method", ["gauss_newton", "levenberg_marquardt"])
def test_fit_never_moves_fixed_knots(method):
    """Issue 18: with `fit_knots=False` neither least-squares solver changes the knots
    (they are partitioned out by `fixed_fields`)."""
    knots = jnp.array([0, 0, 0, 0.3, 0.4, 1, 1, 1.0])
    u = jnp.linspace(0, 1, 12)
    target = curves.bspline(jnp.arange(10.0).reshape(5, 2), 2, u, knots=knots)
    start = curves.BSpline(jnp.zeros((5, 2)), 2, knots)
    result = fit(lambda c: c(u) - target, start, method=method, max_steps=20)
    np.testing.assert_array_equal(result.params.knots, knots)
    np.testing.assert_array_equal(result.params.base_knots, knots)
    assert result.loss < 1e-12


def test_nurbs_fitted_knots_stay_ordered():
    knots = jnp.array([0, 0, 0, 0.3, 0.4, 1, 1, 1.0])
    curve = curves.NURBS(jnp.ones((5, 2)), jnp.ones(5), 2, knots, fit_knots=True)
    np.testing.assert_allclose(curve.knots, knots, atol=1e-12)
    wild = eqx.tree_at(lambda c: c.knot_logits, curve, jnp.array([40.0, -40.0, 3.0]))
    assert np.all(np.diff(np.asarray(wild.knots)) >= 0)
    np.testing.assert_array_equal(np.asarray(wild.knots)[[0, 1, 2, 5, 6, 7]], [0, 0, 0, 1, 1, 1])
    assert np.all(np.isfinite(np.asarray(wild(jnp.linspace(0, 1, 5)))))


def test_fitted_knots_stay_ordered_whatever_the_logits():
    knots = jnp.array([0, 0, 0, 0, 0.2, 0.3, 0.7, 1, 1, 1, 1.0])
    curve = curves.BSpline(jnp.ones((7, 2)), 3, knots, fit_knots=True)
    np.testing.assert_allclose(curve.knots, knots, atol=1e-12)  # starts where given
    assert curve.fixed_fields() == ("base_knots",)
    rng = np.random.default_rng(2)
    for scale in (1.0, 30.0, 300.0):
        wild = eqx.tree_at(lambda c: c.knot_logits, curve, scale * rng.normal(size=4))
        t = np.asarray(wild.knots)
        assert np.all(np.diff(t) >= 0)
        np.testing.assert_array_equal(t[:4], 0)  # the range and the outer knots stay
        np.testing.assert_array_equal(t[-4:], 1)
        assert np.all(np.isfinite(np.asarray(wild(jnp.linspace(0, 1, 5)))))

    def evaluate(logits):
        moved = eqx.tree_at(lambda c: c.knot_logits, curve, logits)
        return moved(jnp.array([0.1, 0.45, 0.8]))

    check_grads(evaluate, (curve.knot_logits,), order=1, modes=["rev"])


def test_fit_moves_free_knots_towards_the_truth_and_keeps_them_ordered():
    u = jnp.linspace(0, 1, 80)
    true_knots = jnp.array([0, 0, 0, 0, 0.15, 0.7, 1, 1, 1, 1.0])
    true_cp = jnp.array([[0, 0], [1, 2], [2, -1], [3, 3], [4, 0], [5, 1.0]])
    target = curves.bspline(true_cp, 3, u, knots=true_knots)
    start = curves.BSpline(curves.fit_bspline(target, 3, 6).control_points, 3, fit_knots=True)
    fixed_loss = float(jnp.sum((start(u) - target) ** 2))
    result = fit(lambda c: c(u) - target, start, method="levenberg_marquardt", max_steps=60)
    fitted = result.params
    assert np.all(np.diff(np.asarray(fitted.knots)) >= 0)
    assert result.loss < 1e-3 * fixed_loss
    np.testing.assert_allclose(fitted.knots, true_knots, atol=1e-3)


def test_closed_and_knot_bad_input():
    cp = jnp.zeros((5, 2))
    with pytest.raises(ValueError, match="num_control_points \\+ 1 = 6 breakpoints"):
        curves.bspline(cp, 3, jnp.array([0.5]), knots=jnp.linspace(0, 1, 9), closed=True)
    with pytest.raises(ValueError, match="positive period"):
        curves.bspline(cp, 3, jnp.array([0.5]), knots=jnp.zeros(6), closed=True)
    with pytest.raises(ValueError, match="`u` must be finite"):
        curves.bspline(cp, 3, jnp.array([jnp.nan]), closed=True)
    with pytest.raises(ValueError, match="`knots` must be finite"):
        curves.bspline(cp, 2, jnp.array([0.5]), knots=jnp.array([0, 0, 0, 0.5, jnp.inf, 1, 1, 1.0]))
    with pytest.raises(ValueError, match="`knots` must be finite"):
        curves.BSpline(cp, 3, jnp.array([0, 0.2, jnp.nan, 0.6, 0.8, 1]), closed=True)
    with pytest.raises(ValueError, match="num_control_points"):
        curves.periodic_breakpoints(1)


def test_none_nan_and_huge_sizes_are_clear_errors():
    cp = jnp.array([[0, 0], [1, 2], [3, 1.0]])
    u = jnp.array([0.0, 0.5])
    for call, name in [
        (lambda: curves.bezier(None, u), "control_points"),
        (lambda: curves.bezier(cp, None), "u"),
        (lambda: curves.bernstein(3, None), "u"),
        (lambda: curves.bspline(None, 2, u), "control_points"),
        (lambda: curves.bspline(cp, 2, u, knots="abc"), "knots"),
        (lambda: curves.de_casteljau(cp, None), "u"),
        (lambda: curves.split(cp, None), "t"),
        (lambda: curves.elevate_degree(None), "control_points"),
        (lambda: curves.ellipse(None, [1, 1], 0, u), "center"),
        (lambda: curves.bezier_patch(None, u, u), "control_net"),
        (lambda: curves.patch_mesh(None, 2), "control_nets"),
        (lambda: curves.fit_bezier(None, 2), "points"),
        (lambda: curves.chord_length_parameters(None), "points"),
        (lambda: curves.nurbs(cp, None, 2, u), "weights"),
        (lambda: curves.teapot("big"), "resolution"),
        (lambda: curves.elevate_degree(cp, times=1.5), "times"),
    ]:
        with pytest.raises(TypeError, match=f"`{name}`"):
            call()
    nan_cp = cp.at[1, 0].set(jnp.nan)
    for call, name in [
        (lambda: curves.bezier(nan_cp, u), "control_points"),
        (lambda: curves.bezier(cp, jnp.array([jnp.nan])), "u"),
        (lambda: curves.bspline(nan_cp, 2, u), "control_points"),
        (lambda: curves.bspline(cp, 2, jnp.array([jnp.nan])), "u"),
        (lambda: curves.bernstein(2, jnp.array([jnp.inf])), "u"),
        (lambda: curves.Bezier(nan_cp), "control_points"),
        (lambda: curves.patch_mesh(jnp.full((4, 4, 3), jnp.inf), 2), "control_nets"),
        (lambda: curves.fit_bezier(jnp.full((6, 2), jnp.nan), 2), "points"),
        (lambda: curves.ellipse([0, jnp.nan], [1, 1], 0.0, u), "center"),
        (lambda: curves.ellipse([0, 0], [1, 1], jnp.inf, u), "angle"),
        (lambda: curves.nurbs(cp, jnp.array([1, jnp.nan, 1]), 2, u), "weights"),
    ]:
        with pytest.raises(ValueError, match=f"`{name}`"):
            call()
    # The same checks under jit (equinox.error_if names the argument too).
    for fn, args, name in [
        (lambda c, v: curves.bezier(c, v), (nan_cp, u), "control_points"),
        (lambda c, v: curves.bspline(c, 2, v), (cp, jnp.array([jnp.nan])), "u"),
        (lambda c, v: curves.bspline(c, 2, v), (nan_cp, u), "control_points"),
    ]:
        with pytest.raises(Exception, match=f"`{name}`"):
            jax.block_until_ready(jax.jit(fn)(*args))
    # Huge sizes are refused before anything is allocated.
    for call, name in [
        (lambda: curves.elevate_degree(cp, times=10**9), "times"),
        (lambda: curves.bernstein(10**9, u), "n"),
        (lambda: curves.clamped_knots(10**12, 3), "num_control_points"),
        (lambda: curves.uniform_knots(10**12, 3), "num_control_points"),
        (lambda: curves.periodic_breakpoints(10**12), "num_control_points"),
        (lambda: curves.teapot(10**6), "resolution"),
        (lambda: curves.bspline(jnp.zeros((100, 2)), 99, u), "degree"),
        (lambda: curves.derivative(cp, order=10**9), "order"),
    ]:
        with pytest.raises(ValueError, match=f"`{name}`"):
            call()


def test_errors_name_the_argument_the_user_passed():
    """Issue 17: NaN in a derived argument is reported under the caller's name, and
    `parameter_range` checks its knots like `bspline` does."""
    for call, name in [
        (lambda: curves.circle([0.0, 0], jnp.nan, jnp.array([0.5])), "radius"),
        (lambda: curves.nurbs_circle((0.0, 0.0), jnp.inf), "radius"),
        (lambda: curves.nurbs_circle((0.0, jnp.nan), 1.0), "center"),
        (lambda: curves.patch_mesh(jnp.full((4, 4, 3), jnp.nan), 2), "control_nets"),
        (lambda: curves.NURBS(jnp.zeros((4, 2)), jnp.array([1, jnp.nan, 1, 1]), 2), "weights"),
        (lambda: curves.NURBS(jnp.zeros((4, 2)), jnp.ones(3), 2), "weights"),
        (lambda: curves.parameter_range(jnp.zeros(7), 3), "knots"),
        (lambda: curves.parameter_range(jnp.array([0, 0, 1, 0.5, 1, 1]), 2), "knots"),
        (lambda: curves.parameter_range(jnp.array([0, 0, 0, jnp.nan, 1, 1]), 2), "knots"),
    ]:
        with pytest.raises(ValueError, match=f"`{name}`"):
            call()
    # Under jit the message is the same (equinox.error_if, recovered by checked_jit).
    with pytest.raises(ValueError, match="`radius` must be finite"):
        checked_jit(lambda r: curves.circle([0.0, 0], r, jnp.array([0.5])))(jnp.nan)
    with pytest.raises(ValueError, match="`knots` must be non-decreasing"):
        checked_jit(lambda t: curves.parameter_range(t, 2)[0])(jnp.array([0, 0, 1, 0.5, 1, 1.0]))
