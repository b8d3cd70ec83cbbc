"""gfxlab.curves: Bernstein/Bezier, de Casteljau, split, degree elevation, derivatives,
the parametric ellipse and the curve modules."""

from fractions import Fraction

import bezier as bezier_pkg
import equinox as eqx
import hypothesis.extra.numpy as hnp
import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from jax.test_util import check_grads

from gfxlab import curves

SEED_POINTS = [(1, 1), (2, 3), (4, 3), (6, 4)]  # A, B, C, D of the seed's question


def seed_point(u: Fraction) -> tuple[Fraction, Fraction]:
    """The seed's P(u) = (1-u)^3 A + 3u(1-u)^2 B + 3u^2(1-u) C + u^3 D, in exact rationals."""
    weights = [(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u**2 * (1 - u), u**3]
    x = sum(w * p[0] for w, p in zip(weights, SEED_POINTS, strict=True))
    y = sum(w * p[1] for w, p in zip(weights, SEED_POINTS, strict=True))
    return x, y


def test_seed_bezier_question(maybe_jit):
    u = [Fraction(0), Fraction(1, 4), Fraction(1, 2), Fraction(3, 4), Fraction(1)]
    expected = np.array([seed_point(v) for v in u], dtype=float)
    # The stated values, for the record: P(1/4) = (123/64, 139/64) etc.
    assert seed_point(Fraction(1, 4)) == (Fraction(123, 64), Fraction(139, 64))
    np.testing.assert_array_equal(
        expected, [[1, 1], [1.921875, 2.171875], [3.125, 2.875], [4.515625, 3.390625], [6, 4]]
    )
    ours = maybe_jit(curves.bezier)(
        jnp.array([[1, 1], [2, 3], [4, 3], [6, 4.0]]), jnp.array([0, 0.25, 0.5, 0.75, 1])
    )
    np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-15)


def test_bezier_matches_bezier_package():
    rng = np.random.default_rng(5)
    u = np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 40)])
    # Random degrees in 1..15 (always both ends) and random dimensions 2..3.
    degrees = [1, 15, *rng.choice(np.arange(2, 15), 6, replace=False)]
    for degree in degrees:
        for dim in rng.choice([2, 3], 1):
            nodes = rng.normal(size=(degree + 1, dim))
            reference = bezier_pkg.Curve(nodes.T, degree=degree).evaluate_multi(u).T
            ours = curves.bezier(nodes, u)
            np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-10)


def test_bernstein_closed_form():
    u = np.linspace(0, 1, 11)
    for n in range(0, 9):
        expected = (
            np.stack(
                [
                    [
                        float(np.prod(range(n - i + 1, n + 1))) / np.prod(range(1, i + 1))
                        for i in range(n + 1)
                    ]
                ]
                * len(u)
            )
            * u[:, None] ** np.arange(n + 1)
            * (1 - u[:, None]) ** (n - np.arange(n + 1))
        )
        np.testing.assert_allclose(curves.bernstein(n, u), expected, rtol=1e-13, atol=1e-15)


@settings(max_examples=25)
@given(
    n=st.integers(0, 20),
    u=hnp.arrays(np.float64, 8, elements=st.floats(0, 1)),
)
def test_bernstein_partition_of_unity_and_nonnegative(n, u):
    basis = np.asarray(curves.bernstein(n, u))
    assert basis.shape == (len(u), n + 1)
    assert np.all(basis >= 0)
    np.testing.assert_allclose(basis.sum(axis=1), 1, rtol=0, atol=1e-13)


@settings(max_examples=25)
@given(
    points=hnp.arrays(
        np.float64, st.tuples(st.integers(2, 9), st.just(2)), elements=st.floats(-10, 10)
    ),
    u=hnp.arrays(np.float64, 10, elements=st.floats(0, 1)),
)
def test_bezier_convex_hull(points, u):
    curve = np.asarray(curves.bezier(points, u))
    # Support functions: in every direction the curve reaches no further than the
    # control polygon does.
    angles = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    reach_curve = (curve @ directions.T).max(axis=0)
    reach_hull = (points @ directions.T).max(axis=0)
    assert np.all(reach_curve <= reach_hull + 1e-9)


