"""Helpers for the lab notebooks: figures with sliders that also work in a headless run.

`interact(fn, **controls)` is `ipywidgets.interact` for the labs: in a live notebook it
shows the sliders above `fn`'s picture and redraws the picture when one moves; in a
headless run (the lab runner `python -m gfxlab run`, the test suite, CI) nobody can move
a slider and a widget's output would not reach the HTML copy, so it draws the picture
once, with each control's initial value, straight into the cell's output.

Example (in a notebook):

    import ipywidgets as widgets
    from gfxlab.labs import interact

    def show(angle=30.0, scale=1.0):
        ...  # draw with matplotlib

    interact(show, angle=widgets.FloatSlider(value=30.0, min=-180.0, max=180.0),
             scale=(0.2, 2.0, 0.1))

The lab kernels (`make lab`, `python -m gfxlab run`) also compile with XLA's older CPU
emitters (`lab_xla_flags`): a lab compiles a hundred small programs, and those emitters
compile them a third faster at the same optimisation level, with the same results. To
keep XLA's own choice, set `XLA_FLAGS=--xla_cpu_use_fusion_emitters=true` before
`make lab` or `python -m gfxlab run` (a user's setting of that flag always wins).

Importing this module is light: ipywidgets is imported only when `interact` is called,
JAX never.
"""

from __future__ import annotations

import functools
import importlib.metadata
import os
import pathlib
import subprocess
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["interact", "headless", "lab_xla_flags", "HEADLESS_ENV", "LAB_XLA_FLAG"]

#: Environment variable that marks a headless run: set to "1" by the lab runner in the
#: kernels it starts (no frontend is attached to them).
HEADLESS_ENV = "GFXLAB_HEADLESS"


def headless() -> bool:
    """Whether this kernel runs without a frontend (`$GFXLAB_HEADLESS` is `"1"`)."""
    return os.environ.get(HEADLESS_ENV) == "1"


#: The XLA flag of the lab kernels: XLA's legacy CPU emitters instead of its newer fusion
#: emitters. Measured on 2 idle cores, a fresh kernel, no compilation cache: labs 05 and
#: 06 take 40 -> 28 s and 31 -> 22 s, the others 0-25 % less; the optimisation level is
#: unchanged, so a long fit runs as fast.
LAB_XLA_FLAG = "--xla_cpu_use_fusion_emitters=false"


def lab_xla_flags(flags: str | None = None) -> str:
    """`XLA_FLAGS` for a lab kernel: `flags` (default: `$XLA_FLAGS`) with `LAB_XLA_FLAG`.

    The flag is left out when `flags` already sets `--xla_cpu_use_fusion_emitters` (the
    user's choice wins) and when this jaxlib does not know it (XLA aborts at start on an
    unknown flag): that is probed once per jaxlib version in a child process, and the
    answer kept in `~/.cache/gfxlab/` (`$XDG_CACHE_HOME/gfxlab/`).

    **Arguments:**

    - `flags`: the XLA flags to extend, a string; `None` reads `$XLA_FLAGS`.

    **Returns:** the flags, space-separated, as a string.

    **Raises:** `TypeError` when `flags` is neither a string nor `None`.
    """
    if flags is None:
        flags = os.environ.get("XLA_FLAGS", "")
    if not isinstance(flags, str):
        raise TypeError(f"`flags` must be a string of XLA flags or None, got {flags!r:.60}")
    name = LAB_XLA_FLAG.split("=")[0]
    if name in flags or not _xla_knows_lab_flag():
        return flags
    return f"{flags} {LAB_XLA_FLAG}".strip()


@functools.cache
def _xla_knows_lab_flag() -> bool:
    """Whether this jaxlib's XLA accepts `LAB_XLA_FLAG` (a child process tries it once per
    jaxlib version; the answer is cached on disk and in memory)."""
    try:
        version = importlib.metadata.version("jaxlib")
    except importlib.metadata.PackageNotFoundError:
        return False
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    answer = pathlib.Path(base) / "gfxlab" / f"xla-flag-{LAB_XLA_FLAG[2:]}-jaxlib-{version}"
    try:
        return answer.read_text().strip() == "accepted"
    except OSError:
        pass
    env = dict(os.environ, XLA_FLAGS=LAB_XLA_FLAG, JAX_PLATFORMS="cpu")
    try:
        probe = subprocess.run(
            [sys.executable, "-c", "import jax.numpy as j; j.zeros(1).block_until_ready()"],
            env=env,
            capture_output=True,
            timeout=120,
        )
        accepted = probe.returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False  # not cached: the next kernel asks again
    try:
        answer.parent.mkdir(parents=True, exist_ok=True)
        answer.write_text("accepted\n" if accepted else "rejected\n")
    except OSError:
        pass  # a read-only home: probe again next time
    return accepted


def interact(fn: Callable[..., Any], /, *, manual: bool = False, **controls: Any) -> Any:
    """A figure with sliders: `fn(**values)` redrawn whenever a control changes.

    **Arguments:**

    - `fn`: draws the picture (e.g. with matplotlib) from the controls' values, passed
      as keyword arguments.
    - `manual`: redraw only when the "Run Interact" button is pressed (for pictures that
      take long to compute), instead of on every change.
    - `**controls`: one per argument of `fn`, anything `ipywidgets.interact` accepts: a
      widget (`FloatSlider(value=0.3, min=0, max=1)`, `Dropdown(...)`), an abbreviation
      (`(0.0, 1.0, 0.05)` for a slider, a list for a drop-down, a number, a string, a
      bool) or `ipywidgets.fixed(value)` for an argument without a control. An argument
      of `fn` with a default and no control gets a control made from its default (as in
      `ipywidgets.interact`); wrap the default in `fixed` to keep it without one.

    **Returns:** what `fn` returned for the controls' initial values (`None` with
    `manual=True` in a live notebook, where nothing is drawn until the button is
    pressed). Headless (`headless()`), `fn` is called exactly once with those values and
    its picture goes into the cell's output, without widgets.

    **Raises:** `TypeError` when `fn` is not callable, `manual` is not a bool, or a
    control names no argument of `fn`; `ValueError` for an argument of `fn` without a
    control or a default, and for a control that is no widget abbreviation.
    """
    if not callable(fn):
        raise TypeError(f"`fn` must be a function that draws the picture, got {fn!r:.60}")
    if not isinstance(manual, bool):
        raise TypeError(f"`manual` must be True or False, got {manual!r:.60}")
    import ipywidgets

    live = not headless()
    # The same widgets (and argument checks) in both cases; `manual` keeps ipywidgets
    # from drawing into its own output area, which a headless copy would not show.
    panel = ipywidgets.interactive(fn, {"manual": manual or not live}, **controls)
    unknown = sorted(set(controls) - {w._kwarg for w in panel.kwargs_widgets})
    if unknown:
        name = getattr(fn, "__name__", repr(fn))
        raise TypeError(f"the controls {unknown} name no argument of `fn` ({name:.60})")
    if live:
        from IPython.display import display

        display(panel)
        return panel.result
    values = {w._kwarg: w.get_interact_value() for w in panel.kwargs_widgets}
    return fn(**values)
