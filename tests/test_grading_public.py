"""The public grading helpers refuse bad input clearly (an outside user's report).

Each wrong argument raises `TypeError` (wrong type) or `ValueError` (bad value) naming
the argument, before anything is made or started; never a silent success, never a raw
error from inside Python or the OS. No sandbox starts here: the cgroup helpers meet
plain temporary folders (what /sys/fs/cgroup is on a cgroup v1 host, a tmpfs), a
`Sandbox` gets a `Protections` that says it cannot start, and `run_pool` is checked
with process start-up made to fail.
"""

import json
import math
import os
import pathlib
import subprocess
import sys
import time

import pytest

from gfxlab.grading import Autograder, Limits, Protections, Sandbox, authoring, commands
from gfxlab.grading import sandbox as sb
from gfxlab.grading.grader import grade_one

NO_SANDBOX = Protections(None, False, (), None, "not on this test machine")


def _autograder(tmp_path, **config) -> pathlib.Path:
    """A hand-written autograder directory (no questions unless given)."""
    directory = tmp_path / "autograder"
    directory.mkdir(exist_ok=True)
    (directory / "config.json").write_text(
        json.dumps({"assignment": "a", "questions": [], **config})
    )
    return directory


def _fake_cgroup(path: pathlib.Path) -> pathlib.Path:
    """A folder laid out like a cgroup v2 group (its mkdir is still a plain mkdir)."""
    path.mkdir()
    for name in ("cgroup.controllers", "cgroup.procs"):
        (path / name).write_text("")
    return path


# 1. make_cgroup


def test_make_cgroup_makes_nothing_under_a_plain_folder(tmp_path):
    before = sorted(os.listdir(tmp_path))
    assert sb.make_cgroup(str(tmp_path), "sub-1", memory_bytes=2**30, processes=10) is None
    assert sorted(os.listdir(tmp_path)) == before  # no folder, no memory.max


def test_make_cgroup_undoes_a_folder_the_kernel_did_not_fill(tmp_path):
    """A parent that looks like a group, but mkdir makes a plain folder (no cgroupfs):
    the new folder gets no `cgroup.procs`, so it is removed and None returned."""
    parent = _fake_cgroup(tmp_path / "parent")
    assert sb.make_cgroup(str(parent), "sub-1", memory_bytes=2**30, processes=10) is None
    assert not (parent / "sub-1").exists()


@pytest.mark.parametrize("name", ["", ".", "..", "a/b", "/abs", "x\0y"])
def test_make_cgroup_refuses_a_name_that_is_not_one_component(tmp_path, name):
    parent = _fake_cgroup(tmp_path / "parent")
    with pytest.raises(ValueError, match="`name`"):
        sb.make_cgroup(str(parent), name, memory_bytes=2**30, processes=10)
    assert sorted(os.listdir(parent)) == ["cgroup.controllers", "cgroup.procs"]


@pytest.mark.parametrize(
    ("kwargs", "error", "word"),
    [
        ({"name": 5}, TypeError, "`name`"),
        ({"memory_bytes": True}, TypeError, "`memory_bytes`"),
        ({"memory_bytes": 1.5}, TypeError, "`memory_bytes`"),
        ({"memory_bytes": "1"}, TypeError, "`memory_bytes`"),
        ({"memory_bytes": 0}, ValueError, "`memory_bytes`"),
        ({"processes": -1}, ValueError, "`processes`"),
        ({"processes": False}, TypeError, "`processes`"),
        ({"processes": None}, TypeError, "`processes`"),
        ({"parent": None}, TypeError, "`parent`"),
    ],
)
def test_make_cgroup_checks_its_arguments_before_making_anything(tmp_path, kwargs, error, word):
    parent = _fake_cgroup(tmp_path / "parent")
    args = {"parent": str(parent), "name": "sub-1", "memory_bytes": 2**30, "processes": 10}
    with pytest.raises(error, match=word):
        sb.make_cgroup(**{**args, **kwargs})
    assert not (parent / "sub-1").exists()


