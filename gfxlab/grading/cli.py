"""`python -m gfxlab assign|check|grade`: the command line of `gfxlab.grading`."""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from . import authoring, grader
from .sandbox import IsolationUnavailable, detect_protections


def _limit_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--timeout", type=float, help="wall seconds per function call")
    parser.add_argument("--memory-mb", type=int, help="address-space limit of the student")


def _limits(args) -> dict:
    out = {}
    if args.timeout is not None:
        out["call_timeout"] = args.timeout
    if args.memory_mb is not None:
        out["memory_mb"] = args.memory_mb
    return out


def _assign(argv) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab assign",
        description="Split an instructor notebook into OUT/student/ and OUT/autograder/.",
    )
    parser.add_argument("source", type=pathlib.Path, help="instructor notebook (.ipynb)")
    parser.add_argument("out", type=pathlib.Path, help="output directory")
    parser.add_argument("--no-verify", action="store_true",
                        help="skip grading the reference and the blank notebook")
    _limit_args(parser)
    args = parser.parse_args(argv)
    try:
        result = grader.assign(args.source, args.out, verify=not args.no_verify,
                               limits=_limits(args))
    except (authoring.AuthoringError, FileNotFoundError) as exc:
        print(f"authoring error: {exc}", file=sys.stderr)
        return 1
    print(f"student notebook: {result.student_notebook}")
    print(f"autograder:       {result.autograder}")
    if result.reference is not None:
        print(f"reference solution: {result.reference.score:g}/{result.reference.max_score:g}; "
              f"unsolved notebook: {result.blank.score:g}/{result.blank.max_score:g}")
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
        result = grader.check(args.notebook, limits=_limits(args))
    except (authoring.AuthoringError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(result.table())
    for q in result.questions:
        print(f"{q.name}:\n{q.feedback()}\n")
    for note in result.notes:
        print(f"note: {note}")
    print("(public tests only; hidden tests decide the final grade)")
    return 0


def _grade(argv) -> int:
    if "--isolation" in argv:  # which isolation layers this machine gives, then exit
        print("\n".join(detect_protections().describe()))
        return 0
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab grade",
        description="Grade a submitted notebook, or every .ipynb in a folder in parallel.",
    )
    parser.add_argument("submission", type=pathlib.Path, help="notebook or folder of notebooks")
    parser.add_argument("--autograder", type=pathlib.Path, required=True,
                        help="the autograder directory written by `assign`")
    parser.add_argument("--out", type=pathlib.Path,
                        help="results.json path (one notebook) or output folder (a folder); "
                             "default: ./results.json or ./grading-results/")
    parser.add_argument("--jobs", type=int, help="parallel graders (default: CPU cores)")
    parser.add_argument("--verbose", action="store_true", help="print per-test feedback")
    parser.add_argument("--isolation", action="store_true",
                        help="print which isolation layers are active here, and exit")
    _limit_args(parser)
    args = parser.parse_args(argv)
    if not (args.autograder / "config.json").is_file():
        print(f"error: {args.autograder} is not an autograder directory", file=sys.stderr)
        return 1
    if args.submission.is_dir():
        notebooks = sorted(args.submission.glob("*.ipynb"))
        if not notebooks:
            print(f"error: no .ipynb files in {args.submission}", file=sys.stderr)
            return 1
        out = args.out or pathlib.Path("grading-results")
        results = grader.grade_many(notebooks, args.autograder, out, jobs=args.jobs,
                                    limits=_limits(args))
        for r in results:
            print(f"{r.submission:40s} {r.score:7.2f} / {r.max_score:g}  ({r.seconds:.1f} s)")
        print(f"summary: {out / 'summary.csv'}")
        return 0
    if not args.submission.is_file():
        print(f"error: {args.submission} not found", file=sys.stderr)
        return 1
    result = grader.Autograder(args.autograder).grade(args.submission, limits=_limits(args))
    out = args.out or pathlib.Path("results.json")
    out.write_text(json.dumps(result.to_gradescope(), indent=1))
    print(result.table())
    if args.verbose:
        for q in result.questions:
            print(f"{q.name}:\n{q.feedback()}\n")
    for note in result.notes:
        print(f"note: {note}")
    print(f"results: {out}  ({result.seconds:.2f} s)")
    return 0


def main(command: str, argv: list[str]) -> int:
    """Entry point used by `python -m gfxlab` (`command` is assign, check or grade)."""
    handlers = {"assign": _assign, "check": _check, "grade": _grade}
    if command not in handlers:
        print(f"unknown grading command {command!r}", file=sys.stderr)
        return 2
    try:
        return handlers[command](list(argv))
    except IsolationUnavailable as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
