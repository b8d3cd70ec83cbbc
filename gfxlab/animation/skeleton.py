"""Skeletons: joint hierarchies, forward kinematics and inverse kinematics.

A `Skeleton` is a tree of joints. Joint `j` has a parent `parents[j] < j` (or `-1` for
a root) and a rest transform `rest[j]`: where the joint sits in its parent's frame.
A pose gives each joint a local transform `pose[j]` (its rotation about itself), and
forward kinematics composes down the tree:

    global[j] = global[parents[j]] @ rest[j] @ pose[j]

2D skeletons use 3x3 matrices (pose by one angle per joint), 3D ones 4x4 (pose by a
quaternion or rotation vector per joint). Inverse kinematics finds the pose that puts
an end effector on a target by fitting joint angles with `gfxlab.fit.fit`; joint limits
come from a smooth reparameterisation `angle = mid + half_range * sin(raw)`: every
raw value is a legal angle, and unlike `tanh` the map does not saturate, so a joint
that touched its limit can come back (gradient descent stalls on a flat `tanh`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .. import transforms as tf
from .._checks import (
    as_float,
    check_last_dim,
    check_shape,
    common_float,
    finite_float,
    value_error_if,
)
from ..fit import FitResult, fit
from .quaternions import quat_from_rotvec, quat_to_matrix

__all__ = [
    "Skeleton",
    "chain",
    "pose_2d",
    "pose_3d",
    "forward_kinematics",
    "forward_kinematics_loop",
    "joint_positions",
    "limit_angles",
    "solve_ik",
    "IKResult",
]


class Skeleton(eqx.Module):
    """A joint hierarchy with rest transforms.

    **Fields:**

    - `parents`: static tuple, `parents[j]` is the parent joint of `j` (`-1` for a root);
      parents come before their children (`parents[j] < j`).
    - `rest`: `(J, n, n)` local rest transforms (n = 3 for 2D, 4 for 3D): joint `j`'s
      frame in its parent's frame.
    """

    parents: tuple[int, ...] = eqx.field(static=True, converter=lambda p: tuple(int(i) for i in p))
    rest: Float[Array, "J n n"] = eqx.field(converter=lambda r: as_float(r, "rest"))

    def __check_init__(self):
        j = len(self.parents)
        if j == 0:
            raise ValueError("`parents` must name at least one joint")
        for i, p in enumerate(self.parents):
            if not -1 <= p < i:
                raise ValueError(
                    f"`parents[{i}]` must be -1 (a root) or an earlier joint in [0, {i}), got {p}"
                )
        if (
            self.rest.ndim != 3
            or self.rest.shape[0] != j
            or self.rest.shape[1:] not in ((3, 3), (4, 4))
        ):
            raise ValueError(
                f"`rest` must have shape ({j}, 3, 3) (2D) or ({j}, 4, 4) (3D), "
                f"got {self.rest.shape}"
            )

    @property
    def num_joints(self) -> int:
        """The number of joints."""
        return len(self.parents)

    @property
    def dim(self) -> int:
        """2 or 3."""
        return self.rest.shape[-1] - 1

    def fk(self, pose: Float[Array, "*batch J n n"] | None = None) -> Float[Array, "*batch J n n"]:
        """Global joint transforms for local `pose` transforms (`None`: the rest pose)."""
        return forward_kinematics(self, pose)

    def rest_globals(self) -> Float[Array, "J n n"]:
        """Global joint transforms in the rest pose (the bind pose for skinning)."""
        return forward_kinematics(self, None)

    @property
    def bones(self) -> tuple[tuple[int, int], ...]:
        """The bones as `(parent, child)` joint pairs, one per non-root joint. A bone moves
        with its parent joint's frame (the joint it rotates about)."""
        return tuple((p, j) for j, p in enumerate(self.parents) if p >= 0)

    def bone_segments(self, pose=None) -> Float[Array, "*batch B 2 d"]:
        """`(start, end)` positions of every bone in `bones` (rest pose by default)."""
        pos = joint_positions(self, pose)
        starts = jnp.array([p for p, _ in self.bones])
        ends = jnp.array([c for _, c in self.bones])
        return jnp.stack([pos[..., starts, :], pos[..., ends, :]], axis=-2)


def chain(lengths: Float[Array, " B"], *, dim: int = 2, root=None) -> Skeleton:
    """A serial chain (an arm, a leg, a tail) of bones along the x axis at rest.

    Joint 0 is the root (at `root`, default the origin); joint `j + 1` sits `lengths[j]`
    along its parent's x axis. The last joint is the tip (end effector), so a chain of
    `B` bones has `B + 1` joints.
    """
    lengths = as_float(lengths, "lengths")
    if lengths.ndim != 1 or lengths.shape[0] < 1:
        raise ValueError(f"`lengths` must be a 1D array of bone lengths, got {lengths.shape}")
    if dim not in (2, 3):
        raise ValueError(f"`dim` must be 2 or 3, got {dim!r}")
    zeros = jnp.zeros_like(lengths)
    offsets = jnp.stack([lengths, zeros] + ([zeros] if dim == 3 else []), axis=-1)
    root = jnp.zeros(dim, lengths.dtype) if root is None else as_float(root, "root")
    check_shape(root, "root", (dim,))
    rest = tf.translate(jnp.concatenate([root[None].astype(lengths.dtype), offsets]))
    return Skeleton(tuple(range(-1, lengths.shape[0])), rest)


