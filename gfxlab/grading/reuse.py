"""Questions that must be answered on their own: no marks for calling another answer.

An assignment's metadata `separate` maps a graded function to the functions it may not
use, e.g. `{"de_casteljau": ["bezier_point"]}`: de Casteljau's algorithm must not be the
Bernstein form of question 1 called again. The check is made in two steps.

1. Static (`plan`): the names `bezier_point` stands for (`forbidden_closure`: the name,
   every name bound by the same top-level statements, and the functions and values of
   the notebook they use) must not be used anywhere else in the notebook. A notebook
   that also uses dynamic lookups (`exec`, `eval`, `globals`, `getattr`, dunder
   attributes, `sys`, `inspect`, ...) cannot be checked this way: the question scores 0
   (`HATCH_NAMES`, `HATCH_MODULES`).
2. Dynamic, for every rule (`rerun`): the question's tests run again in a second
   sandbox in which those statements are replaced by functions that raise
   (`check_cells`): their code is not in that process at all, so no alias, container,
   library state (`np.seterrcall(f)`) or decorator can keep it. A test that passes only
   with them scores 0 (`enforce`). It runs after the first sandbox's public tests and
   before its hidden ones, so it cannot learn a hidden input from them. (`plan` still
   says whether the names are used elsewhere, `Verdict.dynamic`; it cannot prove that
   they are not, since code reaches objects through library state without their names.)
3. Notebooks too deep or too large to analyse (`MAX_DEPTH`, `MAX_NODES`) score 0 on the
   question, as escape hatches do.

Sharing a helper with the forbidden function counts as using it (the handout says so).
"""

from __future__ import annotations

import ast
import builtins
import collections
import dataclasses
import importlib.util
import itertools
import secrets
import sys

from gfxlab.grading.sandbox import Sandbox

# Code the AST cannot see (built from strings, loaded from files or bytes, imported from
# modules the notebook writes or puts on the path): such a notebook cannot be checked and
# the question scores 0.
CODE_HATCH_NAMES = frozenset({"exec", "eval", "compile", "__import__", "breakpoint"})
CODE_HATCH_MODULES = frozenset(
    {
        "importlib", "ctypes", "types", "pickle", "marshal", "dill", "cloudpickle", "code",
        "codeop", "runpy", "copyreg", "pdb", "bdb", "site", "pkgutil", "zipimport",
    }
)  # fmt: skip
# Strings naming Python code files or the import path: a notebook that writes a module
# (or a path hook) and imports it.
CODE_HATCH_STRINGS = (".py", ".pth", ".so", "sys.path", "PYTHONPATH")
# Name lookups (by string, through frames or namespaces): they can only find code that
# is in the process, so the second sandbox (which removes the forbidden code) decides,
# unless the forbidden code itself uses one (it could then share anything: 0 points).
LOOKUP_HATCH_NAMES = frozenset(
    {"globals", "locals", "vars", "getattr", "setattr", "delattr", "attrgetter", "methodcaller"}
)
LOOKUP_HATCH_MODULES = frozenset({"sys", "gc", "inspect", "builtins", "__main__", "traceback"})
LOOKUP_HATCH_ATTRIBUTES = frozenset(
    {
        "tb_frame", "tb_next", "f_globals", "f_locals", "f_back", "f_builtins", "f_code",
        "gi_frame", "cr_frame", "ag_frame", "gi_code", "cr_code", "modules", "exc_info",
        "attrgetter", "methodcaller", "getframe", "get_referrers", "get_objects",
    }
)  # fmt: skip
# Kept for readers of the old names (the handout lists them).
HATCH_NAMES = CODE_HATCH_NAMES | LOOKUP_HATCH_NAMES
HATCH_MODULES = CODE_HATCH_MODULES | LOOKUP_HATCH_MODULES
HATCH_ATTRIBUTES = LOOKUP_HATCH_ATTRIBUTES


@dataclasses.dataclass
class Verdict:
    """What the static step found for one rule."""

    function: str
    forbidden: tuple[str, ...]
    closure: frozenset = frozenset()
    hatch: str | None = None  # an escape hatch that makes the notebook uncheckable
    lookup: str | None = None  # a name lookup elsewhere: the second sandbox decides
    dynamic: bool = False  # the names are used elsewhere (the second sandbox always runs)
    error: str | None = None  # the second sandbox could not start (the grader's problem)


