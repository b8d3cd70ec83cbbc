"""Grading benchmarks: one submission, 50 in parallel, the attack suite.

"Reference" is the unsafe way (otter/nbgrader style): the student's cells and the tests
run in the grader's own interpreter, no process, no limits. The ratio shows what the
isolation costs.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import sys
import tempfile
import time

from harness import Table, timeit

from gfxlab.grading import Autograder, assign, grade_many

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from grading_attacks.attacks import ATTACKS, submission_cells, write_notebook  # noqa: E402

SOURCES = sorted((ROOT / "labs" / "assignments").glob("[0-9][0-9]_*.ipynb"))
ATTACK_LIMITS = dict(
    call_timeout=2.0, exec_timeout=3.0, memory_mb=1024, output_mb=4, processes=32, cpu_seconds=30
)


def _in_process(grader: Autograder, cells: list[str]) -> None:
    namespace: dict = {}
    for cell in cells:
        exec(cell, namespace)
    for q in grader.questions:
        for t in q.tests:
            grader._namespaces[q.name][t.name](*[namespace[p] for p in t.params])


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)  # as in the student process
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench-grading-"))
    graders = {}
    for source in SOURCES:
        result = assign(source, work / source.stem, verify=False)
        graders[source.stem] = Autograder(result.autograder)

    table = Table("one correct submission (sandboxed grade vs in-process exec)", "in-process")
    for name, grader in graders.items():
        cells = grader.solution_cells()
        path = write_notebook(cells, work / f"{name}-ref.ipynb")
        scores: list[float] = []
        ours = timeit(lambda g=grader, p=path, s=scores: s.append(g.grade(p).score), repeat=3)
        ref = timeit(lambda g=grader, c=cells: _in_process(g, c), repeat=3)
        table.add(name, ours, ref, f"score {scores[-1]:g}/15; asked < 3 s")
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
    table.add("01_midpoint_circle x 50", ours, ref, f"sum of scores {total:g}; asked < 90 s")
    bezier = graders["03_bezier"]
    bpaths = [
        write_notebook(bezier.solution_cells(), folder / f"b{i:02d}.ipynb") for i in range(10)
    ]
    start = time.perf_counter()
    bres = grade_many(bpaths, bezier.directory, work / "graded-b")
    table.add(
        "03_bezier (JAX) x 10",
        time.perf_counter() - start,
        None,
        f"all 15: {all(r.score == 15 for r in bres)}",
    )
    table.print()

    table = Table("attack suite on 01_midpoint_circle (q1 attacked; limits 2 s, 1 GiB)")
    cheats, worst = 0, 0.0
    for attack in sorted(ATTACKS):
        attack_cells = submission_cells(
            cells, attack, autograder=str(grader.directory), source=str(SOURCES[0]), port=9
        )
        start = time.perf_counter()
        result = grader.grade_cells(attack_cells, limits=ATTACK_LIMITS)
        elapsed = time.perf_counter() - start
        worst = max(worst, elapsed)
        scores = [q.score for q in result.questions]
        cheated = scores[0] > 0 or scores[1:] != [5, 5]
        cheats += cheated
        table.add(attack, elapsed, None, f"scores {scores}{' CHEAT' if cheated else ''}")
    table.add(
        "total",
        sum(r[1] for r in table.rows),
        None,
        f"{cheats} successful cheats; slowest run {worst:.1f} s",
    )
    table.print()
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
