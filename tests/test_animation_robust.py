"""gfxlab.animation at the edges: antipodal slerp, degenerate parameters, bad input
(eagerly and under jit), size limits, truncated containers."""

import uuid

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from gfxlab import animation as A

Q = np.array([0.6, 0.2, -0.5, 0.5916079783099616])  # unit: 0.36 + 0.04 + 0.25 + 0.35


# --------------------------------------------------------------------------- antipodal slerp


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_slerp_antipodal_is_a_unit_great_circle(dtype):
    q = jnp.asarray(Q, dtype)
    u = jnp.linspace(0.0, 1.0, 17, dtype=dtype)
    path = np.asarray(A.slerp(q, -q, u, shortest=False), np.float64)
    tol = 1e-6 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(np.linalg.norm(path, axis=-1), 1.0, atol=tol)
    np.testing.assert_allclose(path[0], Q, atol=tol)
    np.testing.assert_allclose(path[-1], -Q, atol=tol)
    # Half way it is a quarter turn from both ends (not [0, 0, 0, 0]).
    assert abs(path[8] @ Q) < 10 * tol
    # Constant angular speed: equal steps of pi / 16 along one great circle.
    steps = np.arccos(np.clip(np.sum(path[1:] * path[:-1], axis=-1), -1, 1))
    np.testing.assert_allclose(steps, np.pi / 16, atol=1e-3 if dtype == np.float32 else 1e-9)
    # ... and all of it in one plane through the origin (rank 2).
    assert np.linalg.svd(path, compute_uv=False)[2] < 10 * tol


def test_slerp_antipodal_gradients():
    q = jnp.asarray(Q)
    u = jnp.array([0.1, 0.5, 0.8])
    kw = dict(order=1, modes=["fwd", "rev"])
    # The antipodal pair moved together (q, -q) and the parameter u.
    check_grads(jax.jit(lambda a, t: A.slerp(a, -a, t, shortest=False)), (q, u), **kw)
    q32 = q.astype(jnp.float32)
    check_grads(
        jax.jit(lambda t: A.slerp(q32, -q32, t, shortest=False)), (u.astype(jnp.float32),), **kw
    )
    # Each key alone: finite gradients (no NaN) in both modes.
    grads = jax.jit(
        jax.grad(lambda a, b, t: jnp.sum(A.slerp(a, b, t, shortest=False) ** 3), argnums=(0, 1, 2))
    )(q, -q, u)
    assert all(bool(jnp.all(jnp.isfinite(g))) for g in grads)


def test_slerp_near_antipodal_matches_the_formula():
    # Just outside the antipodal branch, the usual slerp formula (in float64 NumPy).
    q0 = Q
    q1 = -Q + 1e-6 * np.array([0.0, 1.0, 0.0, 0.0])
    q1 = q1 / np.linalg.norm(q1)
    u = np.array([0.25, 0.5])
    omega = np.arccos(q0 @ q1)
    expected = (np.sin((1 - u) * omega)[:, None] * q0 + np.sin(u * omega)[:, None] * q1) / np.sin(
        omega
    )
    got = np.asarray(A.slerp(q0, q1, u, shortest=False))
    np.testing.assert_allclose(got, expected, atol=1e-8)


# --------------------------------------------------------------------------- degenerate input