def pose_2d(angles: Float[Array, "*batch J"]) -> Float[Array, "*batch J 3 3"]:
    """Local 2D joint rotations (3x3) from one angle per joint (counter-clockwise)."""
    return tf.rotate(as_float(angles, "angles"))


def pose_3d(rotations: Float[Array, "*batch J k"]) -> Float[Array, "*batch J 4 4"]:
    """Local 3D joint rotations (4x4) from quaternions `(..., 4)` or rotation vectors
    `(..., 3)` (axis times angle)."""
    rotations = as_float(rotations, "rotations")
    k = check_last_dim(rotations, "rotations", (3, 4), "rotation vectors or quaternions")
    q = quat_from_rotvec(rotations) if k == 3 else rotations
    return tf.linear(quat_to_matrix(q))


def _check_pose(skeleton, pose):
    n = skeleton.rest.shape[-1]
    j = skeleton.num_joints
    if pose is None:
        return jnp.broadcast_to(jnp.eye(n, dtype=skeleton.rest.dtype), (j, n, n))
    pose = as_float(pose, "pose")
    check_shape(pose, "pose", (..., j, n, n))
    return pose


def forward_kinematics(
    skeleton: Skeleton, pose: Float[Array, "*batch J n n"] | None = None
) -> Float[Array, "*batch J n n"]:
    """Global joint transforms: `global[j] = global[parent] @ rest[j] @ pose[j]`.

    Vectorized over the tree's depth: each pass composes every joint with its parent's
    current global transform, and after `depth` passes every chain is complete (the
    depth is static, a handful for a character). Batches of poses broadcast.

    **Arguments:**

    - `skeleton`: the `Skeleton`.
    - `pose`: `(..., J, n, n)` local joint transforms (`pose_2d`, `pose_3d`); `None`
      for the rest pose.

    **Returns:** `(..., J, n, n)` joint-to-world transforms.
    """
    pose = _check_pose(skeleton, pose)
    rest, pose = common_float(skeleton.rest, pose, names=("skeleton.rest", "pose"))
    return _fk_kernel(rest, pose, parents=skeleton.parents)


@functools.partial(jax.jit, static_argnames=("parents",))
def _fk_kernel(rest, pose, *, parents):
    local = rest @ pose
    depth = 0
    for p in parents:
        level = 0
        while p >= 0:
            level, p = level + 1, parents[p]
        depth = max(depth, level)
    is_root = jnp.array([p < 0 for p in parents])[:, None, None]
    parents = jnp.array([max(p, 0) for p in parents])
    glob = local
    for _ in range(depth):
        glob = jnp.where(is_root, local, glob[..., parents, :, :] @ local)
    return glob


def forward_kinematics_loop(
    skeleton: Skeleton, pose: Float[Array, "J n n"] | None = None
) -> Float[Array, "J n n"]:
    """The textbook joint-by-joint FK as a `lax.scan` over joints (parents first).

    Same result as `forward_kinematics` (tested equal); one pose, no batch.
    """
    pose = _check_pose(skeleton, pose)
    rest, pose = common_float(skeleton.rest, pose, names=("skeleton.rest", "pose"))
    if pose.ndim != 3:
        raise ValueError(f"`pose` must be one pose (J, n, n), got shape {pose.shape}")
    n = rest.shape[-1]
    parents = jnp.array(skeleton.parents)

    def step(glob, inputs):
        j, parent, local = inputs
        parent_glob = jnp.where(parent < 0, jnp.eye(n, dtype=rest.dtype), glob[parent])
        return glob.at[j].set(parent_glob @ local), None

    glob, _ = jax.lax.scan(
        step, jnp.zeros_like(rest), (jnp.arange(skeleton.num_joints), parents, rest @ pose)
    )
    return glob


def joint_positions(
    skeleton: Skeleton, pose: Float[Array, "*batch J n n"] | None = None
) -> Float[Array, "*batch J d"]:
    """World positions of the joints (the translation part of the global transforms)."""
    glob = forward_kinematics(skeleton, pose)
    d = skeleton.dim
    return glob[..., :d, d]


def limit_angles(raw: Float[Array, "*batch"], limits: Float[Array, "*batch 2"] | None):
    """Map unconstrained `raw` values into `[low, high]`: `mid + half * sin(raw)`.

    With `limits=None` the angles are `raw` itself. `raw = 0` is the middle of the range.
    """
    raw = as_float(raw, "raw")
    if limits is None:
        return raw
    limits = as_float(limits, "limits").astype(raw.dtype)
    check_shape(limits, "limits", (..., 2))
    limits = value_error_if(
        limits,
        limits[..., 1] <= limits[..., 0],
        "`limits` must be (low, high) pairs with high > low",
    )
    mid = 0.5 * (limits[..., 0] + limits[..., 1])
    half = 0.5 * (limits[..., 1] - limits[..., 0])
    return mid + half * jnp.sin(raw)


