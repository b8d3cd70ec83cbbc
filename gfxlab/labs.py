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

The lab runner is here too: `list_labs()`, `find_lab(name)`, `run_lab(path, out_dir)`
(one notebook executed headless in a fresh kernel, written as HTML; a failing cell raises
`LabError` naming it) and `run_all(out_dir)` (every lab and an `index.html` gallery), the
functions behind `python -m gfxlab labs` and `python -m gfxlab run LAB|all`.

Importing this module is light: ipywidgets is imported only when `interact` is called,
the notebook machinery (nbclient, nbconvert) only when a lab is run, JAX never.
"""

from __future__ import annotations

import functools
import importlib.metadata
import os
import pathlib
import subprocess
import sys
from collections.abc import Callable
from typing import Any, NamedTuple

from ._plain_args import flag, positive_number

__all__ = [
    "interact",
    "headless",
    "lab_xla_flags",
    "HEADLESS_ENV",
    "LAB_XLA_FLAG",
    "list_labs",
    "find_lab",
    "lab_title",
    "run_lab",
    "run_all",
    "write_index",
    "LabError",
    "LabRun",
    "jax_cache_dir",
    "kernel_env",
    "CACHE_ENV",
]

#: Environment variable that marks a headless run: set to "1" by the lab runner in the
#: kernels it starts (no frontend is attached to them).
HEADLESS_ENV = "GFXLAB_HEADLESS"


#: Environment variable overriding where the lab kernels' JAX compilation cache lives.
CACHE_ENV = "GFXLAB_JAX_CACHE"


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
    if name in flags or not _xla_knows_lab_flag(_flag_answer_path()):
        return flags
    return f"{flags} {LAB_XLA_FLAG}".strip()


def _flag_answer_path() -> pathlib.Path | None:
    """Where the probe's answer for this jaxlib is kept (None: no jaxlib installed)."""
    try:
        version = importlib.metadata.version("jaxlib")
    except importlib.metadata.PackageNotFoundError:
        return None
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "gfxlab" / f"xla-flag-{LAB_XLA_FLAG[2:]}-jaxlib-{version}"


@functools.cache
def _xla_knows_lab_flag(answer: pathlib.Path | None) -> bool:
    """Whether this jaxlib's XLA accepts `LAB_XLA_FLAG` (a child process tries it once per
    jaxlib version; the answer is kept in the file `answer` and, per file, in memory)."""
    if answer is None:
        return False
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


# The lab runner. Its work is done in `gfxlab._runner`, imported on the first call so that
# a notebook importing `interact` does not load the runner's machinery.


class LabError(RuntimeError):
    """A lab did not run to the end: a cell raised, ran past the timeout, or the kernel died.

    **Fields:** `lab` (the notebook), `cell_index` (the code cell's position in the
    notebook, counting every cell from 0, or None), `code_cell` (its number among the
    code cells, from 1, as the message says), `cell_source`, `reason` (the error or
    timeout, one line), `html_path` (the partial HTML copy, written before raising),
    `timed_out`.
    """

    def __init__(
        self, lab, cell_index, cell_source, reason, html_path, *, timed_out=False, code_cell=None
    ):
        """The fields as listed above; the message is built from them."""
        self.lab = pathlib.Path(lab)
        self.cell_index = cell_index
        self.code_cell = code_cell
        self.cell_source = cell_source
        self.reason = reason
        self.html_path = html_path
        self.timed_out = timed_out
        where = "before any cell ran" if cell_index is None else f"in {self.where}"
        lines = (cell_source or "").strip().splitlines()
        shown = "\n".join("    " + line for line in lines[:8])
        if len(lines) > 8:
            shown += f"\n    ... ({len(lines) - 8} more lines)"
        message = f"{self.lab.name}: {where}: {reason}"
        if shown:
            message += f"\n  the cell:\n{shown}"
        if html_path is not None:
            message += f"\n  partial HTML (outputs up to this cell): {html_path}"
        super().__init__(message)

    @property
    def where(self) -> str:
        """The failing cell, as Jupyter users count: "code cell 2 (cell 3 of the notebook)"."""
        if self.cell_index is None:
            return "no cell"
        place = f"cell {self.cell_index + 1} of the notebook"
        return f"code cell {self.code_cell} ({place})" if self.code_cell else place


