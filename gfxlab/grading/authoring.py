"""The authoring format: parse an instructor notebook, strip solutions, split tests.

The format follows otter-grader's, so instructors can reuse what they know:

- **Questions.** A raw or markdown cell whose first line is `# BEGIN QUESTION` (or
  `<!-- BEGIN QUESTION -->`), followed by `name: q1` and `points: 5` lines, opens a
  question; a cell `# END QUESTION` (or `<!-- END QUESTION -->`) closes it. In a markdown
  cell, the lines after the configuration are the question's text and stay visible.
- **Solutions.** In code cells, `# BEGIN SOLUTION` ... `# END SOLUTION` is replaced by
  `...` (at the marker's indentation); a line ending in `# SOLUTION` becomes `x = ...`
  for an assignment, `return ...` for a return, `...` otherwise. Raw cells
  `# BEGIN SOLUTION` / `# END SOLUTION` remove whole code cells; raw cells
  `# BEGIN PROMPT` / `# END PROMPT` keep cells for students only.
- **Tests.** Between `# BEGIN TESTS` and `# END TESTS` (raw cells, or the first and last
  line of a code cell), every code cell holds pytest-style functions `def test_...(f)`.
  **Parameters name the student's functions**: `def test_trace(midpoint_circle_trace)`
  receives the student's `midpoint_circle_trace`. A cell starting with otter's
  triple-quoted block (`# BEGIN TEST CONFIG`, `hidden: true`, `points: 2`,
  `# END TEST CONFIG`) makes all its tests hidden (and weighs each by `points`); a
  `# HIDDEN` comment line right above a `def test_...` hides that function alone. Other
  code in test cells (imports, helpers, constants) is shared by the question's tests;
  helpers in a hidden cell stay hidden.
"""

from __future__ import annotations

import ast
import copy
import dataclasses
import json
import re
import uuid

from ._args import module_names

_BEGIN_Q = re.compile(r"^\s*(?:#|<!--)\s*BEGIN\s+QUESTION\s*(?:-->)?\s*$", re.I)
_END_Q = re.compile(r"^\s*(?:#|<!--)\s*END\s+QUESTION\s*(?:-->)?\s*$", re.I)
_MARK = r"^\s*#\s*{}\s+{}\b.*$"
_CONFIG_LINE = re.compile(r"^\s*([A-Za-z_][\w-]*)\s*:\s*(.*?)\s*$")
_SOLUTION_WORDS = re.compile(r"BEGIN\s+SOLUTION|END\s+SOLUTION|#\s*SOLUTION\b", re.I)
_TEST_CONFIG = re.compile(
    r'^\s*(?:"""|\'\'\')\s*#\s*BEGIN TEST CONFIG\s*\n(.*?)\n\s*(?:"""|\'\'\')\s*#\s*END TEST CONFIG'
    r"[^\n]*\n?",
    re.S | re.I,
)
_HIDDEN_LINE = re.compile(r"^\s*#\s*HIDDEN\s*$", re.I)


def read_notebook(path) -> dict:
    """A notebook file as a dict (nbformat 4 JSON), every cell's source one string.

    Plain `json`: nbformat's import costs seconds, too much for a grader started per run.
    """
    with open(path, encoding="utf-8") as f:
        nb = json.load(f)
    if not isinstance(nb, dict) or not isinstance(nb.get("cells"), list):
        raise ValueError(f"{path} is not a Jupyter notebook")
    if not isinstance(nb.get("metadata"), dict):
        nb["metadata"] = {}
    for cell in nb["cells"]:
        if not isinstance(cell, dict) or cell.get("cell_type") not in ("code", "markdown", "raw"):
            raise ValueError(f"{path}: malformed cell")
        source = cell.get("source", "")
        cell["source"] = source if isinstance(source, str) else "".join(map(str, source))
        if not isinstance(cell.get("metadata"), dict):
            cell["metadata"] = {}
        if not isinstance(cell["metadata"].get("gfxlab", {}), dict):
            cell["metadata"]["gfxlab"] = {}
    return nb


