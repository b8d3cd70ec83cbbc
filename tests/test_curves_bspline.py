"""gfxlab.curves: B-splines (Cox-de Boor), knots, NURBS."""

import equinox as eqx
import hypothesis.extra.numpy as hnp
import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate as si
from hypothesis import given, settings
from jax.test_util import check_grads

from gfxlab import curves


def random_knots(rng, degree, count):
    """`count + degree + 1` non-decreasing knots with repeats (interior multiplicities up
    to degree + 1), a non-empty last span so the right end is well defined."""
    while True:
        pool = np.round(rng.uniform(0, 4, count + degree + 1), 1)  # rounding makes repeats
        knots = np.sort(rng.choice(pool, count + degree + 1))
        _, multiplicity = np.unique(knots, return_counts=True)
        if knots[count - 1] < knots[count] and multiplicity.max() <= degree + 1:
            return knots


def test_bspline_matches_scipy_random_knots():
    rng = np.random.default_rng(0)
    count = 8  # fixed sizes keep compilations few: one per degree
    for trial in range(15):
        degree = 1 + trial % 5
        knots = random_knots(rng, degree, count)
        cp = rng.normal(size=(count, 2))
        lo, hi = knots[degree], knots[count]
        # Ends, every knot in range, and random points in between (padded to one shape).
        inner = knots[(knots >= lo) & (knots <= hi)]
        u = np.concatenate([[lo, hi], inner, rng.uniform(lo, hi, 64 - 2 - len(inner))])
        reference = si.BSpline(knots, cp, degree, extrapolate=False)(u)
        np.testing.assert_allclose(
            curves.bspline(cp, degree, u, knots=knots),
            reference,
            rtol=0,
            atol=1e-12,
            err_msg=f"knots {knots}",
        )
        basis = curves.bspline_basis(knots, degree, u)
        np.testing.assert_allclose(basis @ cp, reference, rtol=0, atol=1e-12)


def test_bspline_basis_matches_scipy_design_matrix():
    knots = np.array([0, 0, 0, 1, 2, 2, 3, 4, 4, 4.0])
    u = np.linspace(0, 3.999, 41)
    reference = si.BSpline.design_matrix(u, knots, 2).toarray()
    np.testing.assert_allclose(curves.bspline_basis(knots, 2, u), reference, atol=1e-13)


def test_knot_helpers_and_parameter_range():
    np.testing.assert_array_equal(curves.uniform_knots(5, 2), np.arange(8))
    np.testing.assert_allclose(curves.clamped_knots(6, 3), [0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1])
    np.testing.assert_allclose(curves.clamped_knots(4, 3), [0, 0, 0, 0, 1, 1, 1, 1])
    assert curves.clamped_knots(4, 1, dtype=jnp.float32).dtype == jnp.float32
    lo, hi = curves.parameter_range(curves.uniform_knots(5, 2), 2)
    assert (float(lo), float(hi)) == (2.0, 5.0)
    # Clamped: the curve interpolates its end control points.
    cp = np.random.default_rng(1).normal(size=(6, 2))
    ends = curves.bspline(cp, 3, jnp.array([0.0, 1.0]))
    np.testing.assert_allclose(ends, cp[[0, -1]], atol=1e-15)
    # A clamped B-spline with n = p + 1 control points is the Bezier curve.
    u = np.linspace(0, 1, 9)
    np.testing.assert_allclose(curves.bspline(cp[:4], 3, u), curves.bezier(cp[:4], u), atol=1e-14)


def test_local_control():
    rng = np.random.default_rng(2)
    degree, count = 3, 10
    knots = curves.clamped_knots(count, degree)
    cp = rng.normal(size=(count, 2))
    moved = cp.copy()
    k = 4
    moved[k] += [0.5, -0.3]
    u = np.linspace(0, 1, 301)
    changed = np.any(
        np.asarray(curves.bspline(cp, degree, u)) != np.asarray(curves.bspline(moved, degree, u)),
        axis=1,
    )
    # Only u in (t_k, t_{k+p+1}) can change: the support of N_{k,p}.
    support = (u > knots[k]) & (u < knots[k + degree + 1])
    assert np.all(changed <= support)
    assert changed.any()


