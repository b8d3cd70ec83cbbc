"""The lab runner behind `python -m gfxlab labs` and `python -m gfxlab run LAB|all`.

Its public face is `gfxlab.labs` (`run_lab`, `run_all`, `list_labs`, `LabError`, ...),
which imports this module on first use. `run_lab(path, out_dir)` executes one notebook
in a fresh kernel and writes `out_dir/<name>.html`; a cell that fails or runs past the
timeout raises `LabError` naming the cell, after the partial HTML (everything up to and
including that cell) has been written. `run_all` runs every lab and writes an
`index.html` gallery next to the pages.

The kernels get the JAX persistent compilation cache (`jax_cache_dir()`), so a second
run of a lab skips most XLA compilation, and `GFXLAB_HEADLESS=1`, which makes
`gfxlab.labs.interact` show a slider figure's default picture once instead of a widget.
"""

from __future__ import annotations

import argparse
import html
import os
import pathlib
import subprocess
import sys
import tempfile
import time

# HEADLESS_ENV is "1" in the kernels the runner starts; the public face of this module is
# `gfxlab.labs` (run_lab, run_all, ...), which imports it lazily.
from .labs import CACHE_ENV, HEADLESS_ENV, LabError, LabRun, _check_timeout, lab_xla_flags

# nbformat validates notebooks with jsonschema, which imports `rfc3987_syntax` for its
# "iri" format when that package is installed (JupyterLab pulls it in); it builds an
# Earley parser at import, ~2 s of CPU in every process that reads a notebook. The
# notebook schema uses no "iri" format, so the runner marks the package absent (jsonschema
# then skips that one checker), unless something imported it already.
sys.modules.setdefault("rfc3987_syntax", None)


def labs_dir() -> pathlib.Path:
    """Where the labs are: `$GFXLAB_LABS`, else the shipped labs (`labs/` of a checkout)."""
    env = os.environ.get("GFXLAB_LABS")
    if env:
        return pathlib.Path(env)
    from ._resources import labs_dir as shipped

    return shipped()


def jax_cache_dir() -> pathlib.Path:
    """`gfxlab.labs.jax_cache_dir`: the lab kernels' JAX compilation cache."""
    for name in (CACHE_ENV, "JAX_COMPILATION_CACHE_DIR"):
        env = os.environ.get(name)
        if env:
            return pathlib.Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "gfxlab" / "jax"


