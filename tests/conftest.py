"""Shared test setup: float64 everywhere, hypothesis profile, jit/no-jit fixture."""

import os
import pathlib

# A larger young generation for the cyclic collector, in this process and (through
# tests/_gc_startup/sitecustomize.py, which says why and what it saves) in every Python
# process the run starts: test workers, lab kernels, the contract sweep. The folder goes
# on `PYTHONPATH` only where it shadows no sitecustomize of the interpreter's own.
_GC_STARTUP = pathlib.Path(__file__).resolve().parent / "_gc_startup"


def _use_gc_startup() -> None:
    import gc
    import importlib.util

    gc.set_threshold(50_000, 10, 10)
    spec = importlib.util.find_spec("sitecustomize")
    if spec is not None and pathlib.Path(spec.origin or "").parent != _GC_STARTUP:
        return
    paths = os.environ.get("PYTHONPATH", "").split(os.pathsep)
    if str(_GC_STARTUP) not in paths:
        os.environ["PYTHONPATH"] = os.pathsep.join([str(_GC_STARTUP), *filter(None, paths)])


_use_gc_startup()
# The reference libraries' OpenBLAS would start a thread per core, which spin after each
# call: on two cores shared by three test workers they only take CPU from the others
# (2 % of a worker's CPU time in `blas_thread_server`). The workers and the children
# start with it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# The suite's time is mostly XLA compiling small programs that run once. XLA's legacy
# CPU emitters with LLVM at -O0 compile them in about half the time of the default
# pipeline (whose fusion emitters ignore the optimisation level), and run them slower,
# which tests barely notice. Set before JAX creates its CPU client; the labs keep the
# user's flags (tests/test_labs.py), since they time what students see.
# `GFXLAB_TEST_XLA_FLAGS=""` runs the suite with XLA's defaults.
# One LLVM module per program, not several compiled on threads: on two cores shared by
# two test workers the split only adds a fixed cost (a small program compiles in about
# 50 ms instead of 90, a renderer's gradient in 2/3 of the time).
FAST_COMPILE_XLA_FLAGS = (
    "--xla_cpu_use_fusion_emitters=false --xla_backend_optimization_level=0 "
    "--xla_llvm_disable_expensive_passes=true --xla_cpu_parallel_codegen_split_count=1"
)
# Older XLAs lack the emitter flag (and abort on an unknown flag): fall back to these.
PORTABLE_FAST_COMPILE_XLA_FLAGS = (
    "--xla_backend_optimization_level=0 --xla_llvm_disable_expensive_passes=true"
)
USER_XLA_FLAGS = os.environ.get("GFXLAB_USER_XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))
os.environ["GFXLAB_USER_XLA_FLAGS"] = USER_XLA_FLAGS

import subprocess  # noqa: E402
import sys  # noqa: E402

# Test files read notebooks with nbformat before gfxlab's runner is imported: skip
# jsonschema's IRI checker here too (2 s per pytest process; see gfxlab/_runner.py).
sys.modules.setdefault("rfc3987_syntax", None)


def _test_xla_flags() -> str:
    """The suite's XLA flags: `GFXLAB_TEST_XLA_FLAGS` if set, else the fast-compile ones
    if this XLA accepts them (probed once in a child; xdist workers inherit the answer)."""
    if "GFXLAB_TEST_XLA_FLAGS" not in os.environ:
        probe = subprocess.run(
            [sys.executable, "-c", "import jax.numpy as j; j.zeros(1).block_until_ready()"],
            env=dict(os.environ, XLA_FLAGS=f"{USER_XLA_FLAGS} {FAST_COMPILE_XLA_FLAGS}"),
            capture_output=True,
            timeout=120,
        )
        accepted = probe.returncode == 0
        flags = FAST_COMPILE_XLA_FLAGS if accepted else PORTABLE_FAST_COMPILE_XLA_FLAGS
        os.environ["GFXLAB_TEST_XLA_FLAGS"] = flags
    return os.environ["GFXLAB_TEST_XLA_FLAGS"]


os.environ["XLA_FLAGS"] = f"{USER_XLA_FLAGS} {_test_xla_flags()}".strip()

import jax  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402
from jax_frame_filter import memoize_jax_frame_filter  # noqa: E402

jax.config.update("jax_enable_x64", True)
memoize_jax_frame_filter()

# CI runs on 2 cores: keep property sweeps modest there; `HYPOTHESIS_PROFILE=thorough`
# for more.
settings.register_profile(
    "ci",
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
)
settings.register_profile("thorough", max_examples=1000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(params=[False, True], ids=["eager", "jit"])
def maybe_jit(request):
    """Run a test body both unjitted and under `jax.jit` (dm-pix style).

    Use as `maybe_jit(fn, static_argnames=...)(args...)`.
    """
    if request.param:
        return jax.jit
    return lambda fn, **_: fn


# Under `--dist loadgroup` the tests of one file share a worker (an `xdist_group` named
# after the file), so each file's compiled programs are built once, not once per worker
# (measured: 4,321 programs compiled in a run instead of 4,934). These files' tests are
# independent units instead: each lab is a kernel of its own, each contract group a
# process of its own, and the import checks are subprocesses; spread over the workers,
# they balance the load.
_UNGROUPED_FILES = ("test_labs.py", "test_contract.py", "test_package.py")

# The longest units first, so the workers finish together (xdist hands out work units
# in collection order, with `--no-loadscope-reorder`): the slow labs, the contract sweep,
# the largest test files and grading sandboxes, then the rest.
_SLOW_FIRST = (
    "test_labs.py::test_lab_runs_top_to_bottom[05",
    "test_labs.py::test_lab_runs_top_to_bottom[07",
    "test_contract.py",
    "test_render_renderer.py",
    "test_labs.py::test_lab_runs_top_to_bottom[03",
    "test_labs.py::test_lab_runs_top_to_bottom[08",
    "test_grading_attacks.py",
    "test_jpeg.py",
    "test_labs.py",
    "test_grading",
    "test_image_filters.py",
    "test_render_soft.py",
    "test_wheel.py",
)


class _GroupByFile:
    """Gives every test of a grouped file the file's `xdist_group`, before pytest-xdist
    tags the groups' node ids (a conftest holds one implementation of a hook)."""

    @pytest.hookimpl(tryfirst=True)
    def pytest_collection_modifyitems(self, items):
        for item in items:
            file = item.path.name
            if file.startswith("test_") and file not in _UNGROUPED_FILES:
                if not item.get_closest_marker("xdist_group"):
                    item.add_marker(pytest.mark.xdist_group(item.path.stem))


def pytest_configure(config):
    config.pluginmanager.register(_GroupByFile(), "gfxlab-group-by-file")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    if getattr(config.option, "loadgroup", False):
        # A worker under `--dist loadgroup`: pytest-xdist has tagged each grouped test's
        # node id with `@group` by now. Untagged, the groups' tests (and their module
        # fixtures, such as a whole grading batch) are split over the workers.
        untagged = [
            item.nodeid for item in items
            if item.get_closest_marker("xdist_group") and "@" not in item.nodeid
        ]  # fmt: skip
        if untagged:
            raise pytest.UsageError(
                "pytest-xdist did not tag the xdist_group of "
                f"{untagged[0]} (pytest {pytest.__version__}); install the pytest "
                "versions pyproject.toml's dev extra allows"
            )

    def rank(item):
        found = [i for i, part in enumerate(_SLOW_FIRST) if part in item.nodeid]
        return found[0] if found else len(_SLOW_FIRST)

    items.sort(key=rank)  # stable: the order within a rank is kept


def pytest_sessionfinish(session, exitstatus):
    """After the lab tests (`tests/test_labs.py`), write the gallery's index page.

    Runs once, in the main process (xdist workers carry `workerinput`), and only when
    `make test` asked for the executed labs to be kept (`GFXLAB_LABS_OUT`).
    """
    out = os.environ.get("GFXLAB_LABS_OUT")
    if hasattr(session.config, "workerinput") or not out:
        return
    import pathlib

    from gfxlab import labs

    out = pathlib.Path(out)
    runs = [
        labs.LabRun(lab, labs.lab_title(lab), out / f"{lab.stem}.html", 0.0)
        for lab in labs.list_labs()
        if (out / f"{lab.stem}.html").is_file()
    ]
    if runs:
        labs.write_index(out, runs)


# `GFXLAB_COMPILE_PROFILE=FILE pytest ...` appends one line per test phase to FILE: the
# seconds spent compiling (XLA), the number of compiled programs, the wall time, and the
# CPU seconds of this process and of the child processes it waited for (kernels,
# sandboxes, subprocesses); sort it to see where the suite's CPU goes (mostly compiling).
_PROFILE = os.environ.get("GFXLAB_COMPILE_PROFILE")
if _PROFILE:
    import resource
    import time

    import jax.monitoring

    _compiled = [0.0, 0]

    _programs: list[str] = []  # each compiled program's name and seconds, for FILE.programs

    def _on_duration(event, duration, fun_name="?", **_):
        if event == "/jax/core/compile/backend_compile_duration":
            _compiled[0] += duration
            _compiled[1] += 1
            _programs.append(f"{duration:.3f} {fun_name}")

    jax.monitoring.register_event_duration_secs_listener(_on_duration)

    def _children_cpu() -> float:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        before, start = list(_compiled), time.perf_counter()
        cpu, children = time.process_time(), _children_cpu()
        yield
        with open(_PROFILE, "a") as out:
            out.write(
                f"{os.environ.get('PYTEST_XDIST_WORKER', 'gw')} {start:12.2f} "
                f"{_compiled[0] - before[0]:8.2f} {_compiled[1] - before[1]:5d} "
                f"{time.perf_counter() - start:8.2f} {time.process_time() - cpu:8.2f} "
                f"{_children_cpu() - children:8.2f} {item.nodeid}\n"
            )
        with open(f"{_PROFILE}.programs", "a") as out:
            out.writelines(f"{p} {item.nodeid}\n" for p in _programs)
        _programs.clear()
