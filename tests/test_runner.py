"""The lab runner: gallery index, clear errors naming the cell, timeouts, headless sliders.

Uses tiny synthetic notebooks (a kernel start each), never a real lab.
"""

import base64
import os
import pathlib
import subprocess
import sys

import nbformat
import pytest

import gfxlab.labs as glabs

# A 1x1 GIF, to check that animations embedded as <img> survive into the HTML copy.
GIF = base64.b64encode(
    bytes.fromhex(
        "47494638396101000100800000000000ffffff21f90401000000002c00000000010001000002024401003b"
    )
).decode()


def _notebook(path: pathlib.Path, *codes: str, title: str = "A tiny lab") -> pathlib.Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell(f"# {title}")]
    nb.cells += [nbformat.v4.new_code_cell(code) for code in codes]
    nbformat.write(nb, path)
    return path


@pytest.fixture
def labs(tmp_path, monkeypatch):
    folder = tmp_path / "labs"
    folder.mkdir()
    monkeypatch.setenv("GFXLAB_LABS", str(folder))
    monkeypatch.setenv(glabs.CACHE_ENV, str(tmp_path / "jax-cache"))
    return folder


def test_run_all_writes_pages_and_an_index(labs, tmp_path):
    _notebook(
        labs / "01_good.ipynb",
        "import os\nprint('cache:', os.environ['JAX_COMPILATION_CACHE_DIR'])\n"
        "print('headless:', os.environ['GFXLAB_HEADLESS'])",
        "from IPython.display import HTML\n"
        f'HTML(\'<img alt="walk" src="data:image/gif;base64,{GIF}">\')',
        title="Good lab",
    )
    _notebook(
        labs / "02_bad.ipynb", "x = 1", "raise ValueError('the figure lies')", title="Bad lab"
    )
    out = tmp_path / "site"
    index, runs = glabs.run_all(out, timeout=120)

    assert [r.lab.stem for r in runs] == ["01_good", "02_bad"]
    good, bad = runs
    assert good.error is None and good.html_path == out / "01_good.html"
    page = good.html_path.read_text()
    assert f"cache: {tmp_path / 'jax-cache'}" in page and "headless: 1" in page
    assert f"data:image/gif;base64,{GIF}" in page
    assert (tmp_path / "jax-cache").is_dir()

    assert bad.error is not None and bad.error.cell_index == 2 and not bad.error.timed_out
    assert bad.error.code_cell == 2  # after the title's Markdown cell
    assert "ValueError: the figure lies" in bad.error.reason
    assert "raise ValueError" in bad.error.cell_source
    assert (out / "02_bad.html").exists()  # the partial copy

    text = index.read_text()
    assert index == out / "index.html"
    assert '<a href="01_good.html">Good lab</a>' in text
    assert '<a href="02_bad.html">Bad lab</a>' in text
    assert (
        "failed in code cell 2 (cell 3 of the notebook)" in text
        and "ValueError: the figure lies" in text
    )


def test_write_index_from_runs_made_by_hand(tmp_path):
    # e.g. labs run one by one with run_lab, then one gallery page for all of them
    lab = _notebook(tmp_path / "05_curves.ipynb", "print(1)", title="Curves & <surfaces>")
    assert glabs.lab_title(lab) == "Curves & <surfaces>"
    untitled = nbformat.v4.new_notebook()
    untitled.cells = [nbformat.v4.new_markdown_cell("no heading"), nbformat.v4.new_code_cell("2")]
    nbformat.write(untitled, tmp_path / "06_x.ipynb")
    assert glabs.lab_title(str(tmp_path / "06_x.ipynb")) == "06_x"
    error = glabs.LabError(lab, 2, "1/0", "ZeroDivisionError: division by zero", None, code_cell=1)
    runs = [
        glabs.LabRun(lab, glabs.lab_title(lab), tmp_path / "05_curves.html", 1.25),
        glabs.LabRun(tmp_path / "06_x.ipynb", "X", None, 3.0, error),
    ]
    text = glabs.write_index(tmp_path, runs).read_text()
    assert '<a href="05_curves.html">Curves &amp; &lt;surfaces&gt;</a>' in text
    assert "1.2 s" in text or "1.3 s" in text
    assert "failed in code cell 1 (cell 3 of the notebook)</span>: ZeroDivisionError" in text


