"""The student process: runs the student's cells and answers calls to their functions.

Started by the sandbox as `python -I -c <codec.py + this file> REQ_FD REP_FD`, with the
student's code as its only input. It reads framed requests from REQ_FD and writes framed
replies to REP_FD; stdout and stderr go to a size-capped file the grader never parses.
The fixed menu of operations is `exec` (run one cell), `names` (which names are
functions) and `call` (call a function, optionally through `jax.jit`, `jax.grad`,
`jax.value_and_grad` or `jax.vmap`). No code comes from the grader: only cell sources
(the student's own), function names, operation names and plain data.
"""

import builtins
import os
import signal
import struct
import sys
import traceback

if "encode" not in globals():  # imported as a module (linting, tests), not run as the worker
    from gfxlab.grading.codec import WireError, decode, dumps, encode, loads

TRANSFORMS = ("jit", "grad", "value_and_grad", "vmap")


def _read_exact(fd, n):
    chunks, missing = [], n
    while missing:
        chunk = os.read(fd, missing)
        if not chunk:
            return None
        chunks.append(chunk)
        missing -= len(chunk)
    return b"".join(chunks)


def _write_all(fd, data):
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


def _plain(value):
    """jax arrays -> numpy, recursively through exact lists, tuples and dicts."""
    kind = type(value)
    if kind in (list, tuple):
        return kind(_plain(v) for v in value)
    if kind is dict:
        return {k: _plain(v) for k, v in value.items()}
    jax = sys.modules.get("jax")
    if jax is not None and isinstance(value, jax.Array) and not isinstance(value, jax.core.Tracer):
        import numpy

        return numpy.asarray(value)
    return value


def _student_function(namespace, name):
    if name not in namespace:
        raise NameError(f"`{name}` is not defined in the notebook")
    fn = namespace[name]
    if not callable(fn):
        raise TypeError(f"`{name}` should be a function, got {type(fn).__name__}")
    return fn


def _transformed(fn, transforms):
    for op, options in transforms:
        if op not in TRANSFORMS or type(options) is not dict:
            raise ValueError(f"unknown transform {op!r}")
        import jax

        fn = getattr(jax, op)(fn, **options)
    return fn


def _options(raw):
    """Transform options: only a few plain keywords, ints or tuples of ints."""
    allowed = {"argnums", "static_argnums", "static_argnames", "in_axes", "has_aux"}
    out = {}
    for key, value in raw.items():
        if key not in allowed:
            raise ValueError(f"transform option {key!r} is not allowed")
        out[key] = value
    return out


def _handle(request, namespace, cache):
    op = request["op"]
    if op == "exec":
        code = compile(request["source"], f"<cell {request['cell']}>", "exec")
        try:
            exec(code, namespace)
        finally:
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except Exception:
                    pass
        return None
    if op == "names":
        return [callable(namespace.get(name)) for name in decode(request["names"])]
    if op == "call":
        name = request["name"]
        transforms = tuple(
            (op_, tuple(sorted(_options(opts).items())))
            for op_, opts in decode(request["transforms"])
        )
        key = (name, id(namespace.get(name)), transforms)
        if key not in cache:
            fn = _student_function(namespace, name)
            cache[key] = _transformed(fn, [(op_, dict(opts)) for op_, opts in transforms])
        args = decode(request["args"])
        kwargs = decode(request["kwargs"])
        return _plain(cache[key](*args, **kwargs))
    raise ValueError(f"unknown operation {op!r}")


def _describe(exc):
    """`Type: message` plus the student's own frames, short."""
    frames = [
        f"  {f.filename}, line {f.lineno}, in {f.name}"
        for f in traceback.extract_tb(exc.__traceback__)
        if f.filename.startswith("<cell")
    ]
    kind = "the returned value" if type(exc) is WireError else type(exc).__name__
    text = f"{kind}: {exc}"
    if frames:
        text += "\n" + "\n".join(frames[-6:])
    return text[:4000]


def serve(req_fd, rep_fd):
    pid = os.getpid()
    namespace = {"__name__": "__main__", "__builtins__": builtins}
    cache = {}
    while True:
        header = _read_exact(req_fd, 4)
        if os.getpid() != pid:  # a child the student forked must not answer requests
            os._exit(0)
        if header is None:
            return
        (size,) = struct.unpack(">I", header)
        request = loads(_read_exact(req_fd, size) or b"")
        try:
            reply = {"id": request["id"], "ok": True}
            reply["value"] = encode(_handle(request, namespace, cache))
        except BaseException as exc:  # SystemExit and KeyboardInterrupt too: report, go on
            if os.getpid() != pid:
                os._exit(0)
            reply = {"id": request["id"], "ok": False, "error": _describe(exc)}
        if os.getpid() != pid:
            os._exit(0)
        _write_all(rep_fd, dumps(reply))