def new_cell(kind: str, source: str, metadata: dict | None = None) -> dict:
    """A new notebook cell of type `kind` (code cells get empty outputs)."""
    cell = {
        "cell_type": kind,
        "id": uuid.uuid4().hex[:8],
        "metadata": metadata or {},
        "source": source,
    }
    if kind == "code":
        cell.update(outputs=[], execution_count=None)
    return cell


def new_notebook(metadata: dict | None = None, cells: list | None = None) -> dict:
    """A new, empty nbformat 4.5 notebook (a plain dict)."""
    return {"cells": cells or [], "metadata": metadata or {}, "nbformat": 4, "nbformat_minor": 5}


def write_notebook(nb: dict, path) -> None:
    """Write without outputs (code cells keep empty outputs)."""
    for cell in nb["cells"]:
        cell.setdefault("id", uuid.uuid4().hex[:8])
        if cell["cell_type"] == "code":
            cell["outputs"], cell["execution_count"] = [], None
    with open(path, "w", encoding="utf-8") as f:
        json.dump(nb, f, indent=1, ensure_ascii=False)
        f.write("\n")


class AuthoringError(ValueError):
    """A problem in the instructor's notebook, caught at assign time."""


def _marker(kind: str, word: str) -> re.Pattern:
    return re.compile(_MARK.format(kind, word), re.I)


_BEGIN_SOL, _END_SOL = _marker("BEGIN", "SOLUTION"), _marker("END", "SOLUTION")
_BEGIN_PROMPT, _END_PROMPT = _marker("BEGIN", "PROMPT"), _marker("END", "PROMPT")
_BEGIN_TESTS, _END_TESTS = _marker("BEGIN", "TESTS"), _marker("END", "TESTS")


@dataclasses.dataclass
class TestSpec:
    """One test function: its name, the student functions it takes, hidden or not."""

    name: str
    params: tuple[str, ...]
    hidden: bool
    weight: float


@dataclasses.dataclass
class Question:
    """A question: name, points, its tests and their source (public and full)."""

    name: str
    points: float
    tests: list[TestSpec] = dataclasses.field(default_factory=list)
    public_source: list[str] = dataclasses.field(default_factory=list)
    full_source: list[str] = dataclasses.field(default_factory=list)

    @property
    def functions(self) -> tuple[str, ...]:
        """The student functions the tests take, in order of first use."""
        return tuple(dict.fromkeys(p for t in self.tests for p in t.params))


@dataclasses.dataclass
class Assignment:
    """A parsed instructor notebook.

    `student` is the student notebook (no solutions, public tests only, tagged cells);
    `solution_cells` the reference solution's code cells; `config` assignment options from
    the notebook metadata `gfxlab` (e.g. `{"preload": ["numpy", "jax"]}`).
    """

    name: str
    questions: list[Question]
    student: dict
    solution_cells: list[str]
    config: dict


def _parse_value(text: str):
    low = text.lower()
    if low in ("true", "yes"):
        return True
    if low in ("false", "no"):
        return False
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text.strip("'\"")


def parse_config(lines: list[str]) -> tuple[dict, list[str]]:
    """Leading `key: value` lines -> dict, and the remaining lines."""
    config, rest = {}, list(lines)
    while rest and (rest[0].strip() == "" or _CONFIG_LINE.match(rest[0])):
        line = rest.pop(0)
        if line.strip():
            key, value = _CONFIG_LINE.match(line).groups()
            config[key] = _parse_value(value)
    return config, rest


