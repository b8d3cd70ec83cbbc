"""First stage of the student process (standard library only, run as `python -I -S -c`).

Runs with the grader's privileges, inside fresh namespaces when `unshare` is available,
and narrows everything before it becomes the student worker with `execve`:

1. In a private mount namespace: hides directories (the autograder, the submissions)
   under empty read-only tmpfs mounts, re-exposes the Python installation when it sits
   under a directory an unprivileged user cannot enter (such as `/root`), gives the
   student private small `/tmp`, `/var/tmp` and `/dev/shm`, and binds the trusted JAX
   compilation cache read-only.
2. Sets resource limits (CPU, address space, file size, processes, open files, core).
3. Drops to an unprivileged uid/gid with no supplementary groups.
4. `execve`s the worker with a minimal environment.

Its single argument is a JSON object written by `gfxlab.grading.sandbox`.
"""

import ctypes
import json
import os
import resource
import sys

MS_RDONLY, MS_NOSUID, MS_NODEV, MS_REMOUNT, MS_BIND, MS_REC = 1, 2, 4, 32, 4096, 16384
MS_PRIVATE = 1 << 18


def _mount(source, target, fstype, flags, data=None):
    libc = ctypes.CDLL(None, use_errno=True)
    as_bytes = lambda s: None if s is None else s.encode()
    if libc.mount(as_bytes(source), as_bytes(target), as_bytes(fstype), flags, as_bytes(data)):
        errno = ctypes.get_errno()
        raise OSError(errno, os.strerror(errno), target)


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
    uid = config["uid"]
    if config["mount_namespace"]:
        _mount(None, "/", None, MS_REC | MS_PRIVATE)
        cache = config.get("jax_cache")
        cache_handle = os.open(cache["source"], os.O_PATH) if cache else None
        for blocker, paths in config["expose"]:
            _expose(blocker, paths)
        for path in config["hide"]:
            if os.path.isdir(path):
                _mount("tmpfs", path, "tmpfs", MS_RDONLY | MS_NOSUID | MS_NODEV, "mode=0,size=4k")
        # Private, small temporary directories: nothing shared with other runs or the host,
        # except the Python installation and gfxlab when they live there (a checkout in /tmp).
        for path in config["private_tmp"]:
            if os.path.isdir(path):
                inside = [k for k in config.get("keep", []) if k.startswith(path.rstrip("/") + "/")]
                handles = [os.open(k, os.O_PATH) for k in inside]
                size = f"mode=1777,size={config['tmp_mb']}m"
                _mount("tmpfs", path, "tmpfs", MS_NOSUID | MS_NODEV, size)
                for kept, handle in zip(inside, handles, strict=True):
                    os.makedirs(kept, mode=0o755, exist_ok=True)
                    _mount(f"/proc/self/fd/{handle}", kept, None, MS_BIND | MS_REC)
                    os.close(handle)
        os.makedirs(config["workdir"], mode=0o700, exist_ok=True)
        if uid is not None:
            os.chown(config["workdir"], uid, uid)
        if cache:
            os.makedirs(cache["target"], mode=0o755, exist_ok=True)
            _mount(f"/proc/self/fd/{cache_handle}", cache["target"], None, MS_BIND)
            if not cache["writable"]:
                flags = MS_BIND | MS_REMOUNT | MS_RDONLY | MS_NOSUID | MS_NODEV
                _mount(None, cache["target"], None, flags)
            os.close(cache_handle)
    for name, value in config["rlimits"].items():
        limit = getattr(resource, name)
        resource.setrlimit(limit, (value, value))
    os.chdir(config["workdir"])
    if uid is not None:
        os.setgroups([])
        os.setgid(config["gid"])
        os.setuid(uid)
    os.umask(0o077)
    argv = config["argv"]
    os.execve(argv[0], argv, config["env"])


if __name__ == "__main__":
    main()
