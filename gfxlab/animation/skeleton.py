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
import numpy as np
from jaxtyping import Array, Float

from .. import transforms as tf
from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    check_shape,
    checked_jit,
    finite_float,
    is_traced,
    static_int,
    value_error_if,
)
from ..fit import FitResult, fit
from .quaternions import _exp

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
    "MAX_JOINTS",
]

#: The most joints `chain` builds (forward kinematics unrolls the tree's depth).
MAX_JOINTS = 1024


def _parents(parents) -> tuple[int, ...]:
    if parents is None or isinstance(parents, str | bytes):
        raise TypeError(f"`parents` must be a sequence of joint indices, got {parents!r:.40}")
    try:
        items = list(parents)
    except TypeError:
        raise TypeError(
            f"`parents` must be a sequence of joint indices, got {parents!r:.40}"
        ) from None
    return tuple(static_int(p, f"parents[{i}]") for i, p in enumerate(items))


class Skeleton(eqx.Module):
    """A joint hierarchy with rest transforms.

    **Fields:**

    - `parents`: static tuple, `parents[j]` is the parent joint of `j` (`-1` for a root);
      parents come before their children (`parents[j] < j`).
    - `rest`: `(J, n, n)` local rest transforms (n = 3 for 2D, 4 for 3D): joint `j`'s
      frame in its parent's frame.
    """

    parents: tuple[int, ...] = eqx.field(static=True, converter=lambda p: _parents(p))
    rest: Float[Array, "J n n"] = eqx.field(converter=lambda r: as_float(r, "rest"))

    def __check_init__(self):
        """Check the fields: at least one joint, parents before their children, `rest` of
        shape `(J, 3, 3)` or `(J, 4, 4)` and finite (checked when not traced)."""
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
        if not is_traced(self.rest):
            check_finite(self.rest, "rest")

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

    **Arguments:** `lengths` `(B,)` finite bone lengths (at most `MAX_JOINTS - 1`
    bones), `dim` 2 or 3, `root` `(dim,)` finite.
    """
    lengths = as_float(lengths, "lengths")
    if lengths.ndim != 1 or lengths.shape[0] < 1:
        raise ValueError(f"`lengths` must be a 1D array of bone lengths, got {lengths.shape}")
    if lengths.shape[0] >= MAX_JOINTS:
        raise ValueError(f"`lengths` must hold at most {MAX_JOINTS - 1} bones (MAX_JOINTS)")
    if isinstance(dim, bool) or dim not in (2, 3):
        raise ValueError(f"`dim` must be 2 or 3, got {dim!r}")
    root = jnp.zeros(dim, lengths.dtype) if root is None else as_float(root, "root")
    check_shape(root, "root", (dim,))
    return Skeleton(tuple(range(-1, lengths.shape[0])), _chain_kernel(lengths, root))


@checked_jit
def _chain_kernel(lengths, root):
    lengths = check_finite(lengths, "lengths")
    root = check_finite(root.astype(lengths.dtype), "root")
    zeros = jnp.zeros_like(lengths)
    offsets = jnp.stack([lengths, zeros] + ([zeros] if root.shape[0] == 3 else []), axis=-1)
    return tf.translate(jnp.concatenate([root[None], offsets]))


def pose_2d(angles: Float[Array, "*batch J"]) -> Float[Array, "*batch J 3 3"]:
    """Local 2D joint rotations (3x3) from one finite angle per joint (counter-clockwise)."""
    return _pose_2d_kernel(as_float(angles, "angles"))


@checked_jit
def _pose_2d_kernel(angles):
    return tf.rotate(check_finite(angles, "angles"))


def pose_3d(rotations: Float[Array, "*batch J k"]) -> Float[Array, "*batch J 4 4"]:
    """Local 3D joint rotations (4x4) from quaternions `(..., 4)` (non-zero) or rotation
    vectors `(..., 3)` (axis times angle)."""
    rotations = as_float(rotations, "rotations")
    check_last_dim(rotations, "rotations", (3, 4), "rotation vectors or quaternions")
    return _pose_3d_kernel(rotations)


@checked_jit
def _pose_3d_kernel(rotations):
    rotations = check_finite(rotations, "rotations")
    if rotations.shape[-1] == 3:
        q = _exp(0.5 * rotations)
    else:
        q = value_error_if(
            rotations,
            jnp.all(rotations == 0, axis=-1),
            "`rotations` quaternions must be non-zero",
        )
    return tf.linear(tf.rotation_from_quaternion(q))


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
    - `pose`: `(..., J, n, n)` finite local joint transforms (`pose_2d`, `pose_3d`);
      `None` for the rest pose.

    **Returns:** `(..., J, n, n)` joint-to-world transforms.
    """
    _check_skeleton(skeleton)
    pose = _check_pose(skeleton, pose)
    return _fk_kernel(skeleton.rest, pose, parents=skeleton.parents)


def _check_skeleton(skeleton) -> None:
    if not isinstance(skeleton, Skeleton):
        raise TypeError(f"`skeleton` must be a Skeleton, got {type(skeleton).__name__}")


