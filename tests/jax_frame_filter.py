"""A speed-up for processes of the test suite that trace many `equinox.error_if` checks
(the pytest workers, the contract sweep's interpreter); tests only."""


def memoize_jax_frame_filter() -> None:
    """Cache JAX's per-file "is this frame JAX's own?" test (tests only).

    `equinox.error_if` asks it for every frame of the stack each time it traces a check,
    and JAX answers with `os.path.samefile` against each of ~30 excluded paths: ~1.6 ms a
    frame, ~100 ms a check under pytest's deep stack, a third of some test files' time.
    The answer depends only on the file name and the exclusion list, so it is cached on
    both. A JAX that moved the function keeps its own (only slower).
    """
    try:
        from jax._src import traceback_util
    except ImportError:
        return
    original = getattr(traceback_util, "include_filename", None)
    excluded = getattr(traceback_util, "_exclude_paths", None)
    if original is None or not isinstance(excluded, list):
        return
    answers: dict[tuple[str, int], bool] = {}

    def include_filename(filename: str) -> bool:
        key = (filename, len(excluded))
        if key not in answers:
            answers[key] = original(filename)
        return answers[key]

    traceback_util.include_filename = include_filename
