"""Fit any pytree of parameters by gradient-based optimisation.

One entry point, `fit`, for every lab: least squares with Gauss-Newton or
Levenberg-Marquardt (optimistix), general minimisation with BFGS (optimistix), and
plain or Adam gradient descent (optax). It returns the best parameters it saw together
with the loss after every step, so a lab can plot convergence.

**What `fn` returns, for every method.** A 0-d (scalar) output is a *loss* and is
minimised as it is. Any other output (an array, or a pytree of arrays) is a vector of
*residuals* `r` and the loss is `sum(r**2)`. Least-squares methods need residuals;
BFGS, Adam and gradient descent minimise the loss either way, and `loss_history` is this
loss for every method.

**A driver, not a traceable function.** `fit` runs a Python loop over compiled chunks
of steps (to report progress, stop at convergence and catch NaN early), so it is called
eagerly, not inside `jax.jit`, `jax.grad` or `jax.vmap` (it raises a clear `TypeError`
there). The compiled steps are cached: fitting the same `fn` again with parameters and
arguments of the same structure, shapes and dtypes does not recompile. To differentiate
through a solve, call `optimistix.least_squares`/`optimistix.minimise` directly (they are
traceable).

**Static sizes that run out.** A compiled step whose static size runs out while it
runs (a `gfxlab.render` tile capacity, as a fitted mesh shrinks or turns) does not abort
the fit: the size is grown, a `RuntimeWarning` says so, and the chunk of steps reruns
from its start. (A render of fitted geometry needs an explicit `capacity`, measured
with `gfxlab.render.tile_capacity` on the start: `capacity=None` measures concrete
geometry only.) A check inside `fn` that fails while the steps run (an `eqx.error_if`,
e.g. a curve's control points became NaN) raises a `FitError` naming it and the steps.

**Which leaves are fitted.** Floating-point array leaves of `params` are fitted; other
leaves are held fixed. An `eqx.Module` in `params` may define a method
`fixed_fields(self) -> tuple[str, ...]`: the fields it names are held fixed (e.g. a
`BSpline`'s knots when it is not fitting them). `fixed=` adds to this: a pytree prefix
of `params` with `True` (fixed) / `False`, or a callable `leaf -> bool`. A module's
construction checks do not run on the iterates: a fitted `Mesh`'s colours can leave
[0, 1] unless bounded or fixed.

**Bounds.** `bounds=` gives `(lo, hi)` per parameter, as a pytree prefix of `params` (a
dict `{"quality": (1.0, 100.0)}`, one pair for everything, `None` for unbounded parts;
`lo`/`hi` may be arrays, `None` or infinite for one-sided bounds). A bounded parameter
is fitted through a smooth reparametrisation (a scaled sigmoid, or a softplus for one
side), so it stays strictly inside `(lo, hi)` at every step, never clipped; the start
must be strictly inside. Learning rates apply to the unconstrained variable.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab.fit import fit
    >>> x = jnp.linspace(0, 1, 20); y = 3 * x + 1
    >>> result = fit(lambda p: p["a"] * x + p["b"] - y, {"a": 0.0, "b": 0.0})
    >>> round(float(result.params["a"]), 4), round(float(result.params["b"]), 4)
    (3.0, 1.0)
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax
import optimistix as optx
from jaxtyping import Array, Float, PyTree

from ._checks import is_traced, static_bool, static_int
from ._fit_loop import Progress, drive
from ._fit_params import (
    DRIVER_MESSAGE,
    OUTER_TRACE_ERRORS,
    FitError,
    bounded,
    clearer_error,
    fixed_mask,
    leaf_bounds,
    unbounded,
)

__all__ = ["fit", "FitResult", "FitError", "METHODS", "MAX_STEPS"]

#: Method names accepted by `fit`, and whether each needs a residual vector.
METHODS = {
    "levenberg_marquardt": True,
    "gauss_newton": True,
    "bfgs": False,
    "adam": False,
    "gradient_descent": False,
}

#: The most steps one `fit` may take (its loss history is kept in memory).
MAX_STEPS = 10_000_000


class FitResult(eqx.Module):
    """What `fit` returns.

    **Fields:**

    - `params`: the best parameters seen (lowest loss, the start included), with the
      structure of the start; fixed leaves are returned unchanged.
    - `loss_history`: `(num_steps + 1,)` the loss at the start and after every step.
      The loss is `sum(residuals**2)` for a residual function, or the returned scalar.
    - `num_steps`: steps taken (fewer than `max_steps` if the solver converged).
    - `converged`: whether the solver's own stopping test was met (always False for
      the fixed-step optax methods, which run all `max_steps`).
    - `method`: the method used.
    - `best_step`: the step whose parameters `params` are (0 is the start).
    """

    params: PyTree
    loss_history: Float[Array, " steps"]
    num_steps: int
    converged: bool
    method: str = eqx.field(static=True)
    best_step: int = 0

    @property
    def loss(self) -> float:
        """The loss of the returned `params` (the lowest in `loss_history`)."""
        return float(self.loss_history[self.best_step])

    @property
    def final_loss(self) -> float:
        """The loss after the last step (may be above `loss` if the fit overshot)."""
        return float(self.loss_history[-1])


# ----------------------------------------------------------------------------- checks


def _positive_number(value, name: str, *, allow_zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        if not (isinstance(value, np.ndarray | jax.Array) and np.ndim(value) == 0):
            raise TypeError(f"`{name}` must be a number, got {value!r:.60}")
        if is_traced(value):
            raise TypeError(f"`{name}` must be a concrete number, not a traced value")
    value = float(value)
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise FitError(f"`{name}` must be a finite number {bound}, got {value}")
    return value


def _count(value, name: str, *, optional: bool = False) -> int | None:
    if value is None and optional:
        return None
    try:
        return static_int(value, name, minimum=1, maximum=MAX_STEPS)
    except ValueError as err:
        raise FitError(str(err)) from None


def _check_call(fn, params, args, method, progress) -> None:
    if not callable(fn):
        raise TypeError(
            f"`fn` must be callable (params, *args) -> residuals or loss, got {fn!r:.60}"
        )
    if params is None:
        raise TypeError("`params` must be a pytree of arrays to fit, got None")
    if not isinstance(args, tuple):
        raise FitError(f"`args` must be a tuple of extra arguments, got {type(args).__name__}")
    static_bool(progress, "progress")
    if is_traced((params, args)):
        raise TypeError(DRIVER_MESSAGE)
    if isinstance(method, str):
        if method not in METHODS:
            raise FitError(
                f"`method` must be one of {sorted(METHODS)} (or an optimistix solver or "
                f"optax transformation), got {method!r}"
            )
    elif method is not None and not isinstance(
        method,
        optx.AbstractLeastSquaresSolver | optx.AbstractMinimiser | optax.GradientTransformation,
    ):
        raise TypeError(
            f"`method` must be one of {sorted(METHODS)}, an optimistix least-squares "
            f"solver or minimiser, or an optax GradientTransformation, got {method!r:.80}"
        )


# -------------------------------------------------------------------- the problem


class _Problem(eqx.Module):
    """Everything the compiled steps need besides the state: hashed by `filter_jit`, so
    a refit of the same `fn` with the same structure reuses the compiled code."""

    fn: Callable
    static: PyTree  # the fixed leaves and non-array parts of `params`
    bounds: PyTree  # per trainable leaf: None or (lo, hi)

    def params(self, z):
        values = jax.tree_util.tree_map(
            lambda v, b: v if b is None else bounded(v, *b), z, self.bounds
        )
        return eqx.combine(values, self.static)

    def output(self, z, args):
        return self.fn(self.params(z), *args)

    def loss(self, z, args):
        return _loss_from_output(self.output(z, args))


def _loss_from_output(out: PyTree) -> jax.Array:
    leaves = jax.tree_util.tree_leaves(out)
    if len(leaves) == 1 and jnp.ndim(leaves[0]) == 0:
        return jnp.asarray(leaves[0])
    return sum(jnp.sum(jnp.square(leaf)) for leaf in leaves)


def _setup(fn, params, fixed, bounds):
    params = jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=jnp.result_type(float)) if isinstance(x, float) else x,
        params,
    )
    leaves, treedef = jax.tree_util.tree_flatten(params)
    mask = fixed_mask(params, fixed)
    trainable = [eqx.is_inexact_array(v) and not f for v, f in zip(leaves, mask, strict=True)]
    if not any(trainable):
        raise FitError("`params` contains no floating-point arrays to fit (all fixed or non-float)")
    for i, (leaf, free) in enumerate(zip(leaves, trainable, strict=True)):
        if free and not bool(jnp.all(jnp.isfinite(leaf))):
            raise FitError(f"`params` leaf {i} (shape {leaf.shape}) holds NaN or inf at the start")
    per_leaf = leaf_bounds(params, bounds, leaves, trainable)
    z = [
        (unbounded(v, *b) if b is not None else v) if t else None
        for v, t, b in zip(leaves, trainable, per_leaf, strict=True)
    ]
    static = [None if t else v for v, t in zip(leaves, trainable, strict=True)]
    unflat = functools.partial(jax.tree_util.tree_unflatten, treedef)
    problem = _Problem(fn=fn, static=unflat(static), bounds=unflat(per_leaf))
    return problem, unflat(z)


#: `_describe`'s answers, keyed by the static parts of its arguments and the shapes and
#: dtypes of their arrays (bounded: cleared when full).
_DESCRIBED: dict = {}


def _describe(problem, z, args):
    """Whether `fn` returns a scalar, and its output structure, from `eqx.filter_eval_shape`
    (a trace, nothing compiled: a jitted version would compile `fn`'s whole forward pass
    when it holds effects such as `eqx.error_if`), cached so a refit does not retrace."""
    leaves, treedef = jax.tree_util.tree_flatten((problem, z, args))
    key = (treedef,) + tuple(
        (v.shape, v.dtype, bool(getattr(v, "weak_type", False)))
        if eqx.is_array(v)
        else (type(v), v)
        for v in leaves
    )
    try:
        return _DESCRIBED[key]
    except TypeError:  # an unhashable static leaf: no caching
        key = None
    except KeyError:
        pass
    try:
        out = eqx.filter_eval_shape(problem.output, z, args)
    except FitError:
        raise
    except Exception as err:
        raise FitError(f"calling `fn` with the initial parameters failed: {err}") from err
    out_leaves = jax.tree_util.tree_leaves(out)
    if not out_leaves or not all(isinstance(v, jax.ShapeDtypeStruct) for v in out_leaves):
        raise FitError(
            "`fn` must return an array (residuals or a scalar loss) or a pytree of arrays"
        )
    if not all(jnp.issubdtype(v.dtype, jnp.inexact) for v in out_leaves):
        kinds = sorted({str(v.dtype) for v in out_leaves})
        raise FitError(f"`fn` must return floating-point residuals or a loss, got {kinds}")
    answer = (len(out_leaves) == 1 and out_leaves[0].shape == ()), out
    if key is not None:
        if len(_DESCRIBED) >= 256:
            _DESCRIBED.clear()
        _DESCRIBED[key] = answer
    return answer


# ------------------------------------------------------------------ compiled steps


@functools.lru_cache(maxsize=64)
def _named_optax(method: str, learning_rate: float) -> optax.GradientTransformation:
    # Cached, so the same name and rate give the same object and reuse compiled steps.
    return optax.adam(learning_rate) if method == "adam" else optax.sgd(learning_rate)


@functools.lru_cache(maxsize=64)
def _named_optimistix(method: str, rtol: float, atol: float):
    if method == "levenberg_marquardt":
        return optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    if method == "gauss_newton":
        return optx.GaussNewton(rtol=rtol, atol=atol)
    return optx.BFGS(rtol=rtol, atol=atol)


def _keep_best(best, z, loss, step):
    best_z, best_loss, best_step = best
    better = loss < best_loss  # NaN is never better
    best_z = jax.tree_util.tree_map(lambda a, b: jnp.where(better, b, a), best_z, z)
    return best_z, jnp.where(better, loss, best_loss), jnp.where(better, step, best_step)


@eqx.filter_jit
def _optax_chunk(problem, optimizer, state, args, n, generation):
    """`n` optax steps, scanned as `n + 1` evaluations of the loss and its gradient: the
    last one only gives the loss after the last step (its update is dropped). So `fn` is
    compiled once, inside the loop, not a second time after it (half the compile time of
    a cheap step; one extra gradient per chunk at run time)."""
    value_and_grad = jax.value_and_grad(problem.loss)

    def step(carry, k):
        z, opt_state, best, i = carry
        loss, grads = value_and_grad(z, args)
        best = _keep_best(best, z, loss, i)
        updates, new_state = optimizer.update(grads, opt_state, z)
        move = k < n  # False only for the last evaluation
        z, opt_state = jax.tree_util.tree_map(
            lambda new, old: jnp.where(move, new, old),
            (optax.apply_updates(z, updates), new_state),
            (z, opt_state),
        )
        return (z, opt_state, best, i + move.astype(i.dtype)), loss

    (z, opt_state, best, i), losses = jax.lax.scan(step, state, jnp.arange(n + 1))
    return (z, opt_state, best, i), losses[1:], jnp.zeros(n, bool), losses[0]


def _optimistix_fn(problem, least_squares: bool, scalar: bool):
    def fn(z, args):
        if least_squares:
            return problem.output(z, args), None
        out = problem.output(z, args)
        return (out if scalar else _loss_from_output(out)), None

    return fn


def _solver_state(problem, solver, z, args, f_struct, least_squares, scalar):
    fn = _optimistix_fn(problem, least_squares, scalar)
    return fn, solver.init(fn, z, args, {}, f_struct, None, frozenset())


@eqx.filter_jit
def _optimistix_chunk(problem, solver, state, args, f_struct, least_squares, scalar, n, generation):
    """Up to `n` optimistix steps, stopping once the solver's stopping test holds; returns
    the state, `n` losses (the last one repeated past the stop), `n` "done" flags, and the
    loss at the start on the first call (else `None`).

    The first call (`state` without solver arrays) also initialises the solver, so a fit
    that runs in one chunk compiles one program. The solver state's static parts (jaxprs)
    are rebuilt here, so only its arrays are carried between calls.
    """
    z0, s_arrays0, done0, best0, i0 = state
    fn, fresh = _solver_state(problem, solver, z0, args, f_struct, least_squares, scalar)
    s_static = eqx.filter(fresh, eqx.is_array, inverse=True)
    first = s_arrays0 is None
    if first:
        s_arrays0 = eqx.filter(fresh, eqx.is_array)
    tags, options = frozenset(), {}
    entry = problem.loss(z0, args)
    losses0 = jnp.full((n,), entry)

    def step(carry):
        z, s_arrays, done, best, i, k, losses = carry
        s = eqx.combine(s_arrays, s_static)
        z, s, _ = solver.step(fn, z, args, options, s, tags)
        done, _ = solver.terminate(fn, z, args, options, s, tags)
        loss = problem.loss(z, args)
        best = _keep_best(best, z, loss, i + 1)
        # Past this step, the buffer holds its loss (the driver cuts there).
        losses = jnp.where(jnp.arange(n) >= k, loss, losses)
        return z, eqx.filter(s, eqx.is_array), done, best, i + 1, k + 1, losses

    def more(carry):
        return (carry[5] < n) & ~carry[2]

    start = (z0, s_arrays0, done0, best0, i0, jnp.zeros((), i0.dtype), losses0)
    z, s_arrays, done, best, i, k, losses = jax.lax.while_loop(more, step, start)
    dones = done & (jnp.arange(n) >= k - 1)
    return (z, s_arrays, done, best, i), losses, dones, entry if first else None


# ----------------------------------------------------------------------- the driver


def _runner(problem, method, z, args, scalar, f_struct, options):
    """(name, initial state, run(state, args, n, generation) -> (state, losses, dones, the
    loss at the start or None after the first call), uses_solver_test). `generation`
    (`gfxlab._regrow`) is only part of the compile key: a grown static size retraces."""
    learning_rate, rtol, atol = options
    if method is None:
        method = "bfgs" if scalar else "levenberg_marquardt"
    name = method if isinstance(method, str) else type(method).__name__
    if isinstance(method, optax.GradientTransformation) or method in ("adam", "gradient_descent"):
        optimizer = method if not isinstance(method, str) else _named_optax(method, learning_rate)
        best = (z, jnp.asarray(jnp.inf), jnp.asarray(0))
        state = (z, optimizer.init(z), best, jnp.asarray(0))
        return name, state, functools.partial(_optax_chunk, problem, optimizer), False
    solver = method if not isinstance(method, str) else _named_optimistix(method, rtol, atol)
    least_squares = isinstance(solver, optx.AbstractLeastSquaresSolver)
    if least_squares and scalar:
        raise FitError(
            f"method {name!r} is a least-squares solver: `fn` must return residuals "
            "(an array or pytree of arrays), not a scalar loss; use 'bfgs' or 'adam' "
            "for a scalar objective (or leave `method` at its default)"
        )
    if not least_squares:
        f_struct = jax.ShapeDtypeStruct((), jnp.result_type(*jax.tree_util.tree_leaves(f_struct)))
    best = (z, jnp.asarray(jnp.inf), jnp.asarray(0))
    state = (z, None, jnp.asarray(False), best, jnp.asarray(0))

    def run(state, args, n, generation):
        return _optimistix_chunk(
            problem, solver, state, args, f_struct, least_squares, scalar, n, generation
        )

    return name, state, run, True


def fit(
    fn: Callable[..., PyTree],
    params: PyTree,
    *,
    args: tuple = (),
    method: str
    | optx.AbstractLeastSquaresSolver
    | optx.AbstractMinimiser
    | optax.GradientTransformation
    | None = None,
    max_steps: int = 100,
    learning_rate: float = 1e-2,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    progress: bool = False,
    chunk_size: int | None = None,
    bounds: PyTree | None = None,
    fixed: PyTree | Callable[[Any], bool] | None = None,
) -> FitResult:
    """Fit `params` so that `fn(params, *args)` is as small as possible.

    A driver: call it eagerly, not under `jax.jit`/`jax.grad`/`jax.vmap` (see the
    module docstring, which also details `fixed` and `bounds`).

    **Arguments:**

    - `fn`: returns either residuals (any pytree of arrays; the loss is the sum of
      their squares) or a 0-d scalar loss (minimised as it is), for every method.
    - `params`: the starting point, any pytree (dicts, tuples, `eqx.Module`s such as
      a `Bezier` curve or a `Camera`); its floating-point array leaves are fitted.
    - `args`: extra arguments passed to `fn` (data, targets), not fitted.
    - `method`: `"levenberg_marquardt"`, `"gauss_newton"`, `"bfgs"`, `"adam"`,
      `"gradient_descent"`, or a ready optimistix solver or optax transformation.
      Default: Levenberg-Marquardt for residuals, BFGS for a scalar loss. The first two
      need forward-mode derivatives: for `gfxlab.render`, use `"adam"` or `"bfgs"`.
    - `max_steps`: the most steps to take (1 to `MAX_STEPS`).
    - `learning_rate`: for `"adam"` and `"gradient_descent"`, > 0.
    - `rtol`, `atol`: convergence tolerances of the optimistix solvers, >= 0.
    - `progress`: show a progress line (updates in place in a notebook).
    - `chunk_size`: steps run per compiled call between progress updates and NaN
      checks (default: all at once without progress, about 20 updates with it).
    - `bounds`: `(lo, hi)` per parameter (a pytree prefix of `params`); a bounded
      parameter stays strictly inside through a smooth reparametrisation.
    - `fixed`: leaves to hold fixed (a pytree prefix of `params` of booleans, or a
      callable `leaf -> bool`), besides the `fixed_fields` protocol.

    **Returns:** a `FitResult` with the best `params` seen and the `loss_history` (and a
    `RuntimeWarning` when every step was worse than the start, which is then returned).

    **Raises:** `FitError` (a `ValueError`) when the objective returns NaN or inf
    (naming the step), for a scalar loss given to a least-squares method, and for
    out-of-range settings; `TypeError` for arguments of the wrong kind and when called
    under a JAX transformation.
    """
    _check_call(fn, params, args, method, progress)
    max_steps = _count(max_steps, "max_steps")
    chunk_size = _count(chunk_size, "chunk_size", optional=True)
    options = (
        _positive_number(learning_rate, "learning_rate"),
        _positive_number(rtol, "rtol", allow_zero=True),
        _positive_number(atol, "atol", allow_zero=True),
    )
    try:
        problem, z = _setup(fn, params, fixed, bounds)
        scalar, f_struct = _describe(problem, z, args)
        name, state, run, solver_test = _runner(problem, method, z, args, scalar, f_struct, options)
        if chunk_size is None:
            chunk_size = max(1, max_steps // 20) if progress else max_steps
        bar = Progress(progress, max_steps, name)
        state, loss_history, converged = drive(
            run, state, args, max_steps, min(chunk_size, max_steps), solver_test, name, bar
        )
        return _result(problem, z, state, loss_history, converged, name)
    except (*OUTER_TRACE_ERRORS, TypeError, ValueError) as err:
        clearer = clearer_error(err, fn, method)
        if clearer is None:
            raise  # e.g. a mistake inside `fn` itself: JAX's own message says it
        raise clearer from err


def _result(problem, z, state, loss_history, converged, name) -> FitResult:
    """The `FitResult`: the best parameters seen (the start when nothing was better)."""
    best_z, best_loss, best_step = state[-2]
    best_step = int(best_step) if np.isfinite(float(best_loss)) else 0
    if float(loss_history[0]) <= loss_history[best_step]:
        best_z, best_step = z, 0  # the start is as good as anything seen
    start = float(loss_history[0])  # a scalar loss may be negative: a tolerance on |start|
    if len(loss_history) > 1 and np.min(loss_history[1:]) > start + 1e-6 * abs(start):
        warnings.warn(
            f"fit ({name}): every step made the loss worse than at the start "
            f"({start:.4g}); the start is returned. Try a smaller learning "
            "rate, or hold parameters that should not move fixed (`fixed=`)",
            RuntimeWarning,
            stacklevel=3,
        )
    return FitResult(
        params=problem.params(best_z),
        loss_history=jnp.asarray(loss_history),
        num_steps=len(loss_history) - 1,
        converged=converged,
        method=name,
        best_step=best_step,
    )