class LabRun(NamedTuple):
    """One lab's result in `run_all`.

    **Fields:** `lab` (the notebook), `title` (its first heading), `html_path` (its
    executed HTML copy, partial when it failed; None if none was written), `seconds` (the
    run time) and `error` (the `LabError`, or None when the lab ran to the end).
    """

    lab: pathlib.Path
    title: str
    html_path: pathlib.Path | None
    seconds: float
    error: LabError | None = None


def list_labs(directory: pathlib.Path | str | None = None) -> list[pathlib.Path]:
    """The numbered lab notebooks (`NN_topic.ipynb`), in syllabus order.

    **Arguments:**

    - `directory`: the folder to look in; `None` means `$GFXLAB_LABS`, else the labs
      shipped with gfxlab.

    **Returns:** the notebook paths, sorted (an empty list when the folder holds none).

    **Raises:** `NotADirectoryError` when `directory` (or `$GFXLAB_LABS`) is not an
    existing folder; `TypeError` when `directory` is not a path.
    """
    from . import _runner

    if directory is not None:
        directory = _check_folder(directory, "directory")
    return _runner.list_labs(directory)


def find_lab(name: str, directory: pathlib.Path | str | None = None) -> pathlib.Path:
    """A lab by path, number (`3`, `"03"`) or name (`"03_transforms"`, `"transforms"`).

    **Arguments:**

    - `name`: an existing `.ipynb` path, a lab number or a part of a lab's name.
    - `directory`: where to look, as in `list_labs`.

    **Returns:** the notebook's path.

    **Raises:** `LookupError` (listing the labs) when `name` matches no lab or several;
    `TypeError` when `name` is not a string, path or whole number.
    """
    from . import _runner

    if isinstance(name, bool) or not isinstance(name, str | int | os.PathLike):
        raise TypeError(
            f"`name` must be a lab number, a part of a lab's name or a notebook path, "
            f"got {type(name).__name__}"
        )
    if directory is not None:
        directory = _check_folder(directory, "directory")
    return _runner.find_lab(os.fspath(name) if not isinstance(name, int) else str(name), directory)


def lab_title(path: pathlib.Path | str) -> str:
    """A notebook's title.

    **Arguments:**

    - `path`: the `.ipynb` file.

    **Returns:** its first Markdown heading, without the `#`s (the file's name if it has
    no heading).

    **Raises:** as `run_lab` for a `path` that is not a readable `.ipynb` file.
    """
    from . import _runner

    return _runner.lab_title(_check_notebook(path))


def _check_timeout(timeout) -> float:
    """`timeout` as seconds per cell: a positive, finite number (not a bool)."""
    return positive_number(timeout, "timeout", what="number of seconds")


def run_lab(
    path: pathlib.Path | str,
    out_dir: pathlib.Path | str,
    *,
    timeout: float = 600,
    cache: bool = True,
) -> pathlib.Path:
    """Execute a lab notebook top to bottom in a fresh, headless kernel and write it as HTML.

    The executed notebook is written next to the HTML copy (`out_dir/<name>.ipynb`).

    **Arguments:**

    - `path`: the `.ipynb` file (see `find_lab` to name a lab by number).
    - `out_dir`: folder for `<notebook name>.html` (created if missing).
    - `timeout`: seconds allowed per cell, a positive number.
    - `cache`: give the kernel the JAX persistent compilation cache (`jax_cache_dir()`).

    **Returns:** the path of the HTML file.

    **Raises:** `LabError` (naming the cell, with the partial HTML already written) when
    a cell raises, runs longer than `timeout`, or the kernel dies; `ValueError` for a
    `timeout` that is not positive and finite or a `path` that is not a readable `.ipynb`
    file;
    `FileNotFoundError` when there is no notebook at `path`; `TypeError` for a `timeout`
    that is not a number or a `cache` that is not `True`/`False`.
    """
    from . import _runner

    return _runner.run_lab(
        _check_notebook(path),
        out_dir,
        timeout=_check_timeout(timeout),
        cache=flag(cache, "cache"),
    )


