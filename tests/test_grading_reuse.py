"""Answers that call another answer or the library's own implementation score nothing.

Assignment 3 says `de_casteljau` must not use `bezier_point` (and the other way round),
and every assignment forbids gfxlab itself. The submissions below are graded by the real
command line, inside a throwaway namespace like the attack suite; the static part of the
check (`gfxlab.grading.reuse.plan`) is tested on its own, without a sandbox.
"""

import json
import pathlib
import subprocess
import sys

import pytest
from grading_attacks.attacks import write_notebook

from gfxlab.grading import Autograder, Limits, Sandbox, assign, codec, reuse

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCE = ROOT / "labs/assignments/03_bezier.ipynb"
RULES = {"de_casteljau": ["bezier_point"], "bezier_point": ["de_casteljau"]}

BERNSTEIN = """
from math import comb


def _bern(control, u):
    control = jnp.asarray(control)
    n = control.shape[0] - 1
    w = jnp.array([comb(n, i) * u**i * (1 - u) ** (n - i) for i in range(n + 1)])
    return w @ control
"""
DE_CASTELJAU = """
def de_casteljau(control, u):
    points = jnp.asarray(control)
    while points.shape[0] > 1:
        points = (1 - u) * points[:-1] + u * points[1:]
    return points[0]
"""
CHEATS = {
    # The realistic cheat: q1 written for any degree, q2 the same function again.
    "alias": BERNSTEIN + "\n\nbezier_point = _bern\nde_casteljau = bezier_point\n",
    "call": BERNSTEIN
    + "\n\ndef bezier_point(control, u):\n    return _bern(control, u)\n\n\n"
    + "def de_casteljau(control, u):\n    return bezier_point(control, u)\n",
    "shared_helper": BERNSTEIN
    + "\n\ndef bezier_point(control, u):\n    return _bern(control, u)\n\n\n"
    + "def de_casteljau(control, u):\n    return _bern(control, u)\n",
    "container": BERNSTEIN
    + "\n\ndef bezier_point(control, u):\n    return _bern(control, u)\n\n\nTABLE = {}\n\n\n"
    + "def _register():\n    TABLE['f'] = bezier_point\n\n\n_register()\n\n\n"
    + "def de_casteljau(control, u):\n    return TABLE['f'](control, u)\n",
    # Kept in a library's state by the forbidden code, fetched back without its name.
    "library_state": BERNSTEIN
    + "\n\nimport numpy as np\n\n\ndef bezier_point(control, u):\n"
    + "    np.seterrcall(bezier_point)\n    return _bern(control, u)\n\n\n"
    + "def de_casteljau(control, u):\n    return np.geterrcall()(control, u)\n",
    "exec": BERNSTEIN
    + "\n\ndef bezier_point(control, u):\n    return _bern(control, u)\n\n\n"
    + "exec('def de_casteljau(control, u):\\n    return bezier_point(control, u)')\n",
    # The library's own implementation, through a module the assignment did not name.
    "library": DE_CASTELJAU.replace("def de_casteljau", "def _unused")
    + "\n\nfrom gfxlab.animation.deform import bezier_path\n\n\n"
    + "def de_casteljau(control, u):\n    return bezier_path(jnp.asarray(control))(u)\n",
}


# The forbidden function only on inputs the public tests do not use: only hidden tests
# show the rule broken, which must not show before grades are published.
CHEATS["hidden_only"] = (
    BERNSTEIN
    + "\n\ndef bezier_point(control, u):\n    return _bern(control, u)\n\n\n"
    + DE_CASTELJAU.replace("def de_casteljau", "def _own")
    + "\n\ndef de_casteljau(control, u):\n"
    + "    if float(jnp.asarray(control)[0, 0]) == 1.0:  # the public tests' seed\n"
    + "        return _own(control, u)\n"
    + "    return bezier_point(control, u)\n"
)

# Handed to a library by a decorator: no name of it is written anywhere else.
CHEATS["decorator"] = (
    BERNSTEIN
    + "\n\nimport numpy as np\n\n\n@(lambda f: np.seterrcall(f) or f)\n"
    + "def bezier_point(control, u):\n    return _bern(control, u)\n\n\n"
    + "def de_casteljau(control, u):\n    return np.geterrcall()(control, u)\n"
)
# Through library state, which no reading of names can follow: caught only because the
# second sandbox runs for every rule.
THROUGH_STATE = ("library_state", "decorator")

# Graded through the command line (JAX start-up is slow: the others only statically).
GRADED = ["container", "hidden_only", *THROUGH_STATE]


def _cells(reference, q12):
    """The reference solution with q1 and q2 replaced by `q12` (a demo line kept)."""
    out = []
    for cell in reference:
        if "def bezier_point" in cell:
            out.append(q12)
        elif "def de_casteljau" in cell:
            continue
        else:
            out.append(cell)
    return out


