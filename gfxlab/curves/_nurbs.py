"""Rational B-splines (NURBS): evaluation, the exact circle, `NURBS`."""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_shape
from ._bspline import _bspline_kernel
from ._common import _control_points, _floats, _not_finite, _require
from ._knots import (
    _check_degree,
    _check_in_range,
    _check_knot_fields,
    _check_knots,
    _initial_logits,
    _knots_field,
    _knots_in_use,
    clamped_knots,
    parameter_range,
)


def nurbs(
    control_points: Float[ArrayLike, "*batch n d"],
    weights: Float[ArrayLike, "*batch n"],
    degree: int,
    u: Float[ArrayLike, " N"],
    *,
    knots: Float[ArrayLike, " n+p+1"] | None = None,
) -> Float[Array, "*batch N d"]:
    """A rational B-spline (NURBS) `P(u) = sum_i N_{i,p}(u) w_i p_i / sum_i N_{i,p}(u) w_i`:
    a B-spline of the homogeneous points `(w_i p_i, w_i)` followed by the divide, so
    conics such as circles are exact (`nurbs_circle`).

    **Arguments:** as `bspline`, plus `weights` `(..., n)`, all positive.

    **Returns:** `(..., N, d)`.
    """
    cp = _control_points(control_points)
    cp, weights = _floats(cp, weights, names=("control_points", "weights"))
    weights = _check_weights(weights, cp)
    n, p = _check_degree(cp.shape[-2], degree)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    cp, weights, knots, u = _floats(
        cp, weights, knots, u, names=("control_points", "weights", "knots", "u")
    )
    knots = _check_knots(knots, p, n)
    u = _check_in_range(u, knots, p, n)
    return _nurbs_kernel(cp, weights, knots, u, p)


def _check_weights(weights: jax.Array, cp: jax.Array) -> jax.Array:
    _check_weight_shape(weights, cp)
    return _positive_weights(weights)


def _check_weight_shape(weights: jax.Array, cp: jax.Array) -> None:
    if weights.shape != cp.shape[:-1]:
        raise ValueError(
            f"`weights` must have shape {tuple(cp.shape[:-1])} (one per control point), "
            f"got {tuple(weights.shape)}"
        )


def _positive_weights(weights) -> jax.Array:
    """The `weights` converter of `NURBS` (and the value check of `nurbs`)."""
    return _require(
        as_float(weights, "weights"),
        "`weights` must all be positive and finite",
        lambda w: ~((w > 0) & (w < np.inf)),
    )


@functools.partial(jax.jit, static_argnums=4)
def _nurbs_kernel(cp, weights, knots, u, p: int) -> jax.Array:
    homogeneous = jnp.concatenate([cp * weights[..., None], weights[..., None]], axis=-1)
    h = _bspline_kernel(homogeneous, knots, u, p)
    return h[..., :-1] / h[..., -1:]


def nurbs_circle(
    center: Float[ArrayLike, "2"] = (0.0, 0.0), radius: Float[ArrayLike, ""] = 1.0
) -> NURBS:
    """An exact circle as a quadratic NURBS: nine control points on the corners and edge
    midpoints of the circumscribed square, weights `1, 1/sqrt(2), 1, ...`, knots
    `0,0,0, 1/4,1/4, 1/2,1/2, 3/4,3/4, 1,1,1` (four 90-degree arcs).

    **Returns:** a `NURBS` on `u` in `[0, 1]`, starting and ending at
    `center + (radius, 0)` and running counter-clockwise (not at constant speed).
    """
    center, radius = _floats(center, radius, names=("center", "radius"))
    check_shape(center, "center", (2,))
    check_shape(radius, "radius", ())
    center = _require(center, "`center` must be finite (no NaN or inf)", _not_finite)
    radius = _require(radius, "`radius` must be finite (no NaN or inf)", _not_finite)
    square = jnp.array(
        [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0]],
        dtype=center.dtype,
    )
    corner = math.sqrt(0.5)
    weights = jnp.array([1, corner, 1, corner, 1, corner, 1, corner, 1], dtype=center.dtype)
    knots = jnp.array([0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1], dtype=center.dtype)
    return NURBS(center + radius * square, weights, 2, knots)


class NURBS(eqx.Module):
    """A rational B-spline as a pytree (see `nurbs`).

    **Fields:**

    - `control_points` `(..., n, d)` and `weights` `(..., n)` (positive), fitted by
      `gfxlab.fit`.
    - `base_knots`: the knots as given, `(n + p + 1,)`, held fixed (`fixed_fields()`,
      and behind `lax.stop_gradient`).
    - `knot_logits`: with `fit_knots=True`, the logs of the span widths inside the
      parameter range, `(n - p,)`, so the fitted knots stay increasing whatever the
      optimiser does (a monotone reparametrisation, as in `BSpline`); `None` otherwise.
    - `degree`, `fit_knots`: static.

    The property `knots` is the knot vector in use.
    """

    control_points: Float[Array, "*batch n d"] = eqx.field(converter=_control_points)
    weights: Float[Array, "*batch n"] = eqx.field(converter=_positive_weights)
    base_knots: Float[Array, " n+p+1"] = eqx.field(converter=_knots_field)
    knot_logits: Float[Array, " s"] | None
    degree: int = eqx.field(static=True)
    fit_knots: bool = eqx.field(static=True)

    def __init__(self, control_points, weights, degree: int, knots=None, *, fit_knots=False):
        # As `BSpline`: the default knots, `knot_logits` and the weights' dtype (that of
        # the control points) are made here; converters and `__check_init__` check.
        cp = _control_points(control_points)
        n, p = _check_degree(cp.shape[-2], degree)
        if knots is None:
            knots = clamped_knots(n, p, dtype=cp.dtype)
        self.control_points, self.base_knots, self.degree = cp, _knots_field(knots), p
        self.weights = as_float(weights, "weights").astype(cp.dtype)
        self.fit_knots = bool(fit_knots)
        self.knot_logits = _initial_logits(self.base_knots, p, n) if self.fit_knots else None

    def __check_init__(self):
        """One weight per control point, and the knots against the degree."""
        _check_weight_shape(self.weights, self.control_points)
        _check_knot_fields(self)

    def fixed_fields(self) -> tuple[str, ...]:
        """Fields `gfxlab.fit` holds fixed: the given knots (with `fit_knots=True` they
        move through `knot_logits` instead)."""
        return ("base_knots",)

    @property
    def knots(self) -> Float[Array, " n+p+1"]:
        """The knots in use."""
        n = self.control_points.shape[-2]
        return _knots_in_use(self.base_knots, self.knot_logits, self.degree, n)

    @property
    def parameter_range(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        return parameter_range(self.base_knots, self.degree)

    def __call__(self, u: Float[ArrayLike, " N"]) -> Float[Array, "*batch N d"]:
        return nurbs(self.control_points, self.weights, self.degree, u, knots=self.knots)