def test_de_casteljau_levels_and_equality_with_bernstein_form(maybe_jit):
    rng = np.random.default_rng(1)
    cp = rng.normal(size=(2, 6, 3))  # a batch of two quintic space curves
    u = rng.uniform(0, 1, 7)
    levels = maybe_jit(curves.de_casteljau)(cp, u)
    assert [level.shape for level in levels] == [(2, 7, 6 - r, 3) for r in range(6)]
    np.testing.assert_allclose(levels[0], np.broadcast_to(cp[:, None], (2, 7, 6, 3)))
    # Level 1 by hand: linear interpolation of consecutive control points.
    np.testing.assert_allclose(
        levels[1], (1 - u[:, None, None]) * cp[:, None, :-1] + u[:, None, None] * cp[:, None, 1:]
    )
    np.testing.assert_allclose(levels[-1][..., 0, :], curves.bezier(cp, u), atol=1e-14)
    # A scalar u drops the parameter axis.
    single = curves.de_casteljau(cp[0], 0.3)
    assert single[2].shape == (4, 3)


def test_split_reproduces_both_halves():
    rng = np.random.default_rng(2)
    cp = rng.normal(size=(5, 2))
    t = 0.35
    left, right = curves.split(cp, t)
    s = np.linspace(0, 1, 21)
    np.testing.assert_allclose(curves.bezier(left, s), curves.bezier(cp, t * s), atol=1e-14)
    np.testing.assert_allclose(
        curves.bezier(right, s), curves.bezier(cp, t + (1 - t) * s), atol=1e-14
    )
    np.testing.assert_allclose(left[-1], right[0])


def test_elevate_degree_keeps_the_curve():
    rng = np.random.default_rng(3)
    cp = rng.normal(size=(4, 3))
    raised = curves.elevate_degree(cp, times=3)
    assert raised.shape == (7, 3)
    u = np.linspace(0, 1, 25)
    np.testing.assert_allclose(curves.bezier(raised, u), curves.bezier(cp, u), atol=1e-14)
    # Reference: the bezier package's own elevation.
    reference = bezier_pkg.Curve(cp.T, degree=3).elevate().nodes.T
    np.testing.assert_allclose(curves.elevate_degree(cp), reference, atol=1e-14)


def test_derivative_matches_jax_derivative():
    rng = np.random.default_rng(4)
    cp = jnp.asarray(rng.normal(size=(6, 2)))
    u = jnp.linspace(0.05, 0.95, 9)
    tangent = jax.jit(jax.vmap(jax.jacfwd(lambda s: curves.bezier(cp, s))))(u)
    np.testing.assert_allclose(curves.bezier(curves.derivative(cp), u), tangent, atol=1e-12)
    second = jax.jit(jax.vmap(jax.jacfwd(jax.jacfwd(lambda s: curves.bezier(cp, s)))))(u)
    np.testing.assert_allclose(curves.bezier(curves.derivative(cp, order=2), u), second, atol=1e-11)


def test_bezier_gradients():
    rng = np.random.default_rng(6)
    cp = jnp.asarray(rng.normal(size=(5, 2)))
    u = jnp.array([0.1, 0.4, 0.77])

    @jax.jit
    def everything(c, v, t):  # one compiled check for all the Bezier functions
        parts = [
            curves.bezier(c, v),
            curves.de_casteljau(c, v)[-2],
            curves.split(c, t)[1],
            curves.elevate_degree(c, times=2),
            curves.derivative(c),
            curves.bernstein(4, v),
        ]
        return jnp.concatenate([part.ravel() for part in parts])

    check_grads(everything, (cp, u, jnp.array(0.4)), order=1, modes=["rev"])
    # Finite gradients at the ends of the range.
    ends = jax.jacfwd(lambda v: curves.bernstein(3, v))(jnp.array([0.0, 1.0]))
    assert np.all(np.isfinite(ends))


def test_bezier_under_vmap_and_batch_dims():
    rng = np.random.default_rng(7)
    cp = jnp.asarray(rng.normal(size=(3, 4, 2)))
    u = jnp.linspace(0, 1, 5)
    batched = curves.bezier(cp, u)
    assert batched.shape == (3, 5, 2)
    np.testing.assert_allclose(jax.vmap(curves.bezier, (0, None))(cp, u), batched)
    assert curves.bezier(cp[0], 0.5).shape == (2,)


def test_bezier_bad_input():
    cp = jnp.array([[0.0, 0], [1, 1], [2, 0]])
    with pytest.raises(ValueError, match="`u` must lie in \\[0, 1\\]"):
        curves.bezier(cp, jnp.array([0.5, 1.2]))
    # Under jit the same check fires at run time (equinox.error_if).
    with pytest.raises(RuntimeError, match="`u` must lie in \\[0, 1\\]"):
        jax.block_until_ready(eqx.filter_jit(curves.bezier)(cp, jnp.array([-0.1])))
    with pytest.raises(ValueError, match="control_points"):
        curves.bezier(jnp.array([1.0, 2.0]), jnp.array([0.5]))
    with pytest.raises(ValueError, match="`u`"):
        curves.bernstein(3, jnp.array([2.0]))
    with pytest.raises(ValueError, match="`n` must be >= 0"):
        curves.bernstein(-1, jnp.array([0.5]))
    with pytest.raises(TypeError, match="`n`"):
        jax.jit(curves.bernstein)(3, jnp.array([0.5]))
    with pytest.raises(ValueError, match="`u`"):
        curves.de_casteljau(cp, jnp.array([1.5]))
    with pytest.raises(ValueError, match="`t` must have shape"):
        curves.split(cp, jnp.array([0.2, 0.3]))
    with pytest.raises(ValueError, match="`times` must be >= 0"):
        curves.elevate_degree(cp, times=-1)
    with pytest.raises(ValueError, match="`order` must be at most the degree 2"):
        curves.derivative(cp, order=3)