# Deeper syntax trees are not analysed (`ast.unparse` and Python's own AST construction
# recurse): the cell still runs, but a question with a `separate` rule scores 0.
MAX_DEPTH = 100
_TOO_DEEP = "a cell nested too deeply to be checked"
# A larger notebook is not analysed either (the analysis is linear in its syntax nodes, a
# few tens of microseconds each: a notebook of millions must not stall the grader).
MAX_NODES = 100_000
_TOO_LARGE = f"more than {MAX_NODES:,} syntax nodes of code, too many to be checked"


def _parse(source: str) -> list[ast.stmt] | None:
    """The statements of a cell; [] for a cell that fails in the sandbox too (syntax
    error, NUL byte); None for one this analysis cannot see (too deep for it)."""
    try:
        body = ast.parse(source).body
    except (SyntaxError, ValueError):  # the cell fails in the sandbox anyway
        return []
    except (RecursionError, MemoryError):  # Python may still run it
        return None
    stack = [(node, 1) for node in body]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            return None
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return body


_SCOPES = (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)
_COMPREHENSIONS = (ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)


def _bound(stmt: ast.stmt) -> set[str]:
    """Top-level names `stmt` binds (plus any it declares `global` anywhere inside):
    assignments, walrus targets (also inside comprehensions, which bind the enclosing
    scope), `match` captures, `except ... as`, imports, definitions."""
    names: set[str] = set()
    if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
        names.add(stmt.name)
    elif isinstance(stmt, (ast.Import, ast.ImportFrom)):
        names.update((a.asname or a.name).split(".")[0] for a in stmt.names)
    else:
        stack = [(stmt, False)]
        while stack:
            node, in_comp = stack.pop()
            if isinstance(node, ast.NamedExpr) and isinstance(node.target, ast.Name):
                names.add(node.target.id)
            elif _stored(node) and not in_comp:
                names.add(_stored(node))
            elif isinstance(node, (ast.MatchAs, ast.MatchStar)) and node.name:
                names.add(node.name)
            elif isinstance(node, ast.MatchMapping) and node.rest:
                names.add(node.rest)
            elif isinstance(node, ast.ExceptHandler) and node.name and not in_comp:
                names.add(node.name)
            if isinstance(node, _SCOPES):
                if not isinstance(node, ast.Lambda):
                    names.add(node.name)
                continue
            inner = in_comp or isinstance(node, _COMPREHENSIONS)
            stack.extend((child, inner) for child in ast.iter_child_nodes(node))
    for node in ast.walk(stmt):
        if isinstance(node, (ast.Global, ast.Nonlocal)):
            names.update(node.names)
    return names


def _stored(node) -> str | None:
    """The name a store or delete target binds: `x`, and `np` of `np.helper = f` or
    `TABLE[k] = f` (which change the object `np`, or `TABLE`)."""
    if not isinstance(getattr(node, "ctx", None), (ast.Store, ast.Del)):
        return None
    if isinstance(node, ast.Name):
        return node.id
    return _root(node) if isinstance(node, (ast.Attribute, ast.Subscript)) else None


def _root(node) -> str | None:
    """`a` of `a.b[c].d`, or None when the chain does not start at a name."""
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def _module_alias(stmt: ast.stmt, modules) -> bool:
    """`jnp = jax.numpy`: a name for (part of) an imported module, like an import."""
    if not isinstance(stmt, ast.Assign) or len(stmt.targets) != 1:
        return False
    if not isinstance(stmt.targets[0], ast.Name) or not isinstance(
        stmt.value, (ast.Name, ast.Attribute)
    ):
        return False
    node = stmt.value
    while isinstance(node, ast.Attribute):
        node = node.value
    return isinstance(node, ast.Name) and node.id in modules


