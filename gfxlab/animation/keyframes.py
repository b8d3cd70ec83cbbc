"""Key-frame animation: in-betweens interpolated from key frames.

`interpolate` fills the frames between keys (`(time, value)` pairs) by step, linear,
cubic Hermite / Catmull-Rom or Bezier-eased interpolation; `interpolate_rotations`
does the same for quaternion keys with slerp or squad; a `Track` bundles channels
(position, rotation, scale, color) that share key times and evaluates any number of
tracks at any number of times in one vectorized call.

Easing curves are cubic Bezier timing curves as in animation tools and CSS: the curve
from `(0, 0)` to `(1, 1)` with inner control points `(x1, y1)`, `(x2, y2)`. At time
fraction `u` the eased fraction is `y(s)` where `x(s) = u`.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .. import curves
from .._checks import (
    as_float,
    check_finite,
    check_shape,
    checked_jit,
    safe_divide,
    safe_normalize,
    static_int,
    value_error_if,
)
from .quaternions import _conj, _exp, _log, _mul, _number, _slerp, _squad

__all__ = [
    "EASINGS",
    "cubic_bezier_easing",
    "ease_in",
    "ease_out",
    "ease_in_out",
    "interpolate",
    "interpolate_rotations",
    "catmull_rom_tangents",
    "Track",
    "TrackSample",
    "METHODS",
    "MAX_EASING_ITERATIONS",
]

#: Interpolation methods of `interpolate`.
METHODS = ("step", "linear", "catmull_rom", "hermite", "bezier")

#: Named easing curves: inner control points `(x1, y1, x2, y2)` (the CSS values).
EASINGS = {
    "linear": (0.0, 0.0, 1.0, 1.0),
    "ease": (0.25, 0.1, 0.25, 1.0),
    "ease_in": (0.42, 0.0, 1.0, 1.0),
    "ease_out": (0.0, 0.0, 0.58, 1.0),
    "ease_in_out": (0.42, 0.0, 0.58, 1.0),
}

# The named easings as host arrays (passed to the compiled kernels without conversion).
_EASING_ARRAYS = {name: np.asarray(value) for name, value in EASINGS.items()}

#: The most Newton/bisection steps `cubic_bezier_easing` takes (64 bisections already
#: reach the float64 resolution of `[0, 1]`).
MAX_EASING_ITERATIONS = 64

# Public functions check shapes and static arguments in Python and run one compiled
# kernel (`checked_jit`) that checks values (NaN/inf, unsorted keys) and computes; the
# kernels share the unchecked math (`_interp`, `_rotations`, `_ease`).


def _promote(*arrays):
    dtype = jnp.result_type(*[a for a in arrays if a is not None])
    return [None if a is None else a.astype(dtype) for a in arrays]


def _bezier_1d(s, a, b):
    # Cubic Bezier with control values 0, a, b, 1, and its derivative (the degree-2
    # Bezier of the control differences), in gfxlab.curves' Bernstein basis.
    cubic, quadratic = curves.bernstein(3, s), curves.bernstein(2, s)
    value = cubic[..., 1] * a + cubic[..., 2] * b + cubic[..., 3]
    slope = 3 * (quadratic[..., 0] * a + quadratic[..., 1] * (b - a) + quadratic[..., 2] * (1 - b))
    return value, slope


def _control(control, name: str):
    """Static checks of an easing: a name from `EASINGS` or `(..., 4)` numbers."""
    if isinstance(control, str):
        if control not in EASINGS:
            raise ValueError(
                f"`{name}` must be one of {sorted(EASINGS)} or (x1, y1, x2, y2), got {control!r}"
            )
        return _EASING_ARRAYS[control]
    control = as_float(control, name)
    check_shape(control, name, (..., 4))
    return control


def _check_control(control, name: str):
    """Traced checks of an easing: finite, with `x1, x2` in `[0, 1]`."""
    control = check_finite(control, name)
    x1, x2 = control[..., 0], control[..., 2]
    bad = (x1 < 0) | (x1 > 1) | (x2 < 0) | (x2 > 1)
    return value_error_if(
        control, bad, f"`{name}` x1 and x2 must lie in [0, 1] (time must not run backwards)"
    )


def cubic_bezier_easing(
    u: Float[Array, "*batch"],
    control: Float[Array, "*#batch 4"] | str = "ease_in_out",
    *,
    iterations: int = 24,
) -> Float[Array, "*batch"]:
    """A cubic Bezier timing curve: the eased fraction at time fraction `u`.

    Solves `x(s) = u` for the curve parameter `s` by Newton's method with a bisection
    safeguard (a fixed number of iterations, vectorized, jit-friendly), then returns
    `y(s)`. The derivative comes from one differentiable Newton step at the solution
    (implicit function theorem), so gradients flow to `u` and to the control points.

    **Arguments:**

    - `u`: finite time fractions, clipped to `[0, 1]`.
    - `control`: `(x1, y1, x2, y2)` (broadcast against `u`) with `x1, x2` in `[0, 1]`
      so that time runs forwards, or a name from `EASINGS`.
    - `iterations`: Newton/bisection steps (static, `1..MAX_EASING_ITERATIONS`).

    **Returns:** the eased fractions, same shape as `u`.
    """
    control = _control(control, "control")
    u = as_float(u, "u")
    iterations = static_int(iterations, "iterations", minimum=1, maximum=MAX_EASING_ITERATIONS)
    return _easing_kernel(u, control, iterations=iterations)


@functools.partial(checked_jit, static_argnames=("iterations",))
def _easing_kernel(u, control, *, iterations):
    control = control.astype(u.dtype)
    u = check_finite(u, "u")
    x1, y1, x2, y2 = jnp.moveaxis(_check_control(control, "control"), -1, 0)
    return _ease(u, x1, y1, x2, y2, iterations=iterations)


def _ease(u, x1, y1, x2, y2, *, iterations):
    u = jnp.clip(u, 0.0, 1.0)
    sx1, sx2, su = (jax.lax.stop_gradient(a) for a in (x1, x2, u))
    shape = jnp.broadcast_shapes(u.shape, x1.shape)

    def step(_, state):
        s, lo, hi = state
        fx, dx = _bezier_1d(s, sx1, sx2)
        f = fx - su
        lo = jnp.where(f < 0, s, lo)
        hi = jnp.where(f < 0, hi, s)
        newton = s - f / jnp.where(jnp.abs(dx) > 1e-12, dx, 1.0)
        ok = (jnp.abs(dx) > 1e-12) & (newton >= lo) & (newton <= hi)
        return jnp.where(ok, newton, 0.5 * (lo + hi)), lo, hi

    start = jnp.broadcast_to(su, shape)
    zeros, ones = jnp.zeros(shape, u.dtype), jnp.ones(shape, u.dtype)
    s, _, _ = jax.lax.fori_loop(0, iterations, step, (start, zeros, ones))
    s = jax.lax.stop_gradient(s)
    # One differentiable Newton step: exact value, implicit-function derivative.
    fx, dx = _bezier_1d(s, x1, x2)
    s = jnp.clip(s - safe_divide(fx - u, dx), 0.0, 1.0)
    return _bezier_1d(s, y1, y2)[0]


def ease_in(u: Float[Array, "*batch"]) -> Float[Array, "*batch"]:
    """Slow start, full speed at the end: `cubic-bezier(0.42, 0, 1, 1)`."""
    return cubic_bezier_easing(u, "ease_in")


def ease_out(u: Float[Array, "*batch"]) -> Float[Array, "*batch"]:
    """Full speed at the start, slow stop: `cubic-bezier(0, 0, 0.58, 1)`."""
    return cubic_bezier_easing(u, "ease_out")


def ease_in_out(u: Float[Array, "*batch"]) -> Float[Array, "*batch"]:
    """Slow in and slow out: `cubic-bezier(0.42, 0, 0.58, 1)`."""
    return cubic_bezier_easing(u, "ease_in_out")


def _check_keys(times, values, name="values"):
    """Static checks of key times `(K,)` and key values `(K, ...)`."""
    times = as_float(times, "times")
    if times.ndim != 1 or times.shape[0] < 1:
        raise ValueError(f"`times` must be a 1D array of key times (K,), got shape {times.shape}")
    values = as_float(values, name)
    if values.ndim < 1 or values.shape[0] != times.shape[0]:
        raise ValueError(
            f"`{name}` must have one row per key time: `times` has shape {times.shape}, so "
            f"`{name}` must be ({times.shape[0]}, ...), got {values.shape}"
        )
    return times, values


def _key_values(times, values, name: str):
    """Traced checks of keys: finite, strictly increasing times."""
    times = check_finite(times, "times")
    times = value_error_if(
        times,
        jnp.diff(times) <= 0,
        "`times` must be strictly increasing (sorted key times without duplicates)",
    )
    return times, check_finite(values, name)


_scalar = _number


def _segment(times, t):
    """Segment index `i` (keys i, i+1) and fraction `u` in [0, 1] for times `t` (clamped)."""
    k = times.shape[0]
    i = jnp.clip(jnp.searchsorted(times, t, side="right") - 1, 0, max(k - 2, 0))
    if k == 1:
        return i, jnp.zeros_like(t)
    h = times[i + 1] - times[i]
    u = jnp.clip((t - times[i]) / h, 0.0, 1.0)
    return i, u


def catmull_rom_tangents(
    times: Float[Array, " K"], values: Float[Array, " K *channels"], *, tension: float = 0.0
) -> Float[Array, " K *channels"]:
    """Cardinal-spline tangents (derivatives with respect to time) at the keys.

    Interior keys get `(1 - tension) (p[i+1] - p[i-1]) / (t[i+1] - t[i-1])` (Catmull-Rom
    for `tension = 0`, works for uneven key spacing); end keys get one-sided differences.
    A single key has zero tangents.
    """
    times, values = _check_keys(times, values)
    return _tangents_kernel(times, values, _scalar(tension, "tension"))


@checked_jit
def _tangents_kernel(times, values, tension):
    times, values = _promote(times, values)
    tension = tension.astype(values.dtype)
    times, values = _key_values(times, values, "values")
    tension = check_finite(tension, "tension")
    if times.shape[0] < 2:
        return jnp.zeros_like(values)
    return _cardinal_tangents(times, values, tension)


def _cardinal_tangents(times, values, tension):
    expand = (slice(None),) + (None,) * (values.ndim - 1)
    dp = jnp.concatenate(
        [values[1:2] - values[:1], values[2:] - values[:-2], values[-1:] - values[-2:-1]]
    )
    dt = jnp.concatenate(
        [times[1:2] - times[:1], times[2:] - times[:-2], times[-1:] - times[-2:-1]]
    )
    return (1 - tension) * dp / dt[expand]


def interpolate(
    times: Float[Array, " K"],
    values: Float[Array, " K *channels"],
    t: Float[Array, "*T"],
    *,
    method: str = "linear",
    tangents: Float[Array, " K *channels"] | None = None,
    tension: float = 0.0,
    easing: Float[Array, "*#segments 4"] | str = "ease_in_out",
) -> Float[Array, "*T *channels"]:
    """In-betweens: the value of a key-framed channel at times `t`.

    **Arguments:**

    - `times`: `(K,)` strictly increasing key times (unsorted or repeated times raise).
    - `values`: `(K, ...)` key values (any channel shape, e.g. `(K, 3)` positions).
    - `t`: query times, any shape. Times outside the keys hold the first/last value.
    - `method`:
        - `"step"`: hold each key until the next (stop-motion / blocking);
        - `"linear"`: straight lines between keys;
        - `"catmull_rom"`: cubic Hermite with cardinal tangents (`tension`), C1 and
          passing through every key;
        - `"hermite"`: cubic Hermite with the given `tangents` (time derivatives);
        - `"bezier"`: each segment eased by the cubic Bezier timing curve `easing`
          (like the ease handles of animation tools).
    - `tangents`: `(K, ...)` time derivatives at the keys for `"hermite"`.
    - `tension`: cardinal tension for `"catmull_rom"` (0 is Catmull-Rom).
    - `easing`: for `"bezier"`: a name from `EASINGS`, `(x1, y1, x2, y2)`, or one
      easing per segment `(K-1, 4)`.

    Every argument is checked whatever the method (NaN/inf and unsorted keys raise
    `ValueError` naming the argument). Called eagerly it is one compiled call.

    **Returns:** `(*t.shape, *values.shape[1:])`.
    """
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"`method` must be one of {METHODS}, got {method!r}")
    times, values = _check_keys(times, values)
    t = as_float(t, "t")
    k = times.shape[0]
    control = _control(easing, "easing")
    if control.ndim == 2 and control.shape[0] != k - 1:
        raise ValueError(f"`easing` per segment must have shape ({k - 1}, 4), got {control.shape}")
    if control.ndim > 2:
        raise ValueError(f"`easing` must be (4,) or ({k - 1}, 4), got {control.shape}")
    if method == "hermite" and tangents is None:
        raise ValueError('`tangents` (K, ...) are required for method="hermite"')
    if tangents is not None:
        tangents = as_float(tangents, "tangents")
        if tangents.shape != values.shape:
            raise ValueError(
                f"`tangents` must have the shape of `values` {values.shape}, got {tangents.shape}"
            )
    tension = _scalar(tension, "tension")
    return _interpolate_kernel(times, values, t, tangents, control, tension, method=method)


@functools.partial(checked_jit, static_argnames=("method",))
def _interpolate_kernel(times, values, t, tangents, control, tension, *, method):
    times, values, t, tangents = _promote(times, values, t, tangents)
    control, tension = control.astype(values.dtype), tension.astype(values.dtype)
    times, values = _key_values(times, values, "values")
    t = check_finite(t, "t")
    # Checks of arguments the method may not use ride on `values` (always used), so
    # that the compiler does not drop them.
    values = _unused_checks(values, tension, control, tangents)
    m = tangents
    if method == "catmull_rom" and times.shape[0] > 1:
        m = _cardinal_tangents(times, values, tension)
    return _interp(times, values, t, m, control, method=method)


def _unused_checks(values, tension, control, tangents):
    values = value_error_if(values, ~jnp.isfinite(tension), "`tension` must be finite")
    x1, x2 = control[..., 0], control[..., 2]
    values = value_error_if(
        values, ~jnp.all(jnp.isfinite(control)), "`easing` must be finite (no NaN or inf)"
    )
    values = value_error_if(
        values,
        jnp.any((x1 < 0) | (x1 > 1) | (x2 < 0) | (x2 > 1)),
        "`easing` x1 and x2 must lie in [0, 1] (time must not run backwards)",
    )
    if tangents is not None:
        values = value_error_if(
            values, ~jnp.all(jnp.isfinite(tangents)), "`tangents` must be finite (no NaN or inf)"
        )
    return values


def _interp(times, values, t, m, control, *, method):
    """The unchecked interpolation (keys already validated)."""
    k = times.shape[0]
    i, u = _segment(times, t)
    ch = (None,) * (values.ndim - 1)
    uc = u[(...,) + ch]
    p0, p1 = values[i], values[jnp.minimum(i + 1, k - 1)]
    if method == "step":
        # Hold key i; at and after the last key, the last value.
        return jnp.where((t >= times[-1])[(...,) + ch], values[-1], p0)
    if method == "linear" or k == 1:
        return p0 + uc * (p1 - p0)
    if method == "bezier":
        if control.ndim == 2:
            control = control[i]
        x1, y1, x2, y2 = jnp.moveaxis(control, -1, 0)
        eased = _ease(u, x1, y1, x2, y2, iterations=24)[(...,) + ch]
        return p0 + eased * (p1 - p0)
    h = (times[jnp.minimum(i + 1, k - 1)] - times[i])[(...,) + ch]
    m0, m1 = m[i], m[jnp.minimum(i + 1, k - 1)]
    u2, u3 = uc * uc, uc * uc * uc
    h00 = 2 * u3 - 3 * u2 + 1
    h10 = u3 - 2 * u2 + uc
    h01 = -2 * u3 + 3 * u2
    h11 = u3 - u2
    return h00 * p0 + h10 * h * m0 + h01 * p1 + h11 * h * m1


def _align_signs(quats):
    # Flip keys so consecutive dot products are >= 0 (shortest arcs between keys).
    dots = jnp.sum(quats[1:] * quats[:-1], axis=-1)
    signs = jnp.concatenate(
        [jnp.ones((1,), quats.dtype), jnp.cumprod(jnp.where(dots < 0, -1.0, 1.0))]
    )
    return quats * signs[:, None]


_ROTATION_METHODS = ("step", "slerp", "squad")


def interpolate_rotations(
    times: Float[Array, " K"],
    quats: Float[Array, "K 4"],
    t: Float[Array, "*T"],
    *,
    method: str = "slerp",
) -> Float[Array, "*T 4"]:
    """Interpolate rotation keys (unit quaternions) at times `t`.

    **Arguments:**

    - `times`: `(K,)` strictly increasing key times.
    - `quats`: `(K, 4)` key rotations `(w, x, y, z)`, non-zero (normalised here; signs
      aligned so each segment takes the shorter arc).
    - `t`: query times, any shape (clamped to the key range).
    - `method`: `"step"`, `"slerp"` (piecewise great arcs, constant angular speed) or
      `"squad"` (C1 in time through the keys, also for uneven key spacing).

    **Returns:** `(*t.shape, 4)` unit quaternions.
    """
    if not isinstance(method, str) or method not in _ROTATION_METHODS:
        raise ValueError(f"`method` must be 'step', 'slerp' or 'squad', got {method!r}")
    times, quats = _check_keys(times, quats, "quats")
    check_shape(quats, "quats", (None, 4))
    return _rotations_kernel(times, quats, as_float(t, "t"), method=method)


@functools.partial(checked_jit, static_argnames=("method",))
def _rotations_kernel(times, quats, t, *, method):
    times, quats, t = _promote(times, quats, t)
    times, quats = _key_values(times, quats, "quats")
    quats = value_error_if(
        quats, jnp.sum(quats * quats, axis=-1) == 0, "`quats` must be non-zero quaternions"
    )
    return _rotations(times, quats, check_finite(t, "t"), method=method)


def _rotations(times, quats, t, *, method):
    """The unchecked rotation interpolation (keys already validated)."""
    q = _align_signs(safe_normalize(quats))
    k = times.shape[0]
    if method == "step" or k == 1:
        return _interp(times, q, t, None, None, method="step")
    i, u = _segment(times, t)
    q0, q1 = q[i], q[i + 1]
    if method == "slerp":
        return _slerp(q0, q1, u, shortest=False)
    s_in, s_out = _squad_inners(times, q)
    return _squad(q0, s_out[i], s_in[i + 1], q1, u)


def _squad_inners(times, q):
    """Inner quaternions (incoming, outgoing) per key, for C1 continuity in *time*.

    In the tangent space at key `q_i`, with `L+ = log(q_i^-1 q_i+1)`, `L- = log(q_i^-1 q_i-1)`
    and segment durations `h-`, `h+`, the time tangent is `V = (L+ - L-) / (h- + h+)`.
    Squad leaves `q_i` with u-velocity `L+ + 2 log(q_i^-1 s_out)` and arrives with
    `-L- - 2 log(q_i^-1 s_in)`; setting these to `V h+` and `V h-` gives the inners below.
    For even key spacing both equal Shoemake's `squad_inner`.
    """
    padded = jnp.concatenate([q[:1], q, q[-1:]])
    h = jnp.diff(times)
    h_prev = jnp.concatenate([h[:1], h])
    h_next = jnp.concatenate([h, h[-1:]])
    inv = _conj(q)
    l_next = _log(_mul(inv, padded[2:]))
    l_prev = _log(_mul(inv, padded[:-2]))
    v = (l_next - l_prev) / (h_prev + h_next)[:, None]
    s_out = _mul(q, _exp((v * h_next[:, None] - l_next) / 2))
    s_in = _mul(q, _exp(-(v * h_prev[:, None] + l_prev) / 2))
    return s_in, s_out


from ._tracks import Track, TrackSample  # noqa: E402 - the tracks use the kernels above
