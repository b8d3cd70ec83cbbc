"""Which leaves `gfxlab.fit.fit` fits, how bounded ones are reparametrised, and the
clearer errors `fit` raises for JAX's own.

Fixed leaves: a `fixed=` pytree prefix of bools or a callable on leaves, plus the
protocol: an `eqx.Module` may define `fixed_fields(self) -> tuple[str, ...]` naming the
fields that `fit` holds fixed. Bounds: a `bounds=` pytree prefix of `(lo, hi)` pairs;
a bounded leaf is fitted as an unconstrained variable `z` mapped smoothly into the open
interval (`lo + (hi - lo) sigmoid(z)`, or a softplus for a one-sided bound).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import function_holds_tracer


class FitError(ValueError):
    """The objective produced NaN/inf, or the fit was set up wrongly."""


DRIVER_MESSAGE = (
    "`fit` is a driver that runs compiled steps in a Python loop; call it outside "
    "`jax.jit`, `jax.grad` and `jax.vmap` (to differentiate through a solve use "
    "`optimistix.least_squares` or `optimistix.minimise`, which are traceable)"
)

# What JAX raises when the driver meets a value traced by an outer transformation that
# `fn` captured (a closure over the traced variable, which `fit` cannot see beforehand).
OUTER_TRACE_ERRORS = (
    jax.errors.TracerArrayConversionError,
    jax.errors.ConcretizationTypeError,
    jax.errors.TracerBoolConversionError,
    jax.errors.TracerIntegerConversionError,
)


def clearer_error(err: Exception, fn, method) -> Exception | None:
    """The exception `fit` raises in place of JAX's `err`, or `None` to keep `err`.

    - `fn` captured a value traced by an outer `jit`/`grad`/`vmap`: the driver
      `TypeError` (a tracer error from `fn`'s own code keeps JAX's message).
    - `fn` calls a function with a custom VJP (reverse mode only, such as
      `gfxlab.render.render`) under a method that needs forward mode: a `FitError`
      naming the methods that work.
    - residuals of another float dtype than `params` under a least-squares method
      (lineax cannot mix them): a `FitError` saying so.
    """
    if isinstance(err, OUTER_TRACE_ERRORS):
        if function_holds_tracer(fn):
            return TypeError(DRIVER_MESSAGE + f" ({type(err).__name__})")
        return None
    if isinstance(err, FitError):
        return None
    if "Vector and operator structures do not match" in str(err):  # lineax, mixed dtypes
        return FitError(
            "`fn`'s residuals and `params` have different float dtypes (e.g. float64 data in "
            "`args` with float32 `params`): a least-squares method needs one dtype; convert "
            "`params` or the data"
        )
    if "custom_vjp" in str(err) and "forward-mode" in str(err):
        name = method if isinstance(method, str) or method is None else type(method).__name__
        return FitError(
            f"method {name or 'levenberg_marquardt'!r} differentiates `fn` in forward mode "
            "(Jacobian-vector products), and `fn` calls a function that has only a reverse-mode "
            "derivative (a custom VJP, such as gfxlab.render.render); use method='adam' or "
            "'bfgs' (reverse mode), with a scalar loss or residuals"
        )
    return None


# ------------------------------------------------------- fixed leaves and the protocol


def _module_fixed_names(node) -> frozenset:
    getter = getattr(node, "fixed_fields", None)
    if not callable(getter):
        return frozenset()
    names = getter()
    fields = {f.name for f in dataclasses.fields(node)}
    if isinstance(names, str) or not all(isinstance(n, str) for n in names):
        raise FitError(f"`{type(node).__name__}.fixed_fields()` must return a tuple of field names")
    unknown = sorted(set(names) - fields)
    if unknown:
        raise FitError(
            f"`{type(node).__name__}.fixed_fields()` names {unknown}, which are not fields "
            f"of {type(node).__name__} (fields: {sorted(fields)})"
        )
    return frozenset(names)


def _fixed_by_protocol(params) -> list[bool]:
    """Per leaf: does it sit under a field that an `eqx.Module.fixed_fields()` names?"""
    out = []
    for path, _ in jax.tree_util.tree_flatten_with_path(params)[0]:
        node, fixed = params, False
        for key in path:
            if isinstance(key, jax.tree_util.GetAttrKey):
                if isinstance(node, eqx.Module) and key.name in _module_fixed_names(node):
                    fixed = True
                    break
                node = getattr(node, key.name)
            elif isinstance(key, jax.tree_util.DictKey):
                node = node[key.key]
            elif isinstance(key, jax.tree_util.SequenceKey):
                node = node[key.idx]
            else:  # a custom node: cannot look further down
                break
        out.append(fixed)
    return out


class _Entry:
    """A wrapper that pytrees treat as a leaf."""

    def __init__(self, value):
        self.value = value


def _prefix_leaves(prefix, params, name: str, is_leaf) -> list:
    """The entry of the pytree prefix `prefix` that governs each leaf of `params`."""
    try:
        per_leaf = jax.tree_util.tree_map(
            lambda entry, sub: jax.tree_util.tree_map(lambda _: _Entry(entry), sub),
            prefix,
            params,
            is_leaf=is_leaf,
        )
    except (ValueError, TypeError) as err:
        raise FitError(
            f"`{name}` must be a pytree prefix of `params` (same structure down to where "
            f"it gives one value for a whole subtree): {err}"
        ) from None
    return [e.value for e in jax.tree_util.tree_leaves(per_leaf)]


def fixed_mask(params, fixed) -> list[bool]:
    leaves = jax.tree_util.tree_leaves(params)
    mask = _fixed_by_protocol(params)
    if fixed is None:
        return mask
    if callable(fixed):
        extra = [bool(fixed(leaf)) for leaf in leaves]
    else:
        entries = _prefix_leaves(fixed, params, "fixed", lambda x: x is None or isinstance(x, bool))
        for e in entries:
            if e is not None and not isinstance(e, bool):
                raise TypeError(
                    f"`fixed` must hold True/False (or None) per subtree, got {e!r:.60}"
                )
        extra = [bool(e) for e in entries]
    return [a or b for a, b in zip(mask, extra, strict=True)]


# ---------------------------------------------------------------------------- bounds


def _is_pair(x) -> bool:
    return (
        isinstance(x, tuple | list)
        and len(x) == 2
        and all(v is None or isinstance(v, int | float | np.ndarray | jax.Array) for v in x)
    )


def leaf_bounds(params, bounds, leaves, trainable) -> list:
    """Per leaf `None` or `(lo, hi)` arrays of the leaf's shape (infinite = no bound)."""
    if bounds is None:
        return [None] * len(leaves)
    entries = _prefix_leaves(bounds, params, "bounds", lambda x: x is None or _is_pair(x))
    out = []
    for i, (entry, leaf, free) in enumerate(zip(entries, leaves, trainable, strict=True)):
        if entry is None or not free:
            out.append(None)
            continue
        if not _is_pair(entry):
            raise TypeError(f"`bounds` must hold (lo, hi) pairs or None, got {entry!r:.60}")
        lo, hi = (
            jnp.full(leaf.shape, -jnp.inf if k == 0 else jnp.inf, leaf.dtype)
            if v is None
            else jnp.broadcast_to(jnp.asarray(v, leaf.dtype), leaf.shape)
            for k, v in enumerate(entry)
        )
        if bool(jnp.any(jnp.isnan(lo) | jnp.isnan(hi) | (hi <= lo))):
            raise FitError(f"`bounds` of `params` leaf {i} must have lo < hi (no NaN), got {entry}")
        inside = (leaf > lo) & (leaf < hi)
        if not bool(jnp.all(inside)):
            raise FitError(
                f"`params` leaf {i} starts outside its open `bounds` ({entry[0]}, {entry[1]}): "
                "start strictly inside the bounds"
            )
        out.append((lo, hi))
    return out