def test_forbidding_gfxlab_keeps_only_the_public_test_helpers():
    from gfxlab.grading.sandbox import expand_forbidden

    names = expand_forbidden(["gfxlab", "bezier"])
    for module in ("gfxlab.curves", "gfxlab.animation", "gfxlab.exam", "gfxlab.jpeg"):
        assert module in names
    assert "bezier" in names and "gfxlab" not in names
    assert not any(n.startswith(("gfxlab.grading", "gfxlab._resources")) for n in names)


def test_static_plan_of_the_cheats():
    for name, source in CHEATS.items():
        cells = ["import jax.numpy as jnp", source]
        verdicts = {v.function: v for v in reuse.plan(cells, RULES)}
        q2 = verdicts["de_casteljau"]
        if name == "exec":
            assert q2.hatch == "`exec`"
        elif name in ("library", *THROUGH_STATE):
            assert not q2.dynamic and q2.hatch is None  # the import stub / the rerun stops it
        else:
            assert q2.dynamic, name
    # An honest notebook needs no second sandbox; a demo line using both needs one.
    honest = ["import jax.numpy as jnp", BERNSTEIN.replace("_bern", "bezier_point"), DE_CASTELJAU]
    assert not any(v.dynamic or v.hatch for v in reuse.plan(honest, RULES))
    demo = [*honest, "print(bezier_point([[0.0], [1.0]], 0.5), de_casteljau([[0.0], [1.0]], 0.5))"]
    assert all(v.dynamic for v in reuse.plan(demo, RULES))
    # bezier_point written with de_casteljau breaks the other rule only.
    q1_uses_q2 = [
        "import jax.numpy as jnp",
        DE_CASTELJAU,
        "def bezier_point(c, u):\n    return de_casteljau(c, u)",
    ]
    verdicts = {v.function: v for v in reuse.plan(q1_uses_q2, RULES)}
    assert verdicts["bezier_point"].dynamic and not verdicts["de_casteljau"].dynamic
    assert verdicts["de_casteljau"].closure == {"bezier_point"}


def test_notebooks_too_large_to_analyse_are_hatches_found_fast():
    import time

    # CPU seconds of this process, not wall time (other work on the machine does not
    # count); the quadratic analysis this guards against took 84 s for 1,000 lines.

    honest = ["import jax.numpy as jnp", BERNSTEIN.replace("_bern", "bezier_point"), DE_CASTELJAU]
    for lines in (30_000, 300_000):  # beyond MAX_NODES; beyond what is even parsed
        filler = "\n".join(f"a{i} = jnp.pi" for i in range(lines))
        started = time.process_time()
        verdicts = reuse.plan([*honest, filler], RULES)
        assert time.process_time() - started < 5
        assert all("too many to be checked" in v.hatch for v in verdicts)
    chain = "\n".join(f"a{i} = a{i - 1}.x" if i else "a0 = jnp.x" for i in range(3000))
    started = time.process_time()  # module aliases found in one pass, not one per link
    assert not any(v.hatch for v in reuse.plan([*honest, chain], RULES))
    assert time.process_time() - started < 5


def test_cells_too_deep_for_the_parser_are_hatches_not_crashes():
    """`1+1+...+1`, `x.a.a...`, `f()()...` 3000 deep: Python's `ast.parse` raises
    RecursionError; the rule cannot be checked (0 points for it), nothing crashes."""
    honest = ["import jax.numpy as jnp", BERNSTEIN.replace("_bern", "bezier_point"), DE_CASTELJAU]
    for deep in (
        "_z = " + "+".join(["1"] * 3000),
        "_t = (1)" + ".real" * 3000,
        "_u = de_casteljau" + "()" * 3000,
        "_v = " + "-" * 150 + "1",  # parses, but too deep to rewrite for the second sandbox
    ):
        verdicts = reuse.plan([*honest, deep], RULES)
        assert [v.hatch for v in verdicts] == ["a cell nested too deeply to be checked"] * 2
        assert reuse.plan([*honest, deep], {}) == []  # no rule: nothing to check
        assert reuse.check_cells([*honest, deep], {"bezier_point"}, "t")[-2] == deep
    assert not any(v.hatch for v in reuse.plan([*honest, "_z = " + "+".join("1" * 50)], RULES))