def test_run_lab_names_the_failing_cell(labs, tmp_path):
    path = _notebook(labs / "03_oops.ipynb", "print('first')", "assert 1 + 1 == 3, 'arithmetic'")
    with pytest.raises(glabs.LabError) as info:
        glabs.run_lab(path, tmp_path / "out", timeout=120, cache=False)
    err = info.value
    assert err.cell_index == 2 and "AssertionError: arithmetic" in str(err)
    assert "assert 1 + 1 == 3" in str(err) and str(err.html_path) in str(err)
    page = err.html_path.read_text()
    assert "first" in page and "stopped here" in page
    with pytest.raises(ValueError, match="timeout"):
        glabs.run_lab(path, tmp_path / "out", timeout=0)


def test_cli_timeout_is_a_clear_message_with_partial_html(labs, tmp_path):
    _notebook(
        labs / "04_slow.ipynb",
        "print('done before the slow cell')",
        "import time\ntime.sleep(60)",
        "print('never')",
    )
    out = tmp_path / "out"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gfxlab",
            "run",
            "slow",
            "--timeout",
            "1",
            "--out",
            str(out),
            "--no-cache",
        ],
        capture_output=True,
        text=True,
        env=dict(os.environ),
        timeout=120,
    )
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr, proc.stderr
    assert (
        "04_slow.ipynb: in code cell 2 (cell 3 of the notebook): the cell did not finish within 1 s"
        in proc.stderr
    )
    assert "time.sleep(60)" in proc.stderr and "--timeout" in proc.stderr
    page = (out / "04_slow.html").read_text()
    assert "done before the slow cell" in page and "did not finish within 1 s" in page
    assert "never" not in page.split("time.sleep(60)")[-1].split("stopped here")[0]


def test_cli_rejects_a_bad_timeout_and_an_unknown_lab(labs):
    run = [sys.executable, "-m", "gfxlab", "run"]
    bad = subprocess.run(run + ["all", "--timeout", "0"], capture_output=True, text=True)
    assert bad.returncode == 2 and "--timeout must be a positive" in bad.stderr
    missing = subprocess.run(run + ["nonesuch"], capture_output=True, text=True)
    assert missing.returncode == 2 and "matches no lab" in missing.stderr


def test_jax_cache_dir_is_the_users_and_overridable(monkeypatch, tmp_path):
    monkeypatch.delenv(glabs.CACHE_ENV, raising=False)
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert glabs.jax_cache_dir() == pathlib.Path.home() / ".cache" / "gfxlab" / "jax"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert glabs.jax_cache_dir() == tmp_path / "xdg" / "gfxlab" / "jax"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "jax-own"))
    assert glabs.jax_cache_dir() == tmp_path / "jax-own"  # e.g. a cold cache for timing
    monkeypatch.setenv(glabs.CACHE_ENV, str(tmp_path / "mine"))
    env = glabs.kernel_env()
    assert env["JAX_COMPILATION_CACHE_DIR"] == str(tmp_path / "mine")
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    assert "JAX_COMPILATION_CACHE_DIR" not in glabs.kernel_env(cache=False)


def test_the_runner_marks_its_kernels_headless():
    assert glabs.HEADLESS_ENV == "GFXLAB_HEADLESS"
    assert glabs.kernel_env(cache=False)[glabs.HEADLESS_ENV] == "1"