@pytest.mark.parametrize(
    "fn, args, message",
    [
        (A.quat_log, (jnp.zeros(4),), "`q` must be non-zero"),
        (A.quat_normalize, (jnp.zeros(4),), "`q` must be non-zero"),
        (A.quat_log, (jnp.array([np.nan, 0, 0, 1.0]),), "`q` must be finite"),
        (lambda q: A.quat_multiply(q, Q), (jnp.array([np.inf, 0, 0, 1.0]),), "`q` must be finite"),
        (lambda a: A.quat_from_axis_angle(a, 1.0), (jnp.zeros(3),), "`axis` must be a non-zero"),
        (lambda u: A.slerp(Q, Q, u), (jnp.array(np.nan),), "`u` must be finite"),
        (
            lambda f: A.bone_weights(jnp.zeros((2, 2)), jnp.ones((1, 2, 2)), falloff=f),
            (0.0,),
            "`falloff` must be positive",
        ),
        (
            lambda f: A.bone_weights(jnp.zeros((2, 2)), jnp.ones((1, 2, 2)), falloff=f),
            (np.nan,),
            "`falloff` must be finite",
        ),
        (
            lambda p: A.bone_weights(jnp.zeros((2, 2)), jnp.ones((1, 2, 2)), power=p),
            (-1.0,),
            "`power` must be >= 0",
        ),
        (
            lambda d: A.emit(jax.random.key(0), 4, origin=jnp.zeros(2), direction=d),
            (jnp.zeros(2),),
            "`direction` must be a non-zero",
        ),
        (
            lambda s: A.emit(jax.random.key(0), 4, origin=jnp.zeros(2), direction=Q[:2], speed=s),
            (jnp.inf,),
            "`speed` must be finite",
        ),
        (
            lambda dt: A.damped_spring(0.0, 0.0, 1.0, stiffness=1.0, damping=0.1, dt=dt, steps=3),
            (np.nan,),
            "`dt` must be finite",
        ),
    ],
)
def test_degenerate_input_is_a_clear_error(fn, args, message, maybe_jit):
    with pytest.raises(Exception, match=message):
        jax.block_until_ready(maybe_jit(fn)(*args))


def test_quat_log_of_a_unit_quaternion_still_works():
    v = A.quat_log(A.quat_from_axis_angle(jnp.array([0.0, 0.0, 1.0]), 1.0))
    np.testing.assert_allclose(v, [0.0, 0.0, 0.5], atol=1e-12)


# --------------------------------------------------------------------------- Track


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        (dict(times=["a", "b"], position=np.zeros((2, 3))), TypeError, "`times`"),
        (dict(times=None, position=np.zeros((2, 3))), TypeError, "`times`"),
        (dict(times=[0.0, 1.0], position="xy"), TypeError, "`position`"),
        (dict(times=[0.0, 0.0], position=np.zeros((2, 3))), ValueError, "strictly increasing"),
        (dict(times=[0.0, np.nan], position=np.zeros((2, 3))), ValueError, "`times` must be"),
        (dict(times=[0.0, 1.0], position=np.zeros((3, 3))), ValueError, "`position` must be"),
        (dict(times=[0.0, 1.0], rotation=np.ones((2, 3))), ValueError, "`rotation`"),
        (dict(times=[0.0, 1.0], scale=np.full((2, 3), np.inf)), ValueError, "`scale` must be"),
        (dict(times=[0.0, 1.0]), ValueError, "at least one channel"),
    ],
)
def test_track_validates_at_construction(kwargs, error, message):
    with pytest.raises(error, match=message):
        A.Track(**kwargs)


def test_track_still_builds_under_transforms():
    track = A.Track(times=[0, 1, 2], position=np.arange(9.0).reshape(3, 3))
    assert track.times.dtype.kind == "f"
    out = jax.jit(lambda p: A.Track(times=jnp.array([0.0, 1.0]), position=p)(jnp.array([0.5])))(
        jnp.zeros((2, 3))
    )
    np.testing.assert_allclose(out.position, 0.0)
    np.testing.assert_allclose(track(jnp.array([0.5])).position, [[1.5, 2.5, 3.5]])