def test_module_aliases_are_imports_and_writes_to_modules_bind_them():
    """`jnp = jax.numpy` is an import (an honest notebook keeps every mark); a helper
    stored on a module (`np.bernstein_eval = general`) is shared through it."""
    aliased = [
        "import jax\njnp = jax.numpy",
        BERNSTEIN.replace("_bern", "bezier_point"),
        DE_CASTELJAU,
    ]
    assert not any(v.dynamic or v.hatch for v in reuse.plan(aliased, RULES))
    # An alias of a name the notebook rebinds is not an import.
    rebound = [*aliased, "jax = None"]
    assert all("jnp" in v.closure for v in reuse.plan(rebound, RULES))
    stored = [
        "import jax.numpy as jnp\nimport numpy as np",
        BERNSTEIN.replace("_bern", "general"),
        "np.bernstein_eval = general",
        "def bezier_point(control, u):\n    return np.bernstein_eval(control, u)",
        "def de_casteljau(control, u):\n    return np.bernstein_eval(control, u)",
    ]
    verdicts = {v.function: v for v in reuse.plan(stored, RULES)}
    assert verdicts["de_casteljau"].dynamic
    assert verdicts["de_casteljau"].closure >= {"bezier_point", "np", "general"}
    checked = "\n".join(reuse.check_cells(stored, verdicts["de_casteljau"].closure, "t"))
    assert "w @ control" not in checked and "np = _gx_unavailable_t('np')" in checked


def test_check_cells_remove_the_forbidden_code():
    cells = ["import jax.numpy as jnp", CHEATS["container"]]
    closure = reuse.plan(cells, RULES)[0].closure
    assert closure == {"bezier_point", "_bern"}
    checked = reuse.check_cells(cells, closure, "t0k")
    text = "\n".join(checked)
    assert "w @ control" not in text  # the Bernstein code is not in the second process
    assert "bezier_point = _gx_unavailable_t0k('bezier_point')" in text
    assert "try:\n    _register()\nexcept Exception:\n    pass" in text
    namespace = {}
    for cell in checked:
        exec(cell, namespace)
    with pytest.raises(NameError, match="not available"):
        namespace["de_casteljau"]([[0.0], [1.0]], 0.5)


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("reuse")
    autograder = assign(SOURCE, tmp / "assignment", verify_tests=False).autograder
    reference = json.loads((autograder / "solution.json").read_text())
    folder = tmp / "submissions"
    folder.mkdir()
    honest = next(c for c in reference if "def bezier_point" in c) + "\n\n" + DE_CASTELJAU
    demo = "\n\nprint(bezier_point(SEED, 0.25), de_casteljau(SEED, 0.25))\n"
    write_notebook(_cells(reference, honest + demo), folder / "honest_demo.ipynb")
    for name in GRADED:
        write_notebook(_cells(reference, CHEATS[name]), folder / f"{name}.ipynb")
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); from gfxlab.grading.cli import "
        "main; sys.exit(main('grade', sys.argv[2:]))"
    )
    cmd = ["unshare", "--pid", "--fork", "--kill-child", "--mount-proc", "--ipc", "--mount"]
    cmd += [sys.executable, "-I", "-c", code, str(ROOT), str(folder)]
    cmd += ["--autograder", str(autograder), "--out", str(tmp / "graded"), "--jobs", "2"]
    run = subprocess.run(
        cmd, capture_output=True, text=True, timeout=400, env={"PATH": "/usr/bin:/bin"}
    )
    assert run.returncode == 0, run.stderr[-3000:]
    reports = {}
    for name in ["honest_demo", *GRADED]:
        reports[name] = json.loads((tmp / "graded" / name / "results.json").read_text())
    return reports


def _question(report, name):
    return round(sum(t["score"] for t in report["tests"] if t["name"].startswith(name)), 6)


def test_honest_notebook_with_a_demo_line_keeps_every_mark(graded):
    assert graded["honest_demo"]["score"] == 15, graded["honest_demo"]["output"]


def test_a_rule_only_hidden_tests_show_broken_is_a_staff_note(graded):
    report = graded["hidden_only"]
    public = next(t for t in report["tests"] if t["name"] == "q2")
    assert public["score"] == public["max_score"] and _question(report, "q2") < 5, report
    note = "`de_casteljau` must be written on its own, without `bezier_point`"
    assert note not in report["output"], report["output"]
    assert any(note in n for n in report["extra_data"]["staff_notes"]), report


@pytest.mark.parametrize("name", ["container", *THROUGH_STATE])
def test_answers_made_of_another_answer_score_nothing(graded, name):
    report = graded[name]
    assert _question(report, "q2") == 0, (name, report)
    assert _question(report, "q3") == 5, (name, report)  # the rest is graded as usual
    text = json.dumps(report)
    assert "`de_casteljau` must be written on its own, without `bezier_point`" in text
    assert "this test passes only with them" in text
    if name in ("call", "container"):
        assert _question(report, "q1") == 5, (name, report)  # q1 is its own answer