def strip_solutions(source: str) -> str:
    """Replace solution regions and `# SOLUTION` lines of one code cell by `...`."""
    out, depth, indent = [], 0, ""
    for line in source.splitlines():
        if _BEGIN_SOL.match(line):
            if depth == 0:
                indent = line[: len(line) - len(line.lstrip())]
            depth += 1
            continue
        if _END_SOL.match(line):
            if depth == 0:
                raise AuthoringError(f"`# END SOLUTION` without `# BEGIN SOLUTION`:\n{source}")
            depth -= 1
            if depth == 0:
                out.append(indent + "...")
            continue
        if depth:
            continue
        code, sep, _ = line.rpartition("#")
        if sep and re.fullmatch(r"\s*SOLUTION\s*", _) and code.strip():
            lead = code[: len(code) - len(code.lstrip())]
            assign = re.match(r"^(\s*[\w.\[\], ()]+?)\s*(=|\+=|-=|\*=|/=)(?!=)", code)
            if code.strip().startswith("return"):
                out.append(lead + "return ...")
            elif assign:
                out.append(f"{assign.group(1).rstrip()} {assign.group(2)} ...")
            else:
                out.append(lead + "...")
            continue
        out.append(line)
    if depth:
        raise AuthoringError(f"`# BEGIN SOLUTION` without `# END SOLUTION`:\n{source}")
    return "\n".join(out)


def solution_source(source: str) -> str:
    """The reference version of a code cell: solution markers dropped, code kept."""
    lines = [ln for ln in source.splitlines() if not (_BEGIN_SOL.match(ln) or _END_SOL.match(ln))]
    return "\n".join(re.sub(r"\s*#\s*SOLUTION\s*$", "", ln) for ln in lines)


def _split_tests(source: str, question: Question, cell_hidden: bool, weight: float):
    """Test functions of one cell -> specs, plus the cell's public and full source."""
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        raise AuthoringError(f"test cell of {question.name} does not parse: {exc}") from None
    lines = source.splitlines()
    drop: list[tuple[int, int]] = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef) or not node.name.startswith("test"):
            continue
        start = min([node.lineno] + [d.lineno for d in node.decorator_list]) - 1
        marked = start > 0 and bool(_HIDDEN_LINE.match(lines[start - 1]))
        hidden = cell_hidden or marked
        args = node.args
        if args.vararg or args.kwarg or args.kwonlyargs or args.posonlyargs:
            raise AuthoringError(f"{question.name}.{node.name}: use plain parameters only")
        params = tuple(a.arg for a in args.args)
        question.tests.append(TestSpec(node.name, params, hidden, weight))
        if hidden and not cell_hidden:
            drop.append((start - 1, node.end_lineno))
    full = source
    public = (
        ""
        if cell_hidden
        else "\n".join(ln for i, ln in enumerate(lines) if not any(a <= i < b for a, b in drop))
    )
    return public, full


@dataclasses.dataclass
class _ParseState:
    """What `parse_notebook` has collected so far, and which marker regions are open."""

    questions: list[Question] = dataclasses.field(default_factory=list)
    student_cells: list = dataclasses.field(default_factory=list)
    solution_cells: list = dataclasses.field(default_factory=list)
    question: Question | None = None
    in_tests: bool = False
    in_solution: bool = False
    in_prompt: bool = False


_RAW_MARKERS = (
    (_BEGIN_TESTS, "t+"),
    (_END_TESTS, "t-"),
    (_BEGIN_SOL, "s+"),
    (_END_SOL, "s-"),
    (_BEGIN_PROMPT, "p+"),
    (_END_PROMPT, "p-"),
)


def _load_named(notebook) -> tuple[dict, str]:
    """Read `notebook` if it is a path; return it with its default assignment name."""
    if not isinstance(notebook, dict):
        name = str(notebook).rsplit("/", 1)[-1].removesuffix(".ipynb")
        return read_notebook(notebook), name
    return notebook, "assignment"


def _cell_text(cell) -> str:
    return cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])


def _question_marker(state: _ParseState, cell, src: str, first: str) -> bool:
    """Handle a `# BEGIN/END QUESTION` cell; `False` if `cell` is not one."""
    if cell["cell_type"] not in ("raw", "markdown"):
        return False
    if _BEGIN_Q.match(first):
        if state.question is not None:
            raise AuthoringError(f"question {state.question.name} has no `# END QUESTION`")
        state.question = _open_question(cell, src, state.questions, state.student_cells)
        return True
    if _END_Q.match(first):
        if state.question is None:
            raise AuthoringError("`# END QUESTION` without `# BEGIN QUESTION`")
        state.student_cells.append(_public_test_cell(state.question))
        state.question = None
        return True
    return False


