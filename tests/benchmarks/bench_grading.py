"""Grading benchmarks: one submission, 50 in parallel, Gradescope's run_autograder.

"In-process" is the unsafe way (otter/nbgrader style): the student's cells and the tests
run in the grader's own interpreter, no process, no sandbox, no limits. The ratio shows
what the isolation costs. Targets (issue 14): a numpy submission <= 1 s, a JAX one <= 3 s,
50 submissions <= 60 s on 2 cores, `run_autograder` <= 5 s.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile

from harness import Table, timeit

from gfxlab.grading import Autograder, assign, grade_many

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from grading_attacks.attacks import write_notebook  # noqa: E402

SOURCES = sorted((ROOT / "labs" / "assignments").glob("[0-9][0-9]_*.ipynb"))


def _in_process(grader: Autograder, cells: list[str]) -> None:
    namespace: dict = {}
    for cell in cells:
        exec(cell, namespace)
    for q in grader.questions:
        for t in q.tests:
            grader._namespaces[q.name][t.name](*[namespace[p] for p in t.params])


def _gradescope(work: pathlib.Path, source: pathlib.Path) -> tuple[float, float]:
    result = assign(source, work / "gs-out", verify_tests=False, gradescope=True)
    root = work / "gs"
    for sub in ("source", "submission", "results"):
        (root / sub).mkdir(parents=True)
    with zipfile.ZipFile(result.gradescope) as zf:
        zf.extractall(root / "source")
    os.chmod(root / "source" / "run_autograder", 0o755)
    solution = json.loads((root / "source/autograder/solution.json").read_text())
    write_notebook(solution, root / "submission" / "submission.ipynb")
    env = {"PATH": "/usr/bin:/bin", "AUTOGRADER_ROOT": str(root), "GFXLAB_PYTHON": sys.executable}
    start = time.perf_counter()
    subprocess.run([str(root / "source" / "run_autograder")], env=env, check=True)
    elapsed = time.perf_counter() - start
    return elapsed, json.loads((root / "results" / "results.json").read_text())["score"]


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)  # as in the student process
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench-grading-"))
    graders = {}
    for source in SOURCES:
        result = assign(source, work / source.stem, verify_tests=False)
        graders[source.stem] = Autograder(result.autograder)

    table = Table("one correct submission (sandboxed grade vs in-process exec)", "in-process")
    for name, grader in graders.items():
        cells = grader.solution_cells()
        path = write_notebook(cells, work / f"{name}-ref.ipynb")
        scores: list[float] = []
        ours = timeit(lambda g=grader, p=path, s=scores: s.append(g.grade(p).score), repeat=2)
        ref = timeit(lambda g=grader, c=cells: _in_process(g, c), repeat=2)
        asked = "3 s (JAX)" if "jax" in grader.config.get("preload", []) else "1 s (numpy)"
        table.add(f"{name} (cold)", ours, ref, f"score {scores[-1]:g}/15; asked <= {asked}")
        # In a batch each grader keeps the next submission's sandbox launched.
        warm = Autograder(grader.directory, warm=True)
        ours = timeit(lambda g=warm, p=path, s=scores: s.append(g.grade(p).score), repeat=2)
        warm.close()
        table.add(f"{name} (batch, spare sandbox)", ours, ref, f"score {scores[-1]:g}/15")
    table.print()

    table = Table(f"50 submissions, process pool of {os.cpu_count()}", "in-process, serial")
    grader = graders["01_midpoint_circle"]
    cells = grader.solution_cells()
    folder = work / "subs"
    folder.mkdir()
    wrong = [c.replace("rows.append((p, x, y))", "rows.append((p + 1, x, y))") for c in cells]
    paths = [
        write_notebook(cells if i % 3 else wrong, folder / f"s{i:02d}.ipynb") for i in range(50)
    ]
    start = time.perf_counter()
    results = grade_many(paths, grader.directory, work / "graded")
    ours = time.perf_counter() - start
    start = time.perf_counter()
    for i in range(50):
        if i % 3:
            _in_process(grader, cells)
    ref = time.perf_counter() - start
    total = sum(r.score for r in results)
    table.add("01_midpoint_circle x 50", ours, ref, f"sum of scores {total:g}; asked <= 60 s")
    table.print()

    table = Table("Gradescope autograder.zip: run_autograder on one submission")
    elapsed, score = _gradescope(work, SOURCES[-1])
    table.add("04_jpeg_block", elapsed, None, f"score {score:g}/15; asked <= 5 s")
    table.print()
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
