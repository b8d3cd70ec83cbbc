"""Key frames, easing, quaternions, slerp/squad and tracks (gfxlab.animation)."""

import bezier
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate
import scipy.optimize
from hypothesis import given
from hypothesis import strategies as st
from jax.test_util import check_grads
from scipy.spatial.transform import Rotation, Slerp

from gfxlab import animation as A

TIMES = jnp.array([0.0, 1.0, 2.5, 4.0, 4.5])
VALUES = jnp.array([[0.0, 1.0], [2.0, -1.0], [1.0, 3.0], [4.0, 0.5], [3.0, 3.0]])


def _to_scipy(q):
    return Rotation.from_quat(np.asarray(q)[..., [1, 2, 3, 0]])


def _random_quats(seed, n):
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@pytest.mark.parametrize("method", ["step", "linear", "catmull_rom", "bezier"])
def test_interpolation_passes_through_keys(method, maybe_jit):
    fn = maybe_jit(A.interpolate, static_argnames=("method",))
    np.testing.assert_allclose(fn(TIMES, VALUES, TIMES, method=method), VALUES, atol=1e-12)


def test_linear_and_step_match_numpy_and_scipy():
    t = np.linspace(-1, 5.5, 97)
    ours = A.interpolate(TIMES, VALUES, t, method="linear")
    for c in range(2):
        np.testing.assert_allclose(ours[:, c], np.interp(t, TIMES, VALUES[:, c]), atol=1e-12)
    step = A.interpolate(TIMES, VALUES, t, method="step")
    ref = scipy.interpolate.interp1d(
        TIMES,
        VALUES,
        kind="previous",
        axis=0,
        bounds_error=False,
        fill_value=(VALUES[0], VALUES[-1]),
    )(t)
    np.testing.assert_allclose(step, ref, atol=1e-12)


def test_catmull_rom_matches_scipy_hermite_and_is_c1():
    t = np.linspace(0, 4.5, 211)
    tangents = A.catmull_rom_tangents(TIMES, VALUES)
    ref = scipy.interpolate.CubicHermiteSpline(TIMES, VALUES, tangents, axis=0)(t)
    np.testing.assert_allclose(
        A.interpolate(TIMES, VALUES, t, method="catmull_rom"), ref, atol=1e-12
    )
    # Catmull-Rom interior tangent is the centred difference.
    np.testing.assert_allclose(tangents[1], (VALUES[2] - VALUES[0]) / (TIMES[2] - TIMES[0]))
    # C1: one-sided derivatives agree at interior keys.
    f = lambda s: A.interpolate(TIMES, VALUES, s, method="catmull_rom")
    for k in TIMES[1:-1]:
        left = jax.jvp(f, (k - 1e-9,), (1.0,))[1]
        right = jax.jvp(f, (k + 1e-9,), (1.0,))[1]
        np.testing.assert_allclose(left, right, atol=1e-6)
    # value continuity too
    np.testing.assert_allclose(f(TIMES[2] - 1e-12), f(TIMES[2] + 1e-12), atol=1e-9)


def test_hermite_uses_given_tangents():
    tangents = jnp.ones_like(VALUES)
    f = lambda s: A.interpolate(TIMES, VALUES, s, method="hermite", tangents=tangents)
    for k in TIMES[1:-1]:
        np.testing.assert_allclose(jax.jvp(f, (k + 1e-9,), (1.0,))[1], [1.0, 1.0], atol=1e-6)


def test_bezier_easing_matches_bezier_library():
    control = (0.42, 0.0, 0.58, 1.0)
    curve = bezier.Curve(np.asfortranarray([[0, 0.42, 0.58, 1], [0, 0.0, 1.0, 1]]), degree=3)
    u = np.linspace(0, 1, 23)
    ours = np.asarray(A.cubic_bezier_easing(u, control))
    for ui, yi in zip(u, ours, strict=True):
        s = scipy.optimize.brentq(lambda s, ui=ui: curve.evaluate(s)[0, 0] - ui, 0, 1, xtol=1e-14)
        np.testing.assert_allclose(yi, curve.evaluate(s)[1, 0], atol=1e-9)
    np.testing.assert_allclose(A.ease_in_out(u), ours)


