"""`python -m gfxlab assign|check|grade`: the command line of `gfxlab.grading`."""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from . import authoring, commands, grader
from .sandbox import IsolationUnavailable, detect_protections


def _limit_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--timeout",
        type=float,
        help="CPU seconds per function call (the wall-clock limit is 3x that plus 5 s)",
    )
    parser.add_argument("--memory-mb", type=int, help="address-space limit of the student")
    parser.add_argument(
        "--budget", type=float, help="wall seconds for one whole submission (restarts included)"
    )


def _limits(args) -> dict:
    out = {}
    if args.timeout is not None:
        out["call_timeout"] = args.timeout
    if args.memory_mb is not None:
        out["memory_mb"] = args.memory_mb
    if args.budget is not None:
        out["budget_seconds"] = args.budget
    return out


def _assign(argv) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab assign",
        description="Split an instructor notebook into OUT/student/ and OUT/autograder/. "
        "Public-test cells are copied verbatim into the student notebook (the handout): "
        "nothing in them may compute the answer; `assign` tries each helper function "
        "defined there as a wrong answer and refuses the assignment if one earns marks.",
    )
    parser.add_argument("source", type=pathlib.Path, help="instructor notebook (.ipynb)")
    parser.add_argument("out", type=pathlib.Path, help="output directory")
    parser.add_argument(
        "--no-verify",
        action="store_true",
        help="skip proving the tests (reference, blank notebook, wrong answers)",
    )
    parser.add_argument(
        "--gradescope", action="store_true", help="also write OUT/autograder.zip for Gradescope"
    )
    _limit_args(parser)
    args = parser.parse_args(argv)
    try:
        result = commands.assign(
            args.source,
            args.out,
            verify_tests=not args.no_verify,
            limits=_limits(args),
            gradescope=args.gradescope,
        )
    except (authoring.AuthoringError, FileNotFoundError) as exc:
        print(f"authoring error: {exc}", file=sys.stderr)
        return 1
    print(f"student notebook: {result.student_notebook}")
    print(f"autograder:       {result.autograder}")
    if result.gradescope is not None:
        print(f"gradescope:       {result.gradescope}")
    if result.reference is not None:
        print(
            f"reference solution: {result.reference.score:g}/{result.reference.max_score:g}; "
            f"unsolved notebook: {result.blank.score:g}/{result.blank.max_score:g}; "
            f"{result.mutants} generated wrong answers earn nothing"
        )
    return 0


def _check(argv) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab check",
        description="Run the public tests of an assignment notebook on that notebook.",
    )
    parser.add_argument("notebook", type=pathlib.Path)
    _limit_args(parser)
    args = parser.parse_args(argv)
    try:
        result = commands.check(args.notebook, limits=_limits(args))
    except (authoring.AuthoringError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(result.table())
    for q in result.questions:
        print(f"{q.name}:\n{q.feedback()}\n")
    for note in result.notes:
        print(f"note: {note}")
    print("(public tests only; hidden tests decide the final grade)")
    if result.error:
        print(f"error: the sandbox failed: {result.error}", file=sys.stderr)
        return 2
    return 0


def _grade_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab grade",
        usage="python -m gfxlab grade SUBMISSION --autograder DIR [options]\n"
        "       python -m gfxlab grade --isolation",
        description="Grade a submitted notebook, or every .ipynb in a folder in parallel.",
    )
    parser.add_argument("submission", type=pathlib.Path, help="notebook or folder of notebooks")
    parser.add_argument(
        "--autograder",
        type=pathlib.Path,
        required=True,
        help="the autograder directory written by `assign` (required to grade)",
    )
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        help="results.json path (one notebook) or output folder (a folder); "
        "default: ./results.json or ./grading-results/",
    )
    parser.add_argument("--jobs", type=int, help="parallel graders (default: CPU cores)")
    parser.add_argument("--verbose", action="store_true", help="print per-test feedback")
    parser.add_argument(
        "--isolation",
        action="store_true",
        help="print which isolation layers are active here, and exit",
    )
    _limit_args(parser)
    return parser


