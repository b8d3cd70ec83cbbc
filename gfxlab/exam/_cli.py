"""`python -m gfxlab exam [ID] [--markdown [FILE]] [--set NAME=VALUE ...]`."""

from __future__ import annotations

import argparse
import sys

from ._registry import QUESTIONS, question, solve


def _parse_value(text: str):
    import ast

    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


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
        for q in QUESTIONS.values():
            kind = "numeric" if q.numeric else "descriptive"
            print(f"{q.id}  {q.marks} marks  {kind:<11}  {q.title}")
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
    try:
        answers = [solve(qid, **options) for qid in ids]
    except TypeError as err:
        print(f"bad option for {args.id}: {err}", file=sys.stderr)
        return 2
    if args.markdown:
        text = "\n".join(a.to_markdown() for a in answers)
        if args.markdown == "-":
            print(text)
        else:
            with open(args.markdown, "w", encoding="utf-8") as handle:
                handle.write(text)
            print(f"wrote {args.markdown}")
    else:
        print("\n".join(a.to_text() for a in answers))
    return 0
