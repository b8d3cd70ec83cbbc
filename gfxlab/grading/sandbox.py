"""Isolated student processes and the narrow RPC to them.

A `Sandbox` is one student process: a fresh `python -I` inside bubblewrap (`bwrap`), started
through `gfxlab/grading/_launcher.py`. The student sees an allow-list filesystem only: the
system libraries (`/usr`), the Python installation and its packages (read-only), the
`gfxlab` package (read-only, forbidden modules replaced by stubs that raise `ImportError`),
a private `/proc`, a minimal `/dev`, and empty private `/tmp` and `/dev/shm` tmpfs that
vanish with the process; nothing of the checkout, the autograder, caches or home
directories. Every namespace is new (user, mount, pid, ipc, net, uts, cgroup), the
process runs as a fresh unprivileged uid (grader as root) or through an unprivileged user
namespace (grader not root), and dies with the grader. Resource limits come from cgroup v2
(`memory.max`, `pids.max`, `cpu.max`) where the host delegates it, and from rlimits always;
`GradeResult` says which applied. Requests and replies travel over a dedicated pipe pair,
not stdout; every request carries a random id the reply must echo.

What the sandbox is made of is public here, for instructors and auditors:
`forbidden_files(expand_forbidden(modules))` (what an assignment's `forbid` list hides),
`seccomp_program` and `SECCOMP_RULES` (the system-call filter), and the cgroup v2 groups:
`cgroup_parent`, `make_cgroup`, `cgroup_members`, `cgroup_cpu_seconds`, `remove_cgroup`.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import pathlib
import secrets
import select
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

from . import codec
from ._args import flag, limits_arg, module_names
from ._host import (
    _MEMORY_POLL,
    _PACKAGE,
    _PACKAGE_TARGET,
    _SCRATCH_INODES,
    _closed_to_others,
    _minimal_env,
    _package_inside,
    _python,
    _runtime_paths,
    _signal_name,
    _source,
    _system_binds,
    _tasks_of,
    _tree_usage,
    bwrap_binary,
    cgroup_cpu_seconds,
    cgroup_members,
    cgroup_parent,
    expand_forbidden,
    forbidden_files,
    make_cgroup,
    remove_cgroup,
    sandbox_path,
    unused_site_dirs,
)
from ._host import ALWAYS_FORBIDDEN as ALWAYS_FORBIDDEN  # public here: hidden in every sandbox
from ._policy import (
    _ENABLE,
    IsolationUnavailable,
    Limits,
    Protections,
    limits_kind,
    seccomp_program,
)
from ._policy import SECCOMP_RULES as SECCOMP_RULES  # what `seccomp_program` refuses


@functools.cache
def detect_protections() -> Protections:
    """Probe this machine once: bwrap present? user namespaces? interpreter readable?"""
    bwrap = bwrap_binary()
    if bwrap is None:
        return Protections(None, False, (), None, f"no bwrap found; {_ENABLE}")
    root = os.geteuid() == 0
    blocked: dict[str, list[str]] = {}
    paths = _runtime_paths() + ([] if _package_inside() else [_PACKAGE])
    for path in paths:
        blocker = _closed_to_others(path) if root else None
        if blocker is not None:
            blocked.setdefault(str(blocker), []).append(str(path))
    expose = tuple((b, tuple(p)) for b, p in blocked.items())
    prot = Protections(bwrap, root, expose, cgroup_parent())
    # Each sandbox's working folder is made in the temporary folder, and the submission's
    # own uid must enter it (a TMPDIR below a private folder would stop every start).
    temp = pathlib.Path(tempfile.gettempdir())
    closed = _closed_to_others(temp) if root else None
    if closed is not None:
        return dataclasses.replace(
            prot,
            problem=f"the temporary folder {temp} is below {closed}, which the submission's "
            "own user cannot enter; set TMPDIR to a folder other users can enter, such as /tmp",
        )
    error = _probe(prot)
    if error:
        return dataclasses.replace(
            prot, problem=f"the sandbox does not start here ({error}); to grade, {_ENABLE}"
        )
    return prot


def _probe(prot: Protections) -> str | None:
    """Start `python -c pass` through the whole chain; the error text, or None."""
    with Sandbox(Limits(start_timeout=60), preload=(), protections=prot) as box:
        try:
            box.start()
        except SandboxError as exc:
            return str(exc).strip()[-600:] or "no reply"
    return None


def require_confinement() -> Protections:
    """The protections, or `IsolationUnavailable` saying what to enable."""
    prot = detect_protections()
    if not prot.confined:
        raise IsolationUnavailable(f"refusing to run student code: {prot.problem}")
    return prot


MAX_ERROR_CHARS = 8000  # an error reply's text (the worker's own are at most 4000)


class SandboxError(Exception):
    """The student process failed to answer; the message is shown to the student."""


class Timeout(SandboxError):
    """The student process did not answer in time."""


class Crash(SandboxError):
    """The student process could not start, or died."""


class ProtocolError(SandboxError):
    """The student process sent a reply that breaks the protocol."""


class StudentError(SandboxError):
    """The student's code raised; the worker is still alive."""