def _raw_from_angles(angles, limits):
    if limits is None:
        return angles
    mid = 0.5 * (limits[..., 0] + limits[..., 1])
    half = 0.5 * (limits[..., 1] - limits[..., 0])
    return jnp.arcsin(jnp.clip((angles - mid) / half, -1.0, 1.0))


class IKResult(NamedTuple):
    """What `solve_ik` returns: the joint `angles` (2D: `(J,)`; 3D: rotation vectors
    `(J, 3)`), the posed `globals` `(J, n, n)`, the `effector` position reached, and the
    underlying `FitResult`."""

    angles: jax.Array
    globals: jax.Array
    effector: jax.Array
    fit: FitResult


def _active_joints(skeleton: Skeleton, effector: int, active) -> jax.Array:
    j = skeleton.num_joints
    if active is None:
        # Only the effector's ancestors move it; fixing the rest keeps the problem regular.
        active, p = [], skeleton.parents[effector % j]
        while p >= 0:
            active, p = [p, *active], skeleton.parents[p]
    if not active:
        raise ValueError(f"joint {effector} has no ancestors to move it (a root effector)")
    return jnp.array(sorted(set(int(a) % j for a in active)), int)


def _ik_start(initial, limits, k_shape, dtype):
    """The unconstrained start parameters and the start angles of `solve_ik`."""
    if initial is None:
        raw0 = jnp.zeros(k_shape, dtype)
        return raw0, limit_angles(raw0, limits)
    initial = finite_float(initial, "initial").astype(dtype)
    check_shape(initial, "initial", k_shape)
    return _raw_from_angles(initial, limits), initial


def solve_ik(
    skeleton: Skeleton,
    target: Float[Array, " d"],
    *,
    effector: int = -1,
    initial: Float[Array, " J *k"] | None = None,
    limits: Float[Array, " J *k 2"] | None = None,
    active: tuple[int, ...] | None = None,
    method: str = "levenberg_marquardt",
    max_steps: int = 200,
    learning_rate: float = 0.05,
) -> IKResult:
    """Inverse kinematics: joint angles that put joint `effector` on `target`.

    Fits the joint angles through `gfxlab.fit.fit` with the residual
    `effector_position(angles) - target` (plus nothing else: among many solutions the
    one nearest the start is found). Limits go through `limit_angles`, so every iterate
    respects them.

    **Arguments:**

    - `skeleton`: a 2D or 3D `Skeleton`.
    - `target`: `(d,)` the point to reach, or `(..., d)` several targets solved at once
      (one pose each, in one fit).
    - `effector`: index of the end-effector joint (default the last, the tip of a
      `chain`).
    - `initial`: start angles, 2D `(J,)`, 3D rotation vectors `(J, 3)` (broadcast over
      the targets); default zeros
      (the middle of the limits when limits are given).
    - `limits`: `(J, 2)` (2D) or `(J, 3, 2)` (3D, per rotation-vector component)
      `(low, high)` in radians; `None` for free joints.
    - `active`: joints that may move (default the effector's ancestors).
    - `method`, `max_steps`, `learning_rate`: passed to `fit`.

    **Returns:** an `IKResult`.

    A driver, like `gfxlab.fit.fit`: it runs jitted solver steps and reads their results
    on the host, so call it eagerly (not inside `jax.jit` or `jax.grad`).
    """
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"`skeleton` must be a Skeleton, got {type(skeleton).__name__}")
    target = finite_float(target, "target")
    d = skeleton.dim
    check_shape(target, "target", (..., d))
    j = skeleton.num_joints
    k_shape = (j,) if d == 2 else (j, 3)
    if not -j <= effector < j:
        raise ValueError(f"`effector` must be a joint index in [-{j}, {j}), got {effector}")
    if limits is not None:
        limits = finite_float(limits, "limits").astype(target.dtype)
        check_shape(limits, "limits", k_shape + (2,))
    active = _active_joints(skeleton, effector, active)
    raw0, base = _ik_start(initial, limits, k_shape, target.dtype)

    batch = target.shape[:-1]
    raw0 = jnp.broadcast_to(raw0, batch + k_shape)
    base = jnp.broadcast_to(base, batch + k_shape)

    idx = (Ellipsis, active) if d == 2 else (Ellipsis, active, slice(None))

    def angles_of(raw_active):
        raw = raw0.at[idx].set(raw_active)
        return base.at[idx].set(limit_angles(raw, limits)[idx])

    def pose_of(angles):
        return pose_2d(angles) if d == 2 else pose_3d(angles)

    def residual(raw):
        return joint_positions(skeleton, pose_of(angles_of(raw)))[..., effector, :] - target

    result = fit(
        residual, raw0[idx], method=method, max_steps=max_steps, learning_rate=learning_rate
    )
    angles = angles_of(result.params)
    glob = forward_kinematics(skeleton, pose_of(angles))
    return IKResult(angles, glob, glob[..., effector, :d, d], result)
