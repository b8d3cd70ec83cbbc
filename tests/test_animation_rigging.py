"""Skeletons (FK, IK), linear blend skinning and the curve deformer (gfxlab.animation)."""

import logging

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from scipy.spatial.transform import Rotation

from gfxlab import animation as A
from gfxlab import transforms as tf


def test_fk_2d_hand_computed_chain(maybe_jit):
    sk = A.chain(jnp.array([1.0, 2.0]))
    angles = jnp.array([jnp.pi / 2, -jnp.pi / 2, 0.0])
    pos = maybe_jit(lambda a: A.joint_positions(sk, A.pose_2d(a)))(angles)
    # Up 1 along y, then 2 along x (the second joint turns back by 90 degrees).
    np.testing.assert_allclose(pos, [[0, 0], [0, 1], [2, 1]], atol=1e-12)
    angles = jnp.array([0.3, 0.5, 0.0])
    pos = A.joint_positions(sk, A.pose_2d(angles))
    a1, a2 = 0.3, 0.8
    hand = [
        [0, 0],
        [np.cos(a1), np.sin(a1)],
        [np.cos(a1) + 2 * np.cos(a2), np.sin(a1) + 2 * np.sin(a2)],
    ]
    np.testing.assert_allclose(pos, hand, atol=1e-12)


def test_fk_3d_hand_computed_and_scipy():
    sk = A.chain(jnp.array([1.0, 1.0]), dim=3, root=jnp.array([0.0, 0.0, 1.0]))
    rotvecs = jnp.array([[0.0, 0.0, jnp.pi / 2], [0.0, -jnp.pi / 2, 0.0], [0.0, 0.0, 0.0]])
    pos = A.joint_positions(sk, A.pose_3d(rotvecs))
    # Turn to +y, then pitch up (-90 deg about local y takes local x to +z).
    np.testing.assert_allclose(pos, [[0, 0, 1], [0, 1, 1], [0, 1, 2]], atol=1e-12)
    rv = np.random.default_rng(0).normal(size=(3, 3))
    pos = A.joint_positions(sk, A.pose_3d(rv))
    r0, r01 = Rotation.from_rotvec(rv[0]), Rotation.from_rotvec(rv[0]) * Rotation.from_rotvec(rv[1])
    expected = [
        [0, 0, 1],
        r0.apply([1, 0, 0]) + [0, 0, 1],
        r0.apply([1, 0, 0]) + r01.apply([1, 0, 0]) + [0, 0, 1],
    ]
    np.testing.assert_allclose(pos, expected, atol=1e-12)
    # quaternion poses give the same
    q = A.quat_from_rotvec(rv)
    np.testing.assert_allclose(A.joint_positions(sk, A.pose_3d(q)), pos, atol=1e-12)


def test_fk_vectorized_equals_joint_by_joint_loop_on_a_tree():
    parents = (-1, 0, 1, 1, 0, 4, 2, 5)
    rng = np.random.default_rng(1)
    rest = tf.compose(tf.rotate(rng.normal(size=8)), tf.translate(rng.normal(size=(8, 2))))
    sk = A.Skeleton(parents, rest)
    pose = A.pose_2d(rng.normal(size=8))
    loop = A.forward_kinematics_loop(sk, pose)
    np.testing.assert_allclose(A.forward_kinematics(sk, pose), loop, atol=1e-12)
    # independent reference: plain recursion in numpy
    ref = [None] * 8
    for j, p in enumerate(parents):
        local = np.asarray(rest[j]) @ np.asarray(pose[j])
        ref[j] = local if p < 0 else ref[p] @ local
    np.testing.assert_allclose(loop, np.stack(ref), atol=1e-12)
    # batches of poses broadcast
    poses = A.pose_2d(rng.normal(size=(4, 8)))
    batched = A.forward_kinematics(sk, poses)
    np.testing.assert_allclose(batched[2], A.forward_kinematics_loop(sk, poses[2]), atol=1e-12)


