"""Procedural animation: motion from rules instead of key frames.

A particle system (emitter, gravity, drag, collisions with planes), damped springs and
mass-spring chains integrated with a fixed time step under `lax.scan`, and smooth
value/gradient noise for secondary motion (wobble, breathing, camera shake).
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int

from .._checks import (
    as_float,
    check_finite,
    check_key,
    check_last_dim,
    check_shape,
    checked_jit,
    common_float,
    finite_float,
    is_traced,
    safe_norm,
    safe_normalize,
    static_int,
    value_error_if,
)

# Noise has one owner, gfxlab.image; procedural motion re-exports it.
from ..image import fractal_noise, gradient_noise, value_noise
from .quaternions import _number  # noqa: E402

__all__ = [
    "Particles",
    "emit",
    "simulate_particles",
    "damped_spring",
    "chain_springs",
    "simulate_springs",
    "value_noise",
    "gradient_noise",
    "fractal_noise",
    "MAX_PARTICLES",
    "MAX_STEPS",
    "MAX_SPRING_MASSES",
    "MAX_SAMPLES",
]

#: Size limits, refused before allocating: particles per `emit`, time steps per
#: simulation, masses in `chain_springs`, and stored samples (steps x N x d) per run.
MAX_PARTICLES = 1_000_000
MAX_STEPS = 1_000_000
MAX_SPRING_MASSES = 1_000_000
MAX_SAMPLES = 1 << 26


def _check_output_size(steps: int, shape: tuple, name: str = "steps") -> None:
    size = (steps + 1) * math.prod(shape)
    if size > MAX_SAMPLES:
        raise ValueError(
            f"`{name}` = {steps} would store {size} samples, above MAX_SAMPLES = {MAX_SAMPLES} "
            "(a documented size limit); simulate fewer steps or fewer particles"
        )


def _finite_scalar(value, name: str, dtype, *, positive: bool = False, low=None):
    x = finite_float(value, name).astype(dtype)
    if positive:
        x = value_error_if(x, x <= 0, f"`{name}` must be positive")
    if low is not None:
        x = value_error_if(x, x < low, f"`{name}` must be >= {low:g}")
    return x


def _direction(v, name: str):
    """Unit vectors along `v`; a zero (or NaN/inf) vector is an error naming `name`."""
    v = check_finite(v, name)
    v = value_error_if(v, safe_norm(v) == 0, f"`{name}` must be a non-zero vector")
    return safe_normalize(v)


def _float_field(name: str):
    def convert(x):
        return x if is_traced(x) else as_float(x, name)

    return convert


class Particles(eqx.Module):
    """A particle system's state: `(N, d)` positions and velocities, `(N,)` birth times.

    A particle is alive (moves) once the simulation time reaches its birth time; before
    that it waits at its start position. The fields are checked at construction
    (`d` = 2 or 3, matching shapes, finite values).
    """

    position: Float[Array, "N d"] = eqx.field(converter=_float_field("position"))
    velocity: Float[Array, "N d"] = eqx.field(converter=_float_field("velocity"))
    birth: Float[Array, " N"] = eqx.field(converter=_float_field("birth"))

    def __check_init__(self):
        """Check the fields: `d` is 2 or 3, the shapes match, the values are finite
        (checked when not traced)."""
        check_last_dim(self.position, "position", (2, 3), "2D or 3D points")
        check_shape(self.position, "position", (None, self.position.shape[-1]))
        if self.velocity.shape != self.position.shape:
            raise ValueError(
                f"`velocity` must have the shape of `position` {self.position.shape}, "
                f"got {self.velocity.shape}"
            )
        check_shape(self.birth, "birth", self.position.shape[:1])
        for name in ("position", "velocity", "birth"):
            value = getattr(self, name)
            if not is_traced(value):
                check_finite(value, name)


def emit(
    key: Array,
    count: int,
    *,
    origin: Float[Array, " d"],
    direction: Float[Array, " d"],
    speed: float = 1.0,
    spread: float = 0.3,
    speed_jitter: float = 0.1,
    rate: float | None = None,
) -> Particles:
    """A point emitter: `count` particles leaving `origin` around `direction`.

    **Arguments:**

    - `key`: a `jax.random` key.
    - `count`: number of particles (static, at most `MAX_PARTICLES`).
    - `origin`: `(d,)` emitter position (d = 2 or 3).
    - `direction`: `(d,)` mean launch direction (normalised).
    - `speed`: mean launch speed; `speed_jitter` its relative random spread.
    - `spread`: standard deviation of the launch direction (radians-like, added to
      the unit direction before renormalising).
    - `rate`: particles per second (births spread evenly); `None` emits all at `t = 0`.

    **Returns:** `Particles`.
    """
    check_key(key)
    count = static_int(count, "count", minimum=1, maximum=MAX_PARTICLES)
    origin, direction = as_float(origin, "origin"), as_float(direction, "direction")
    d = check_last_dim(origin, "origin", (2, 3), "a 2D or 3D point")
    check_shape(origin, "origin", (d,))
    check_shape(direction, "direction", (d,))
    scalars = {"speed": speed, "spread": spread, "speed_jitter": speed_jitter}
    if rate is not None:
        scalars["rate"] = rate
    scalars = {n: _scalar_arg(v, n) for n, v in scalars.items()}
    return _emit_kernel(key, origin, direction, scalars, count=count)


def _scalar_arg(value, name: str):
    return _number(value, name)


@functools.partial(checked_jit, static_argnames=("count",))
def _emit_kernel(key, origin, direction, scalars, *, count):
    dtype = jnp.result_type(origin, direction)
    origin = check_finite(origin.astype(dtype), "origin")
    unit = _direction(direction.astype(dtype), "direction")
    speed = _finite_scalar(scalars["speed"], "speed", dtype)
    spread = _finite_scalar(scalars["spread"], "spread", dtype, low=0.0)
    speed_jitter = _finite_scalar(scalars["speed_jitter"], "speed_jitter", dtype, low=0.0)
    d = origin.shape[0]
    k1, k2 = jax.random.split(key)
    dirs = safe_normalize(unit + spread * jax.random.normal(k1, (count, d), dtype))
    speeds = speed * (1 + speed_jitter * jax.random.normal(k2, (count, 1), dtype))
    birth = jnp.zeros((count,), dtype)
    if "rate" in scalars:
        rate = _finite_scalar(scalars["rate"], "rate", dtype, positive=True)
        birth = jnp.arange(count, dtype=dtype) / rate
    position = jnp.broadcast_to(origin, (count, d))
    return Particles(position, dirs * speeds, birth)


def simulate_particles(
    particles: Particles,
    *,
    steps: int,
    dt: float,
    gravity: Float[Array, " d"] | None = None,
    drag: float = 0.0,
    planes: tuple[Float[Array, "P d"], Float[Array, " P"]] | None = None,
    restitution: float = 0.8,
    friction: float = 0.0,
) -> tuple[Float[Array, "steps+1 N d"], Float[Array, "steps+1 N d"]]:
    """Run a particle system for `steps` fixed steps of `dt` under `lax.scan`.

    Each step (semi-implicit Euler): `v += dt (g - drag v)`, `p += dt v`; then every
    particle below a plane `n . p = c` is reflected back above it, its normal velocity
    reversed and scaled by `restitution` and its tangential velocity by `1 - friction`.
    Unborn particles (birth time later than the step's time) stay put.

    **Arguments:**

    - `particles`: the start state (`emit`, or your own `Particles`).
    - `steps`: number of steps (static, at most `MAX_STEPS`, with
      `(steps + 1) N d <= MAX_SAMPLES`); `dt`: step size in seconds.
    - `gravity`: `(d,)` acceleration, default `(0, -9.81)` / `(0, -9.81, 0)` (y up).
    - `drag`: linear air drag coefficient (1/s).
    - `planes`: `(normals (P, d), offsets (P,))`: solid half-spaces `n . p < c` that
      particles bounce off; `None` for none.
    - `restitution`: fraction of normal speed kept in a bounce (0 dead, 1 elastic).
    - `friction`: fraction of tangential speed lost in a bounce.

    **Returns:** `(positions, velocities)`, each `(steps + 1, N, d)` including the start.
    """
    if not isinstance(particles, Particles):
        raise TypeError(f"`particles` must be a Particles (from emit), got {particles!r:.60}")
    steps = static_int(steps, "steps", minimum=1, maximum=MAX_STEPS)
    position = particles.position
    d = position.shape[-1]
    _check_output_size(steps, position.shape)
    if gravity is None:
        gravity = jnp.zeros((d,), position.dtype).at[1].set(-9.81)
    gravity = as_float(gravity, "gravity")
    check_shape(gravity, "gravity", (d,))
    scalars = {"dt": dt, "drag": drag, "restitution": restitution, "friction": friction}
    scalars = {n: _scalar_arg(v, n) for n, v in scalars.items()}
    if planes is not None:
        if not isinstance(planes, tuple | list) or len(planes) != 2:
            raise TypeError(f"`planes` must be (normals (P, d), offsets (P,)), got {planes!r:.60}")
        normals = jnp.atleast_2d(as_float(planes[0], "planes normals"))
        offsets = jnp.atleast_1d(as_float(planes[1], "planes offsets"))
        check_shape(normals, "planes normals", (None, d))
        check_shape(offsets, "planes offsets", (normals.shape[0],))
        planes = (normals, offsets)
    return _particles_kernel(particles, gravity, scalars, planes, steps=steps)


@functools.partial(checked_jit, static_argnames=("steps",))
def _particles_kernel(particles, gravity, scalars, planes, *, steps):
    position = check_finite(particles.position, "particles.position")
    dtype = position.dtype
    velocity = check_finite(particles.velocity.astype(dtype), "particles.velocity")
    birth = check_finite(particles.birth.astype(dtype), "particles.birth")
    dt = _finite_scalar(scalars["dt"], "dt", dtype, positive=True)
    gravity = check_finite(gravity.astype(dtype), "gravity")
    drag = _finite_scalar(scalars["drag"], "drag", dtype, low=0.0)
    restitution = _finite_scalar(scalars["restitution"], "restitution", dtype, low=0.0)
    friction = _finite_scalar(scalars["friction"], "friction", dtype)
    # Without planes these are unused: tie their checks to the positions (always used).
    position = position + 0 * (restitution + friction)
    if planes is None:
        normals, offsets = jnp.zeros((0, position.shape[-1]), dtype), jnp.zeros((0,), dtype)
    else:
        normals = _direction(planes[0].astype(dtype), "planes normals")
        offsets = check_finite(planes[1].astype(dtype), "planes offsets")

    def step(state, k):
        p, v = state
        alive = ((k + 1) * dt >= birth)[:, None]
        v_new = v + dt * (gravity - drag * v)
        p_new = p + dt * v_new
        for n, c in zip(normals, offsets, strict=True):
            depth = p_new @ n - c  # < 0: inside the solid
            hit = (depth < 0)[:, None]
            vn = (v_new @ n)[:, None] * n
            vt = v_new - vn
            # Only a particle moving into the plane bounces (normal speed reversed).
            into = (v_new @ n < 0)[:, None]
            bounced_v = jnp.where(into, -restitution * vn, vn) + (1 - friction) * vt
            p_new = jnp.where(hit, p_new - (1 + restitution) * depth[:, None] * n, p_new)
            v_new = jnp.where(hit, bounced_v, v_new)
        p_new = jnp.where(alive, p_new, p)
        v_new = jnp.where(alive, v_new, v)
        return (p_new, v_new), (p_new, v_new)

    _, (ps, vs) = jax.lax.scan(step, (position, velocity), jnp.arange(steps))
    return jnp.concatenate([position[None], ps]), jnp.concatenate([velocity[None], vs])


def damped_spring(
    x0: Float[Array, "*batch"],
    v0: Float[Array, "*batch"],
    target: Float[Array, "*T *batch"],
    *,
    stiffness: float,
    damping: float,
    dt: float,
    steps: int | None = None,
) -> Float[Array, " T *batch"]:
    """A damped spring following a target: `x'' = k (target - x) - c x'` (unit mass).

    Integrated by semi-implicit Euler under `lax.scan`. A constant `target` gives the
    classic overshoot-and-settle of follow-through; a time series `target` (one value per
    step, leading axis) makes `x` lag and wobble behind it (secondary motion).

    **Arguments:**

    - `x0`, `v0`: start position and velocity (any shape).
    - `target`: `(T, ...)` one target per step, or one target of `x0`'s shape with
      `steps` given.
    - `stiffness` (k, 1/s^2), `damping` (c, 1/s), `dt` (s).
    - `steps`: number of steps when `target` is constant.

    **Returns:** `(T, ...)` positions after each step.
    """
    x0, v0, target = as_float(x0, "x0"), as_float(v0, "v0"), as_float(target, "target")
    scalars = {"stiffness": stiffness, "damping": damping, "dt": dt}
    scalars = {n: _scalar_arg(v, n) for n, v in scalars.items()}
    shape = jnp.broadcast_shapes(x0.shape, v0.shape)
    if steps is not None:
        steps = static_int(steps, "steps", minimum=1, maximum=MAX_STEPS)
        shape = jnp.broadcast_shapes(shape, target.shape)
        _check_output_size(steps, shape)
    elif target.ndim == 0 or target.shape[1:] != jnp.broadcast_shapes(shape, target.shape[1:]):
        raise ValueError(
            f"`target` must be (T, *x0.shape) = (T, *{shape}), got shape {target.shape}; "
            "or give `steps` for a constant target"
        )
    return _spring_kernel(x0, v0, target, scalars, steps=steps)


@functools.partial(checked_jit, static_argnames=("steps",))
def _spring_kernel(x0, v0, target, scalars, *, steps):
    dtype = jnp.result_type(x0, v0, target)
    x0, v0 = check_finite(x0.astype(dtype), "x0"), check_finite(v0.astype(dtype), "v0")
    target = check_finite(target.astype(dtype), "target")
    stiffness = _finite_scalar(scalars["stiffness"], "stiffness", dtype)
    damping = _finite_scalar(scalars["damping"], "damping", dtype)
    dt = _finite_scalar(scalars["dt"], "dt", dtype, positive=True)
    if steps is not None:
        shape = jnp.broadcast_shapes(x0.shape, v0.shape, target.shape)
        target = jnp.broadcast_to(target, (steps,) + shape)

    def step(state, goal):
        x, v = state
        v = v + dt * (stiffness * (goal - x) - damping * v)
        x = x + dt * v
        return (x, v), x

    state = (jnp.broadcast_to(x0, target.shape[1:]), jnp.broadcast_to(v0, target.shape[1:]))
    _, xs = jax.lax.scan(step, state, target)
    return xs


def chain_springs(count: int) -> Int[Array, "E 2"]:
    """Edges `(i, i+1)` of a chain of `count` masses (a rope, a tail, an antenna).

    `count` is a static int in `2..MAX_SPRING_MASSES`.
    """
    count = static_int(count, "count", minimum=2, maximum=MAX_SPRING_MASSES)
    i = jnp.arange(count - 1)
    return jnp.stack([i, i + 1], axis=-1)


def simulate_springs(
    position: Float[Array, "N d"],
    velocity: Float[Array, "N d"],
    springs: Int[Array, "E 2"],
    *,
    steps: int,
    dt: float,
    stiffness: float | Float[Array, " E"] = 100.0,
    damping: float = 0.5,
    rest_length: Float[Array, " E"] | None = None,
    mass: float | Float[Array, " N"] = 1.0,
    gravity: Float[Array, " d"] | None = None,
    pinned: Bool[Array, " N"] | None = None,
    anchor: Float[Array, "steps N d"] | None = None,
    integrator: str = "semi_implicit_euler",
) -> Float[Array, "steps+1 N d"]:
    """A mass-spring system (Hooke springs, velocity damping) under `lax.scan`.

    **Arguments:**

    - `position`, `velocity`: `(N, d)` start state.
    - `springs`: `(E, 2)` integer pairs of connected masses (`chain_springs(n)`).
    - `steps` (static, at most `MAX_STEPS`, with `(steps + 1) N d <= MAX_SAMPLES`), `dt`:
      fixed time stepping.
    - `stiffness`: spring constant(s) k; `damping`: velocity damping coefficient (1/s);
      `rest_length`: `(E,)`, default the start lengths; `mass`: scalar or `(N,)`.
    - `gravity`: `(d,)` acceleration (default none).
    - `pinned`: `(N,)` masses that do not integrate: they stay put, or follow `anchor`.
    - `anchor`: `(steps, N, d)` prescribed positions used for the pinned masses at each
      step (e.g. the root of a tail following a character).
    - `integrator`: `"semi_implicit_euler"` (`v += dt a; x += dt v`) or `"verlet"`
      (position Verlet `x' = 2x - x_prev + dt^2 a`, velocity from the difference).

    **Returns:** `(steps + 1, N, d)` positions including the start.
    """
    if integrator not in ("semi_implicit_euler", "verlet"):
        raise ValueError(
            f"`integrator` must be 'semi_implicit_euler' or 'verlet', got {integrator!r}"
        )
    steps = static_int(steps, "steps", minimum=1, maximum=MAX_STEPS)
    position, velocity = common_float(position, velocity, names=("position", "velocity"))
    n, d = position.shape[0], check_last_dim(position, "position", (1, 2, 3))
    if velocity.shape != position.shape:
        raise ValueError(
            f"`velocity` must have the shape of `position` {position.shape}, got {velocity.shape}"
        )
    _check_output_size(steps, position.shape)
    position, velocity = check_finite(position, "position"), check_finite(velocity, "velocity")
    springs = _spring_pairs(springs, n)
    dtype = position.dtype
    if rest_length is None:
        rest_length = safe_norm(position[springs[:, 1]] - position[springs[:, 0]])
    rest_length = finite_float(rest_length, "rest_length").astype(dtype)
    mass = jnp.broadcast_to(finite_float(mass, "mass").astype(dtype), (n,))
    mass = value_error_if(mass, mass <= 0, "`mass` must be positive")
    dt = _finite_scalar(dt, "dt", dtype, positive=True)
    stiffness = finite_float(stiffness, "stiffness").astype(dtype)
    damping = _finite_scalar(damping, "damping", dtype)
    g = jnp.zeros((d,), dtype) if gravity is None else finite_float(gravity, "gravity")
    check_shape(g, "gravity", (d,))
    free = jnp.ones((n, 1), bool) if pinned is None else ~jnp.asarray(pinned, bool)[:, None]
    if anchor is None:
        anchor = jnp.broadcast_to(position, (steps, n, d))
    anchor = finite_float(anchor, "anchor").astype(dtype)
    check_shape(anchor, "anchor", (steps, n, d))
    params = (springs, rest_length, mass, stiffness, damping, g.astype(dtype), free)
    return _springs_kernel(position, velocity, anchor, dt, params, verlet=integrator == "verlet")


def _spring_pairs(springs, n: int) -> jax.Array:
    if springs is None:
        raise TypeError("`springs` must be integer pairs (E, 2), got None")
    if isinstance(springs, str | bytes):
        raise TypeError(f"`springs` must be integer pairs (E, 2), got {springs!r:.40}")
    try:
        springs = jnp.asarray(springs)
    except (TypeError, ValueError) as err:
        raise TypeError(f"`springs` must be integer pairs (E, 2) ({err})") from None
    if springs.ndim != 2 or springs.shape[1] != 2 or not jnp.issubdtype(springs.dtype, jnp.integer):
        raise ValueError(
            f"`springs` must be integer pairs (E, 2), got {springs.shape} {springs.dtype}"
        )
    bad = jnp.any((springs < 0) | (springs >= n))
    return value_error_if(springs, bad, f"`springs` indices must lie in [0, {n})")


@functools.partial(jax.jit, static_argnames=("verlet",))
def _springs_kernel(position, velocity, anchor, dt, params, *, verlet):
    springs, rest_length, mass, stiffness, damping, g, free = params
    a_idx, b_idx = springs[:, 0], springs[:, 1]

    def accel(x, v):
        delta = x[b_idx] - x[a_idx]
        length = safe_norm(delta, keepdims=True)
        direction = safe_normalize(delta)
        f = (stiffness * (length[:, 0] - rest_length))[:, None] * direction
        force = jnp.zeros_like(x).at[a_idx].add(f).at[b_idx].add(-f)
        return force / mass[:, None] + g - damping * v

    def euler(state, goal):
        x, v = state
        v_new = v + dt * accel(x, v)
        x_new = jnp.where(free, x + dt * v_new, goal)
        v_new = jnp.where(free, v_new, (goal - x) / dt)
        return (x_new, v_new), x_new

    def verlet_step(state, goal):
        x, x_prev = state
        v = (x - x_prev) / dt
        x_new = jnp.where(free, 2 * x - x_prev + dt * dt * accel(x, v), goal)
        return (x_new, x), x_new

    if verlet:
        _, xs = jax.lax.scan(verlet_step, (position, position - dt * velocity), anchor)
    else:
        _, xs = jax.lax.scan(euler, (position, velocity), anchor)
    return jnp.concatenate([position[None], xs])
