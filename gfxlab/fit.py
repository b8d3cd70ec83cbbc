"""Fit any pytree of parameters by gradient-based optimisation.

One entry point, `fit`, for every lab: least squares with Gauss-Newton or
Levenberg-Marquardt (optimistix), general minimisation with BFGS (optimistix), and
plain or Adam gradient descent (optax). It returns the fitted parameters together
with the loss after every step, so a lab can plot convergence.

Example:
    >>> import jax.numpy as jnp
    >>> from gfxlab.fit import fit
    >>> x = jnp.linspace(0, 1, 20); y = 3 * x + 1
    >>> result = fit(lambda p: p["a"] * x + p["b"] - y, {"a": 0.0, "b": 0.0})
    >>> result.params, result.loss_history[-1]
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import optax
import optimistix as optx
from jaxtyping import Array, Float, PyTree

__all__ = ["fit", "FitResult", "FitError", "METHODS"]

#: Method names accepted by `fit`, and whether each needs a residual vector.
METHODS = {
    "levenberg_marquardt": True,
    "gauss_newton": True,
    "bfgs": False,
    "adam": False,
    "gradient_descent": False,
}


class FitError(ValueError):
    """The objective produced NaN/inf, or the fit was set up wrongly."""


class FitResult(eqx.Module):
    """What `fit` returns.

    **Fields:**

    - `params`: the fitted parameters (same pytree structure as the start).
    - `loss_history`: `(num_steps + 1,)` the loss at the start and after every step.
      The loss is `sum(residuals**2)` for a residual function, or the returned scalar.
    - `num_steps`: steps taken (fewer than `max_steps` if the solver converged).
    - `converged`: whether the solver's own stopping test was met (always False for
      the fixed-step optax methods, which run all `max_steps`).
    - `method`: the method used.
    """

    params: PyTree
    loss_history: Float[Array, " steps"]
    num_steps: int
    converged: bool
    method: str = eqx.field(static=True)

    @property
    def loss(self) -> float:
        """The final loss."""
        return float(self.loss_history[-1])


def _loss_from_output(out: PyTree) -> jax.Array:
    leaves = jax.tree_util.tree_leaves(out)
    if len(leaves) == 1 and jnp.ndim(leaves[0]) == 0:
        return jnp.asarray(leaves[0])
    return sum(jnp.sum(jnp.square(leaf)) for leaf in leaves)


def _is_scalar_output(out_struct: PyTree) -> bool:
    leaves = jax.tree_util.tree_leaves(out_struct)
    return len(leaves) == 1 and leaves[0].shape == ()


def _check_finite(losses, start_step: int, method: str) -> None:
    bad = ~jnp.isfinite(losses)
    if bool(jnp.any(bad)):
        step = start_step + int(jnp.argmax(bad))
        raise FitError(
            f"the objective returned NaN or inf at step {step} of the {method!r} fit; "
            "check the residual function for divisions by zero, sqrt/log of negative "
            "values, or a learning rate that is too large"
        )


class _Progress:
    """A one-line progress report that updates in place in a notebook or terminal."""

    def __init__(self, enabled: bool, max_steps: int, method: str):
        self.enabled = enabled
        self.max_steps = max_steps
        self.method = method
        self.handle = None
        self.start = time.perf_counter()

    def update(self, step: int, loss: float, done: bool = False) -> None:
        if not self.enabled:
            return
        text = (
            f"{self.method}: step {step}/{self.max_steps}  loss {loss:.6g}  "
            f"({time.perf_counter() - self.start:.1f} s){'  done' if done else ''}"
        )
        try:
            from IPython import get_ipython
            from IPython.display import display

            if get_ipython() is not None:
                if self.handle is None:
                    self.handle = display({"text/plain": text}, raw=True, display_id=True)
                else:
                    self.handle.update({"text/plain": text}, raw=True)
                return
        except ImportError:
            pass
        print("\r" + text, end="\n" if done else "", flush=True)


def _prepare(fn, params, args, method):
    if isinstance(method, str):
        if method not in METHODS:
            raise FitError(
                f"`method` must be one of {sorted(METHODS)} (or an optimistix solver or "
                f"optax transformation), got {method!r}"
            )
    # Python floats are parameters too; ints, bools and strings stay fixed.
    params = jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=jnp.result_type(float)) if isinstance(x, float) else x,
        params,
    )
    dynamic, static = eqx.partition(params, eqx.is_inexact_array)
    if not jax.tree_util.tree_leaves(dynamic):
        raise FitError("`params` contains no floating-point arrays to fit")

    def objective(dyn, fn_args):
        return fn(eqx.combine(dyn, static), *fn_args)

    try:
        out_struct = jax.eval_shape(objective, dynamic, args)
    except Exception as err:  # pragma: no cover - re-raised with context
        raise FitError(f"calling the objective with the initial parameters failed: {err}") from err
    return dynamic, static, objective, out_struct


def fit(
    fn: Callable[..., PyTree],
    params: PyTree,
    *,
    args: tuple = (),
    method: str
    | optx.AbstractLeastSquaresSolver
    | optx.AbstractMinimiser
    | optax.GradientTransformation = "levenberg_marquardt",
    max_steps: int = 100,
    learning_rate: float = 1e-2,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    progress: bool = False,
    chunk_size: int | None = None,
) -> FitResult:
    """Fit `params` so that `fn(params, *args)` is as small as possible.

    **Arguments:**

    - `fn`: returns either residuals (any pytree of arrays; the loss is the sum of
      their squares) or a scalar loss. Least-squares methods need residuals.
    - `params`: the starting point, any pytree (dicts, tuples, `eqx.Module`s such as
      a `Bezier` curve or a `Camera`). Floating-point array leaves are fitted; other
      leaves are held fixed.
    - `args`: extra arguments passed to `fn` (data, targets), not fitted.
    - `method`: `"levenberg_marquardt"` (default), `"gauss_newton"`, `"bfgs"`,
      `"adam"`, `"gradient_descent"`, or a ready optimistix solver or optax
      transformation.
    - `max_steps`: the most steps to take.
    - `learning_rate`: for `"adam"` and `"gradient_descent"`.
    - `rtol`, `atol`: convergence tolerances of the optimistix solvers.
    - `progress`: show a progress line (updates in place in a notebook).
    - `chunk_size`: steps run per compiled call between progress updates and NaN
      checks (default: all at once without progress, about 20 updates with it).

    **Returns:** a `FitResult` with the fitted `params` and the `loss_history`.

    **Raises:** `FitError` when the objective returns NaN or inf (naming the step), or
    when a least-squares method is given a scalar loss.
    """
    if not isinstance(max_steps, int) or max_steps < 1:
        raise FitError(f"`max_steps` must be a positive int, got {max_steps!r}")
    if not isinstance(args, tuple):
        raise FitError(f"`args` must be a tuple of extra arguments, got {type(args).__name__}")
    dynamic, static, objective, out_struct = _prepare(fn, params, args, method)
    scalar = _is_scalar_output(out_struct)
    name = method if isinstance(method, str) else type(method).__name__
    if chunk_size is None:
        chunk_size = max(1, max_steps // 20) if progress else max_steps
    chunk_size = max(1, min(int(chunk_size), max_steps))

    def loss_of(dyn):
        return _loss_from_output(objective(dyn, args))

    initial_loss = loss_of(dynamic)
    _check_finite(initial_loss[None], 0, name)
    bar = _Progress(progress, max_steps, name)
    bar.update(0, float(initial_loss))

    if isinstance(method, optax.GradientTransformation) or method in ("adam", "gradient_descent"):
        if isinstance(method, optax.GradientTransformation):
            optimizer = method
        elif method == "adam":
            optimizer = optax.adam(learning_rate)
        else:
            optimizer = optax.sgd(learning_rate)
        run = _optax_runner(loss_of, optimizer)
        state = (dynamic, optimizer.init(dynamic))
        solver_done = None
    else:
        solver = _optimistix_solver(method, rtol, atol)
        is_least_squares = isinstance(solver, optx.AbstractLeastSquaresSolver)
        if is_least_squares and scalar:
            raise FitError(
                f"method {name!r} is a least-squares solver: `fn` must return residuals "
                "(an array or pytree of arrays), not a scalar loss; use 'bfgs' or 'adam' "
                "for a scalar objective"
            )
        run, state = _optimistix_runner(
            objective, loss_of, solver, dynamic, args, out_struct, is_least_squares, scalar
        )
        solver_done = True

    history = [initial_loss[None]]
    steps_done = 0
    converged = False
    while steps_done < max_steps:
        n = min(chunk_size, max_steps - steps_done)
        state, losses, done_flags = run(state, n)
        if solver_done is not None:
            # Steps after convergence repeat the converged loss; drop them.
            done_np = jnp.asarray(done_flags)
            if bool(jnp.any(done_np)):
                first = int(jnp.argmax(done_np))
                losses = losses[: first + 1]
                converged = True
        _check_finite(losses, steps_done + 1, name)
        history.append(losses)
        steps_done += int(losses.shape[0])
        bar.update(steps_done, float(losses[-1]), done=converged or steps_done >= max_steps)
        if converged:
            break
    fitted = eqx.combine(state[0], static)
    return FitResult(
        params=fitted,
        loss_history=jnp.concatenate(history),
        num_steps=steps_done,
        converged=converged,
        method=name,
    )


def _optax_runner(loss_of, optimizer):
    value_and_grad = jax.value_and_grad(loss_of)

    @eqx.filter_jit
    def run(state, n):
        def step(carry, _):
            dyn, opt_state = carry
            _, grads = value_and_grad(dyn)
            updates, opt_state = optimizer.update(grads, opt_state, dyn)
            dyn = optax.apply_updates(dyn, updates)
            return (dyn, opt_state), loss_of(dyn)

        carry, losses = jax.lax.scan(step, state, None, length=n)
        return carry, losses, jnp.zeros(losses.shape, bool)

    return lambda state, n: run(state, int(n))


def _optimistix_solver(method, rtol, atol):
    if not isinstance(method, str):
        return method
    if method == "levenberg_marquardt":
        return optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    if method == "gauss_newton":
        return optx.GaussNewton(rtol=rtol, atol=atol)
    return optx.BFGS(rtol=rtol, atol=atol)


def _optimistix_runner(
    objective, loss_of, solver, dynamic, args, out_struct, least_squares, scalar
):
    if least_squares:

        def fn(y, fn_args):
            return objective(y, fn_args), None

        f_struct = out_struct
    else:

        def fn(y, fn_args):
            out = objective(y, fn_args)
            return (out if scalar else _loss_from_output(out)), None

        f_struct = jax.ShapeDtypeStruct((), jnp.result_type(*jax.tree_util.tree_leaves(out_struct)))
    options: dict[str, Any] = {}
    tags = frozenset()
    solver_state = solver.init(fn, dynamic, args, options, f_struct, None, tags)

    # The solver state holds static parts (e.g. jaxprs of the Jacobian) that cannot be
    # scan carries: carry only its arrays.
    state_arrays, state_static = eqx.partition(solver_state, eqx.is_array)

    @eqx.filter_jit
    def run(state, n):
        def step(carry, _):
            y, s_arrays, done = carry
            y_new, s_new, _ = solver.step(
                fn, y, args, options, eqx.combine(s_arrays, state_static), tags
            )
            s_new_arrays = eqx.filter(s_new, eqx.is_array)
            y = jax.tree_util.tree_map(lambda a, b: jnp.where(done, a, b), y, y_new)
            s_arrays = jax.tree_util.tree_map(
                lambda a, b: jnp.where(done, a, b), s_arrays, s_new_arrays
            )
            finished, _ = solver.terminate(
                fn, y, args, options, eqx.combine(s_arrays, state_static), tags
            )
            done = done | finished
            return (y, s_arrays, done), (loss_of(y), done)

        carry, (losses, dones) = jax.lax.scan(step, state, None, length=n)
        return carry, losses, dones

    state = (dynamic, state_arrays, jnp.array(False))
    return (lambda state, n: run(state, int(n))), state