def test_lab_kernels_get_the_labs_xla_flag_once_and_the_users_choice_wins(monkeypatch, tmp_path):
    """The flag is probed in a child once per jaxlib (this one accepts it), the answer kept
    on disk and read from there (a cache folder that says "rejected" leaves the flag out);
    flags that already choose the emitters are left alone."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "probed"))
    assert glabs.lab_xla_flags("--xla_dump_to=/x") == f"--xla_dump_to=/x {glabs.LAB_XLA_FLAG}"
    (answer,) = (tmp_path / "probed" / "gfxlab").iterdir()
    assert answer.read_text() == "accepted\n"
    assert glabs.lab_xla_flags("--a") == f"--a {glabs.LAB_XLA_FLAG}"  # the same answer
    assert list((tmp_path / "probed" / "gfxlab").iterdir()) == [answer]
    rejected = tmp_path / "rejected" / "gfxlab" / answer.name  # e.g. a jaxlib without the flag
    rejected.parent.mkdir(parents=True)
    rejected.write_text("rejected\n")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "rejected"))
    assert glabs.lab_xla_flags("--a") == "--a"
    mine = "--xla_cpu_use_fusion_emitters=true"
    assert glabs.lab_xla_flags(mine) == mine
    monkeypatch.setenv("XLA_FLAGS", mine)
    assert glabs.kernel_env(cache=False)["XLA_FLAGS"] == mine
    with pytest.raises(TypeError, match="`flags`"):
        glabs.lab_xla_flags(["--a"])


def test_interact_shows_the_default_picture_once_when_headless(monkeypatch):
    import ipywidgets

    calls = []

    def draw(a, b, c, d=0.5):
        calls.append((a, b, c, d))
        return a + b

    monkeypatch.setenv(glabs.HEADLESS_ENV, "1")
    assert glabs.headless()
    result = glabs.interact(
        draw,
        a=ipywidgets.FloatSlider(value=0.25, min=0, max=1),
        b=3,  # an abbreviation: a slider starting at 3
        c=ipywidgets.fixed(7),
    )
    assert calls == [(0.25, 3, 7, 0.5)] and result == 3.25
    calls.clear()
    assert glabs.interact(draw, a=(0.0, 2.0, 0.5), b=ipywidgets.fixed(1), c=[4, 5]) == 2.0
    assert calls == [(1.0, 1, 4, 0.5)]  # a slider's middle, a drop-down's first entry


def test_interact_in_a_live_notebook_shows_widgets_and_draws_once(monkeypatch, capsys):
    calls = []
    monkeypatch.delenv(glabs.HEADLESS_ENV, raising=False)
    assert not glabs.headless()
    assert glabs.interact(lambda x=2.0: calls.append(x) or x * 10, x=(0.0, 4.0)) == 20.0
    assert calls == [2.0]
    assert "interactive" in capsys.readouterr().out  # the panel (repr outside IPython)
    assert glabs.interact(lambda x: calls.append(x), manual=True, x=(0.0, 4.0)) is None
    assert calls == [2.0], "manual: nothing is drawn before the button is pressed"


@pytest.mark.parametrize("headless", ["1", ""])
def test_interact_rejects_bad_input(monkeypatch, headless):
    monkeypatch.setenv(glabs.HEADLESS_ENV, headless)
    with pytest.raises(TypeError, match="`fn` must be a function"):
        glabs.interact(None, x=1)
    with pytest.raises(TypeError, match="`manual` must be True or False"):
        glabs.interact(lambda x: x, manual="yes", x=1)
    with pytest.raises(TypeError, match=r"\['y'\] name no argument of `fn`"):
        glabs.interact(lambda x: x, x=1, y=2)
    with pytest.raises(ValueError, match="cannot find widget or abbreviation"):
        glabs.interact(lambda x, y: x, x=1)
    with pytest.raises(ValueError):
        glabs.interact(lambda x: x, x=object())


def test_import_gfxlab_labs_is_light():
    code = (
        "import sys, gfxlab, gfxlab.labs\n"
        "heavy = [m for m in ('ipywidgets', 'matplotlib', 'jax', 'IPython') if m in sys.modules]\n"
        "assert not heavy, heavy"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