@settings(max_examples=30)
@given(
    degree=st.integers(0, 4),
    u01=hnp.arrays(np.float64, 16, elements=st.floats(0, 1)),
    data=st.data(),
)
def test_bspline_partition_of_unity_and_local_convex_hull(degree, u01, data):
    count = 6
    gaps = data.draw(
        hnp.arrays(np.float64, count + degree, elements=st.sampled_from([0.0, 0.5, 1.0, 2.0]))
    )
    knots = np.concatenate([[0.0], np.cumsum(gaps)])
    lo, hi = knots[degree], knots[count]
    if lo >= hi:
        return
    u = lo + (hi - lo) * u01
    basis = np.asarray(curves.bspline_basis(knots, degree, u))
    assert np.all(basis >= -1e-15)
    np.testing.assert_allclose(basis.sum(axis=1), 1, atol=1e-13)
    # Each point uses at most degree + 1 consecutive control points...
    nonzero = basis > 0
    first = nonzero.argmax(axis=1)
    last = count - 1 - nonzero[:, ::-1].argmax(axis=1)
    assert np.all(last - first <= degree)
    # ...and lies in their convex hull (support-function test).
    cp = data.draw(hnp.arrays(np.float64, (count, 2), elements=st.floats(-5, 5)))
    points = basis @ cp  # bspline == bspline_basis @ cp is tested against SciPy above
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    for point, i, j in zip(points, first, last, strict=True):
        reach = (cp[i : j + 1] @ directions.T).max(axis=0)
        assert np.all(point @ directions.T <= reach + 1e-9)


def test_bspline_batch_jit_and_vmap(maybe_jit):
    rng = np.random.default_rng(3)
    cp = jnp.asarray(rng.normal(size=(4, 7, 3)))
    u = jnp.linspace(0, 1, 11)
    out = maybe_jit(curves.bspline, static_argnames=("degree",))(cp, degree=3, u=u)
    assert out.shape == (4, 11, 3)
    np.testing.assert_allclose(out[2], curves.bspline(cp[2], 3, u), atol=1e-15)
    mapped = jax.vmap(lambda c: curves.bspline(c, 3, u))(cp)
    np.testing.assert_allclose(mapped, out, atol=1e-15)
    assert curves.bspline(cp, 3, 0.5).shape == (4, 3)


def test_bspline_gradients():
    # Distinct knots: the numerical derivative perturbs them, and must keep their order.
    knots = jnp.array([-0.3, -0.2, -0.1, 0.3, 0.5, 0.55, 0.8, 1.1, 1.2, 1.3])
    cp = jnp.asarray(np.random.default_rng(4).normal(size=(7, 2)))
    u = jnp.array([0.1, 0.42, 0.6, 0.9])  # away from knots, so spans stay put
    weights = jnp.array([1.0, 0.5, 2.0, 1.0, 0.7, 1.2, 1.0])

    @jax.jit
    def everything(c, t, v, w):  # one compiled check for the B-spline functions
        parts = [
            curves.bspline(c, 2, v, knots=t),
            curves.bspline_basis(t, 2, v),
            curves.nurbs(c, w, 2, v, knots=t),
        ]
        return jnp.concatenate([part.ravel() for part in parts])

    check_grads(everything, (cp, knots, u, weights), order=1, modes=["rev"])
    # The two evaluations (local triangle and full Cox-de Boor) agree, read from the
    # program check_grads compiled (the eager ones: test_bspline_matches_scipy_random_knots).
    parts = np.asarray(everything(cp, knots, u, weights))
    points, basis = parts[:8].reshape(4, 2), parts[8:36].reshape(4, 7)
    np.testing.assert_allclose(points, basis @ np.asarray(cp), atol=1e-14)


def test_nurbs_circle_is_exact():
    center, radius = jnp.array([1.5, -2.0]), 3.0
    circle = curves.nurbs_circle(center, radius)
    u = jnp.linspace(0, 1, 2001)
    points = eqx.filter_jit(lambda c: c(u))(circle)
    distance = np.linalg.norm(np.asarray(points) - np.asarray(center), axis=1)
    assert np.abs(distance - radius).max() < 1e-12
    # All the way round, counter-clockwise.
    angles = np.unwrap(np.arctan2(points[:, 1] - center[1], points[:, 0] - center[0]))
    assert np.all(np.diff(angles) > 0)
    np.testing.assert_allclose(angles[-1] - angles[0], 2 * np.pi, atol=1e-12)
    # Unit weights give the ordinary B-spline.
    cp = np.random.default_rng(5).normal(size=(5, 2))
    u = jnp.linspace(0, 1, 7)
    np.testing.assert_allclose(
        curves.nurbs(cp, jnp.ones(5), 2, u), curves.bspline(cp, 2, u), atol=1e-14
    )


def test_bspline_module_fits_control_points_only():
    curve = curves.BSpline(jnp.zeros((5, 2)), 2)
    u = jnp.linspace(0, 1, 9)
    grads = eqx.filter_jit(jax.grad(lambda c: jnp.sum(c(u) ** 2) + jnp.sum(c(u))))(curve)
    np.testing.assert_array_equal(grads.base_knots, 0)
    free = curves.BSpline(jnp.ones((5, 2)), 2, fit_knots=True)
    grads = eqx.filter_jit(jax.grad(lambda c: jnp.sum(c(jnp.array([0.3, 0.7])))))(free)
    assert grads.knot_logits.shape == (3,)  # the spans of the range [t_2, t_5]
    lo, hi = curve.parameter_range
    assert (float(lo), float(hi)) == (0.0, 1.0)