def test_check_grads_fk():
    sk = A.chain(jnp.array([1.0, 0.7, 0.4]))
    check_grads(
        lambda a: A.joint_positions(sk, A.pose_2d(a)), (jnp.array([0.2, -0.4, 0.9, 0.0]),), order=1
    )
    sk3 = A.chain(jnp.array([1.0, 0.5]), dim=3)
    check_grads(
        lambda r: A.joint_positions(sk3, A.pose_3d(r)),
        (jnp.array([[0.1, 0.2, 0.3], [0.0, -0.4, 0.2], [0.0, 0.0, 0.0]]),),
        order=1,
        modes=["rev"],
    )


def test_skeleton_bad_inputs():
    eye = jnp.broadcast_to(jnp.eye(3), (3, 3, 3))
    with pytest.raises(ValueError, match="parents"):
        A.Skeleton((-1, 2, 0), eye)
    with pytest.raises(ValueError, match="rest"):
        A.Skeleton((-1, 0, 1), jnp.eye(3))
    sk = A.Skeleton((-1, 0, 1), eye)
    with pytest.raises(ValueError, match="pose"):
        A.forward_kinematics(sk, jnp.broadcast_to(jnp.eye(3), (2, 3, 3)))
    with pytest.raises(ValueError, match="lengths"):
        A.chain(jnp.ones((2, 2)))
    with pytest.raises(ValueError, match="target"):
        A.solve_ik(A.chain(jnp.ones(2)), jnp.zeros(3))
    with pytest.raises(ValueError, match="limits"):
        A.limit_angles(jnp.zeros(2), jnp.array([[1.0, 0.0], [0.0, 1.0]]))


def test_ik_reaches_reachable_targets_2d_with_limits(caplog):
    sk = A.chain(jnp.array([1.0, 0.8, 0.5]))
    # Targets made by FK from poses inside the limits, so they are reachable.
    limits = jnp.array([[-1.5, 1.5], [0.0, 2.0], [-1.0, 1.0], [-1.0, 1.0]])
    poses = jnp.array([[0.3, 0.9, -0.5, 0.0], [-1.0, 1.5, 0.8, 0.0], [1.2, 0.2, 0.3, 0.0]])
    targets = A.joint_positions(sk, A.pose_2d(poses))[:, -1]
    result = A.solve_ik(sk, targets, limits=limits, initial=jnp.array([0.0, 1.0, 0.0, 0.0]))
    np.testing.assert_allclose(result.effector, targets, atol=1e-4)
    assert jnp.all(result.angles >= limits[:, 0] - 1e-12)
    assert jnp.all(result.angles <= limits[:, 1] + 1e-12)
    # New targets and start of the same shapes reuse every compiled program.
    others, start = np.asarray(targets)[::-1], np.array([0.1, 1.0, 0.0, 0.0])
    with jax.log_compiles(), caplog.at_level(logging.DEBUG):
        again = A.solve_ik(sk, others, limits=limits, initial=start)
    assert [r.getMessage() for r in caplog.records if "Compiling" in r.getMessage()] == []
    np.testing.assert_allclose(again.effector, others, atol=1e-4)
    with pytest.raises(ValueError, match="`limits`.*high > low"):
        A.solve_ik(sk, targets, limits=limits[:, ::-1])
    # A joint starting on (or past) its limit would stay pinned there, and a joint that
    # does not move would keep an angle outside its limits.
    for start in ([1.5, 1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 3.0]):
        with pytest.raises(ValueError, match="`initial` must lie strictly inside `limits`"):
            A.solve_ik(sk, targets, limits=limits, initial=np.array(start))
    with pytest.raises(TypeError, match="`solve_ik` is a driver"):
        jax.jit(lambda t: A.solve_ik(sk, t).angles)(targets)


