"""The Python loop of `gfxlab.fit.fit`: compiled chunks of steps, a progress line, the
NaN/inf checks, and the reruns when a chunk outgrew a static size.

A chunk that raises after reporting an outgrown size (a render's tile capacity, through
`gfxlab._regrow`) is rerun from its start with the size grown, with a `RuntimeWarning`:
a fit never aborts midway for want of room. A check inside `fn` that fails while the
chunk runs (`eqx.error_if`: the solver moved the parameters where `fn` is undefined)
becomes a `FitError` that names the steps and the check's message.
"""

from __future__ import annotations

import time
import warnings

import equinox as eqx
import jax
import numpy as np

from . import _regrow
from ._check_errors import check_message
from ._fit_params import FitError

#: The most reruns of one chunk with grown sizes (a size grows to what the run needed).
MAX_REGROWTHS = 16


class Progress:
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


def _check_finite(losses, start_step: int, method: str) -> None:
    bad = ~np.isfinite(np.asarray(losses))
    if bad.any():
        raise FitError(
            f"the objective returned NaN or inf at step {start_step + int(np.argmax(bad))} of "
            f"the {method!r} fit; check the residual function for divisions by zero, sqrt/log "
            "of negative values, or a learning rate that is too large"
        )


def _run_chunk(run, state, args, n: int, first: int, name: str):
    """`run(state, args, n, generation)`, rerun with grown sizes when it outgrew one."""
    for _ in range(MAX_REGROWTHS):
        _regrow.clear_reports()
        try:
            return jax.block_until_ready(run(state, args, n, _regrow.generation()))
        except Exception as err:
            grown = _regrow.grow_reported()
            if grown:
                warnings.warn(
                    f"fit ({name}): {'; '.join(grown)}; steps {first}-{first + n - 1} were rerun",
                    RuntimeWarning,
                    stacklevel=4,
                )
                continue
            # fit compiles with eqx.filter_jit: a failed check is an EquinoxRuntimeError
            message = check_message(err) if isinstance(err, eqx.EquinoxRuntimeError) else None
            if message is None:
                raise
            raise FitError(
                f"a check inside `fn` failed during steps {first}-{first + n - 1} of the "
                f"{name!r} fit: {message}. The solver moved the parameters to where `fn` "
                "is not defined (often NaN from a singular system: try "
                "'levenberg_marquardt', which is damped, or hold fixed the parameters "
                "the data does not determine, `fixed=`)"
            ) from err
    raise FitError(f"fit ({name}): a static size kept growing; gave up after {MAX_REGROWTHS}")


def drive(run, state, args, max_steps, chunk_size, solver_test, name, bar):
    """Run compiled chunks until `max_steps` or convergence; check each for NaN/inf.
    Returns the state, the loss history (the initial loss first) and convergence."""
    history, steps_done, converged = [], 0, False
    while steps_done < max_steps:
        n = min(chunk_size, max_steps - steps_done)
        state, losses, dones, entry = _run_chunk(run, state, args, n, steps_done + 1, name)
        if not history:
            history.append(_initial(entry, name, bar))
        losses, dones = np.asarray(losses), np.asarray(dones)
        if solver_test and dones.any():  # steps after convergence repeat the loss
            losses, converged = losses[: int(np.argmax(dones)) + 1], True
        losses, exact = _cut_at_exact_solution(losses, history)
        converged = converged or exact
        _check_finite(losses, steps_done + 1, name)
        history.append(losses)
        steps_done += int(losses.shape[0])
        bar.update(steps_done, float(losses[-1]), done=converged or steps_done >= max_steps)
        if converged:
            break
    return state, np.concatenate(history), converged


def _cut_at_exact_solution(losses: np.ndarray, history: list) -> tuple[np.ndarray, bool]:
    """The losses before the first NaN/inf that follows a loss of exactly 0, and whether
    that happened. A Gauss-Newton step from an exact solution can divide 0 by 0 (the
    Jacobian of `r**2` vanishes where `r = 0`): that is convergence, not a failing fit."""
    bad = ~np.isfinite(losses)
    if not bad.any():
        return losses, False
    first = int(np.argmax(bad))
    before = losses[first - 1] if first else (history[-1][-1] if history else np.nan)
    return (losses[:first], True) if before == 0 else (losses, False)


def _initial(loss, name: str, bar: Progress) -> np.ndarray:
    loss = np.asarray(loss)[None]
    _check_finite(loss, 0, name)
    bar.update(0, float(loss[0]))
    return loss