def test_bspline_bad_input():
    cp = jnp.zeros((4, 2))
    with pytest.raises(ValueError, match="`degree` 4 is too high for 4 control points"):
        curves.bspline(cp, 4, jnp.array([0.5]))
    with pytest.raises(ValueError, match="too high"):
        curves.clamped_knots(3, 3)
    with pytest.raises(ValueError, match="too high"):
        curves.uniform_knots(2, 5)
    with pytest.raises(ValueError, match="non-decreasing"):
        curves.bspline(cp, 2, jnp.array([0.5]), knots=jnp.array([0, 0, 0, 0.6, 0.5, 1, 1.0]))
    with pytest.raises(RuntimeError, match="non-decreasing"):
        jax.block_until_ready(
            eqx.filter_jit(lambda t: curves.bspline(cp, 2, jnp.array([0.5]), knots=t))(
                jnp.array([0, 0, 0, 0.6, 0.5, 1, 1.0])
            )
        )
    with pytest.raises(ValueError, match="must have num_control_points \\+ degree \\+ 1"):
        curves.bspline(cp, 2, jnp.array([0.5]), knots=jnp.linspace(0, 1, 6))
    with pytest.raises(ValueError, match="parameter range"):
        curves.bspline(cp, 2, jnp.array([0.5, 1.01]))
    with pytest.raises(ValueError, match="parameter range"):
        curves.bspline(cp, 2, jnp.array([0.5]), knots=curves.uniform_knots(4, 2))  # [2, 4]
    with pytest.raises(RuntimeError, match="parameter range"):
        jax.block_until_ready(eqx.filter_jit(curves.bspline)(cp, 2, jnp.array([-0.5])))
    with pytest.raises(ValueError, match="empty parameter range"):
        curves.bspline(cp, 1, jnp.array([0.0]), knots=jnp.array([0, 0, 0, 0, 0, 1.0]))
    with pytest.raises(TypeError, match="`degree`"):
        jax.jit(curves.bspline)(cp, 2, jnp.array([0.5]))
    with pytest.raises(ValueError, match="too high for 4 knots"):
        curves.bspline_basis(jnp.arange(4.0), 3, jnp.array([1.5]))
    with pytest.raises(ValueError, match="parameter range"):
        curves.bspline_basis(jnp.arange(8.0), 3, jnp.array([0.5]))
    with pytest.raises(ValueError, match="too high for 3 knots"):
        curves.parameter_range(jnp.arange(3.0), 2)
    with pytest.raises(ValueError, match="`weights` must all be positive"):
        curves.nurbs(cp, jnp.array([1.0, 0, 1, 1]), 2, jnp.array([0.5]))
    with pytest.raises(ValueError, match="`weights` must have shape"):
        curves.nurbs(cp, jnp.ones(3), 2, jnp.array([0.5]))
    with pytest.raises(ValueError, match="`center` must have shape"):
        curves.nurbs_circle(jnp.zeros(3), 1.0)
    with pytest.raises(ValueError, match="too high"):
        curves.BSpline(cp, 5)


def test_bspline_evaluation_paths_match_scipy():
    """Issue 19: `bspline` finds spans through a uniform cell grid (two comparisons per
    `u`) and evaluates power-form span polynomials; clustered knots take a binary search
    instead, degrees above 5 the Bernstein form, many curves at once a row gather. Every
    path equals SciPy to 1e-12, at the knots, just beside them and in between."""
    rng = np.random.default_rng(7)
    grid = curves.clamped_knots(30, 3)  # uniform: the cell grid
    clustered = np.concatenate([[0, 0, 0, 0], 1e-7 * np.arange(1, 6), np.linspace(0.5, 0.9, 21)])
    clustered = np.concatenate([clustered, [1, 1, 1, 1]])  # 3 knots per cell: the search
    uneven = np.concatenate([[0] * 4, np.sort(rng.uniform(0, 1, 26)), [1] * 4])
    for knots, degree, batch in [
        (np.asarray(grid), 3, ()),
        (clustered, 3, ()),
        (uneven, 3, (9,)),  # 18 columns: whole rows gathered
        (np.asarray(curves.clamped_knots(30, 7)), 7, ()),  # the Bernstein form
    ]:
        count = len(knots) - degree - 1
        cp = rng.normal(size=batch + (count, 2))
        inner = knots[degree : count + 1]
        u = np.concatenate(
            [inner, np.nextafter(inner, 2), np.nextafter(inner, -1), rng.uniform(0, 1, 40)]
        ).clip(0, 1)
        reference = np.moveaxis(si.BSpline(knots, np.moveaxis(cp, -2, 0), degree)(u), 0, -2)
        ours = curves.bspline(cp, degree, u, knots=knots)
        np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-12, err_msg=f"{knots}")