def _raw_cell(state: _ParseState, cell, first: str) -> None:
    """Open or close a TESTS/SOLUTION/PROMPT region, or copy any other raw cell."""
    for pattern, flag in _RAW_MARKERS:
        if pattern.match(first):
            if flag[0] == "t":
                state.in_tests = flag[1] == "+"
            elif flag[0] == "s":
                state.in_solution = flag[1] == "+"
            else:
                state.in_prompt = flag[1] == "+"
            return
    state.student_cells.append(copy.deepcopy(cell))


def _code_cell(state: _ParseState, cell, src: str, first: str) -> None:
    """Route a code cell to the tests, the student notebook and/or the solution."""
    inline_tests = bool(_BEGIN_TESTS.match(first))
    if state.in_tests or inline_tests:
        if state.question is None:
            raise AuthoringError(f"tests outside a question:\n{src}")
        _add_test_cell(state.question, src, inline_tests)
        return
    if state.in_prompt:
        state.student_cells.append(copy.deepcopy(cell))
        return
    if state.in_solution:
        state.solution_cells.append(solution_source(src))
        return
    state.solution_cells.append(solution_source(src))
    student = copy.deepcopy(cell)
    student["source"] = strip_solutions(src)
    student["outputs"], student["execution_count"] = [], None
    state.student_cells.append(student)


def _check_closed(state: _ParseState) -> None:
    """Raise `AuthoringError` for an unclosed region or a question without tests."""
    if state.question is not None:
        raise AuthoringError(f"question {state.question.name} has no `# END QUESTION`")
    if state.in_tests or state.in_solution or state.in_prompt:
        raise AuthoringError("a `# BEGIN TESTS/SOLUTION/PROMPT` raw cell is never closed")
    for q in state.questions:
        if not q.tests:
            raise AuthoringError(f"question {q.name} has no tests")


def parse_notebook(notebook) -> Assignment:
    """Parse an instructor notebook (path or `NotebookNode`) into an `Assignment`."""
    notebook, name = _load_named(notebook)
    config = dict(notebook["metadata"].get("gfxlab", {}))
    name = config.get("name", name)
    state = _ParseState()
    for cell in notebook["cells"]:
        src = _cell_text(cell)
        lines = src.splitlines()
        first = next((ln for ln in lines if ln.strip()), "")
        if _question_marker(state, cell, src, first):
            continue
        if cell["cell_type"] == "raw":
            _raw_cell(state, cell, first)
        elif cell["cell_type"] == "markdown":
            state.student_cells.append(copy.deepcopy(cell))
        else:
            _code_cell(state, cell, src, first)
    _check_closed(state)
    student = _student_notebook(notebook, name, config, state.questions, state.student_cells)
    return Assignment(name, state.questions, student, state.solution_cells, config)


def _open_question(cell, src, questions, student_cells) -> Question:
    """A `BEGIN QUESTION` cell: the new question; its text (markdown) stays visible."""
    lines = src.splitlines()
    first = next(ln for ln in lines if ln.strip())
    options, rest = parse_config(lines[lines.index(first) + 1 :])
    if "name" not in options:
        raise AuthoringError(f"a question has no `name:` line:\n{src}")
    question = Question(str(options["name"]), float(options.get("points", 1)))
    if any(q.name == question.name for q in questions):
        raise AuthoringError(f"two questions are named {question.name}")
    questions.append(question)
    if cell["cell_type"] == "markdown" and any(r.strip() for r in rest):
        student_cells.append(new_cell("markdown", "\n".join(rest).strip()))
    return question


