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

Importing this module is light: ipywidgets is imported only when `interact` is called.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

__all__ = ["interact", "headless", "HEADLESS_ENV"]

#: Environment variable that marks a headless run: set to "1" by the lab runner in the
#: kernels it starts (no frontend is attached to them).
HEADLESS_ENV = "GFXLAB_HEADLESS"


def headless() -> bool:
    """Whether this kernel runs without a frontend (`$GFXLAB_HEADLESS` is `"1"`)."""
    return os.environ.get(HEADLESS_ENV) == "1"


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
