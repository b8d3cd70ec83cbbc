"""The grader's own bounds on what a submission's data can make it do (red team 2)."""

from __future__ import annotations

import time

import pytest

from gfxlab.grading import authoring
from gfxlab.grading.grader import Autograder, run_bounded


class _FakeSession:
    """Stands in for a student process: `call` returns `reply` after `spin` CPU seconds."""

    def __init__(self, reply, spin=0.0):
        self.reply, self.spin, self.calls = reply, spin, 0

    def call(self, name, transforms, args, kwargs):
        end = time.process_time() + self.spin
        while time.process_time() < end:
            pass
        self.calls += 1
        return self.reply


def _grader(seconds):
    grader = Autograder.without_tests(".", assignment="a", preload=(), forbid=())
    grader.config["test_cpu_seconds"] = seconds
    return grader


def _colliding_pairs(n):
    # Multiples of 2**61 - 1 all hash to 0: (x, 0) tuples that collide.
    return [(k * (2**61 - 1), 0) for k in range(1, n)]


SPEC = authoring.TestSpec("test_points_unique", ("circle_points",), False, 1.0)


def test_a_test_slow_on_the_students_data_times_out_and_scores_zero():
    def test_points_unique(circle_points):
        pts = circle_points(5)
        try:  # a test's own `except Exception` does not swallow the deadline
            seen = set()
            while True:  # the grader's own check never ends on this data
                seen |= {tuple(p) for p in pts}
        except Exception:
            pass

    started = time.monotonic()
    result = _grader(0.5).run_test(
        test_points_unique, SPEC, _FakeSession(_colliding_pairs(2000)), {}
    )
    assert not result.passed and result.message.startswith("timed out")
    assert time.monotonic() - started < 20


def test_the_deadline_waits_for_a_call_to_the_student_to_finish():
    session = _FakeSession([1, 2], spin=1.0)  # the deadline passes during the call

    def test_points_unique(circle_points):
        assert circle_points(5) == [1, 2]

    result = _grader(0.2).run_test(test_points_unique, SPEC, session, {})
    assert session.calls == 1  # the call was not interrupted mid-message
    assert not result.passed and result.message.startswith("timed out")
    fast = _grader(5.0).run_test(test_points_unique, SPEC, _FakeSession([1, 2]), {})
    assert fast.passed and fast.message == ""


def _spin_forever():
    while True:
        pass


def _fails():
    raise ValueError("no sandbox here")


def test_run_bounded_kills_at_the_hard_limit():
    started = time.monotonic()
    assert run_bounded(_spin_forever, 1.0) == ("timeout", None)
    assert time.monotonic() - started < 15
    assert run_bounded(lambda: {"score": 3}, 30.0) == ("ok", {"score": 3})
    kind, exc = run_bounded(_fails, 30.0)
    assert kind == "raise" and isinstance(exc, ValueError)
    with pytest.raises(ValueError, match="no sandbox"):
        raise exc


def test_codec_bounds_values_before_parsing():
    from gfxlab.grading import codec

    bomb = b"[" + b",".join([b"[]"] * (codec.MAX_ITEMS + 1)) + b"]"  # 6 MB, small frame
    assert len(bomb) < codec.MAX_MESSAGE_BYTES
    with pytest.raises(codec.WireError, match="more than"):
        codec.loads(bomb)
    assert codec.loads(b'{"a":[1,2,[3]],"b":"x,y[{"}') == {"a": [1, 2, [3]], "b": "x,y[{"}


def test_magics_are_commented_only_at_the_start_of_a_logical_line():
    from gfxlab.grading.authoring import comment_magics

    src = (
        "%matplotlib inline\n"
        "  !pip install x\n"
        "odd = (\n    n\n    % 2\n    == 1\n)\n"
        "y = 3 \\\n    % 2\n"
        'z = """\n!not a shell line\n"""\n'
        "w = 1  # a comment ending in \\\n"
        "%time w\n"
        "s = '(' \n!ls\n"
    )
    out = comment_magics(src).splitlines()
    assert out[0] == "# %matplotlib inline" and out[1] == "  # !pip install x"
    assert out[4] == "    % 2" and out[8] == "    % 2" and out[10] == "!not a shell line"
    assert out[13] == "# %time w" and out[15] == "# !ls"
    namespace = {"n": 5}
    exec("\n".join(out), namespace)
    assert namespace["odd"] is True and namespace["y"] == 1 and "!not" in namespace["z"]


def test_grade_one_is_stopped_at_the_hard_limit(tmp_path, monkeypatch):
    import json

    from gfxlab.grading import grader as grader_module

    config = {"assignment": "a", "questions": [], "limits": {"budget_seconds": 1.0}}
    (tmp_path / "config.json").write_text(json.dumps(config))
    monkeypatch.setattr(grader_module, "HARD_MARGIN_SECONDS", 0.5)
    monkeypatch.setattr(Autograder, "grade", lambda self, submission, **kw: _spin_forever())
    started = time.monotonic()
    result = grader_module.grade_one(tmp_path, tmp_path / "x.ipynb", warm=False)
    assert "longer than 1.5 s and was stopped" in result.error
    assert result.to_gradescope()["extra_data"]["grading_error"] is True
    assert time.monotonic() - started < 20
    with pytest.raises(TypeError, match="`warm` must be True or False"):
        grader_module.grade_one(tmp_path, tmp_path / "x.ipynb", warm="no")


def test_assignments_forbid_ready_made_solvers():
    import json
    import pathlib

    root = pathlib.Path(__file__).resolve().parents[1] / "labs" / "assignments"
    needed = {  # red team 2 #5, #6, #10: libraries that answer the questions
        "01_midpoint_circle": {"skimage", "cv2", "PIL", "matplotlib"},
        "02_cohen_sutherland": {"shapely", "matplotlib", "cv2", "skimage"},
        "03_bezier": {"bezier", "scipy.interpolate", "matplotlib"},
        "04_jpeg_block": {"scipy.fft", "cv2", "jpeglib", "PIL"},
    }
    for name, modules in needed.items():
        meta = json.loads((root / f"{name}.ipynb").read_text())["metadata"]["gfxlab"]
        assert modules <= set(meta["forbid"]), name
