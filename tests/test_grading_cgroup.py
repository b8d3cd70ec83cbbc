"""The cgroup v2 path of the grading sandbox, on hosts without cgroup v2.

The kernel feature is simulated in a temporary directory laid out like a delegated
cgroup v2 subtree, where `os.mkdir` and `os.rmdir` act as in cgroupfs: creating a group
makes the interface files the kernel would make, removing one removes them. What is
tested for real, through `gfxlab.grading.sandbox`: which groups the grader creates and
what it writes into them, the decision whether cgroup limits apply (and the fallback
when any step is refused), that the student process joins its group, and that
`extra_data.isolation` of a result says what really applied to that submission.
"""

import dataclasses
import json
import os
import pathlib

import pytest

from gfxlab.grading import Autograder, Limits, Sandbox, assign, codec, sandbox

ROOT = pathlib.Path(__file__).resolve().parents[1]
INTERFACE = {
    "cgroup.controllers": "cpu memory pids",
    "cgroup.subtree_control": "",
    "cgroup.procs": "",
    "cgroup.kill": "",
    "memory.max": "max",
    "pids.max": "max",
    "cpu.max": "max 100000",
    "cpu.stat": "usage_usec 0\nuser_usec 0\nsystem_usec 0\n",
}


class Cgroupfs:
    """`os.mkdir`/`os.rmdir` below `root` as in cgroupfs, the real ones elsewhere.

    mkdir makes a group with its interface files (`files`; `refuse`: a permission
    error; `joinable=False`: a `cgroup.procs` no pid can be written to); rmdir removes
    a group with its interface files, and fails for a group with child groups."""

    def __init__(self, root: pathlib.Path, monkeypatch):
        self.root = str(root) + os.sep
        self.files, self.refuse, self.joinable = dict(INTERFACE), False, True
        self._mkdir, self._rmdir = os.mkdir, os.rmdir
        monkeypatch.setattr(os, "mkdir", self.mkdir)
        monkeypatch.setattr(os, "rmdir", self.rmdir)

    def below(self, path) -> bool:
        return isinstance(path, str | os.PathLike) and os.fspath(path).startswith(self.root)

    def mkdir(self, path, mode=0o777, **kwargs):
        if kwargs or not self.below(path):
            return self._mkdir(path, mode, **kwargs)
        if self.refuse:
            raise PermissionError(13, "Permission denied", os.fspath(path))
        self.group(path, self.files)
        if not self.joinable:
            os.remove(pathlib.Path(path, "cgroup.procs"))
            self._mkdir(pathlib.Path(path, "cgroup.procs"))  # writing the pid fails
        return None

    def group(self, path, files) -> None:
        self._mkdir(path)
        for name, text in files.items():
            pathlib.Path(path, name).write_text(text)

    def rmdir(self, path, **kwargs):
        if kwargs or not self.below(path):
            return self._rmdir(path, **kwargs)
        for entry in os.scandir(path):
            if entry.is_file():
                os.remove(entry.path)
            elif entry.name in INTERFACE:
                self._rmdir(entry.path)
        return self._rmdir(path)  # a group with child groups stays (OSError)


@pytest.fixture
def fake_cgroupfs(tmp_path, monkeypatch):
    """`root` (the unified hierarchy) with the grader in `/user.slice/grader`, and the
    simulated cgroupfs below it."""
    root = tmp_path / "cgroup"
    root.mkdir()
    (root / "cgroup.controllers").write_text("cpuset cpu io memory pids")
    here = root / "user.slice" / "grader"
    here.parent.mkdir()
    fs = Cgroupfs(root, monkeypatch)
    fs.group(here, {**INTERFACE, "cgroup.controllers": "cpu io memory pids"})
    (here / "cgroup.procs").write_text(f"{os.getpid()}\n")
    self_cgroup = tmp_path / "self_cgroup"
    self_cgroup.write_text("1:name=systemd:/user.slice\n0::/user.slice/grader\n")
    return root, here, self_cgroup, fs


def test_delegated_subtree_gets_a_grading_parent(fake_cgroupfs):
    root, here, self_cgroup, fs = fake_cgroupfs
    parent = sandbox.cgroup_parent(str(root), str(self_cgroup))
    assert parent == str(here / "gfxlab-grading")
    # cgroup v2 enables controllers only in groups without processes: the grader first
    # moves itself into a leaf, then enables memory, pids and cpu below its own group.
    assert (here / "gfxlab-grader" / "cgroup.procs").read_text() == str(os.getpid())
    assert (here / "cgroup.subtree_control").read_text() == "+memory +pids +cpu"
    assert (here / "gfxlab-grading" / "cgroup.subtree_control").read_text() == (
        "+memory +pids +cpu"
    )
    assert [p.name for p in (here / "gfxlab-grading").iterdir() if p.is_dir()] == []


def test_controllers_already_enabled_leave_the_grader_where_it_is(fake_cgroupfs):
    root, here, self_cgroup, fs = fake_cgroupfs
    (here / "cgroup.subtree_control").write_text("memory pids cpu io")
    assert sandbox.cgroup_parent(str(root), str(self_cgroup)) == str(here / "gfxlab-grading")
    assert not (here / "gfxlab-grader").exists()