def test_ellipse_matches_the_seed_equations(maybe_jit):
    t = np.linspace(0, 2 * np.pi, 13)
    h, k, a, b = 2.0, -1.0, 3.0, 1.5
    points = maybe_jit(curves.ellipse)(jnp.array([h, k]), jnp.array([a, b]), 0.0, t)
    np.testing.assert_allclose(points[:, 0], h + a * np.cos(t), atol=1e-14)
    np.testing.assert_allclose(points[:, 1], k + b * np.sin(t), atol=1e-14)
    # Rotated: the implicit equation holds in the rotated frame.
    angle = 0.7
    rotated = np.asarray(curves.ellipse(jnp.array([h, k]), jnp.array([a, b]), angle, t))
    local = (rotated - [h, k]) @ np.array(
        [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    )
    np.testing.assert_allclose((local[:, 0] / a) ** 2 + (local[:, 1] / b) ** 2, 1, atol=1e-13)
    circle = curves.circle(jnp.array([1.0, 1.0]), 2.0, t)
    np.testing.assert_allclose(np.linalg.norm(circle - 1.0, axis=1), 2.0, atol=1e-14)
    # Batches of ellipses.
    many = curves.ellipse(jnp.zeros((4, 2)), jnp.ones((4, 2)), jnp.zeros(4), t)
    assert many.shape == (4, 13, 2)


def test_ellipse_gradients_and_bad_input():
    t = jnp.array([0.3, 1.9, 4.0])
    check_grads(
        jax.jit(curves.ellipse),
        (jnp.array([1.0, 2.0]), jnp.array([2.0, 0.5]), 0.3, t),
        order=1,
        modes=["rev"],
    )
    check_grads(jax.jit(curves.circle), (jnp.array([1.0, 2.0]), 1.5, t), order=1, modes=["rev"])
    with pytest.raises(ValueError, match="`center` must have shape"):
        curves.ellipse(jnp.zeros(3), jnp.ones(2), 0.0, t)
    with pytest.raises(ValueError, match="`radii` must have shape"):
        curves.ellipse(jnp.zeros(2), jnp.ones(3), 0.0, t)
    with pytest.raises(ValueError, match="`center` must have shape"):
        curves.circle(jnp.zeros(3), 1.0, t)


def test_modules_are_pytrees():
    cp = jnp.array([[1, 1], [2, 3], [4, 3], [6, 4.0]])
    curve = curves.Bezier(cp)
    assert curve.degree == 3
    u = jnp.linspace(0, 1, 5)
    np.testing.assert_allclose(eqx.filter_jit(lambda c: c(u))(curve), curves.bezier(cp, u))
    grads = eqx.filter_jit(jax.grad(lambda c: jnp.sum(c(u))))(curve)
    np.testing.assert_allclose(grads.control_points.sum(axis=0), [5, 5])  # sum of weights
    left, right = curve.split(0.5)
    np.testing.assert_allclose(left(jnp.array([1.0])), right(jnp.array([0.0])))
    assert curve.elevate_degree().degree == 4
    assert curve.derivative().degree == 2
    ellipse = curves.Ellipse([0.0, 0.0], [1.0, 3.0], 0.2)
    norm = ellipse.normalized()
    np.testing.assert_allclose(norm.radii, [3.0, 1.0])
    t = jnp.linspace(0, 2 * np.pi, 50, endpoint=False)
    # Same point set: every point of one lies on the other's implicit curve.
    local = (norm(t) - norm.center) @ np.array(
        [[np.cos(norm.angle), -np.sin(norm.angle)], [np.sin(norm.angle), np.cos(norm.angle)]]
    )
    np.testing.assert_allclose(local[:, 0] ** 2 / 9 + local[:, 1] ** 2, 1, atol=1e-12)
    with pytest.raises(ValueError, match="`radii` must have shape"):
        curves.Ellipse([0.0, 0.0], [1.0], 0.0)
    with pytest.raises(ValueError, match="control_points"):
        curves.Bezier(jnp.zeros(3))