class Sandbox:
    """One student process and its request/reply pipes.

    Constructing one does not start the student process: `start` (or `launch` then
    `wait_ready`) starts it, `close` stops it; used as a context manager, it is closed
    on exit.
    """

    def __init__(
        self,
        limits: Limits = Limits(),  # noqa: B008 (frozen)
        *,
        preload: tuple[str, ...] = ("numpy",),
        x64: bool = True,
        forbid: tuple[str, ...] = (),
        protections: Protections | None = None,
    ):
        """**Arguments:**

        - `limits`: a `Limits` (not a dict); default `Limits()`.
        - `preload`: modules the worker imports before any student code; default
          `("numpy",)`.
        - `x64`: float64 in JAX (`JAX_ENABLE_X64`) in the student process; default `True`.
        - `forbid`: modules the student may not import (a list or tuple of dotted names; a
          package forbids its
          submodules, and `"gfxlab"` every gfxlab module but `gfxlab.grading`): inside the
          sandbox they are stubs raising `ImportError`; default none.
        - `protections`: how to isolate the process; default `detect_protections()` (this
          machine, probed once per grader process).

        **Raises:** `TypeError`/`ValueError` naming a wrong argument.
        """
        self.limits = limits_arg(limits, "limits")
        self.preload = module_names(preload, "preload")
        self.x64 = flag(x64, "x64")
        self.forbid = tuple(expand_forbidden(module_names(forbid, "forbid")))
        self.protections = protections or detect_protections()
        self.proc: subprocess.Popen | None = None
        self.workdir: str | None = None
        self.uid: int | None = None
        self.cgroup: str | None = None
        self._memory_checked = 0.0
        self._ready = False
        self._cpu_limit: tuple[float, float] | None = None
        self._cpu_at_close = 0.0  # the last reading, kept by `close`
        self.applied: set[str] = set()  # the resource limits each start really got

    @property
    def alive(self) -> bool:
        """Whether the student process is running and ready for requests."""
        return self._ready and self.proc is not None and self.proc.poll() is None

    def _rlimits(self) -> dict[str, int]:
        limits = self.limits.rlimits()
        if self.uid is None:
            # RLIMIT_NPROC counts every task of the uid: sharing the grader's uid, allow
            # what that uid already runs plus the student's share.
            limits["RLIMIT_NPROC"] += _tasks_of(os.getuid())
        return limits

    def _forbid_args(self) -> list[str]:
        """Empty folders over the base Python's unused package folders; forbidden modules stubbed"""
        stubs = pathlib.Path(self.workdir, "stubs")
        for path in [stubs, stubs / "empty", stubs / "pkg"]:
            path.mkdir(mode=0o755)
            os.chmod(path, 0o755)
        args = [a for d in unused_site_dirs() for a in ("--ro-bind", str(stubs / "empty"), str(d))]
        if not self.forbid:
            return args
        text = f"raise ImportError({'this module is not allowed in this assignment'!r})\n"
        for path in [stubs / "stub.py", stubs / "pkg" / "__init__.py"]:
            path.write_text(text)
            os.chmod(path, 0o644)
        for path, is_dir in forbidden_files(self.forbid):
            source = stubs / ("pkg" if is_dir else "stub.py")
            args += ["--ro-bind", str(source), sandbox_path(path)]
        return args

    def _bwrap_argv(self, req_fd: int, rep_fd: int) -> list[str]:
        prot = self.protections
        tmp = str(int(self.limits.tmp_mb) * 2**20)
        args = [
            prot.bwrap,
            "--unshare-all",
            "--unshare-user",
            "--disable-userns",
            "--uid",
            "1000",
            "--gid",
            "1000",
            "--hostname",
            "sandbox",
            "--die-with-parent",
            "--new-session",
            "--clearenv",
            *_system_binds(),
            "--proc",
            "/proc",
            "--dev",
            "/dev",
        ]
        # The private scratch /tmp and /dev/shm come before the runtime binds: a Python
        # installation or venv that lives under /tmp (a CI checkout, a temporary
        # environment) is then bound on top of the scratch tmpfs instead of hidden by it.
        if self.uid is not None:  # the launcher mounts them, bounded in size and inodes
            args += [
                "--bind",
                self._scratch("shm"),
                "/dev/shm",
                "--bind",
                self._scratch("tmp"),
                "/tmp",
            ]
        else:  # bwrap's tmpfs: bounded in size (inodes only by a cgroup, if any)
            args += ["--size", tmp, "--tmpfs", "/dev/shm", "--size", tmp, "--tmpfs", "/tmp"]
        for path in _runtime_paths():
            args += ["--ro-bind", str(path), str(path)]
        python = _python()
        if os.path.realpath(os.path.dirname(python)) != os.path.dirname(python):
            args += ["--ro-bind", os.path.dirname(python), os.path.dirname(python)]
        if not _package_inside():
            args += ["--ro-bind", str(_PACKAGE), f"{_PACKAGE_TARGET}/gfxlab"]
        args += self._forbid_args()
        if getattr(self, "_seccomp_fd", None) is not None:
            args += ["--seccomp", str(self._seccomp_fd)]
        args += [
            "--remount-ro",
            "/dev",
            # No writes through /proc/PID/mem, which ignore page protections: patching
            # the worker's own code, or bwrap's init to outlive the grading.
            "--remount-ro",
            "/proc",
            "--remount-ro",
            "/",
            "--chdir",
            "/tmp",
        ]
        for key, value in _minimal_env(self.x64).items():
            args += ["--setenv", key, value]
        worker_src = _source("codec.py") + "\n" + _source("_worker.py")
        args += [
            python,
            "-I",
            "-c",
            worker_src,
            str(req_fd),
            str(rep_fd),
            ",".join(self.preload),
            ",".join(self.forbid),
            _PACKAGE_TARGET,
        ]
        return args

    def _scratch(self, name: str) -> str:
        path = os.path.join(self.workdir, name)
        os.makedirs(path, mode=0o755, exist_ok=True)
        return path

    def _make_cgroup(self) -> None:
        parent = self.protections.cgroup_parent
        self.cgroup = None
        if parent:
            self.cgroup = make_cgroup(
                parent,
                f"sub-{secrets.token_hex(6)}",
                memory_bytes=int(self.limits.memory_mb) * 2**20,
                processes=int(self.limits.processes),
            )

    def _joined_cgroup(self) -> None:
        """After the start: the process is in its group, or no cgroup counts as applied."""
        if self.cgroup and self.proc.pid not in cgroup_members(self.cgroup):
            remove_cgroup(self.cgroup)
            self.cgroup = None
        self.applied.add(limits_kind(self.cgroup is not None))

    def start(self) -> None:
        """Start the student process and wait until it is ready."""
        self.launch()
        self.wait_ready()

    @property
    def launched(self) -> bool:
        """Started (perhaps still importing its preloads) and running."""
        return self.proc is not None and self.proc.poll() is None

    def launch(self) -> None:
        """Start the student process without waiting for it (`wait_ready` does).

        A sandbox launched ahead of time (a spare, while the previous submission is
        graded) has run nothing but its preloads: it is as fresh as one started later.
        """
        self.close()
        self._ready, self._cpu_at_close = False, 0.0
        prot = self.protections
        if prot.bwrap is None:
            raise Crash(f"the sandbox cannot start: {prot.problem}")
        self.workdir = tempfile.mkdtemp(prefix="gfxlab-sandbox-")
        os.chmod(self.workdir, 0o711)
        self.uid = secrets.randbelow(900_000) + 1_100_000 if prot.drop_privileges else None
        self._make_cgroup()
        req_r, self._req_w = os.pipe()
        self._rep_r, rep_w = os.pipe()
        self._seccomp_fd = None
        program = seccomp_program()
        if program is not None:
            path = os.path.join(self.workdir, ".seccomp")
            with open(path, "wb") as f:
                f.write(program)
            self._seccomp_fd = os.open(path, os.O_RDONLY)
        extra = () if self._seccomp_fd is None else (self._seccomp_fd,)
        output = open(os.path.join(self.workdir, ".output"), "wb")  # noqa: SIM115
        scratch = []
        if self.uid is not None:
            options = f"size={int(self.limits.tmp_mb)}m,nr_inodes={_SCRATCH_INODES},mode=0700"
            scratch = [
                [self._scratch(n), f"{options},uid={self.uid},gid={self.uid}"]
                for n in ("tmp", "shm")
            ]
        config = {
            "expose": [list(e) for e in prot.expose] if self.uid is not None else [],
            "scratch": scratch,
            "cgroup": self.cgroup,
            "rlimits": self._rlimits(),
            "uid": self.uid,
            "argv": self._bwrap_argv(req_r, rep_w),
        }
        cmd = [sys.executable, "-I", "-S", "-c", _source("_launcher.py"), json.dumps(config)]
        try:
            self.proc = subprocess.Popen(
                cmd,
                stdin=subprocess.DEVNULL,
                stdout=output,
                stderr=subprocess.STDOUT,
                pass_fds=(req_r, rep_w, *extra),
                close_fds=True,
                start_new_session=True,
                env={"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8"},
            )
        finally:
            os.close(req_r)
            os.close(rep_w)
            output.close()
            if self._seccomp_fd is not None:
                os.close(self._seccomp_fd)
        os.set_blocking(self._req_w, False)

    def wait_ready(self) -> None:
        """Wait until a launched student process has imported its preloads."""
        if self.proc is None:
            raise Crash("the student process was not started")
        deadline = time.monotonic() + self.limits.start_timeout
        try:
            reply = self._read_reply(deadline)
        except SandboxError as exc:
            tail = self.output_tail()
            self.close()
            raise Crash(f"the student process did not start: {exc}\n{tail}") from None
        if type(reply) is not dict or reply.get("id") != "ready":
            self.close()
            raise Crash("the student process did not start properly")
        self._joined_cgroup()
        self._ready = True

    def describe(self) -> list[str]:
        """The isolation layers, with the resource limits this submission really got."""
        applied = " / ".join(sorted(self.applied)) or None
        return self.protections.describe(applied)

    def output_tail(self, chars: int = 2000) -> str:
        """The end of the student's stdout/stderr (never parsed, only shown)."""
        if not self.workdir:
            return ""
        try:
            with open(os.path.join(self.workdir, ".output"), "rb") as f:
                f.seek(0, os.SEEK_END)
                f.seek(max(0, f.tell() - chars))
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def request(self, op: str, timeout: float, *, budget: float | None = None, **fields):
        """Send one request; return the decoded value or raise a `SandboxError`.

        `timeout`: CPU seconds the submission's processes may use on it; it also stops at
        `Limits.wall_limit(timeout)` wall seconds, and at `budget` wall seconds if given.
        """
        if not self.alive:
            raise Crash("the student process is not running")
        rid = secrets.token_hex(16)
        wall = self.limits.wall_limit(timeout)
        deadline = time.monotonic() + (wall if budget is None else min(wall, budget))
        try:
            message = codec.dumps({"id": rid, "op": op, **fields})
        except codec.WireError as exc:  # a cell or an argument over the wire limit
            raise StudentError(f"cannot be sent to the student process: {exc}") from None
        # The CPU baseline is taken at the request's first poll (at most 0.25 s in).
        self._cpu_limit = (None, timeout)
        try:
            self._write(message, deadline)
            reply = self._read_reply(deadline)
        except SandboxError:
            self.close()
            raise
        finally:
            self._cpu_limit = None
        if type(reply) is not dict or reply.get("id") != rid or type(reply.get("ok")) is not bool:
            self.close()
            raise ProtocolError("the student process sent an unexpected message")
        if not reply["ok"]:
            error = reply.get("error")
            if type(error) is not str or len(error) > MAX_ERROR_CHARS:
                # The worker sends at most 4000 characters: a forged reply (its sender
                # is stopped like a crash, not called again with the same cost).
                self.close()
                raise ProtocolError("the student process sent a malformed error reply")
            raise StudentError(error)
        try:
            return codec.decode(reply.get("value"), deadline=max(deadline, time.monotonic() + 5))
        except codec.WireError as exc:
            raise ProtocolError(f"unreadable value: {exc}") from None

    def _write(self, data: bytes, deadline: float) -> None:
        view = memoryview(data)
        while view:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise Timeout("timed out")
            _, ready, _ = select.select([], [self._req_w], [], remaining)
            if ready:
                try:
                    view = view[os.write(self._req_w, view) :]
                except BlockingIOError:
                    continue
                except BrokenPipeError:
                    raise Crash(self._death()) from None

    def _read_exact(self, n: int, deadline: float) -> bytes:
        chunks, missing = [], n
        while missing:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self._check_usage(force=True)  # a memory overrun wins over the timeout
                raise Timeout("timed out")
            ready, _, _ = select.select([self._rep_r], [], [], min(remaining, _MEMORY_POLL))
            self._check_usage()  # at most every 0.25 s, quick requests included
            if not ready:
                continue
            chunk = os.read(self._rep_r, min(missing, 1 << 20))
            if not chunk:
                raise Crash(self._death())
            chunks.append(chunk)
            missing -= len(chunk)
        return b"".join(chunks)

    def cpu_seconds(self) -> float:
        """CPU seconds used so far by the submission's processes: its cgroup's account
        where it has one (`cgroup_cpu_seconds`), else the process tree's from /proc; 0
        before it starts; after `close`, the reading taken as it stopped the processes."""
        if self.cgroup:
            seconds = cgroup_cpu_seconds(self.cgroup)
            if seconds is not None:
                return seconds
        if self.proc is None:
            return self._cpu_at_close
        return _tree_usage(self.proc.pid)[1]

    def _check_usage(self, force: bool = False) -> None:
        """Polled while the grader waits for a reply (every 0.25 s): the CPU time of the
        current request, and without cgroup v2 the memory of all the submission's
        processes together (RLIMIT_AS bounds one process; children each under it could
        together exhaust the host).
        """
        if self.proc is None:
            return
        now = time.monotonic()
        if not force and now - self._memory_checked < _MEMORY_POLL:
            return
        self._memory_checked = now
        rss, cpu = (0, self.cpu_seconds()) if self.cgroup else _tree_usage(self.proc.pid)
        if rss > int(self.limits.memory_mb) * 2**20:
            self.close()
            raise Crash(
                f"the submission used more than {self.limits.memory_mb} MB of memory "
                "(all its processes together) and was stopped"
            )
        if self._cpu_limit is not None:
            start, limit = self._cpu_limit
            if start is None:
                self._cpu_limit = (cpu, limit)
            elif cpu - start > limit:
                raise Timeout("timed out (CPU time)")

    def _read_reply(self, deadline: float):
        (size,) = struct.unpack(">I", self._read_exact(4, deadline))
        if size > codec.MAX_MESSAGE_BYTES:
            raise ProtocolError("reply too large")
        try:
            return codec.loads(self._read_exact(size, deadline))
        except codec.WireError as exc:
            raise ProtocolError(str(exc)) from None

    def _death(self) -> str:
        try:
            code = self.proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            return "the student process stopped answering"
        if code > 128:  # bwrap's init reports a child killed by signal N as 128 + N
            code = 128 - code
        if code < 0:
            return f"the student process was killed by {_signal_name(-code)}"
        return f"the student process exited (status {code})"

    def close(self) -> None:
        """Kill the student process, every process it started, and remove its files;
        `cpu_seconds` keeps reporting the CPU time they used."""
        if self.proc is not None:
            self._cpu_at_close = self.cpu_seconds()
        proc, self.proc = self.proc, None
        self._ready = False
        if proc is not None:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                pass
            for fd in (self._req_w, self._rep_r):
                try:
                    os.close(fd)
                except OSError:
                    pass
        if self.cgroup:
            remove_cgroup(self.cgroup)
            self.cgroup = None
        if self.workdir:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None

    def __enter__(self):
        """Return the sandbox itself (not started: call `start`)."""
        return self

    def __exit__(self, *exc):
        """Close the sandbox (`close`); exceptions propagate."""
        self.close()