def test_ik_reaches_reachable_target_3d():
    sk = A.chain(jnp.array([1.0, 1.0, 0.5]), dim=3)
    pose = jnp.array([[0.2, 0.4, 0.6], [0.0, 0.5, -0.3], [0.3, 0.0, 0.2], [0.0, 0.0, 0.0]])
    target = A.joint_positions(sk, A.pose_3d(pose))[-1]
    result = A.solve_ik(sk, target)
    np.testing.assert_allclose(result.effector, target, atol=1e-4)


# ---------------------------------------------------------------- skinning


def _arm_mesh(n=40):
    x = jnp.linspace(0.0, 2.0, n)
    return jnp.concatenate(
        [jnp.stack([x, jnp.full(n, 0.2)], -1), jnp.stack([x, jnp.full(n, -0.2)], -1)]
    )


def test_lbs_identity_and_single_rigid_bone(maybe_jit):
    sk = A.chain(jnp.array([1.0, 1.0]))
    verts = _arm_mesh()
    weights = A.bone_weights(verts, sk.bone_segments(), falloff=0.05)
    np.testing.assert_allclose(weights.sum(-1), 1.0, atol=1e-12)
    rest_mats = A.skinning_matrices(sk, None)
    np.testing.assert_allclose(maybe_jit(A.skin)(verts, weights, rest_mats), verts, atol=1e-12)
    # All weight on one bone: the mesh moves rigidly with that bone.
    pose = A.pose_2d(jnp.array([0.7, -1.1, 0.0]))
    mats = A.skinning_matrices(sk, pose)
    one = jnp.zeros_like(weights).at[:, 1].set(1.0)
    np.testing.assert_allclose(
        maybe_jit(A.skin)(verts, one, mats), tf.apply(mats[1], verts), atol=1e-12
    )
    # The bone's matrix carries its start joint from rest to posed position.
    glob = A.forward_kinematics(sk, pose)
    np.testing.assert_allclose(
        tf.apply(mats[1], sk.bone_segments()[1, 0]), glob[1, :2, 2], atol=1e-12
    )


def test_lbs_matches_numpy_reference_3d_and_batches():
    rng = np.random.default_rng(4)
    verts = rng.normal(size=(30, 3))
    weights = rng.uniform(size=(30, 5))
    weights /= weights.sum(-1, keepdims=True)
    spin = tf.rotate_axis(rng.normal(size=(2, 5, 3)), rng.normal(size=(2, 5)))
    mats = np.asarray(tf.compose(spin, tf.translate(rng.normal(size=(2, 5, 3)))))
    ref = np.einsum("nb,fbij,nj->fni", weights, mats, np.c_[verts, np.ones(30)])[..., :3]
    np.testing.assert_allclose(A.skin(verts, weights, mats), ref, atol=1e-12)


def test_candy_wrapper_collapse():
    # A tube twisted by 180 degrees about its axis: LBS blends identity and the twist
    # 50/50 in the middle, and the average of +r and -r is 0: the tube pinches to a line.
    angle = jnp.linspace(0, 2 * jnp.pi, 12, endpoint=False)
    ring = jnp.stack([jnp.ones(12), jnp.cos(angle), jnp.sin(angle)], -1)
    weights = jnp.full((12, 2), 0.5)
    mats = jnp.stack([jnp.eye(4), tf.rotate_x(jnp.pi)])
    out = A.skin(ring, weights, mats)
    np.testing.assert_allclose(out[:, 1:], 0.0, atol=1e-12)


def test_check_grads_skinning():
    rng = np.random.default_rng(5)
    verts = jnp.asarray(rng.normal(size=(6, 2)))
    weights = jnp.asarray(rng.dirichlet(np.ones(3), size=6))
    mats = tf.compose(
        tf.rotate(jnp.asarray(rng.normal(size=3))),
        tf.translate(jnp.asarray(rng.normal(size=(3, 2)))),
    )
    check_grads(lambda v, m: A.skin(v, weights, m), (verts, mats), order=1)