def bounded(z, lo, hi):
    """Unconstrained `z` -> a value in the open interval (lo, hi) (smooth, monotone)."""
    has_lo, has_hi = jnp.isfinite(lo), jnp.isfinite(hi)
    lo_s, hi_s = jnp.where(has_lo, lo, 0.0), jnp.where(has_hi, hi, 1.0)
    both = lo_s + (hi_s - lo_s) * jax.nn.sigmoid(z)
    lower = lo_s + jax.nn.softplus(z)
    upper = hi_s - jax.nn.softplus(-z)
    return jnp.where(has_lo & has_hi, both, jnp.where(has_lo, lower, jnp.where(has_hi, upper, z)))


def unbounded(p, lo, hi):
    """The inverse of `bounded`, for a start strictly inside the bounds."""
    has_lo, has_hi = jnp.isfinite(lo), jnp.isfinite(hi)
    lo_s, hi_s = jnp.where(has_lo, lo, 0.0), jnp.where(has_hi, hi, 1.0)
    t = jnp.clip((p - lo_s) / (hi_s - lo_s), 1e-300, 1.0)
    both = jnp.log(t) - jnp.log1p(-jnp.minimum(t, 1 - 1e-16))
    inv_softplus = lambda u: u + jnp.log(-jnp.expm1(-jnp.maximum(u, 1e-300)))  # noqa: E731
    lower = inv_softplus(p - lo_s)
    upper = -inv_softplus(hi_s - p)
    return jnp.where(has_lo & has_hi, both, jnp.where(has_lo, lower, jnp.where(has_hi, upper, p)))