def _imports(units) -> tuple[set[str], list[ast.stmt]]:
    """Names bound only by imports and module aliases (never changed by the notebook),
    and the alias statements."""
    imported = {n for u in units if isinstance(u, (ast.Import, ast.ImportFrom)) for n in _bound(u)}
    others = [u for u in units if not isinstance(u, (ast.Import, ast.ImportFrom))]
    bound = {id(u): _bound(u) for u in others}
    # How many statements bind each name (linear: a notebook of thousands of statements
    # must not make the grader slow).
    binders = collections.Counter(n for u in others for n in bound[id(u)])
    aliases: list[ast.stmt] = []
    alias_ids: set[int] = set()
    while True:
        rest_bound = {n for n, count in binders.items() if count}
        modules = imported - rest_bound
        added = False
        for u in others:
            if id(u) in alias_ids or not _module_alias(u, modules):
                continue
            # an alias counts only if no other statement binds its name
            if all(binders[n] == 1 for n in bound[id(u)]):
                aliases.append(u)
                alias_ids.add(id(u))
                imported |= bound[id(u)]
                modules |= bound[id(u)]  # a later `b = a.x` is an alias in this same pass
                binders.subtract(bound[id(u)])
                added = True
        if not added:
            return modules, aliases


def _loaded(stmt: ast.stmt) -> set[str]:
    return {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and type(n.ctx) is ast.Load}


def _hatch(stmt: ast.stmt, lookup: bool = False) -> str | None:
    """The first escape hatch in `stmt`: code hatches, or (`lookup`) name lookups."""
    names = LOOKUP_HATCH_NAMES if lookup else CODE_HATCH_NAMES
    modules = LOOKUP_HATCH_MODULES if lookup else CODE_HATCH_MODULES
    for node in ast.walk(stmt):
        if isinstance(node, ast.Name) and (
            node.id in names or (lookup and node.id.startswith("__") and node.id.endswith("__"))
        ):
            return f"`{node.id}`"
        if lookup and isinstance(node, ast.Attribute):
            if node.attr.startswith("_") or node.attr in LOOKUP_HATCH_ATTRIBUTES:
                return f"the attribute `{node.attr}`"
        if not lookup and isinstance(node, ast.Constant) and isinstance(node.value, str):
            hit = next((h for h in CODE_HATCH_STRINGS if h.lower() in node.value.lower()), None)
            if hit:
                return f"a string naming `{hit}` (a module written or put on the path)"
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in modules:
                    return f"the module `{alias.name}`"
        if isinstance(node, ast.ImportFrom):
            module = (node.module or "").split(".")[0]
            if (node.level and not lookup) or module in modules:
                return f"the module `{node.module}`"
            if lookup and any(a.name in LOOKUP_HATCH_ATTRIBUTES for a in node.names):
                return f"`{node.module}.{node.names[0].name}`"
    return None


def forbidden_closure(units, forbidden, function) -> frozenset:
    """The names `forbidden` stand for: every name bound by a statement that binds one,
    and the notebook's functions and values such statements use (not imports, and not
    `function` itself when only used: the forbidden code may use the graded one)."""
    imports, aliases = _imports(units)
    bound_by = {}
    for u in units:
        if not isinstance(u, (ast.Import, ast.ImportFrom)) and u not in aliases:
            for name in _bound(u):
                bound_by.setdefault(name, []).append(u)
    closure, todo = set(), list(forbidden)
    while todo:
        name = todo.pop()
        if name in closure:
            continue
        closure.add(name)
        for u in bound_by.get(name, []):
            todo.extend(_bound(u))
            todo.extend(
                n for n in _loaded(u) if n in bound_by and n not in imports and n != function
            )
    return frozenset(closure)


def _foreign_import(units) -> str | None:
    """An import of a module that is not installed (one the notebook writes at run time)."""
    for node in (n for u in units for n in ast.walk(u)):
        if isinstance(node, ast.Import):
            modules = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            modules = [node.module]
        else:
            continue
        for module in modules:
            top = module.split(".")[0]
            try:
                found = top in sys.builtin_module_names or importlib.util.find_spec(top)
            except (ImportError, ValueError):
                found = None
            if not found:
                return f"an import of `{module}`, which is not an installed module"
    return None


def _unbound_reads(units, closure) -> set[str]:
    """Names the closure's statements read that no statement visibly binds and that are
    not builtins: bound in a way the analysis does not see, so they are stubbed too."""
    bound = {n for u in units for n in _bound(u)}
    binders = [u for u in units if _bound(u) & closure]
    reads = {n for u in binders for n in _loaded(u)}
    local = {n for u in binders for node in ast.walk(u) for n in _locals(node)}
    return reads - bound - local - set(dir(builtins))