def kernel_env(*, cache: bool = True) -> dict[str, str]:
    """The environment of a lab kernel: ours, headless, with the JAX cache switched on and
    the labs' XLA flag (`gfxlab.labs.lab_xla_flags`)."""
    env = dict(os.environ)
    env[HEADLESS_ENV] = "1"
    env["XLA_FLAGS"] = lab_xla_flags(env.get("XLA_FLAGS", ""))
    # figures go inline into the notebook, whatever backend the caller uses (e.g. Agg)
    env["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
    if cache:
        directory = jax_cache_dir()
        directory.mkdir(parents=True, exist_ok=True)
        env["JAX_COMPILATION_CACHE_DIR"] = str(directory)
        # Cache every program, however quick to compile (the default, 1 s, would skip
        # most of a lab's many small ones, which together take most of its time).
        env.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
    return env


def list_labs(directory: pathlib.Path | None = None) -> list[pathlib.Path]:
    """The numbered lab notebooks, in syllabus order."""
    directory = labs_dir() if directory is None else directory
    if not directory.is_dir():  # only $GFXLAB_LABS can lead here (`labs.list_labs` checks)
        raise NotADirectoryError(f"$GFXLAB_LABS must be an existing folder, got {str(directory)!r}")
    return sorted(p for p in directory.glob("[0-9][0-9]_*.ipynb"))


def lab_title(path: pathlib.Path) -> str:
    """The first Markdown heading of a notebook (its file name if it has none)."""
    nb = read_notebook(path)
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("#"):
                    return line.lstrip("#").strip()
    return path.stem


def find_lab(name: str, directory: pathlib.Path | None = None) -> pathlib.Path:
    """A lab by path, number (`3`, `03`) or name prefix (`03_transforms`, `transforms`)."""
    path = pathlib.Path(name)
    if path.suffix == ".ipynb" and path.exists():
        return path
    labs = list_labs(directory)
    key = name.removesuffix(".ipynb").lower()
    if key.isdigit():
        key = f"{int(key):02d}_"
    stems = [(p, p.stem.lower()) for p in labs]
    matches = [p for p, stem in stems if stem.startswith(key) or key in stem.split("_", 1)[-1]]
    if len(matches) == 1:
        return matches[0]
    names = ", ".join(p.stem for p in labs) or "(none found)"
    what = "matches several labs" if matches else "matches no lab"
    if not matches and path.suffix == ".ipynb":
        what = "is not a notebook file and matches no lab"
    raise LookupError(f"{name!r} {what}; the labs are: {names}")


def read_notebook(path: pathlib.Path):
    """The notebook at `path`; a file that is not one is a `ValueError` naming it."""
    import nbformat

    try:
        return nbformat.read(path, as_version=4)
    except (ValueError, nbformat.ValidationError) as err:  # NotJSONError is a ValueError
        first = (str(err).strip().splitlines() or [type(err).__name__])[0][:200]
        raise ValueError(f"`path` {str(path)!r} is not a readable notebook: {first}") from None


def _html(nb) -> str:
    from nbconvert import HTMLExporter

    exporter = HTMLExporter()
    # nbconvert passes every code cell's highlighted source through bleach (a third of
    # the export time) although pygments has escaped it already; the notebooks are the
    # ones this runner just executed (their code ran on this machine), and their outputs
    # are sanitised or not exactly as before (`sanitize_html`, off by default).
    exporter.register_filter("clean_html", _as_text)
    body, _ = exporter.from_notebook_node(nb)
    return body


def _as_text(element) -> str:
    return element.decode() if isinstance(element, bytes) else str(element)


def _note(cell, text: str) -> None:
    """Append a visible note from the runner to a cell's outputs."""
    import nbformat

    cell.setdefault("outputs", []).append(
        nbformat.v4.new_output("stream", name="stderr", text=f"[gfxlab run] {text}\n")
    )


def run_lab(path, out_dir, *, timeout=600, cache=True) -> pathlib.Path:
    """`gfxlab.labs.run_lab`: execute a lab notebook in a fresh kernel, write its HTML."""
    import nbformat
    from nbclient import NotebookClient
    from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

    path, out_dir = pathlib.Path(path), pathlib.Path(out_dir)
    timeout = _check_timeout(timeout)
    nb = read_notebook(path)
    current: dict = {"index": None}

    def on_cell_start(cell, cell_index, **_):
        current["index"] = cell_index

    client = NotebookClient(
        nb,
        timeout=int(max(1, round(timeout))),
        kernel_name="python3",
        resources={"metadata": {"path": str(path.parent.resolve())}},
        on_cell_start=on_cell_start,
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    html_path = out_dir / f"{path.stem}.html"
    failure = None
    # The kernel's own stderr (start-up warnings, its complaints when stopped at a
    # timeout) goes to a log that is shown only if the kernel dies.
    log = tempfile.TemporaryFile(mode="w+b")
    try:
        client.execute(env=kernel_env(cache=cache), stdout=subprocess.DEVNULL, stderr=log)
    except CellTimeoutError:
        failure = (
            f"the cell did not finish within {timeout:g} s (the per-cell timeout; "
            "raise it with `timeout=SECONDS`, or --timeout SECONDS on the command line)",
            True,
        )
    except CellExecutionError as err:
        failure = (f"{err.ename}: {err.evalue}".strip().splitlines()[0], False)
    except DeadKernelError as err:
        log.seek(0)
        tail = log.read().decode(errors="replace").strip().splitlines()[-5:]
        failure = (f"the kernel died ({err}); its last words: " + " | ".join(tail), False)
    finally:
        log.close()
    index = current["index"]
    cell = nb.cells[index] if index is not None else None
    if failure is not None and cell is not None:
        _note(cell, "stopped here: " + failure[0])
    html_path.write_text(_html(nb), encoding="utf-8")
    # The executed notebook too: the documentation site renders it without running it.
    nbformat.write(nb, out_dir / path.name)
    if failure is not None:
        source = cell.source if cell is not None else ""
        code_cell = sum(c.cell_type == "code" for c in nb.cells[: index + 1]) if cell else None
        raise LabError(
            path, index, source, failure[0], html_path, timed_out=failure[1], code_cell=code_cell
        )
    return html_path


def write_index(out_dir: pathlib.Path, runs: list[LabRun]) -> pathlib.Path:
    """Write `out_dir/index.html`: one line per lab, linking its executed HTML copy."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for run in runs:
        link = run.html_path.name if run.html_path is not None else None
        title = html.escape(run.title)
        name = f'<a href="{html.escape(link)}">{title}</a>' if link else title
        if run.error is None:
            status = '<span class="ok">ran</span>'
        else:
            kind = "timed out" if run.error.timed_out else "failed"
            where = "" if run.error.cell_index is None else f" in {run.error.where}"
            status = f'<span class="bad">{kind}{where}</span>: {html.escape(run.error.reason)}'
        rows.append(
            f"<tr><td>{html.escape(run.lab.stem)}</td><td>{name}</td>"
            f"<td>{status}</td><td>{run.seconds:.1f} s</td></tr>"
        )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>gfxlab labs</title>
<style>
body {{ font-family: sans-serif; max-width: 60em; margin: 2em auto; }}
td, th {{ padding: 0.3em 0.8em; text-align: left; border-bottom: 1px solid #ddd; }}
.ok {{ color: #2a7d2a; }} .bad {{ color: #b00; font-weight: bold; }}
</style></head><body>
<h1>gfxlab labs</h1>
<p>Every lab executed top to bottom, with its figures, animations and videos embedded.
Generated by <code>python -m gfxlab run all</code>.</p>
<table><tr><th>lab</th><th>title</th><th>status</th><th>run time</th></tr>
{chr(10).join(rows)}
</table></body></html>
"""
    path = out_dir / "index.html"
    path.write_text(page, encoding="utf-8")
    return path


def run_all(
    out_dir: pathlib.Path | str,
    *,
    labs: list[pathlib.Path] | None = None,
    timeout: float = 600,
    cache: bool = True,
    log=None,
) -> tuple[pathlib.Path, list[LabRun]]:
    """`gfxlab.labs.run_all`: run every lab (or `labs`), write their HTML and an index."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    runs = []
    for lab in list_labs() if labs is None else labs:
        start = time.perf_counter()
        try:
            page, error = run_lab(lab, out_dir, timeout=timeout, cache=cache), None
        except LabError as err:
            page, error = err.html_path, err
        runs.append(LabRun(lab, lab_title(lab), page, time.perf_counter() - start, error))
        if log is not None:
            log(runs[-1])
    return write_index(out_dir, runs), runs


def _report(run: LabRun) -> None:
    if run.error is None:
        print(f"{run.lab.name}: ran in {run.seconds:.1f} s -> {run.html_path}")
    else:
        print(f"{run.error}\n", file=sys.stderr)


def main(command: str, argv: list[str]) -> int:
    if command == "labs":
        parser = argparse.ArgumentParser(
            prog="python -m gfxlab labs",
            description="List the labs, or copy them into a folder of yours.",
        )
        parser.add_argument(
            "--copy",
            metavar="DIR",
            help="copy the lab notebooks into DIR (files already there are kept)",
        )
        args = parser.parse_args(argv)
        if args.copy:
            from ._resources import copy_labs

            written = copy_labs(args.copy)
            print(f"copied {len(written)} labs into {args.copy}")
            return 0
        labs = list_labs()
        if not labs:
            print(f"no labs found in {labs_dir()} (set GFXLAB_LABS to the labs folder)")
            return 1
        for path in labs:
            print(f"{path.stem:<45} {lab_title(path)}")
        return 0

    parser = argparse.ArgumentParser(
        prog="python -m gfxlab run",
        description="Execute a lab (or all of them) headless in a fresh kernel and write HTML "
        "copies; `all` also writes an index.html gallery.",
        epilog="The kernels use the JAX compilation cache in ~/.cache/gfxlab/jax "
        "($GFXLAB_JAX_CACHE) and XLA's legacy CPU emitters, which compile the labs a third "
        "faster (set XLA_FLAGS=--xla_cpu_use_fusion_emitters=true to keep XLA's choice).",
    )
    parser.add_argument(
        "lab", help="`all`, or a lab path, number (e.g. 3) or name (e.g. transforms)"
    )
    parser.add_argument("--out", default="out", help="folder for the HTML copies (default: out/)")
    parser.add_argument("--timeout", type=float, default=600, help="seconds allowed per cell")
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help=f"do not use the JAX compilation cache ({jax_cache_dir()})",
    )
    args = parser.parse_args(argv)
    if args.timeout <= 0:
        parser.error(f"--timeout must be a positive number of seconds, got {args.timeout:g}")
    out = pathlib.Path(args.out)
    if args.lab == "all":
        if not list_labs():
            print(
                f"no labs found in {labs_dir()} (set GFXLAB_LABS to the labs folder)",
                file=sys.stderr,
            )
            return 2
        index, runs = run_all(out, timeout=args.timeout, cache=not args.no_cache, log=_report)
        failed = [r for r in runs if r.error is not None]
        print(f"{len(runs) - len(failed)} of {len(runs)} labs ran; index: {index}")
        return 1 if failed else 0
    try:
        path = find_lab(args.lab)
    except LookupError as err:
        print(err, file=sys.stderr)
        return 2
    start = time.perf_counter()
    try:
        page, error = run_lab(path, out, timeout=args.timeout, cache=not args.no_cache), None
    except LabError as err:
        page, error = err.html_path, err
    _report(LabRun(path, path.stem, page, time.perf_counter() - start, error))
    return 0 if error is None else 1
