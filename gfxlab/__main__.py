"""Command line: `python -m gfxlab COMMAND ...`.

- `labs`: list the labs.
- `run LAB|all [--out DIR] [--timeout S]`: execute a lab (or every lab) headless and write
  HTML copies (`all` adds an index page).
- `assign`, `check`, `grade`: autograded assignments (`gfxlab.grading`).
- `exam [ID] [--markdown FILE]`: the course exam, solved step by step (`gfxlab.exam`).
"""

from __future__ import annotations

import importlib
import sys

# Subcommands implemented by other modules, imported only when used.
_DELEGATED = {
    "assign": "gfxlab.grading.cli",
    "check": "gfxlab.grading.cli",
    "grade": "gfxlab.grading.cli",
    "exam": "gfxlab.exam",
}

_USAGE = """usage: python -m gfxlab COMMAND [ARGS]

commands:
  labs                      list the labs
  run LAB [--out DIR]       execute a lab headless (nbclient) and write an HTML copy
  run all [--out DIR]       execute every lab; HTML copies plus an index.html gallery
  assign SOURCE.ipynb OUT/  split an instructor notebook into student and autograder parts
  check NOTEBOOK.ipynb      run an assignment's public tests on a student notebook
  grade SUBMISSION --autograder DIR
                            grade a submission (or a folder of them)
  exam [ID] [--markdown F]  list the course exam's questions, or print one worked answer

Run `python -m gfxlab COMMAND --help` for a command's options."""


def main(argv: list[str] | None = None) -> int:
    """The `python -m gfxlab` / `gfxlab` command line; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(_USAGE)
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    if command in ("labs", "run"):
        from . import _runner

        return _runner.main(command, rest)
    if command in _DELEGATED:
        module = importlib.import_module(_DELEGATED[command])
        return module.main(command, rest)
    print(f"unknown command {command!r}\n\n{_USAGE}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