# 2. remove_cgroup and the path arguments


def test_remove_cgroup_writes_nothing_into_a_plain_folder(tmp_path):
    folder = tmp_path / "plain"
    folder.mkdir()
    with pytest.raises(ValueError, match="not a cgroup v2 group"):
        sb.remove_cgroup(str(folder))
    assert folder.is_dir() and os.listdir(folder) == []  # no cgroup.kill, not removed
    sb.remove_cgroup(str(tmp_path / "gone"))  # a group already removed: nothing to do
    assert not (tmp_path / "gone").exists()


@pytest.mark.parametrize(
    "call",
    [
        lambda v: sb.cgroup_parent(v),
        lambda v: sb.cgroup_parent("/sys/fs/cgroup", v),
        sb.cgroup_members,
        sb.cgroup_cpu_seconds,
        sb.remove_cgroup,
    ],
)
@pytest.mark.parametrize("value", [None, 5, b"/sys/fs/cgroup"])
def test_cgroup_helpers_refuse_a_non_path(call, value):
    with pytest.raises(TypeError, match=r"`(root|self_cgroup|path)` must be a path"):
        call(value)


# 3. forbidden modules


@pytest.mark.parametrize(
    ("modules", "error"),
    [("scipy", TypeError), (None, TypeError), ([5], TypeError), ([""], ValueError),
     (["scipy."], ValueError), (["sci py"], ValueError)],
)  # fmt: skip
def test_forbidden_module_lists_are_lists_of_dotted_names(modules, error):
    with pytest.raises(error, match="`modules`"):
        sb.expand_forbidden(modules)
    with pytest.raises(error, match="`modules`"):
        sb.forbidden_files(modules)
    with pytest.raises(error, match="`forbid`"):
        Sandbox(forbid=modules, protections=NO_SANDBOX)


def test_forbidden_module_lists_take_lists_and_tuples():
    assert sb.expand_forbidden(["scipy.fft"]) == [*sb.ALWAYS_FORBIDDEN, "scipy.fft"]
    assert sb.expand_forbidden(("scipy",))[-1] == "scipy"
    assert Sandbox(forbid=["scipy"], protections=NO_SANDBOX).forbid[-1] == "scipy"


def test_an_assignment_forbid_that_is_a_string_is_refused(tmp_path):
    nb = authoring.new_notebook(
        cells=[
            authoring.new_cell("markdown", "# BEGIN QUESTION\nname: q1\npoints: 1"),
            authoring.new_cell("code", "def f(x):\n    return x"),
            authoring.new_cell("code", "# BEGIN TESTS\ndef test_a(f):\n    assert f(1) == 1"),
            authoring.new_cell("raw", "# END TESTS"),
            authoring.new_cell("raw", "# END QUESTION"),
        ]
    )
    nb["metadata"]["gfxlab"] = {"forbid": "scipy"}
    with pytest.raises(TypeError, match="`forbid`"):
        authoring.parse_notebook(nb)
    with pytest.raises(ValueError, match=r"config\.json.*`forbid`"):
        Autograder(_autograder(tmp_path, forbid="scipy"))


# 4. flags and limits


@pytest.mark.parametrize("warm", ["no", 1, None])
def test_autograder_warm_is_true_or_false(tmp_path, warm):
    with pytest.raises(TypeError, match="`warm` must be True or False"):
        Autograder(_autograder(tmp_path), warm=warm)


def test_sandbox_flags_and_limits_have_their_types():
    with pytest.raises(TypeError, match="`x64` must be True or False"):
        Sandbox(x64="no", protections=NO_SANDBOX)
    with pytest.raises(TypeError, match="`limits` must be a Limits"):
        Sandbox({"call_timeout": 1}, protections=NO_SANDBOX)
    with pytest.raises(TypeError, match="`preload`"):
        Sandbox(preload="numpy", protections=NO_SANDBOX)


