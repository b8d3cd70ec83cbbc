"""The attack suite: each attack must score 0 on q1 while q2 and q3 are graded normally.

Attack code lives in `tests/grading_attacks/attacks.py`. Limits are small (2 s per call)
so the suite stays fast; every run must also finish within a fixed time bound.
"""

import json
import pathlib
import socket
import threading
import time

import pytest
from grading_attacks.attacks import ATTACKS, submission_cells

from gfxlab.grading import Autograder, assign

SOURCE = pathlib.Path(__file__).resolve().parents[1] / "labs/assignments/01_midpoint_circle.ipynb"
LIMITS = dict(call_timeout=2.0, exec_timeout=3.0, memory_mb=1024, output_mb=4, processes=32,
              cpu_seconds=30)
TIME_BOUND = 30.0  # seconds for one graded submission, attack included (loaded CI)

pytestmark = pytest.mark.xdist_group("grading")


@pytest.fixture(scope="module")
def grader(tmp_path_factory):
    result = assign(SOURCE, tmp_path_factory.mktemp("attacks"), verify=False)
    return Autograder(result.autograder)


@pytest.fixture(scope="module")
def answer_server():
    """A helper on 127.0.0.1 that hands out q1's answer to whoever connects."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.2)
    hits = []
    stop = threading.Event()

    def serve():
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            hits.append(1)
            rows = [[-9, 1, 10], [-6, 2, 10], [-1, 3, 10], [6, 4, 9], [-3, 5, 9], [8, 6, 8],
                    [5, 7, 7]]
            conn.sendall(json.dumps(rows).encode())
            conn.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server.getsockname()[1], hits
    stop.set()
    thread.join()
    server.close()


@pytest.mark.parametrize("attack", sorted(ATTACKS))
def test_attack_scores_zero(grader, answer_server, attack):
    port, hits = answer_server
    cells = submission_cells(grader.solution_cells(), attack, autograder=str(grader.directory),
                             source=str(SOURCE), port=port)
    started = time.monotonic()
    result = grader.grade_cells(cells, label=attack, limits=LIMITS)
    elapsed = time.monotonic() - started
    scores = {q.name: q.score for q in result.questions}
    feedback = result.questions[0].feedback()
    assert scores == {"q1": 0, "q2": 5, "q3": 5}, feedback
    assert elapsed < TIME_BOUND
    assert hits == []  # nobody reached the network
    if attack in ("cpu_loop", "fork_bomb"):
        assert "timed out after 2 s" in feedback
    if attack in ("eq_always_true", "eq_plain_object"):
        assert "cannot be returned" in feedback


def test_reference_passes_under_attack_limits(grader):
    # The small limits themselves do not cost a correct submission anything.
    result = grader.grade_cells(grader.solution_cells(), limits=LIMITS)
    assert result.score == 15