@functools.partial(checked_jit, static_argnames=("parents",))
def _fk_kernel(rest, pose, *, parents):
    dtype = jnp.result_type(rest, pose)
    rest = check_finite(rest.astype(dtype), "skeleton.rest")
    return _fk(rest, check_finite(pose.astype(dtype), "pose"), parents)


def _fk(rest, pose, parents):
    """The unchecked forward kinematics (`parents` a static tuple)."""
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
    _check_skeleton(skeleton)
    pose = _check_pose(skeleton, pose)
    if pose.ndim != 3:
        raise ValueError(f"`pose` must be one pose (J, n, n), got shape {pose.shape}")
    return _fk_loop_kernel(skeleton.rest, pose, jnp.array(skeleton.parents))


@checked_jit
def _fk_loop_kernel(rest, pose, parents):
    dtype = jnp.result_type(rest, pose)
    rest = check_finite(rest.astype(dtype), "skeleton.rest")
    pose = check_finite(pose.astype(dtype), "pose")
    n = rest.shape[-1]

    def step(glob, inputs):
        j, parent, local = inputs
        parent_glob = jnp.where(parent < 0, jnp.eye(n, dtype=rest.dtype), glob[parent])
        return glob.at[j].set(parent_glob @ local), None

    glob, _ = jax.lax.scan(
        step, jnp.zeros_like(rest), (jnp.arange(rest.shape[0]), parents, rest @ pose)
    )
    return glob


def joint_positions(
    skeleton: Skeleton, pose: Float[Array, "*batch J n n"] | None = None
) -> Float[Array, "*batch J d"]:
    """World positions of the joints (the translation part of the global transforms)."""
    _check_skeleton(skeleton)
    pose = _check_pose(skeleton, pose)
    return _positions_kernel(skeleton.rest, pose, parents=skeleton.parents)


@functools.partial(checked_jit, static_argnames=("parents",))
def _positions_kernel(rest, pose, *, parents):
    d = rest.shape[-1] - 1
    return _fk_kernel(rest, pose, parents=parents)[..., :d, d]


def limit_angles(
    raw: Float[Array, "*batch"], limits: Float[Array, "*batch 2"] | None = None
) -> Float[Array, "*batch"]:
    """Map unconstrained `raw` values into `[low, high]`: `mid + half * sin(raw)`.

    With `limits=None` (free joints) the angles are `raw` itself. `raw = 0` is the
    middle of the range. Both must be finite, with `high > low`.
    """
    raw = as_float(raw, "raw")
    if limits is not None:
        limits = as_float(limits, "limits")
        check_shape(limits, "limits", (..., 2))
    return _limit_kernel(raw, limits)


_LIMITS_ORDER = "`limits` must be (low, high) pairs with high > low"


@checked_jit
def _limit_kernel(raw, limits):
    raw = check_finite(raw, "raw")
    if limits is None:
        return raw
    limits = check_finite(limits.astype(raw.dtype), "limits")
    limits = value_error_if(limits, limits[..., 1] <= limits[..., 0], _LIMITS_ORDER)
    return _limited(raw, limits)


def _limited(raw, limits):
    mid = 0.5 * (limits[..., 0] + limits[..., 1])
    half = 0.5 * (limits[..., 1] - limits[..., 0])
    return mid + half * jnp.sin(raw)


def _raw_from_angles(angles, limits):
    if limits is None:
        return angles
    mid = 0.5 * (limits[..., 0] + limits[..., 1])
    half = 0.5 * (limits[..., 1] - limits[..., 0])
    return jnp.arcsin(jnp.clip((angles - mid) / half, -1.0, 1.0))


class _IKFields(NamedTuple):
    angles: jax.Array
    globals: jax.Array
    effector: jax.Array
    fit: FitResult


class IKResult(_IKFields):
    """What `solve_ik` returns: the joint `angles` (2D: `(..., J)`; 3D: rotation vectors
    `(..., J, 3)`), the posed `globals` `(..., J, n, n)`, the `effector` position reached
    `(..., n - 1)`, and the underlying `FitResult`. Checked at construction."""

    __slots__ = ()

    def __new__(cls, angles, globals, effector, fit):  # noqa: A002 - the field's name
        """Check the fields (shapes consistent, finite) and build the tuple."""
        if not isinstance(fit, FitResult):
            raise TypeError(f"`fit` must be a gfxlab.fit.FitResult, got {type(fit).__name__}")
        globals = as_float(globals, "globals")
        if globals.ndim < 3 or globals.shape[-2:] not in ((3, 3), (4, 4)):
            raise ValueError(f"`globals` must be (..., J, n, n), n = 3 or 4, got {globals.shape}")
        n = globals.shape[-1]
        angles, effector = as_float(angles, "angles"), as_float(effector, "effector")
        expected = globals.shape[:-2] + (() if n == 3 else (3,))
        if angles.shape != expected:
            raise ValueError(
                f"`angles` must have shape {expected} (one per joint of `globals` "
                f"{globals.shape}), got {angles.shape}"
            )
        if effector.shape != globals.shape[:-3] + (n - 1,):
            raise ValueError(
                f"`effector` must have shape {globals.shape[:-3] + (n - 1,)}, got {effector.shape}"
            )
        for name, value in (("angles", angles), ("globals", globals), ("effector", effector)):
            if not is_traced(value):
                check_finite(value, name)
        return super().__new__(cls, angles, globals, effector, fit)


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