# --------------------------------------------------------------------------- sizes


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: A.chain_springs(10**9), "MAX_SPRING_MASSES|<= "),
        (
            lambda: A.emit(jax.random.key(0), 10**9, origin=np.zeros(2), direction=[1.0, 0.0]),
            "`count` must be <=",
        ),
        (
            lambda: A.simulate_springs(
                np.zeros((3, 2)), np.zeros((3, 2)), A.chain_springs(3), steps=10**9, dt=0.1
            ),
            "`steps` must be <=",
        ),
        (
            lambda: A.simulate_springs(
                np.zeros((10**4, 3)), np.zeros((10**4, 3)), A.chain_springs(2), steps=10**5, dt=0.1
            ),
            "MAX_SAMPLES",
        ),
        (
            lambda: A.simulate_particles(
                A.emit(jax.random.key(0), 1000, origin=np.zeros(3), direction=[0.0, 1.0, 0.0]),
                steps=10**5,
                dt=0.01,
            ),
            "MAX_SAMPLES",
        ),
        (lambda: A.damped_spring(0.0, 0.0, 1.0, stiffness=1, damping=1, dt=1, steps=10**9), "<="),
        (lambda: A.emit(None, 3, origin=np.zeros(2), direction=[1.0, 0.0]), "`key`"),
        (lambda: A.simulate_particles("p", steps=3, dt=0.1), "`particles`"),
        (
            lambda: A.simulate_springs(np.zeros((3, 2)), np.zeros((3, 2)), None, steps=3, dt=0.1),
            "`springs`",
        ),
    ],
)
def test_sizes_are_bounded_and_arguments_named(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


# --------------------------------------------------------------------------- containers and files


def _asf_header_guid():
    return uuid.UUID("75B22630-668E-11CF-A6D9-00AA0062CE6C").bytes_le


@pytest.mark.parametrize(
    "data",
    [
        b"RIFF" + (4).to_bytes(4, "little") + b"AVI ",  # no avih chunk
        b"RIFF" + (100).to_bytes(4, "little") + b"AVI LIST\x50\x00\x00\x00hdrl",
        _asf_header_guid() + (30).to_bytes(8, "little") + (0).to_bytes(4, "little") + b"\x01\x02",
        _asf_header_guid() + b"\x00" * 3,
    ],
    ids=["riff-empty", "riff-cut", "asf-empty", "asf-cut"],
)
def test_container_info_truncated_raises_value_error(tmp_path, data):
    path = tmp_path / "bad.bin"
    path.write_bytes(data)
    with pytest.raises(ValueError, match="damaged or truncated|not a recognised"):
        A.container_info(path)


def test_video_entry_points_name_their_arguments(tmp_path):
    frames = np.zeros((2, 4, 4, 3))
    with pytest.raises(TypeError, match="`path`"):
        A.container_info(None)
    with pytest.raises(TypeError, match="`frames`"):
        A.save_animation(None, tmp_path / "a.gif")
    with pytest.raises(TypeError, match="`path`"):
        A.save_animation(frames, None)
    with pytest.raises(ValueError, match="`fps`"):
        A.save_animation(frames, tmp_path / "a.gif", fps=float("inf"))
    with pytest.raises(TypeError, match="`fps`"):
        A.save_animation(frames, tmp_path / "a.gif", fps="fast")
    with pytest.raises(ValueError, match="`frames` has NaN"):
        A.save_animation(np.full((2, 4, 4), np.nan), tmp_path / "a.gif")


def test_easing_uses_the_bernstein_form():
    # An independent reference: the cubic Bezier timing curve solved by bisection in NumPy.
    x1, y1, x2, y2 = 0.42, 0.0, 0.58, 1.0
    u = np.linspace(0.0, 1.0, 11)

    def bez(s, a, b):
        return 3 * (1 - s) ** 2 * s * a + 3 * (1 - s) * s**2 * b + s**3

    lo, hi = np.zeros_like(u), np.ones_like(u)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = bez(mid, x1, x2) < u
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    expected = bez(0.5 * (lo + hi), y1, y2)
    np.testing.assert_allclose(A.cubic_bezier_easing(u, "ease_in_out"), expected, atol=1e-12)


# --------------------------------------------------------------------------- issue 17: values


K4 = jnp.array([0.0, 1.0, 2.0, 3.0])
V4 = jnp.array([[0.0, 1.0], [1.0, 0.0], [2.0, 2.0], [0.0, 3.0]])
Q4 = jnp.asarray(np.stack([Q, -Q[[1, 0, 3, 2]], Q[[2, 3, 0, 1]], Q]))
T2 = jnp.array([0.5, 2.5])
NAN4 = jnp.array([0.0, np.nan, 2.0, 3.0])
TRACK = A.Track(times=K4, position=np.ones((4, 3)), rotation=np.asarray(Q4))


def _nan_like(x):
    return jnp.full(jnp.shape(x), jnp.nan)


VALUE_CASES = {
    "interpolate times": (lambda x: A.interpolate(x, V4, T2), NAN4, "`times` must be finite"),
    "interpolate values": (lambda x: A.interpolate(K4, x, T2), _nan_like(V4), "`values`"),
    "interpolate t": (lambda x: A.interpolate(K4, V4, x), _nan_like(T2), "`t` must be finite"),
    "interpolate tension": (
        lambda x: A.interpolate(K4, V4, T2, method="catmull_rom", tension=x),
        jnp.array(np.nan),
        "`tension` must be finite",
    ),
    "interpolate unsorted": (
        lambda x: A.interpolate(x, V4, T2),
        K4[::-1],
        "`times` must be strictly increasing",
    ),
    "interpolate easing": (
        lambda x: A.interpolate(K4, V4, T2, method="bezier", easing=x),
        jnp.array([1.5, 0.0, 0.5, 1.0]),
        "`easing` x1 and x2",
    ),
    "rotations quats": (
        lambda x: A.interpolate_rotations(K4, x, T2),
        _nan_like(Q4),
        "`quats` must be finite",
    ),
    "rotations zero": (
        lambda x: A.interpolate_rotations(K4, x, T2, method="squad"),
        Q4.at[1].set(0.0),
        "`quats` must be non-zero",
    ),
    "tangents tension": (
        lambda x: A.catmull_rom_tangents(K4, V4, tension=x),
        jnp.array(np.inf),
        "`tension` must be finite",
    ),
    "easing u": (lambda x: A.ease_in_out(x), _nan_like(T2), "`u` must be finite"),
    "track t": (lambda x: TRACK(x), _nan_like(T2), "`t` must be finite"),
    "squad_inner q": (lambda x: A.squad_inner(Q, x, Q), _nan_like(Q), "`q` must be finite"),
    "squad u": (lambda x: A.squad(Q, Q, Q, Q, x), _nan_like(T2), "`u` must be finite"),
    "skin weights": (
        lambda x: A.skin(V4, x, jnp.broadcast_to(jnp.eye(3), (2, 3, 3))),
        jnp.full((4, 2), np.nan),
        "`weights` must be finite",
    ),
    "skin atol": (
        lambda x: A.skin(
            V4, jnp.full((4, 2), 0.5), jnp.broadcast_to(jnp.eye(3), (2, 3, 3)), atol=x
        ),
        jnp.array(-1.0),
        "`atol` must be >= 0",
    ),
    "chain lengths": (lambda x: A.chain(x).rest, NAN4, "`lengths` must be finite"),
    "pose_2d": (A.pose_2d, NAN4, "`angles` must be finite"),
    "pose_3d zero": (A.pose_3d, jnp.zeros((2, 4)), "`rotations` quaternions must be non-zero"),
    "limit_angles": (
        lambda x: A.limit_angles(jnp.zeros(2), x),
        jnp.array([[0.0, 1.0], [1.0, np.nan]]),
        "`limits` must be finite",
    ),
    "fk pose": (
        lambda x: A.forward_kinematics(A.chain([1.0, 1.0]), x),
        jnp.full((3, 3, 3), np.nan),
        "`pose` must be finite",
    ),
    "damped_spring target": (
        lambda x: A.damped_spring(0.0, 0.0, x, stiffness=1.0, damping=0.1, dt=0.1),
        jnp.array([1.0, np.nan]),
        "`target` must be finite",
    ),
    "bone_weights vertices": (
        lambda x: A.bone_weights(x, jnp.ones((1, 2, 2))),
        jnp.full((2, 2), np.inf),
        "`vertices` must be finite",
    ),
}


@pytest.mark.parametrize("case", sorted(VALUE_CASES))
def test_bad_values_name_the_argument_eagerly_and_under_jit(case, maybe_jit):
    from gfxlab import check_message

    fn, bad, message = VALUE_CASES[case]
    with pytest.raises(Exception) as info:  # ValueError eagerly, JaxRuntimeError under jit
        jax.block_until_ready(maybe_jit(fn)(bad))
    assert message in (check_message(info.value) or ""), str(info.value)[-300:]


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: A.interpolate(K4, V4, T2, tension=None), TypeError, "`tension`"),
        (lambda: A.interpolate(K4, V4, T2, easing=None), TypeError, "`easing`"),
        (lambda: A.interpolate(K4, V4, T2, easing="bouncy"), ValueError, "`easing`"),
        (lambda: A.interpolate(K4, V4, T2, method=None), ValueError, "`method`"),
        (lambda: A.interpolate(jnp.zeros(7), V4, T2), ValueError, "`times`"),
        (lambda: A.cubic_bezier_easing(T2, iterations=10**12), ValueError, "`iterations`"),
        (lambda: A.format_tree([A.Node("a", 0, 8)], max_children=10**12), ValueError, "max_"),
        (lambda: A.format_tree(None), TypeError, "`nodes`"),
        (lambda: A.Particles(None, np.zeros((2, 2)), np.zeros(2)), TypeError, "`position`"),
        (
            lambda: A.Particles(np.zeros((2, 2)), np.full((2, 2), np.nan), np.zeros(2)),
            ValueError,
            "`velocity` must be finite",
        ),
        (lambda: A.Particles(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(3)), ValueError, "birth"),
        (lambda: A.Skeleton(None, np.zeros((1, 3, 3))), TypeError, "`parents`"),
        (lambda: A.Skeleton("ab", np.zeros((2, 3, 3))), TypeError, "`parents`"),
        (lambda: A.Skeleton([-1], np.full((1, 3, 3), np.nan)), ValueError, "`rest`"),
        (lambda: A.solve_ik(A.chain([1.0]), [1.0, 0.0], effector=0.5), TypeError, "`effector`"),
        (lambda: A.skinning_matrices(None, None), TypeError, "`skeleton`"),
        (lambda: A.emit("key", 3, origin=np.zeros(2), direction=[1.0, 0.0]), TypeError, "`key`"),
        (lambda: A.chain(np.ones(A.MAX_JOINTS)), ValueError, "MAX_JOINTS"),
        (lambda: A.bezier_path(np.zeros((3, 5))), ValueError, "`control_points`"),
        (lambda: A.curve_deform(V4, A.bezier_path(V4), samples=10**9), ValueError, "`samples`"),
    ],
)
def test_static_arguments_are_checked(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_ik_result_checks_its_fields():
    result = A.solve_ik(A.chain([1.0, 1.0]), [1.0, 1.0], max_steps=5)
    assert isinstance(result, A.IKResult)
    angles, glob, effector, fit = result  # still a tuple
    with pytest.raises(ValueError, match="`angles`"):
        A.IKResult(np.zeros(7), glob, effector, fit)
    with pytest.raises(ValueError, match="`effector` must be finite"):
        A.IKResult(angles, glob, effector * np.nan, fit)
    with pytest.raises(TypeError, match="`fit`"):
        A.IKResult(angles, glob, effector, None)


def test_limit_angles_without_limits_is_the_identity():
    raw = jnp.array([0.3, -2.0])
    np.testing.assert_array_equal(A.limit_angles(raw), raw)
    np.testing.assert_allclose(A.limit_angles(raw, jnp.array([[0.0, 2.0]] * 2)), 1 + np.sin(raw))