def _grade(argv) -> int:
    if "--isolation" in argv:  # which isolation layers this machine gives, then exit
        protections = detect_protections()
        print("\n".join(protections.describe()))
        return 0 if protections.confined else 1  # a script can test the host by exit code
    args = _grade_parser().parse_args(argv)
    if not (args.autograder / "config.json").is_file():
        print(f"error: {args.autograder} is not an autograder directory", file=sys.stderr)
        return 1
    if args.submission.is_dir():
        return _grade_folder(args)
    if not args.submission.is_file():
        print(f"error: {args.submission} not found", file=sys.stderr)
        return 1
    return _grade_notebook(args)


def _grade_folder(args) -> int:
    """Grade every .ipynb of the folder `args.submission` in parallel."""
    notebooks = sorted(args.submission.glob("*.ipynb"))
    if not notebooks:
        print(f"error: no .ipynb files in {args.submission}", file=sys.stderr)
        return 1
    out = args.out or pathlib.Path("grading-results")
    results = commands.grade_many(
        notebooks, args.autograder, out, jobs=args.jobs, limits=_limits(args)
    )
    for r in results:
        flag = "  GRADING ERROR" if r.error else ""
        print(
            f"{r.submission[:40]!s:40s} {r.score:7.2f} / {r.max_score:g}  ({r.seconds:.1f} s){flag}"
        )
    print(f"summary: {out / 'summary.csv'}")
    errors = sum(bool(r.error) for r in results)
    if errors:
        print(
            f"error: the grader failed on {errors} submission(s); see summary.csv",
            file=sys.stderr,
        )
        return 2
    return 0


def _grade_notebook(args) -> int:
    """Grade the one notebook `args.submission`."""
    # In a child process killed at the hard limit; its sandbox starts while tests load.
    try:
        result = grader.grade_one(args.autograder, args.submission, limits=_limits(args))
    except IsolationUnavailable:
        raise
    except Exception as exc:  # the grader broke: still a bounded results file, exit code 2
        autograder = grader.Autograder(args.autograder)
        result = autograder.empty_result(args.submission.name, "", f"grader error: {exc!r}")
    out = args.out or pathlib.Path("results.json")
    out.write_text(json.dumps(result.to_gradescope(), indent=1))
    print(result.table())
    if args.verbose:
        for q in result.questions:
            print(f"{q.name}:\n{q.feedback()}\n")
    for note in result.notes:
        print(f"note: {note}")
    for note in result.staff_notes:
        print(f"staff note (not shown to the student): {note}")
    print(f"results: {out}  ({result.seconds:.2f} s)")
    if result.error:
        print(f"error: the grader failed: {result.error}", file=sys.stderr)
        return 2
    return 0


def _gradescope(argv) -> int:
    """`python -m gfxlab.grading.cli gradescope AUTOGRADER SUBMISSION_DIR RESULTS_JSON`."""
    from .gradescope import run

    return run(*[pathlib.Path(a) for a in argv])


def _safe_streams() -> None:
    """Print any text (student exception messages may hold lone surrogates or characters the
    terminal's encoding lacks) as escapes instead of failing with `UnicodeEncodeError`."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # a detached or closed stream: leave it
                pass


def main(command: str, argv: list[str]) -> int:
    """Entry point used by `python -m gfxlab` (`command` is assign, check or grade)."""
    _safe_streams()
    handlers = {"assign": _assign, "check": _check, "grade": _grade, "gradescope": _gradescope}
    if command not in handlers:
        print(f"unknown grading command {command!r}", file=sys.stderr)
        return 2
    try:
        return handlers[command](list(argv))
    except IsolationUnavailable as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2:]) if len(sys.argv) > 1 else 2)
