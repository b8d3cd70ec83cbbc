"""Package-level promises: light imports, the CLI and the lab runner."""

import pathlib
import subprocess
import sys

import nbformat
import pytest

from gfxlab import labs as glabs

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _python(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return out.stdout.strip()


@pytest.mark.parametrize("module", ["gfxlab", "gfxlab.transforms", "gfxlab.viewing", "gfxlab.fit"])
def test_imports_stay_light(module):
    heavy = _python(
        f"import sys, {module}; print(' '.join(m for m in ('colour', 'matplotlib', 'PIL') "
        "if m in sys.modules))"
    )
    assert heavy == ""


def test_the_lab_runner_is_public_and_gfxlab_labs_stays_light():
    loaded = _python(
        "import sys, gfxlab.labs; print(' '.join(m for m in ('gfxlab._runner', 'nbformat', "
        "'nbclient', 'ipywidgets', 'jax', 'argparse') if m in sys.modules))"
    )
    assert loaded == ""
    for name in ("run_lab", "run_all", "list_labs", "find_lab", "LabError", "LabRun"):
        assert name in glabs.__all__ and "**" in getattr(glabs, name).__doc__, name


def test_import_gfxlab_is_fast_after_first_import():
    seconds = float(
        _python(
            "import time; t = time.perf_counter(); import gfxlab; print(time.perf_counter() - t)"
        )
    )
    assert seconds < 1.0


def test_lazy_submodules():
    import gfxlab

    assert gfxlab.transforms.translate is not None
    with pytest.raises(AttributeError, match="no attribute"):
        gfxlab.not_a_module  # noqa: B018


def test_cli_usage_and_unknown_command():
    ok = subprocess.run([sys.executable, "-m", "gfxlab", "--help"], capture_output=True, text=True)
    assert ok.returncode == 0 and "labs" in ok.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "gfxlab", "frobnicate"], capture_output=True, text=True
    )
    assert bad.returncode == 2 and "unknown command" in bad.stderr


def test_cli_lists_the_labs():
    out = subprocess.run(
        [sys.executable, "-m", "gfxlab", "labs"], capture_output=True, text=True, cwd=ROOT
    )
    assert out.returncode == 0
    assert "00_welcome" in out.stdout and "03_transforms_and_viewing" in out.stdout


def _notebook(path: pathlib.Path, code: str) -> pathlib.Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# A tiny lab"), nbformat.v4.new_code_cell(code)]
    nbformat.write(nb, path)
    return path


def test_run_writes_html_and_reports_failure(tmp_path, monkeypatch):
    labs = tmp_path / "labs"
    labs.mkdir()
    _notebook(labs / "01_good.ipynb", "print(6 * 7)")
    _notebook(labs / "02_bad.ipynb", "raise RuntimeError('boom')")
    monkeypatch.setenv("GFXLAB_LABS", str(labs))
    assert [p.stem for p in glabs.list_labs()] == ["01_good", "02_bad"]
    assert glabs.find_lab("1").stem == "01_good"
    assert glabs.find_lab("bad").stem == "02_bad"
    with pytest.raises(LookupError, match="no lab"):
        glabs.find_lab("missing")

    out = tmp_path / "out"
    good = subprocess.run(
        [sys.executable, "-m", "gfxlab", "run", "01", "--out", str(out)],
        capture_output=True,
        text=True,
        env={**_env(), "GFXLAB_LABS": str(labs)},
    )
    assert good.returncode == 0, good.stderr
    assert "42" in (out / "01_good.html").read_text()
    bad = subprocess.run(
        [sys.executable, "-m", "gfxlab", "run", "bad", "--out", str(out)],
        capture_output=True,
        text=True,
        env={**_env(), "GFXLAB_LABS": str(labs)},
    )
    assert bad.returncode == 1 and "boom" in bad.stderr
    assert (out / "02_bad.html").exists()


def _env():
    import os

    return dict(os.environ)