class _IKProblem(eqx.Module):
    """The residual of `solve_ik`, `effector_position(angles) - target`, as a pytree with
    its static choices as fields: the same problem shapes give an equal object, so `fit`
    reuses its compiled steps from one call of `solve_ik` to the next."""

    effector: int = eqx.field(static=True)
    dim: int = eqx.field(static=True)

    def angles(self, raw_active, raw0, base, limits, active):
        """All joint angles from the active joints' unconstrained values."""
        idx = _active_index(active, self.dim)
        raw = raw0.at[idx].set(raw_active)
        limited = raw if limits is None else _limited(raw, limits)
        return base.at[idx].set(limited[idx])

    def globals(self, skeleton, angles):
        pose = pose_2d(angles) if self.dim == 2 else pose_3d(angles)
        return _fk_kernel(skeleton.rest, pose, parents=skeleton.parents)

    def __call__(self, raw_active, skeleton, raw0, base, limits, active, target):
        glob = self.globals(skeleton, self.angles(raw_active, raw0, base, limits, active))
        return glob[..., self.effector, : self.dim, self.dim] - target


def _active_index(active, dim):
    return (Ellipsis, active) if dim == 2 else (Ellipsis, active, slice(None))


@functools.partial(jax.jit, static_argnames=("batch", "dim"))
def _ik_start(initial, limits, active, *, batch, dim):
    """The start angles (default: zeros, the middle of the limits), their unconstrained
    values, one per target, and those of the active joints."""
    if initial is None:
        initial = _limited(jnp.zeros_like(limits[..., 0]), limits)
    raw0 = jnp.broadcast_to(_raw_from_angles(initial, limits), batch + initial.shape)
    base = jnp.broadcast_to(initial, batch + initial.shape)
    return raw0, base, raw0[_active_index(active, dim)]


@functools.partial(jax.jit, static_argnames=("problem",))
def _ik_finish(problem, raw_active, skeleton, raw0, base, limits, active, target):
    """The fitted angles, the global transforms and the effector's position."""
    angles = problem.angles(raw_active, raw0, base, limits, active)
    glob = problem.globals(skeleton, angles)
    return angles, glob, glob[..., problem.effector, : problem.dim, problem.dim]


def _ik_limits_and_start(limits, initial, k_shape, dtype):
    """`solve_ik`'s checked `limits` (high > low) and start (strictly inside the limits;
    `None` for the middle of the limits, zeros without limits). Values are known here:
    `solve_ik` refuses traced inputs first."""
    if limits is not None:
        limits = finite_float(limits, "limits").astype(dtype)
        check_shape(limits, "limits", k_shape + (2,))
        low, high = np.moveaxis(np.asarray(limits), -1, 0)
        if np.any(high <= low):
            raise ValueError(_LIMITS_ORDER)  # (NumPy: values are known, no program)
    if initial is None:
        return limits, None if limits is not None else np.zeros(k_shape, dtype)
    initial = finite_float(initial, "initial").astype(dtype)
    check_shape(initial, "initial", k_shape)
    start = np.asarray(initial)
    if limits is not None and not np.all((low < start) & (start < high)):
        raise ValueError(
            "`initial` must lie strictly inside `limits` (low < angle < high): a joint "
            "that starts on or beyond a limit cannot move off it"
        )
    return limits, initial


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
      the targets), strictly inside `limits` when they are given; default zeros (the
      middle of the limits when limits are given).
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
    if is_traced((skeleton, target, initial, limits)):
        raise TypeError(
            "`solve_ik` is a driver (it runs `gfxlab.fit.fit`, which steps in a Python "
            "loop); call it outside `jax.jit`, `jax.grad` and `jax.vmap`"
        )
    target = finite_float(target, "target")
    d = skeleton.dim
    check_shape(target, "target", (..., d))
    j = skeleton.num_joints
    k_shape = (j,) if d == 2 else (j, 3)
    effector = static_int(effector, "effector")
    if method is None:
        raise TypeError("`method` must name a fit method (see gfxlab.fit.fit), got None")
    if not -j <= effector < j:
        raise ValueError(f"`effector` must be a joint index in [-{j}, {j}), got {effector}")
    limits, initial = _ik_limits_and_start(limits, initial, k_shape, target.dtype)
    active = _active_joints(skeleton, effector, active)
    raw0, base, start = _ik_start(initial, limits, active, batch=target.shape[:-1], dim=d)
    problem = _IKProblem(effector % j, d)
    data = (skeleton, raw0, base, limits, active, target)
    result = fit(
        problem, start, args=data, method=method, max_steps=max_steps, learning_rate=learning_rate
    )
    angles, glob, tip = _ik_finish(problem, result.params, *data)
    return IKResult(angles, glob, tip, result)