class _Forbidden:
    """Meta-path finder: the assignment's forbidden modules raise `ImportError`.

    A convenience for a clear message; the sandbox also replaces their files by stubs, so
    removing this finder does not make them importable.
    """

    def __init__(self, names):
        self.names = names

    def find_spec(self, name, path=None, target=None):
        for banned in self.names:
            if name == banned or name.startswith(banned + "."):
                raise ImportError(f"`{banned}` is not allowed in this assignment" + _via(banned))
        return None


NATIVE_GATED = ("ctypes", "_ctypes")  # numpy.ctypeslib does without (and loads nothing)
NATIVE_IMPORTERS = ("jax", "jaxlib", "scipy")  # they import it themselves


class _NativeGate:
    """Meta-path finder for `ctypes`, which runs any native library (a forbidden
    package's own, the system's libjpeg).

    A student's import of it fails. JAX and SciPy import it as they load
    (`jax._src.ffi`, `scipy._lib._ccallback`) but need it only to call native code the
    student would bring: they get `_InertCtypes`, a stand-in with the names they read
    and nothing that runs native code. So no module attribute (`jax._src.ffi.ctypes`)
    leads to the real one, and the real one's files can be forbidden like `cffi`'s.
    """

    def find_spec(self, name, path=None, target=None):
        if not any(name == g or name.startswith(g + ".") for g in NATIVE_GATED):
            return None
        if not _imported_by_a_library():
            raise ImportError(f"`{name}` (native code) is not allowed in a graded submission")
        import importlib.machinery

        return importlib.machinery.ModuleSpec(name, self)

    def create_module(self, spec):
        return _InertCtypes(spec.name)

    def exec_module(self, module):
        pass


class _NoNativeCode:
    """Every type and value of the stand-in `ctypes`: making one, calling it or reading
    its attributes gives another (what SciPy does as it loads), and none is native."""

    def __init__(self, *args, **kwargs):
        pass

    def __call__(self, *args, **kwargs):
        return _NoNativeCode()

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return _NoNativeCode()


def _function_type(*args, **kwargs):
    """`CFUNCTYPE(...)`: a function-pointer type no object is an instance of."""
    return type("CFunctionType", (_NoNativeCode,), {})


_INERT_TYPES: dict = {}


def _inert_attribute(module, name):
    if name.startswith("__"):
        raise AttributeError(name)
    if name in ("CFUNCTYPE", "PYFUNCTYPE"):
        return _function_type
    if name not in _INERT_TYPES:
        _INERT_TYPES[name] = type(name, (_NoNativeCode,), {})
    return _INERT_TYPES[name]


class _InertCtypes(type(sys)):
    """What JAX and SciPy see of `ctypes` in a student process (see `_NativeGate`)."""

    __getattr__ = _inert_attribute


def _imported_by_a_library():
    frame = sys._getframe(2)
    while frame is not None:
        name = frame.f_globals.get("__name__")
        if type(name) is not str:
            return False
        if not name.startswith(("importlib", "_frozen_importlib")):
            break
        frame = frame.f_back
    if frame is None or name.split(".")[0] not in (*NATIVE_IMPORTERS, "ctypes"):
        return False
    package = sys.modules.get(name.split(".")[0])
    places = [os.path.realpath(p) + os.sep for p in getattr(package, "__path__", [])]
    filename = os.path.realpath(frame.f_code.co_filename)
    return any(filename.startswith(p) for p in places)


def _via(banned):
    """` (imported through `scipy.signal` -> `scipy`)`: the modules that needed it."""
    chain, frame = [], sys._getframe(2)
    while frame is not None:
        name = frame.f_globals.get("__name__")
        if name == "__main__" or type(name) is not str:
            break
        if not name.startswith(("importlib", "_frozen_importlib", banned)):
            if name not in chain:
                chain.append(name)
        frame = frame.f_back
    if not chain:
        return ""
    return " (imported through " + " -> ".join(f"`{n}`" for n in chain[::-1][:5]) + ")"


def main():
    req_fd, rep_fd = int(sys.argv[1]), int(sys.argv[2])
    preload = [m for m in sys.argv[3].split(",") if m]
    forbid = [m for m in sys.argv[4].split(",") if m]
    sys.path.insert(0, sys.argv[5])  # where the sandbox binds the gfxlab package
    # Past the output cap a write fails with an error instead of killing the process.
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    sys.argv = ["student"]
    if forbid:
        sys.meta_path.insert(0, _Forbidden(tuple(forbid)))
    sys.meta_path.insert(0, _NativeGate())
    for module in preload:
        __import__(module)
    for name in NATIVE_GATED:  # imported by JAX or SciPy: the next `import ctypes` asks the gate
        sys.modules.pop(name, None)
    _write_all(rep_fd, dumps({"id": "ready", "ok": True, "value": encode(os.getuid())}))
    serve(req_fd, rep_fd)


if __name__ == "__main__":
    main()
