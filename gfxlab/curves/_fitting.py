"""Fitting curves to points: chord-length parameters, least-squares Bezier and B-spline
fits with parameter correction, geometric ellipse fitting (all through `gfxlab.fit`)."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_last_dim, check_shape, is_traced, static_bool, static_int
from ._bezier import Bezier, _bezier_kernel
from ._bspline import BSpline, _bspline_kernel, _lookup_path
from ._common import MAX_DEGREE, _check_unit_interval, _not_finite, _require
from ._conics import Ellipse
from ._knots import _check_degree, _check_in_range, _check_knots, clamped_knots


def chord_length_parameters(points: Float[ArrayLike, "N d"]) -> Float[Array, " N"]:
    """Parameters proportional to the cumulative chord length of a point sequence,
    from 0 to 1 (uniform when all points coincide)."""
    points = _fit_points(points)
    if points.shape[0] < 2:
        raise ValueError(f"`points` must hold at least 2 points, got {points.shape[0]}")
    return _chord_length_kernel(points)


@jax.jit
def _chord_length_kernel(points: jax.Array) -> jax.Array:
    steps = points[1:] - points[:-1]
    squared = jnp.sum(steps * steps, axis=-1)
    positive = squared > 0
    lengths = jnp.where(positive, jnp.sqrt(jnp.where(positive, squared, 1)), 0)
    cumulative = jnp.concatenate([jnp.zeros((1,), points.dtype), jnp.cumsum(lengths)])
    total = cumulative[-1]
    uniform = jnp.linspace(0, 1, points.shape[0], dtype=points.dtype)
    return jnp.where(total > 0, cumulative / jnp.where(total > 0, total, 1), uniform)


@functools.partial(jax.jit, static_argnums=2)
def _resample(points: jax.Array, parameters: jax.Array, count: int) -> jax.Array:
    """`count` points spread along the polyline through `points` at `parameters`."""
    lo, hi = parameters[0], parameters[-1]
    targets = jnp.linspace(0, 1, count, dtype=points.dtype) * (hi - lo) + lo
    return jax.vmap(lambda column: jnp.interp(targets, parameters, column), 1, 1)(points)


def _fit_curve(evaluate, start, points, parameters, lo, hi, correct, method, max_steps):
    """Least-squares control points for fixed parameters, then (optionally) parameter
    correction: a few rounds of foot-point projection alternated with the linear
    least-squares solve (Hoschek's iteration, cheap and one compiled call), finished by a
    joint Levenberg-Marquardt over control points and parameters.

    `evaluate(control_points, parameters)` is an unchecked kernel: the inputs were
    validated by the caller, which keeps the compiled solver small."""
    from ..fit import fit

    def residuals(cp, t, data):
        return evaluate(cp, t) - data

    result = fit(residuals, start, args=(parameters, points), method=method, max_steps=max_steps)
    cp = result.params
    if correct:
        bounds = (jnp.asarray(lo, points.dtype), jnp.asarray(hi, points.dtype))
        cp, parameters = _alternate(evaluate, cp, parameters, points, bounds)

        def joint_residuals(params, data):
            cp, t = params
            return evaluate(cp, jnp.clip(t, lo, hi)) - data

        result = fit(
            joint_residuals,
            (cp, parameters),
            args=(points,),
            method="levenberg_marquardt",
            max_steps=max_steps,
        )
        cp, parameters = result.params
        parameters = jnp.clip(parameters, lo, hi)
    return cp, parameters, result


@functools.partial(jax.jit, static_argnums=(0, 5))
def _alternate(evaluate, cp, t, data, bounds, rounds: int = 24):
    """`rounds` of: move each parameter to its point's foot on the curve (one Newton
    step), then re-solve the control points by linear least squares."""
    eye = jnp.eye(cp.shape[-2], dtype=cp.dtype)  # evaluate(eye, t) is the basis matrix

    def one_round(carry, _):
        cp, t = carry
        t = _foot_point_step(evaluate, cp, t, data, *bounds)
        cp = jnp.linalg.lstsq(evaluate(eye, t), data)[0]
        return (cp, t), None

    (cp, t), _ = jax.lax.scan(one_round, (cp, t), None, length=rounds)
    return cp, t


def _foot_point_step(evaluate, cp, t, data, lo, hi):
    """One Newton step on `<P(t_k) - x_k, P'(t_k)> = 0` for every `k` (each point depends
    on its own parameter only, so forward-mode derivatives give `P'` and `P''`); where
    the curvature term would make the step uphill, a Gauss-Newton step instead."""
    ones = jnp.ones_like(t)

    def with_tangent(s):
        return jax.jvp(lambda v: evaluate(cp, v), (s,), (ones,))

    (point, d1), (_, d2) = jax.jvp(with_tangent, (t,), (ones,))
    r = point - data
    gradient = jnp.sum(r * d1, axis=-1)
    speed = jnp.sum(d1 * d1, axis=-1)
    newton = speed + jnp.sum(r * d2, axis=-1)
    curvature = jnp.where(newton > 0, newton, speed)
    step = jnp.where(curvature > 0, gradient / jnp.where(curvature > 0, curvature, 1), 0)
    return jnp.clip(t - step, lo, hi)


def _check_driver(function: str, method, max_steps, *arrays) -> None:
    """The checks of a fitting driver: called eagerly (it runs `gfxlab.fit.fit`'s Python
    loop), with a known `method` and a bounded `max_steps`."""
    from ..fit import MAX_STEPS, METHODS

    if is_traced(arrays):
        raise TypeError(
            f"`{function}` is a driver that runs compiled solver steps in a Python loop "
            "(`gfxlab.fit.fit`); call it outside `jax.jit`, `jax.grad` and `jax.vmap`"
        )
    if not isinstance(method, str):
        raise TypeError(f"`method` must be one of {sorted(METHODS)}, got {method!r:.60}")
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {sorted(METHODS)}, got {method!r:.60}")
    static_int(max_steps, "max_steps", minimum=1, maximum=MAX_STEPS)


def _fit_points(points, name="points") -> jax.Array:
    points = as_float(points, name)
    check_shape(points, name, (None, None))
    return _require(points, f"`{name}` must be finite (no NaN or inf)", _not_finite)


def fit_bezier(
    points: Float[ArrayLike, "N d"],
    degree: int,
    *,
    parameters: Float[ArrayLike, " N"] | None = None,
    correct_parameters: bool = False,
    method: str = "gauss_newton",
    max_steps: int = 50,
    full_output: bool = False,
):
    """Fit a degree-`degree` Bezier curve to a sequence of points by least squares.

    A **driver**, like `gfxlab.fit.fit`, which it calls: it runs compiled solver steps in
    a Python loop, so call it eagerly, not inside `jax.jit`, `jax.grad` or `jax.vmap`
    (there it raises a clear `TypeError`). To differentiate through a fit, evaluate
    `bezier` inside your own `optimistix` solve.

    The control points minimise `sum_k |P(u_k) - x_k|^2` (solved with `gfxlab.fit.fit`)
    for parameters `u_k` given, or by chord length. With `correct_parameters=True` the
    parameters are then optimised too (joint Levenberg-Marquardt), which moves each
    `u_k` towards the foot point of `x_k` on the curve and lowers the error further.

    **Arguments:**

    - `points`: `(N, d)` data in order along the curve, `N >= degree + 1`.
    - `degree`: a static int `>= 1`.
    - `parameters`: `(N,)` in `[0, 1]`; default chord-length parameters.
    - `correct_parameters`: optimise the parameters too.
    - `method`, `max_steps`: passed to `gfxlab.fit.fit` for the control-point fit.
    - `full_output`: also return the parameters and the last `FitResult`.

    **Returns:** a `Bezier`, or `(Bezier, parameters, FitResult)` with `full_output`.
    """
    correct_parameters = static_bool(correct_parameters, "correct_parameters")
    full_output = static_bool(full_output, "full_output")
    _check_driver("fit_bezier", method, max_steps, points, parameters)
    points = _fit_points(points)
    degree = static_int(degree, "degree", minimum=1, maximum=MAX_DEGREE)
    if points.shape[0] < degree + 1:
        raise ValueError(
            f"`points` must hold at least degree + 1 = {degree + 1} points to fit a degree-"
            f"{degree} Bezier curve, got {points.shape[0]}"
        )
    if parameters is None:
        parameters = chord_length_parameters(points)
    parameters = _check_unit_interval(
        as_float(parameters, "parameters").astype(points.dtype), "parameters"
    )
    check_shape(parameters, "parameters", (points.shape[0],))
    start = _resample(points, parameters, degree + 1)
    cp, parameters, result = _fit_curve(
        _bezier_kernel,
        start,
        points,
        parameters,
        0.0,
        1.0,
        correct_parameters,
        method,
        max_steps,
    )
    curve = Bezier(cp)
    return (curve, parameters, result) if full_output else curve


def fit_bspline(
    points: Float[ArrayLike, "N d"],
    degree: int,
    num_control_points: int,
    *,
    knots: Float[ArrayLike, " n+p+1"] | None = None,
    parameters: Float[ArrayLike, " N"] | None = None,
    correct_parameters: bool = False,
    method: str = "gauss_newton",
    max_steps: int = 50,
    full_output: bool = False,
):
    """Fit a B-spline with `num_control_points` control points to a sequence of points by
    least squares (the control points of `scipy.interpolate.make_lsq_spline` for the
    same knots and parameters).

    A **driver** (see `fit_bezier`): call it eagerly, not inside `jax.jit`/`grad`/`vmap`.

    **Arguments:**

    - `points`: `(N, d)` data in order along the curve, `N >= num_control_points`.
    - `degree`, `num_control_points`: static ints, `degree < num_control_points`.
    - `knots`: `(num_control_points + degree + 1,)`; default `clamped_knots`.
    - `parameters`: `(N,)` in `parameter_range(knots, degree)`; default chord length
      mapped onto that range.
    - `correct_parameters`: then optimise the parameters too (joint Levenberg-Marquardt).
    - `method`, `max_steps`: passed to `gfxlab.fit.fit` for the control-point fit.
    - `full_output`: also return the parameters and the last `FitResult`.

    **Returns:** a `BSpline`, or `(BSpline, parameters, FitResult)` with `full_output`.
    """
    correct_parameters = static_bool(correct_parameters, "correct_parameters")
    full_output = static_bool(full_output, "full_output")
    _check_driver("fit_bspline", method, max_steps, points, knots, parameters)
    points = _fit_points(points)
    n, p = _check_degree(num_control_points, degree)
    if points.shape[0] < n:
        raise ValueError(
            f"`points` must hold at least num_control_points = {n} points, got {points.shape[0]}"
        )
    if knots is None:
        knots = clamped_knots(n, p, dtype=points.dtype)
    knots = _check_knots(as_float(knots, "knots").astype(points.dtype), p, n)
    lo, hi = knots[p], knots[n]
    if parameters is None:
        parameters = lo + (hi - lo) * chord_length_parameters(points)
    parameters = _check_in_range(
        as_float(parameters, "parameters").astype(points.dtype), knots, p, n, "parameters"
    )
    check_shape(parameters, "parameters", (points.shape[0],))
    start = _resample(points, parameters, n)

    path = _lookup_path(knots, p, n)  # one branch: a smaller program to compile

    def evaluate(cp, t):  # inputs already checked; parameters stay clipped to the range
        return _bspline_kernel(cp, knots, t, p, path)

    cp, parameters, result = _fit_curve(
        evaluate, start, points, parameters, lo, hi, correct_parameters, method, max_steps
    )
    curve = BSpline(cp, p, knots)
    return (curve, parameters, result) if full_output else curve


def fit_ellipse(
    points: Float[ArrayLike, "N 2"],
    *,
    initial: Ellipse | None = None,
    method: str = "levenberg_marquardt",
    max_steps: int = 100,
    full_output: bool = False,
):
    """Fit an ellipse to noisy points by geometric least squares.

    A **driver** (see `fit_bezier`): call it eagerly, not inside `jax.jit`/`grad`/`vmap`.

    Minimises `sum_k |E(t_k) - x_k|^2` over the ellipse (centre, semi-axes, angle) and
    one parameter `t_k` per point, so the residuals are true point-to-curve offsets
    at convergence. The start (unless `initial` is given) comes from the points'
    principal axes: centre = mean, axes along the covariance eigenvectors, semi-axes
    `sqrt(2 variance)` (exact for evenly spread points on an ellipse).

    **Arguments:**

    - `points`: `(N, 2)`, `N >= 5`, in any order.
    - `initial`: a starting `Ellipse`.
    - `method`, `max_steps`: passed to `gfxlab.fit.fit`.
    - `full_output`: also return the parameters `t_k` and the `FitResult`.

    **Returns:** the fitted `Ellipse`, normalised (`rx >= ry`, angle in `[0, pi)`), or
    `(Ellipse, t, FitResult)` with `full_output`.
    """
    full_output = static_bool(full_output, "full_output")
    from ..fit import fit

    _check_driver("fit_ellipse", method, max_steps, points, initial)
    points = _fit_points(points)
    check_last_dim(points, "points", (2,), "2D points")
    if points.shape[0] < 5:
        raise ValueError(
            f"`points` must hold at least 5 points to fix an ellipse, got {points.shape[0]}"
        )
    if initial is None:
        initial = Ellipse(*_principal_axes(points))
    t = _ellipse_parameters(initial, points)

    def residuals(params, data):
        shape, t = params
        return shape(t) - data

    result = fit(residuals, (initial, t), args=(points,), method=method, max_steps=max_steps)
    fitted, t = result.params
    normalized = fitted.normalized()
    if full_output:
        # The parameters of the same points on the normalised ellipse.
        return normalized, _ellipse_parameters(normalized, fitted(t)), result
    return normalized


@jax.jit
def _principal_axes(points: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Centre, semi-axes and angle of the ellipse with the points' mean and covariance
    (points spread evenly in `t` over an ellipse have variance `a^2 / 2` along it)."""
    center = jnp.mean(points, axis=0)
    offsets = points - center
    variances, axes = jnp.linalg.eigh(offsets.T @ offsets / points.shape[0])
    major = axes[:, 1]
    angle = jnp.arctan2(major[1], major[0])
    radii = jnp.sqrt(2 * jnp.maximum(variances[::-1], 1e-12))
    return center, radii, angle


@eqx.filter_jit
def _ellipse_parameters(shape: Ellipse, points: jax.Array) -> jax.Array:
    """The parameter `t` of each point's direction in the ellipse's own frame (exact for
    points on the ellipse)."""
    c, s = jnp.cos(shape.angle), jnp.sin(shape.angle)
    offsets = points - shape.center
    local_x = c * offsets[:, 0] + s * offsets[:, 1]
    local_y = -s * offsets[:, 0] + c * offsets[:, 1]
    return jnp.arctan2(local_y / shape.radii[1], local_x / shape.radii[0])