def test_autograder_and_grade_one_limits_are_overrides_or_limits(tmp_path):
    directory = _autograder(tmp_path)
    with pytest.raises(TypeError, match="`limits` must be a Limits, a dict"):
        Autograder(directory, limits="x")
    with pytest.raises(TypeError, match="`limits` must be a Limits, a dict"):
        grade_one(directory, tmp_path / "nb.ipynb", limits="x", warm=False)
    with pytest.raises(TypeError, match="`warm` must be True or False"):
        grade_one(directory, tmp_path / "nb.ipynb", warm="no")
    grader = Autograder(directory, limits={"call_timeout": 2.0})  # documented: overrides
    assert grader.limits({"call_timeout": 2.0}).call_timeout == 2.0
    assert grader.limits(Limits(memory_mb=100)).memory_mb == 100


# 5. run_pool


@pytest.fixture
def no_processes(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("run_pool started processes for bad arguments")

    monkeypatch.setattr(commands.multiprocessing, "get_context", refuse)


GOOD_TASK = ("/grader", "/nb.ipynb", "nb.ipynb", None, False)


@pytest.mark.parametrize(
    ("tasks", "jobs", "hard_limit", "error", "word"),
    [
        ([GOOD_TASK], 0, 10.0, ValueError, "`jobs`"),
        ([GOOD_TASK], True, 10.0, TypeError, "`jobs`"),
        ([GOOD_TASK], 1.5, 10.0, TypeError, "`jobs`"),
        ([GOOD_TASK], "2", 10.0, TypeError, "`jobs`"),
        ([GOOD_TASK], 2, 0, ValueError, "`hard_limit`"),
        ([GOOD_TASK], 2, -1.0, ValueError, "`hard_limit`"),
        ([GOOD_TASK], 2, math.inf, ValueError, "`hard_limit`"),
        ([GOOD_TASK], 2, math.nan, ValueError, "`hard_limit`"),
        ([GOOD_TASK], 2, "10", TypeError, "`hard_limit`"),
        ([GOOD_TASK], 2, True, TypeError, "`hard_limit`"),
        ("abc", 2, 10.0, TypeError, "`tasks`"),
        (None, 2, 10.0, TypeError, "`tasks`"),
        ([list(GOOD_TASK)], 2, 10.0, TypeError, r"`tasks\[0\]`"),
        ([GOOD_TASK[:4]], 2, 10.0, TypeError, r"`tasks\[0\]` must be a tuple of 5"),
        ([(*GOOD_TASK[:2], 5, *GOOD_TASK[3:])], 2, 10.0, TypeError, "label"),
        ([(None, *GOOD_TASK[1:])], 2, 10.0, TypeError, "autograder folder"),
        ([(*GOOD_TASK[:3], "x", False)], 2, 10.0, TypeError, "limits"),
        ([(*GOOD_TASK[:4], "yes")], 2, 10.0, TypeError, "spare sandbox"),
    ],
)
def test_run_pool_checks_before_starting_a_process(
    no_processes, tasks, jobs, hard_limit, error, word
):
    with pytest.raises(error, match=word):
        commands.run_pool(tasks, jobs, hard_limit)


def test_run_pool_with_its_own_grade_needs_only_labelled_tuples(no_processes):
    with pytest.raises(TypeError, match="`grade`"):
        commands.run_pool([GOOD_TASK], 2, 10.0, grade="grade")
    with pytest.raises(TypeError, match=r"`tasks\[0\]` must be a tuple of at least 3"):
        commands.run_pool([("a", "b")], 2, 10.0, grade=print)
    with pytest.raises(AssertionError, match="started processes"):  # valid: it starts
        commands.run_pool([(None, None, "a", None)], 2, 10.0, grade=print)
    assert "__main__" in commands.run_pool.__doc__


# 6. Autograder.run_test


class _Squares:
    """A session whose student function squares its argument."""

    def call(self, name, transforms, args, kwargs):
        return args[0] ** 2


def _square_test(f):
    assert f(3) == 9


def test_run_test_refuses_caller_mistakes_before_running(tmp_path):
    grader = Autograder(_autograder(tmp_path))
    spec = authoring.TestSpec("test_square", ("f",), False, 1.0)
    ran = []

    def test(f):
        ran.append(f)

    cases = [
        ((5, spec, _Squares()), "`test` must be a callable"),
        ((test, {"name": "x"}, _Squares()), "`spec` must be an authoring.TestSpec"),
        ((test, spec, object()), "`session` must have a callable `call`"),
        ((test, spec, _Squares(), ["f", "g"]), "`rename` must be a dict or None"),
    ]
    for args, message in cases:
        with pytest.raises(TypeError, match=message):
            grader.run_test(*args)
    assert ran == []
    assert grader.run_test(_square_test, spec, _Squares()).passed
    assert grader.run_test(_square_test, spec, _Squares(), {"f": "g"}).passed


# 7. config.json and the autograder directory


@pytest.mark.parametrize(
    ("config", "missing"),
    [
        ({"assignment": "a"}, "`questions`"),
        ({"questions": []}, "`assignment`"),
        ({"assignment": "a", "questions": [{"name": "q1", "tests": []}]}, "`points`"),
        (
            {"assignment": "a", "questions": [{"name": "q", "points": 1, "tests": [{}]}]},
            "test 0 of question 0 lacks the key `name`",
        ),
        ({"assignment": "a", "questions": {}}, "`questions` must be a list"),
        ({"assignment": "a", "questions": [], "x64": "no"}, "`x64` must be true or false"),
        ({"assignment": "a", "questions": [], "preload": "numpy"}, "`preload`"),
    ],
)
def test_a_hand_written_config_names_the_file_and_the_key(tmp_path, config, missing):
    directory = tmp_path / "autograder"
    directory.mkdir()
    (directory / "config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError, match="config.json") as info:
        Autograder(directory)
    assert missing in str(info.value)


def test_not_json_and_no_folder_say_what_is_wrong(tmp_path):
    directory = tmp_path / "autograder"
    directory.mkdir()
    (directory / "config.json").write_text("{")
    with pytest.raises(ValueError, match="config.json is not valid JSON"):
        Autograder(directory)
    message = "is this an autograder directory?"
    with pytest.raises(FileNotFoundError, match=message):
        Autograder(tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match=message):
        grade_one(tmp_path / "missing", tmp_path / "nb.ipynb", warm=False)


# 8. cpu_seconds after close


def test_cpu_seconds_keep_the_last_reading_after_close():
    """A stand-in process (no sandbox) that burns CPU: `close` keeps what it used."""
    burn = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.3: pass\n"
    proc = subprocess.Popen([sys.executable, "-c", burn + "time.sleep(60)"], start_new_session=True)
    box = Sandbox(protections=NO_SANDBOX)
    assert box.cpu_seconds() == 0.0  # before it starts
    box.proc = proc
    box._req_w, box._rep_r = os.pipe()
    deadline = time.monotonic() + 30
    while box.cpu_seconds() < 0.25 and time.monotonic() < deadline:
        time.sleep(0.05)
    box.close()
    assert proc.poll() is not None
    assert box.cpu_seconds() >= 0.25


# 9. describe, 10. seccomp_program


def test_describe_names_every_refused_system_call():
    machine = os.uname().machine
    lines = " ".join(Protections("/usr/bin/bwrap", False, (), None).describe())
    for name in sb.SECCOMP_RULES.get(machine, (0, {}))[1]:
        assert name in lines, name
    if machine in sb.SECCOMP_RULES:
        assert "memfd_secret" in lines and "process_vm_readv" in lines


def test_seccomp_program_checks_its_machine():
    with pytest.raises(ValueError, match="`machine`"):
        sb.seccomp_program("")
    with pytest.raises(TypeError, match="`machine`"):
        sb.seccomp_program(5)
    assert sb.seccomp_program(None) == sb.seccomp_program(os.uname().machine)
    assert sb.seccomp_program("riscv64") is None  # documented: no filter known