def _locals(node) -> set[str]:
    """Names local to a function, lambda or comprehension inside a statement."""
    if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
        args = node.args
        every = [*args.posonlyargs, *args.args, *args.kwonlyargs, args.vararg, args.kwarg]
        names = {a.arg for a in every if a is not None}
        body = node.body if isinstance(node.body, list) else [node.body]
        for stmt in body:
            for sub in ast.walk(stmt):
                if isinstance(sub, ast.Name) and isinstance(sub.ctx, ast.Store):
                    names.add(sub.id)
        return names
    if isinstance(node, _COMPREHENSIONS):
        return {
            n.id for gen in node.generators for n in ast.walk(gen.target) if isinstance(n, ast.Name)
        }
    return set()


def _too_large(units) -> bool:
    """More than `MAX_NODES` syntax nodes (counted only that far)."""
    nodes = (node for u in units for node in ast.walk(u))
    return next(itertools.islice(nodes, MAX_NODES, None), None) is not None


def plan(cells, rules: dict) -> list[Verdict]:
    """The static step for every rule `function -> [forbidden names]`."""
    if not rules:
        return []
    if sum(len(source) for source in cells) > 10 * MAX_NODES:  # not even parsed
        parsed, deep = [], _TOO_LARGE
    else:
        parsed = [_parse(source) for source in cells]
        deep = _TOO_DEEP if any(body is None for body in parsed) else None
    units = [u for body in parsed for u in body or []]
    if deep is None and _too_large(units):
        deep, units = _TOO_LARGE, []
    hatch = deep or next((h for h in map(_hatch, units) if h), None) or _foreign_import(units)
    verdicts = []
    for function, forbidden in rules.items():
        verdict = Verdict(function, tuple(forbidden))
        closure = forbidden_closure(units, verdict.forbidden, function)
        verdict.closure = closure | _unbound_reads(units, closure)
        binders = [u for u in units if _bound(u) & verdict.closure]
        binder_ids = {id(u) for u in binders}
        others = [u for u in units if id(u) not in binder_ids]
        # A lookup inside the forbidden code could share anything with the graded one.
        inside = next((h for h in (_hatch(u, lookup=True) for u in binders) if h), None)
        verdict.hatch = hatch or inside
        verdict.lookup = next((h for h in (_hatch(u, lookup=True) for u in others) if h), None)
        verdict.dynamic = (
            bool(verdict.lookup)
            or any(_loaded(u) & verdict.closure for u in others)
            or any(function in _bound(u) for u in binders)
        )
        verdicts.append(verdict)
    return verdicts