def test_the_library_is_unimportable_through_any_of_its_modules():
    """`forbid: ["gfxlab"]`: a Bezier curve from `gfxlab.animation` is out of reach too."""
    source = (
        "try:\n    from gfxlab.animation.deform import bezier_path\n"
        "except ImportError as exc:\n    MESSAGE = str(exc)\n"
        "def get():\n    return MESSAGE\n"
    )
    with Sandbox(Limits(), preload=(), forbid=("gfxlab",)) as box:
        box.start()
        box.request("exec", 10, cell=1, source=source)
        message = box.request(
            "call",
            10,
            name="get",
            transforms=codec.encode([]),
            args=codec.encode([]),
            kwargs=codec.encode({}),
        )
    assert message.startswith("`gfxlab.animation` is not allowed in this assignment")


HELPER = "lambda control, u: sum(u**i * jnp.asarray(control)[i] for i in range(len(control)))"
USERS = (
    "def bezier_point(control, u):\n    return bern(control, u)\n\n\n"
    "def de_casteljau(control, u):\n    return bern(control, u)\n"
)


def test_shared_helpers_bound_any_way_are_in_the_closure():
    # Red team 2 #1, #2: a walrus inside a comprehension, a `match` capture.
    for binder in (
        f"[bern := ({HELPER}) for _ in (0,)]",
        f"match ({HELPER}):\n    case bern:\n        pass",
        f"match {{'k': 1}}:\n    case {{**bern}}:\n        bern = {HELPER}",
        f"try:\n    1 / 0\nexcept ZeroDivisionError as bern:\n    pass\nbern2 = {HELPER}",
    ):
        cells = ["import jax.numpy as jnp", binder, USERS.replace("bern(", "bern2(")]
        if "bern2 =" not in binder:
            cells[2] = USERS
        q2 = {v.function: v for v in reuse.plan(cells, RULES)}["de_casteljau"]
        assert q2.dynamic and q2.hatch is None, binder
        assert {"bezier_point"} < q2.closure
        namespace = {}
        for cell in reuse.check_cells(cells, q2.closure, "t0k"):
            exec(cell, namespace)
        with pytest.raises(NameError, match="not available"):
            namespace["de_casteljau"]([[0.0], [1.0]], 0.5)


def test_modules_written_at_run_time_are_hatches_and_debug_lines_are_not():
    # Red team 2 #2c: a helper module written to /tmp and put on the path.
    written = (
        "import pathlib, site\n"
        "pathlib.Path('/tmp/bh/bhelp.py').write_text('def bern(c, u): ...')\n"
        "site.addsitedir('/tmp/bh')\nfrom bhelp import bern\n"
    )
    for hidden in (written, written.replace(".py", ""), "from gx_no_such_module import bern"):
        cells = ["import jax.numpy as jnp", hidden, USERS]
        q2 = {v.function: v for v in reuse.plan(cells, RULES)}["de_casteljau"]
        assert q2.hatch, hidden
    # Red team 2 #3: an honest debug line with `type` (or a lookup outside the forbidden
    # code) runs the second sandbox instead of scoring 0.
    honest = ["import jax.numpy as jnp", BERNSTEIN.replace("_bern", "bezier_point"), DE_CASTELJAU]
    for line in ("print(type(bezier_point([[0.0], [1.0]], 0.5)))", "print(globals().keys())"):
        verdicts = reuse.plan([*honest, line], RULES)
        assert all(v.hatch is None for v in verdicts), line
        assert {v.function: v for v in verdicts}["de_casteljau"].dynamic, line
    # A lookup inside the forbidden code could reach anything: 0 points.
    sneaky = [*honest, "def bezier_point(c, u):\n    return globals()['de_casteljau'](c, u)"]
    assert {v.function: v for v in reuse.plan(sneaky, RULES)}["de_casteljau"].hatch


def test_second_sandboxes_are_launched_ahead_used_and_closed(tmp_path, monkeypatch):
    grader = Autograder(assign(SOURCE, tmp_path / "a", verify_tests=False).autograder)
    reference = grader.solution_cells()
    launched, served = [], []
    real_launch, real_session = reuse.launch_ahead, grader.session

    def launch_ahead(*args, **kwargs):
        launched.append(real_launch(*args, **kwargs))
        return launched[-1]

    def session(*args, sandbox=None, **kwargs):
        served.append(sandbox)
        return real_session(*args, sandbox=sandbox, **kwargs)

    monkeypatch.setattr(reuse, "launch_ahead", launch_ahead)
    monkeypatch.setattr(grader, "session", session)
    assert grader.grade_cells(reference).score == 15
    # One per rule, each serving one second sandbox, every one stopped at the end.
    assert [len(batch) for batch in launched] == [len(RULES)]
    assert served[1:] == launched[0] and served[0] is None
    assert all(not sandbox.launched for sandbox in launched[0])
    # A notebook the static step cannot check (exec) launches nothing ahead.
    launched.clear()
    hatch = [*reference, "exec('x = 1')"]
    assert grader.grade_cells(hatch).score < 15
    assert launched == [[]]
