"""`python -m gfxlab exam [ID] [--markdown [FILE]] [--set NAME=VALUE ...]`."""

from __future__ import annotations

import argparse
import inspect
import sys

from ._registry import QUESTIONS, question, solve


def _parse_value(text: str):
    import ast

    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _options(qid: str) -> list[str]:
    """The options `--set` can give question `qid` (its solver's keyword arguments)."""
    solver = question(qid).solver
    parameters = list(inspect.signature(solver).parameters.values())[1:]  # after the question
    return [p.name for p in parameters if p.kind is not p.VAR_KEYWORD]


def main(command: str = "exam", argv: list[str] | None = None) -> int:
    """`python -m gfxlab exam [ID] [--markdown [FILE]] [--set NAME=VALUE ...]`."""
    parser = argparse.ArgumentParser(
        prog="python -m gfxlab exam",
        description="The course exam solved with gfxlab: list the questions or show one answer.",
    )
    parser.add_argument("id", nargs="?", help="question id, e.g. Q2b; 'all' for every answer")
    parser.add_argument(
        "--markdown",
        nargs="?",
        const="-",
        metavar="FILE",
        help="write Markdown with LaTeX (to FILE, or stdout)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a question option, e.g. --set radius=12 for Q1b",
    )
    args = parser.parse_args(argv if argv is not None else sys.argv[1:])
    if args.id is None:
        if args.set:
            parser.error("--set needs a question id, e.g. Q1b --set radius=12")
        for q in QUESTIONS.values():
            kind = "numeric" if q.numeric else "descriptive"
            extra = f"  (--set {', '.join(_options(q.id))})" if _options(q.id) else ""
            print(f"{q.id}  {q.marks} marks  {kind:<11}  {q.title}{extra}")
        return 0
    options = {}
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep:
            parser.error(f"--set expects NAME=VALUE, got {item!r}")
        options[name] = _parse_value(value)
    try:
        ids = list(QUESTIONS) if args.id.lower() == "all" else [question(args.id).id]
    except KeyError as err:
        print(err.args[0], file=sys.stderr)
        return 2
    if len(ids) > 1 and options:
        print("--set applies to one question: give its id, e.g. Q1b", file=sys.stderr)
        return 2
    unknown = sorted(set(options) - set(_options(ids[0])))
    if unknown:
        known = ", ".join(_options(ids[0])) or "none"
        print(f"{ids[0]} has no option {unknown[0]!r} (its options: {known})", file=sys.stderr)
        return 2
    try:
        answers = [solve(qid, **options) for qid in ids]
    except (TypeError, ValueError) as err:  # a value the question cannot take
        print(f"bad option for {ids[0]}: {err}", file=sys.stderr)
        return 2
    if args.markdown:
        text = "\n".join(a.to_markdown() for a in answers)
        if args.markdown == "-":
            print(text)
        else:
            try:
                with open(args.markdown, "w", encoding="utf-8") as handle:
                    handle.write(text)
            except OSError as err:
                print(f"cannot write {args.markdown}: {err.strerror}", file=sys.stderr)
                return 2
            print(f"wrote {args.markdown}")
    else:
        print("\n".join(a.to_text() for a in answers))
    return 0