def check_cells(cells, closure, token: str) -> list[str]:
    """The notebook with `closure`'s code removed: each statement binding one of them
    becomes a stub that raises; every other top-level statement that is not a definition
    runs under `try` (a demo line calling a stub does not stop the cell)."""
    stub = f"_gx_unavailable_{token}"
    out = [
        f"def {stub}(name):\n"
        "    def unavailable(*args, **kwargs):\n"
        "        raise NameError(f'`{name}` is not available in this question')\n"
        "    return unavailable\n"
    ]
    for source in cells:
        body = _parse(source)
        if not body:  # fails in the sandbox too (a too-deep cell is a hatch: never here)
            out.append(source)
            continue
        new = []
        for u in body:
            names = _bound(u)
            if names & closure:
                new.extend(ast.parse(f"{n} = {stub}({n!r})").body[0] for n in sorted(names))
            elif isinstance(u, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                new.append(u)
            else:
                new.append(ast.Try(body=[u], handlers=[_pass_handler()], orelse=[], finalbody=[]))
        out.append(ast.unparse(ast.fix_missing_locations(ast.Module(body=new, type_ignores=[]))))
    out.append("\n".join(f"{n} = {stub}({n!r})" for n in sorted(closure)))
    return out


def _pass_handler() -> ast.ExceptHandler:
    return ast.ExceptHandler(type=ast.Name("Exception", ast.Load()), name=None, body=[ast.Pass()])


def _message(verdict: Verdict, why: str) -> str:
    names = ", ".join(f"`{n}`" for n in verdict.forbidden)
    return (
        f"`{verdict.function}` must be written on its own, without {names} (nor the "
        f"functions and values they use): {why}"
    )


def pending(grader, cells) -> list[tuple[Verdict, int]]:
    """Every rule's verdict from `plan` on a graded question, with the question's index."""
    rules = grader.config.get("separate") or {}
    out = []
    for verdict in plan(cells, rules):
        index = next(
            (i for i, q in enumerate(grader.questions) if verdict.function in q.functions), None
        )
        if index is not None:
            out.append((verdict, index))
    return out


def launch_ahead(grader, verdicts, limits=None) -> list:
    """Sandboxes for the second step of `verdicts` (from `pending`), launched now (the
    grader calls this once the first sandbox is ready) so that their `import jax`
    overlaps the first sandbox's public tests (measured on 2 cores: 03_bezier, two rules,
    graded in 2.3-2.4 s instead of 2.6-2.9 s). A launched sandbox has run nothing but its
    preloads: the student's code reaches it only in `rerun`."""
    wanted = sum(1 for verdict, _ in verdicts if not verdict.hatch)
    launched = []
    for _ in range(wanted):
        sandbox = Sandbox(grader.limits(limits), **grader._sandbox_options())
        try:
            sandbox.launch()
        except Exception:  # no sandbox here: `rerun` starts its own and reports it
            sandbox.close()
            break
        launched.append(sandbox)
    return launched


def rerun(
    grader, cells, limits=None, verdicts=None, sandboxes=()
) -> list[tuple[Verdict, int, set[str] | None]]:
    """The second step for every rule: each rule's question graded again without the
    forbidden code (`check_cells`), in a second sandbox, public tests first.

    Called by the grader after the public tests and before any hidden test of the first
    sandbox: nothing the student's code learns from a hidden call there (and could
    signal through the clock) exists yet, so what the second sandbox shows of its public
    tests cannot depend on a hidden input.

    `verdicts` (default `pending(grader, cells)`) and `sandboxes` (from `launch_ahead`,
    used in turn and closed here) let the grader prepare the step ahead.

    **Returns:** per rule, its verdict, the question's index and the names of the tests
    that passed without the forbidden code (`None`: the notebook cannot be checked, or
    the second sandbox could not start, in which case `verdict.error` says why).
    """
    verdicts = pending(grader, cells) if verdicts is None else verdicts
    sandboxes = list(sandboxes)
    out = []
    try:
        for verdict, index in verdicts:
            if verdict.hatch:
                out.append((verdict, index, None))
                continue
            checked = check_cells(cells, verdict.closure, secrets.token_hex(8))
            ahead = sandboxes.pop(0) if sandboxes else None
            session = grader.session(checked, limits, sandbox=ahead)
            try:  # public tests first, as in the first sandbox
                session.start()
                again = [
                    t
                    for which in ("public", "hidden")
                    for t in grader._grade_question(grader.questions[index], session, which).tests
                ]
            except Exception:  # anything that stops the check: nothing passes it
                again = []
            finally:
                session.close()
            verdict.error = session.infrastructure_error
            passed = None if verdict.error else {t.name for t in again if t.passed}
            out.append((verdict, index, passed))
    finally:
        for sandbox in sandboxes:
            sandbox.close()
    return out


def enforce(results, reruns) -> tuple[list[str], list[str], str | None]:
    """Apply the `rerun` outcomes to `results` (QuestionResults of the first sandbox,
    changed in place): a test that passes only with a forbidden function's code fails.

    **Returns:** notes for the student, notes for the staff only (a rule that only hidden
    tests showed broken: when a hidden test fails there is the student's code's to
    choose, and would spell out a hidden input), and the grader's own error if a second
    sandbox could not start (the submission is then a grading error, never a silent zero).
    """
    notes, staff_notes, error = [], [], None
    for verdict, index, passed in reruns:
        if verdict.error:
            error = error or verdict.error
            continue
        if passed is None:
            why = f"the notebook uses {verdict.hatch}, so this cannot be checked; 0 points"
            passed = set()
        else:
            why = "this test passes only with them"
        failed = [t for t in results[index].tests if t.passed and t.name not in passed]
        for test in failed:
            test.passed, test.message = False, _message(verdict, why)
        if failed:
            public = any(not t.hidden for t in failed)
            (notes if public else staff_notes).append(
                f"{results[index].name}: " + _message(verdict, why)
            )
    return notes, staff_notes, error