def _add_test_cell(question: Question, src: str, inline: bool) -> None:
    """A code cell of tests (markers and TEST CONFIG stripped) -> the question's tests."""
    body = src
    if inline:
        kept = [
            ln for ln in src.splitlines() if not (_BEGIN_TESTS.match(ln) or _END_TESTS.match(ln))
        ]
        body = "\n".join(kept)
    match = _TEST_CONFIG.match(body)
    options = {}
    if match:
        options, _ = parse_config(match.group(1).splitlines())
        body = body[match.end() :]
    public, full = _split_tests(
        body, question, bool(options.get("hidden", False)), float(options.get("points", 1))
    )
    question.full_source.append(full)
    if public.strip():
        question.public_source.append(public)


def _student_notebook(notebook, name, config, questions, cells) -> dict:
    """The student notebook: cells, notices (forbidden modules, float64), metadata."""
    student = new_notebook(copy.deepcopy(notebook["metadata"]))
    student["metadata"].pop("gfxlab", None)
    extra = [c for c in (_forbid_cell(config), _x64_cell(config)) if c is not None]
    student["cells"] = cells[:1] + extra + cells[1:]
    student["metadata"]["gfxlab"] = {
        "assignment": name,
        "questions": [{"name": q.name, "points": q.points} for q in questions],
        "preload": list(config.get("preload", ["numpy"])),
        "forbid": list(config.get("forbid", [])),
    }
    return student


_RUN_LINE = "run_tests(globals(), "


def _public_test_cell(q: Question) -> dict:
    """The question's public tests, in one tagged code cell of the student notebook.

    It runs as it is in Jupyter ("Run All"): it imports what the tests use, and its last
    line runs them on the notebook's functions, printing PASS/FAIL without raising.
    """
    source = "\n\n".join(part.strip("\n") for part in q.public_source)
    names = [t.name for t in q.tests if not t.hidden]
    header = (
        f"# Public tests for {q.name}: run this cell, or `python -m gfxlab check "
        "THIS_NOTEBOOK.ipynb`.\n"
        "# Each test receives your functions by parameter name.\n"
        "import numpy as np\n"
        "from gfxlab.grading.checks import check_array, run_tests\n\n"
    )
    run = f"\n\n\n{_RUN_LINE}{names!r}, question={q.name!r})\n"
    return new_cell("code", header + source + run, {"gfxlab": {"tests": q.name}})


def public_test_cells(notebook) -> dict[str, str]:
    """Question name -> the source of its public-test cell (without the line running it)."""
    out = {}
    for cell in notebook["cells"]:
        name = cell["metadata"].get("gfxlab", {}).get("tests")
        if cell["cell_type"] == "code" and isinstance(name, str):
            lines = [ln for ln in cell["source"].splitlines() if not ln.startswith(_RUN_LINE)]
            out[name] = "\n".join(lines)
    return out


def _x64_cell(config: dict) -> dict | None:
    """JAX assignments: the notebook computes in float64, as the grader does."""
    if "jax" not in config.get("preload", []) or not config.get("x64", True):
        return None
    source = "# The grader runs JAX in float64; so does this notebook.\nimport jax\n\n"
    source += 'jax.config.update("jax_enable_x64", True)'
    return new_cell("code", source, {"gfxlab": {"setup": True}})


def _forbid_cell(config: dict) -> dict | None:
    forbid = module_names(config.get("forbid") or [], "forbid")  # a str alone: TypeError
    separate = config.get("separate") or {}
    if not forbid and not separate:
        return None
    text = ""
    if forbid:
        names = ", ".join(f"`{m}`" for m in forbid)
        text = (
            f"**Not allowed in this assignment:** {names} (and their submodules). The grader "
            "makes these modules unimportable: a cell that imports one fails with an "
            "`ImportError` there, so what it defines is missing and the tests that need it "
            "score 0. A module that itself needs a forbidden one cannot be imported either "
            "(the message names both)."
        )
        if "gfxlab" in forbid:
            text += " `gfxlab.grading.checks`, which the public tests use, stays importable."
    for function, others in separate.items():
        names = " or ".join(f"`{n}`" for n in others)
        text += (
            f"\n\n**Write `{function}` on its own:** it may not call {names}, nor share "
            "their helper functions or values; a test that passes only with them scores 0 "
            "(the grader runs it again with them removed). Code the grader cannot read "
            "scores 0 on such a question: `exec`, `eval`, `compile`, `__import__`, the "
            "modules `importlib`, `types`, `pickle`, `marshal`, `runpy`, `site`, `ctypes`, "
            "and importing modules the notebook writes (`.py` files) or puts on the path; "
            "so do name lookups (`globals`, `vars`, `getattr`, `sys`, `gc`, `inspect`, "
            "frames, dunder attributes) inside the functions it may not use."
        )
    return new_cell("markdown", text.strip())