def test_skinning_bad_inputs():
    verts = _arm_mesh(5)
    mats = jnp.broadcast_to(jnp.eye(3), (2, 3, 3))
    with pytest.raises(ValueError, match="sum to 1"):
        A.skin(verts, jnp.full((10, 2), 0.4), mats)
    with pytest.raises(ValueError, match="sum to 1"):
        A.skin(verts, jnp.tile(jnp.array([1.5, -0.5]), (10, 1)), mats)
    with pytest.raises(ValueError, match="weights"):
        A.skin(verts, jnp.full((9, 2), 0.5), mats)
    with pytest.raises(ValueError, match="bone_transforms"):
        A.skin(verts, jnp.full((10, 2), 0.5), jnp.broadcast_to(jnp.eye(4), (2, 4, 4)))
    with pytest.raises(ValueError, match="per"):
        A.skinning_matrices(A.chain(jnp.ones(2)), None, per="vertex")


# ---------------------------------------------------------------- curve deformer


def test_curve_deformer_circle_and_line():
    n = 21
    shape = jnp.stack([jnp.linspace(0, 1, n), jnp.linspace(-0.1, 0.1, n)], -1)
    radius = 2.0
    circle = lambda u: radius * jnp.stack([jnp.cos(jnp.pi * u), jnp.sin(jnp.pi * u)], -1)
    bent = A.curve_deform(shape, circle)
    # The x axis goes along the half circle by arc length; y becomes the inward offset.
    np.testing.assert_allclose(jnp.linalg.norm(bent, axis=-1), radius - shape[:, 1], atol=1e-4)
    np.testing.assert_allclose(jnp.arctan2(bent[:, 1], bent[:, 0]), jnp.pi * shape[:, 0], atol=1e-4)
    # an explicit tangent gives the same as automatic differentiation
    tangent = lambda u: radius * jnp.pi * jnp.stack([-jnp.sin(jnp.pi * u), jnp.cos(jnp.pi * u)], -1)
    np.testing.assert_allclose(A.curve_deform(shape, circle, tangent=tangent), bent, atol=1e-12)
    # A straight path of the same length along x leaves the shape unchanged (2D and 3D).
    line = A.bezier_path(jnp.array([[0.0, 0.0], [1.0 / 3, 0.0], [2.0 / 3, 0.0], [1.0, 0.0]]))
    np.testing.assert_allclose(A.curve_deform(shape, line), shape, atol=1e-9)
    shape3 = jnp.c_[shape, jnp.linspace(0.2, -0.2, n)]
    line3 = A.bezier_path(jnp.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    np.testing.assert_allclose(A.curve_deform(shape3, line3), shape3, atol=1e-9)


def test_bezier_path_matches_bezier_library():
    import bezier

    nodes = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, -1.0], [4.0, 1.0]])
    u = np.linspace(0, 1, 9)
    ref = bezier.Curve(np.asfortranarray(nodes.T), degree=3).evaluate_multi(u).T
    np.testing.assert_allclose(A.bezier_path(nodes)(u), ref, atol=1e-12)


def test_curve_deformer_bad_inputs():
    shape = jnp.zeros((4, 2)).at[:, 0].set(jnp.arange(4.0))
    with pytest.raises(TypeError, match="path"):
        A.curve_deform(shape, [0, 1])
    with pytest.raises(ValueError, match="path"):
        A.curve_deform(shape, lambda u: jnp.zeros((3, 2)))
    with pytest.raises(ValueError, match="length"):
        A.curve_deform(shape, A.bezier_path(jnp.eye(2)), length=0.0)
    with pytest.raises(ValueError, match="control_points"):
        A.bezier_path(jnp.zeros(3))
    assert jax.jit(lambda v: A.curve_deform(v, A.bezier_path(jnp.eye(2))))(shape).shape == (4, 2)