@pytest.mark.parametrize(
    "breakage",
    ["cgroup_v1_only", "no_memory_controller", "not_writable", "probe_without_controllers"],
)
def test_no_cgroup_limits_when_any_step_is_missing(fake_cgroupfs, breakage):
    root, here, self_cgroup, fs = fake_cgroupfs
    if breakage == "cgroup_v1_only":
        self_cgroup.write_text("9:memory:/user.slice\n8:pids:/user.slice\n")
    elif breakage == "no_memory_controller":
        (here / "cgroup.controllers").write_text("cpu io pids")
    elif breakage == "not_writable":
        fs.refuse = True
    else:  # a kernel that makes groups without the memory/pids interface files
        fs.files = {"cgroup.procs": ""}
    assert sandbox.cgroup_parent(str(root), str(self_cgroup)) is None


def test_submission_group_gets_its_limits(fake_cgroupfs):
    root, here, self_cgroup, fs = fake_cgroupfs
    parent = sandbox.cgroup_parent(str(root), str(self_cgroup))
    path = pathlib.Path(sandbox.make_cgroup(parent, "sub-1", memory_bytes=3 * 2**30, processes=70))
    assert (path / "memory.max").read_text() == str(3 * 2**30)
    assert (path / "memory.swap.max").read_text() == "0"
    assert (path / "pids.max").read_text() == "70"
    assert (path / "cpu.max").read_text() == "100000 100000"
    (path / "cpu.stat").write_text("usage_usec 2500000\nuser_usec 2000000\n")
    assert sandbox.cgroup_cpu_seconds(str(path)) == 2.5
    assert sandbox.cgroup_members(str(path)) == []
    sandbox.remove_cgroup(str(path))
    assert not path.exists()
    assert sandbox.cgroup_cpu_seconds(str(path)) is None
    # A group the kernel refuses to make: no group.
    os.rename(pathlib.Path(parent), pathlib.Path(parent + "-old"))
    assert sandbox.make_cgroup(parent, "sub-2", memory_bytes=1, processes=1) is None


def _protections(parent):
    real = sandbox.detect_protections()
    if not real.confined:
        pytest.fail(f"the grading sandbox does not start here: {real.problem}")
    return dataclasses.replace(real, cgroup_parent=parent)


def _call(box, name, *args):
    return box.request(
        "call",
        5,
        name=name,
        transforms=codec.encode([]),
        args=codec.encode(list(args)),
        kwargs=codec.encode({}),
    )


def test_student_process_joins_its_group_and_results_say_so(fake_cgroupfs):
    root, here, self_cgroup, fs = fake_cgroupfs
    parent = sandbox.cgroup_parent(str(root), str(self_cgroup))
    prot = _protections(parent)
    limits = Limits(memory_mb=2048, processes=40)
    with Sandbox(limits, preload=(), protections=prot) as box:
        box.start()
        group = pathlib.Path(box.cgroup)
        assert group.parent == pathlib.Path(parent)
        assert sandbox.cgroup_members(str(group)) == [box.proc.pid]  # the launcher joined it
        assert (group / "memory.max").read_text() == str(2048 * 2**20)
        assert (group / "pids.max").read_text() == "40"
        box.request("exec", 5, source="def f(x):\n    return x + 1\n", cell=1)
        assert _call(box, "f", 41) == 42
        # CPU time comes from the group's cpu.stat (the fake kernel counts none).
        assert box.cpu_seconds() == 0.0
        lines = " ".join(box.describe())
        assert "cgroup v2 (memory.max, pids.max, cpu.max of one core)" in lines
        assert "no cgroup v2" not in lines
    assert not group.exists(), "the submission's group is removed with it"

    # A group the process could not join: the result says rlimits and the grader's watch.
    fs.joinable = False
    with Sandbox(limits, preload=(), protections=prot) as box:
        box.start()
        assert box.cgroup is None
        lines = " ".join(box.describe())
        assert "no cgroup v2" in lines and "cgroup v2 (" not in lines
        assert box.cpu_seconds() > 0  # from /proc: the grader's own accounting


def test_grade_result_isolation_is_what_applied(fake_cgroupfs, monkeypatch, tmp_path):
    root, here, self_cgroup, fs = fake_cgroupfs
    source = ROOT / "labs/assignments/02_cohen_sutherland.ipynb"
    grader = Autograder(assign(source, tmp_path / "a", verify_tests=False).autograder)
    cells = grader.solution_cells()[:1]  # no functions: every test fails, quickly
    parent = sandbox.cgroup_parent(str(root), str(self_cgroup))
    with_cgroup, without = _protections(parent), _protections(None)
    monkeypatch.setattr(sandbox, "detect_protections", lambda: with_cgroup)
    report = grader.grade_cells(cells).to_gradescope()
    isolation = json.dumps(report["extra_data"]["isolation"])
    assert "cgroup v2 (memory.max" in isolation and "no cgroup v2" not in isolation
    monkeypatch.setattr(sandbox, "detect_protections", lambda: without)
    report = grader.grade_cells(cells).to_gradescope()
    isolation = json.dumps(report["extra_data"]["isolation"])
    assert "no cgroup v2" in isolation and "cgroup v2 (" not in isolation
