"""The lab runner behind `python -m gfxlab labs` and `python -m gfxlab run LAB`."""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time


def labs_dir() -> pathlib.Path:
    """Where the labs are: `$GFXLAB_LABS`, else `labs/` next to the package (a checkout)."""
    env = os.environ.get("GFXLAB_LABS")
    if env:
        return pathlib.Path(env)
    return pathlib.Path(__file__).resolve().parents[1] / "labs"


def list_labs(directory: pathlib.Path | None = None) -> list[pathlib.Path]:
    """The numbered lab notebooks, in syllabus order."""
    directory = labs_dir() if directory is None else directory
    return sorted(p for p in directory.glob("[0-9][0-9]_*.ipynb"))


def _title(path: pathlib.Path) -> str:
    import nbformat

    nb = nbformat.read(path, as_version=4)
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
    key = name.removesuffix(".ipynb")
    if key.isdigit():
        key = f"{int(key):02d}_"
    matches = [p for p in labs if p.stem.startswith(key) or key in p.stem.split("_", 1)[-1]]
    if len(matches) == 1:
        return matches[0]
    names = ", ".join(p.stem for p in labs) or "(none found)"
    what = "matches several labs" if matches else "matches no lab"
    raise LookupError(f"{name!r} {what}; the labs are: {names}")


def run_lab(path: pathlib.Path, out_dir: pathlib.Path, *, timeout: int = 600) -> pathlib.Path:
    """Execute a notebook in a fresh kernel and write `out_dir/<name>.html`.

    Raises `nbclient.exceptions.CellExecutionError` when a cell fails (the HTML with
    the error is written first).
    """
    import nbformat
    from nbclient import NotebookClient
    from nbclient.exceptions import CellExecutionError
    from nbconvert import HTMLExporter

    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(
        nb,
        timeout=timeout,
        kernel_name="python3",
        resources={"metadata": {"path": str(path.parent)}},
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    html_path = out_dir / f"{path.stem}.html"
    failure = None
    try:
        client.execute()
    except CellExecutionError as err:
        failure = err
    body, _ = HTMLExporter().from_notebook_node(nb)
    html_path.write_text(body, encoding="utf-8")
    if failure is not None:
        raise failure
    return html_path


def main(command: str, argv: list[str]) -> int:
    if command == "labs":
        parser = argparse.ArgumentParser(prog="python -m gfxlab labs", description="List the labs.")
        parser.parse_args(argv)
        labs = list_labs()
        if not labs:
            print(f"no labs found in {labs_dir()} (set GFXLAB_LABS to the labs folder)")
            return 1
        for path in labs:
            print(f"{path.stem:<45} {_title(path)}")
        return 0

    parser = argparse.ArgumentParser(
        prog="python -m gfxlab run",
        description="Execute a lab headless in a fresh kernel and write an HTML copy.",
    )
    parser.add_argument("lab", help="lab path, number (e.g. 3) or name (e.g. transforms)")
    parser.add_argument("--out", default="out", help="folder for the HTML copy (default: out/)")
    parser.add_argument("--timeout", type=int, default=600, help="seconds allowed per cell")
    args = parser.parse_args(argv)
    try:
        path = find_lab(args.lab)
    except LookupError as err:
        print(err, file=sys.stderr)
        return 2
    from nbclient.exceptions import CellExecutionError

    start = time.perf_counter()
    try:
        html = run_lab(path, pathlib.Path(args.out), timeout=args.timeout)
    except CellExecutionError as err:
        print(f"{path.name}: a cell failed\n{err}", file=sys.stderr)
        return 1
    print(f"{path.name}: ran in {time.perf_counter() - start:.1f} s -> {html}")
    return 0