def _scan_line(line: str, state: list) -> None:
    """Advance `state` = [bracket depth, open string quote or "", line continues] over one
    physical line (strings, comments, brackets and backslashes as Python reads them)."""
    depth, quote = state[0], state[1]
    i, n, comment = 0, len(line), False
    while i < n:
        c = line[i]
        if quote:
            if c == "\\":
                i += 2
                continue
            if line.startswith(quote, i):
                i += len(quote)
                quote = ""
                continue
            i += 1
            continue
        if c == "#":
            comment = True
            break
        if c in "\"'":
            quote = c * 3 if line.startswith(c * 3, i) else c
            i += len(quote)
            continue
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth = max(0, depth - 1)
        i += 1
    if quote and len(quote) == 1 and not line.endswith("\\"):
        quote = ""  # an unterminated one-line string ends with its line (a syntax error)
    state[0], state[1] = depth, quote
    state[2] = bool(depth or quote or (line.endswith("\\") and not comment))


def comment_magics(src: str) -> str:
    """IPython magics and shell escapes (`%...`, `!...`) that start a logical line become
    comments; a `%` or `!` continuing an expression (inside brackets, after a backslash,
    in a string) is Python and stays."""
    lines, state = [], [0, "", False]
    for line in src.splitlines():
        stripped = line.lstrip()
        if not state[2] and stripped.startswith(("%", "!")):
            line = line[: len(line) - len(stripped)] + "# " + stripped
        else:
            _scan_line(line, state)
        lines.append(line)
    return "\n".join(lines)


def student_code_cells(notebook) -> list[str]:
    """The code a submission runs: every code cell except tagged public-test cells.

    IPython magics and shell escapes (`%...`, `!...`) at the start of a logical line
    become comments (`comment_magics`).
    """
    cells = []
    for cell in notebook["cells"]:
        if cell["cell_type"] != "code" or "tests" in cell["metadata"].get("gfxlab", {}):
            continue
        src = cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])
        cells.append(comment_magics(src))
    return cells


def student_code_cell_numbers(notebook) -> list[int]:
    """For each cell of `student_code_cells`, its number as the student sees it: its
    position among the notebook's code cells (`In [n]` after "Restart & Run All")."""
    numbers, n = [], 0
    for cell in notebook["cells"]:
        if cell["cell_type"] != "code":
            continue
        n += 1
        if "tests" not in cell["metadata"].get("gfxlab", {}):
            numbers.append(n)
    return numbers


def check_student_notebook(assignment: Assignment) -> None:
    """Authoring errors visible in the student notebook itself."""
    hidden = {t.name for q in assignment.questions for t in q.tests if t.hidden}
    for i, cell in enumerate(assignment.student["cells"]):
        src = cell["source"]
        if _SOLUTION_WORDS.search(src):
            raise AuthoringError(f"a solution marker is left in student cell {i}:\n{src}")
        if cell["cell_type"] == "code":
            try:
                tree = ast.parse("\n".join(student_code_cells(_one(cell))) or "pass")
            except SyntaxError as exc:
                raise AuthoringError(
                    f"student cell {i} does not parse after removing solutions: {exc}\n{src}"
                ) from None
            names = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
            if names & hidden:
                raise AuthoringError(f"hidden test {sorted(names & hidden)} in student cell {i}")


def _one(cell):
    plain = copy.deepcopy(cell)
    plain["metadata"] = {}
    return new_notebook(cells=[plain])
