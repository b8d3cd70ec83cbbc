"""First stage of the student process (standard library only, run as `python -I -S -c`).

Runs with the grader's privileges and narrows everything before it becomes bubblewrap
(`bwrap`), which builds the student's allow-list filesystem and namespaces:

1. As root only: in a private mount namespace, re-exposes the Python installation when it
   sits under a directory an unprivileged user cannot enter (such as `/root`), so that
   bwrap, started as a fresh unprivileged uid, can bind it; and mounts the student's
   scratch tmpfs (`/tmp`, `/dev/shm`) bounded in size and in inodes.
2. Joins the submission's cgroup (cgroup v2 `memory.max`, `pids.max`, `cpu.max`) when the
   grader made one.
3. Sets resource limits (CPU, address space, file size, processes, open files, core).
4. As root: drops to a fresh unprivileged uid/gid with no supplementary groups.
5. `execve`s bwrap with an empty environment.

Its single argument is a JSON object written by `gfxlab.grading.sandbox`.
"""

import ctypes
import json
import os
import resource
import sys

MS_NOSUID, MS_NODEV, MS_BIND, MS_REC, MS_PRIVATE = 2, 4, 4096, 16384, 1 << 18
CLONE_NEWNS = 0x00020000


def _libc():
    return ctypes.CDLL(None, use_errno=True)


def _check(result, what):
    if result:
        errno = ctypes.get_errno()
        raise OSError(errno, os.strerror(errno), what)


def _mount(source, target, fstype, flags, data=None):
    as_bytes = lambda s: None if s is None else s.encode()
    _check(
        _libc().mount(as_bytes(source), as_bytes(target), as_bytes(fstype), flags, as_bytes(data)),
        target,
    )


def _expose(blocker, paths):
    """Make `paths` reachable although their ancestor `blocker` is closed to other users.

    Everything else under `blocker` disappears behind an empty tmpfs.
    """
    handles = [os.open(path, os.O_PATH) for path in paths]
    _mount("tmpfs", blocker, "tmpfs", MS_NOSUID | MS_NODEV, "mode=0755,size=64k")
    for path, handle in zip(paths, handles, strict=True):
        os.makedirs(path, mode=0o755, exist_ok=True)
        _mount(f"/proc/self/fd/{handle}", path, None, MS_BIND | MS_REC)
        os.close(handle)


def main():
    config = json.loads(sys.argv[1])
    scratch = config.get("scratch", [])
    if config["expose"] or scratch:
        _check(_libc().unshare(CLONE_NEWNS), "unshare(CLONE_NEWNS)")
        _mount(None, "/", None, MS_REC | MS_PRIVATE)
        for blocker, paths in config["expose"]:
            _expose(blocker, paths)
        for path, options in scratch:  # private scratch, bounded in bytes and inodes
            _mount("tmpfs", path, "tmpfs", MS_NOSUID | MS_NODEV, options)
    if config.get("cgroup"):
        try:  # the grader checks membership and reports what applied
            with open(os.path.join(config["cgroup"], "cgroup.procs"), "w") as f:
                f.write(str(os.getpid()))
        except OSError:
            pass
    for name, value in config["rlimits"].items():
        limit = getattr(resource, name)
        resource.setrlimit(limit, (value, value))
    uid = config["uid"]
    if uid is not None:
        os.setgroups([])
        os.setgid(uid)
        os.setuid(uid)
    argv = config["argv"]
    os.execve(argv[0], argv, {})


if __name__ == "__main__":
    main()