def test_easing_shapes():
    grid = np.linspace(0, 1, 101)  # one shape for every easing below (one compile)
    u, inner = jnp.asarray(grid), slice(5, -5)  # strict inequalities on [0.05, 0.95]
    assert np.all(np.asarray(A.ease_in(u))[inner] < grid[inner])  # slow start
    assert np.all(np.asarray(A.ease_out(u))[inner] > grid[inner])  # fast start
    np.testing.assert_allclose(A.ease_in_out(0.5), 0.5, atol=1e-12)
    np.testing.assert_allclose(A.cubic_bezier_easing(u, "linear"), grid, atol=1e-12)
    assert np.all(np.diff(np.asarray(A.ease_in_out(u))) >= 0)
    # Gradient is finite where x'(0) = 0 (ease_out starts with a vertical tangent in s).
    assert jnp.isfinite(jax.grad(A.ease_out)(0.0))


def test_bezier_method_per_segment_easing():
    easing = jnp.array([A.EASINGS["ease_out"], A.EASINGS["ease_in"]])
    times, values = jnp.array([0.0, 1.0, 2.0]), jnp.array([0.0, 1.0, 0.0])
    mid = A.interpolate(times, values, jnp.array([0.5, 1.5]), method="bezier", easing=easing)
    np.testing.assert_allclose(mid, [A.ease_out(0.5), 1 - A.ease_in(0.5)], atol=1e-12)


def test_check_grads_interpolation():
    t = jnp.array([0.3, 1.7, 3.1])
    for method in ("linear", "catmull_rom", "bezier"):
        check_grads(  # jitted: one compile per mode (the eager path is tested elsewhere)
            jax.jit(lambda v, s, m=method: A.interpolate(TIMES, v, s, method=m)),
            (VALUES, t),
            order=1,
            modes=["rev", "fwd"],
        )
    check_grads(
        jax.jit(lambda u: A.cubic_bezier_easing(u, (0.3, 0.1, 0.7, 0.9))),
        (jnp.array([0.2, 0.5, 0.8]),),
        order=1,
    )


def test_interpolation_bad_inputs():
    with pytest.raises(ValueError, match="strictly increasing"):
        A.interpolate(jnp.array([0.0, 2.0, 1.0]), jnp.zeros(3), 0.5)
    with pytest.raises(ValueError, match="strictly increasing"):
        A.interpolate(jnp.array([0.0, 1.0, 1.0]), jnp.zeros(3), 0.5)
    with pytest.raises(ValueError, match="method"):
        A.interpolate(TIMES, VALUES, 0.5, method="cubic")
    with pytest.raises(ValueError, match="one row per key"):
        A.interpolate(TIMES, VALUES[:3], 0.5)
    with pytest.raises(ValueError, match="tangents"):
        A.interpolate(TIMES, VALUES, 0.5, method="hermite")
    with pytest.raises(ValueError, match="x1 and x2"):
        A.cubic_bezier_easing(0.5, (1.5, 0.0, 0.5, 1.0))
    with pytest.raises(ValueError, match="control"):
        A.cubic_bezier_easing(0.5, "bouncy")
    with pytest.raises(Exception, match="strictly increasing"):  # eqx.error_if under jit
        jax.block_until_ready(jax.jit(A.interpolate)(jnp.array([0.0, 2.0, 1.0]), jnp.zeros(3), 0.5))
    with pytest.raises(ValueError, match="strictly increasing"):
        A.catmull_rom_tangents(jnp.array([1.0, 0.0]), jnp.zeros(2))


# ---------------------------------------------------------------- quaternions