def _check_folder(directory, name: str) -> pathlib.Path:
    if not isinstance(directory, str | os.PathLike):
        raise TypeError(f"`{name}` must be a folder path, got {type(directory).__name__}")
    folder = pathlib.Path(directory)
    if not folder.is_dir():
        raise NotADirectoryError(f"`{name}` must be an existing folder, got {str(folder)!r}")
    return folder


def _check_notebook(path, name: str = "path") -> pathlib.Path:
    """`path` as an existing `.ipynb` file, or a clear error (not nbformat's JSON error)."""
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"`{name}` must hold notebook paths, got {type(path).__name__}")
    notebook = pathlib.Path(path)
    if notebook.suffix != ".ipynb":
        raise ValueError(
            f"`{name}` must be a Jupyter notebook (a .ipynb file), got {str(notebook)!r}"
        )
    if not notebook.is_file():
        raise FileNotFoundError(f"`{name}`: no notebook at {str(notebook)!r}")
    return notebook


def run_all(
    out_dir: pathlib.Path | str,
    *,
    labs: list[pathlib.Path] | None = None,
    timeout: float = 600,
    cache: bool = True,
    log: Callable[[LabRun], Any] | None = None,
) -> tuple[pathlib.Path, list[LabRun]]:
    """Run every lab (or `labs`), write their HTML and an `index.html`; never stops early.

    **Arguments:**

    - `out_dir`: folder for the HTML copies and the index (created if missing).
    - `labs`: the notebooks to run; `None` means `list_labs()`.
    - `timeout`, `cache`: as in `run_lab`, for every lab.
    - `log`: called with each lab's `LabRun` as soon as it has run (e.g. to print it).

    **Returns:** the path of `index.html` and one `LabRun` per lab, in order (a failed
    lab has its `LabError` in `.error`).

    **Raises:** before any lab runs, the errors of `run_lab` for a bad `timeout`,
    `cache` or notebook path in `labs`.
    """
    from . import _runner

    timeout, cache = _check_timeout(timeout), flag(cache, "cache")
    if log is not None and not callable(log):
        raise TypeError(f"`log` must be a function of a LabRun or None, got {type(log).__name__}")
    if labs is not None:  # every notebook checked before the first kernel starts
        if isinstance(labs, str | bytes | os.PathLike) or not hasattr(labs, "__iter__"):
            raise TypeError(f"`labs` must be a list of notebook paths, got {type(labs).__name__}")
        labs = [_check_notebook(lab, "labs") for lab in labs]
    return _runner.run_all(out_dir, labs=labs, timeout=timeout, cache=cache, log=log)


def write_index(out_dir: pathlib.Path | str, runs: list[LabRun]) -> pathlib.Path:
    """Write the gallery page `out_dir/index.html`: one line per lab, linking its HTML copy.

    **Arguments:**

    - `out_dir`: the folder holding the labs' HTML copies (created if missing).
    - `runs`: one `LabRun` per lab (its status and time are shown; a failure in red).

    **Returns:** the path of `index.html`.
    """
    from . import _runner

    return _runner.write_index(pathlib.Path(out_dir), runs)


def jax_cache_dir() -> pathlib.Path:
    """Where the lab kernels keep the JAX compilation cache.

    `$GFXLAB_JAX_CACHE` (`CACHE_ENV`), else JAX's own `$JAX_COMPILATION_CACHE_DIR`, else
    `~/.cache/gfxlab/jax` (`$XDG_CACHE_HOME/gfxlab/jax` when `XDG_CACHE_HOME` is set). It
    is private to the user running the labs; nothing else reads it.

    **Returns:** the folder's path (it may not exist yet).
    """
    from . import _runner

    return _runner.jax_cache_dir()


def kernel_env(*, cache: bool = True) -> dict[str, str]:
    """The environment a lab kernel runs with (e.g. to run the labs with another tool).

    **Arguments:**

    - `cache`: switch on the JAX persistent compilation cache in `jax_cache_dir()`
      (created if missing).

    **Returns:** this process's environment with `HEADLESS_ENV` set to `"1"`, the labs'
    XLA flag (`lab_xla_flags`) and inline matplotlib figures.
    """
    from . import _runner

    return _runner.kernel_env(cache=flag(cache, "cache"))