def test_quaternions_match_scipy():
    q, r = _random_quats(0, 8), _random_quats(1, 8)
    np.testing.assert_allclose(A.quat_to_matrix(q), _to_scipy(q).as_matrix(), atol=1e-12)
    prod = A.quat_multiply(q, r)
    np.testing.assert_allclose(
        A.quat_to_matrix(prod), (_to_scipy(q) * _to_scipy(r)).as_matrix(), atol=1e-12
    )
    axis, angle = np.array([1.0, 2.0, -0.5]), 0.7
    np.testing.assert_allclose(
        A.quat_to_matrix(A.quat_from_axis_angle(axis, angle)),
        Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix(),
        atol=1e-12,
    )
    rotvec = np.array([[0.3, -0.2, 0.9], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(
        A.quat_to_matrix(A.quat_from_rotvec(rotvec)),
        Rotation.from_rotvec(rotvec).as_matrix(),
        atol=1e-12,
    )
    pts = np.random.default_rng(2).normal(size=(5, 3))
    np.testing.assert_allclose(A.quat_rotate(q[0], pts), _to_scipy(q[0]).apply(pts), atol=1e-12)
    np.testing.assert_allclose(
        A.quat_exp(A.quat_log(q)) * np.sign(q[:, :1]), q * np.sign(q[:, :1]), atol=1e-12
    )


@given(st.integers(0, 10_000), st.floats(0.0, 1.0))
def test_slerp_unit_ends_and_closed_form(seed, u):
    q0, q1 = _random_quats(seed, 2)
    out = A.slerp(q0, q1, u)
    np.testing.assert_allclose(np.linalg.norm(out), 1.0, atol=1e-12)
    q1s = q1 if q0 @ q1 >= 0 else -q1
    omega = np.arccos(np.clip(q0 @ q1s, -1, 1))
    closed = (np.sin((1 - u) * omega) * q0 + np.sin(u * omega) * q1s) / np.sin(omega)
    np.testing.assert_allclose(out, closed, atol=1e-9)
    np.testing.assert_allclose(A.slerp(q0, q1, 0.0), q0, atol=1e-12)
    np.testing.assert_allclose(A.slerp(q0, q1, 1.0), q1s, atol=1e-12)


def test_slerp_matches_scipy_and_same_axis_angles():
    q = _random_quats(5, 2)
    u = np.linspace(0, 1, 9)
    ref = Slerp([0, 1], _to_scipy(q))(u).as_matrix()
    np.testing.assert_allclose(A.quat_to_matrix(A.slerp(q[0], q[1], u)), ref, atol=1e-10)
    axis = jnp.array([0.0, 0.0, 1.0])
    out = A.slerp(A.quat_from_axis_angle(axis, 0.2), A.quat_from_axis_angle(axis, 1.4), 0.25)
    np.testing.assert_allclose(out, A.quat_from_axis_angle(axis, 0.5), atol=1e-12)
    # nearly equal quaternions: no NaN values or gradients
    same = A.quat_from_axis_angle(axis, 0.3)
    np.testing.assert_allclose(A.slerp(same, same, 0.4), same, atol=1e-12)
    assert jnp.all(jnp.isfinite(jax.jacfwd(lambda u: A.slerp(same, same, u))(0.4)))
    check_grads(lambda a, u: A.slerp(q[0], a, u), (jnp.asarray(q[1]), 0.3), order=1, modes=["rev"])


def test_rotation_keys_slerp_and_squad():
    times = jnp.array([0.0, 1.0, 2.0, 3.5])
    quats = jnp.asarray(_random_quats(9, 4))
    # squad at the keys and at 50 times between them in one call, of the length the
    # Shoemake comparison below uses too (one compiled squad)
    t = np.linspace(0, 3.5, 50)
    samples = jnp.asarray(np.concatenate([np.asarray(times), t]))
    squad_all = np.asarray(A.interpolate_rotations(times, quats, samples, method="squad"))
    for method in ("slerp", "squad", "step"):
        if method == "squad":
            at_keys = squad_all[:4]
        else:
            at_keys = A.interpolate_rotations(times, quats, times, method=method)
        np.testing.assert_allclose(np.abs(np.sum(at_keys * quats, -1)), 1.0, atol=1e-9)
    squad = squad_all[4:]
    np.testing.assert_allclose(np.linalg.norm(squad, axis=-1), 1.0, atol=1e-9)

    # squad is C1 at interior keys (slerp is not).
    # squad is C1 in time at interior keys (uneven spacing too); slerp is not.
    def velocity(method, s):
        f = lambda s: A.interpolate_rotations(times, quats, s, method=method)
        return jax.jit(jax.vmap(lambda s: jax.jvp(f, (s,), (jnp.ones_like(s),))[1]))(s)

    keys = np.asarray(times[1:-1])
    sides = jnp.asarray(np.concatenate([keys - 1e-9, keys + 1e-9]))  # one compiled call
    for method, continuous in (("squad", True), ("slerp", False)):
        left, right = np.split(np.asarray(velocity(method, sides)), 2)
        jump = np.abs(left - right).max()
        assert (jump < 1e-6) if continuous else (jump > 1e-2)
    # With even spacing the inner quaternions are Shoemake's: the middle segment is his
    # squad with `squad_inner` controls (keys normalised and sign-aligned, as documented).
    even = jnp.arange(4.0)
    q = np.asarray(quats) / np.linalg.norm(quats, axis=-1, keepdims=True)
    for k in range(1, 4):
        q[k] *= np.sign(np.dot(q[k], q[k - 1])) or 1.0
    u = np.linspace(0.0, 1.0, len(samples))
    inner = A.squad_inner(q[:2], q[1:3], q[2:])
    controls = [jnp.broadcast_to(x, (len(u), 4)) for x in (q[1], inner[0], inner[1], q[2])]
    ref = A.squad(*controls, jnp.asarray(u))
    ours = A.interpolate_rotations(even, quats, jnp.asarray(1.0 + u), method="squad")
    np.testing.assert_allclose(ours, ref, atol=1e-12)
    with pytest.raises(ValueError, match="method"):
        A.interpolate_rotations(times, quats, t, method="lerp")
    with pytest.raises(ValueError, match="quats"):
        A.interpolate_rotations(times, quats[:, :3], t)


def test_quaternion_bad_inputs():
    with pytest.raises(ValueError, match="non-zero"):
        A.quat_from_axis_angle(jnp.zeros(3), 1.0)
    with pytest.raises(ValueError, match="q"):
        A.quat_to_matrix(jnp.ones(3))
    with pytest.raises(ValueError, match="non-zero"):
        A.quat_normalize(jnp.zeros(4))
    with pytest.raises(ValueError, match="q0"):
        A.slerp(jnp.ones(3), jnp.ones(4), 0.5)


# ---------------------------------------------------------------- tracks


def test_tracks_vectorized_over_tracks_and_times(maybe_jit):
    rng = np.random.default_rng(3)
    b, k = 3, 5
    times = np.sort(rng.uniform(0, 4, (b, k)), axis=-1)
    track = A.Track(
        times=jnp.asarray(times),
        position=jnp.asarray(rng.normal(size=(b, k, 3))),
        rotation=jnp.asarray(_random_quats(4, b * k).reshape(b, k, 4)),
        scale=jnp.asarray(rng.uniform(0.5, 2, (b, k, 3))),
        color=jnp.asarray(rng.uniform(0, 1, (b, k, 3))),
        method="catmull_rom",
    )
    t = jnp.linspace(0, 4, 11)
    sample = maybe_jit(lambda tr, s: tr(s))(track, t)
    assert sample.position.shape == (b, 11, 3) and sample.rotation.shape == (b, 11, 4)
    for i in range(b):
        np.testing.assert_allclose(
            sample.position[i],
            A.interpolate(times[i], track.position[i], t, method="catmull_rom"),
            atol=1e-12,
        )
        np.testing.assert_allclose(
            sample.rotation[i], A.interpolate_rotations(times[i], track.rotation[i], t), atol=1e-12
        )
    m = sample.matrix()
    assert m.shape == (b, 11, 4, 4)
    expected = A.quat_to_matrix(sample.rotation) * sample.scale[..., None, :]
    np.testing.assert_allclose(m[..., :3, :3], expected, atol=1e-12)
    np.testing.assert_allclose(m[..., :3, 3], sample.position, atol=1e-12)


def test_track_bad_inputs():
    with pytest.raises(ValueError, match="at least one channel"):
        A.Track(times=jnp.arange(3.0))
    with pytest.raises(ValueError, match="method"):
        A.Track(times=jnp.arange(3.0), position=jnp.zeros((3, 2)), method="spline")
    with pytest.raises(ValueError, match="strictly increasing"):
        A.Track(times=jnp.array([0.0, 2.0, 1.0]), position=jnp.zeros((3, 2)))(jnp.array([0.5]))
