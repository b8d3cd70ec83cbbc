"""Rooms of a readable size (issue 16): no module over 600 lines and no function over 80
lines in `gfxlab/`, data-table modules aside; and the architecture page's module map
names every module.

A function counts from its `def` line to its last line (docstring included); a
decorator does not count. Run as a script to list the offenders:

    python tests/test_layout.py
"""

from __future__ import annotations

import ast
import pathlib
import sys

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "gfxlab"
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80
# Modules that are mostly data (tables of numbers), exempt from both limits. Each
# entry is a path relative to `gfxlab/`; the test fails for an entry that no longer
# exists, so the list stays true.
DATA_TABLES: frozenset[str] = frozenset({"color/_tables.py", "jpeg/_tables.py"})


def oversized(package: pathlib.Path = PACKAGE) -> list[str]:
    """Every module over `MAX_MODULE_LINES` lines and every function over
    `MAX_FUNCTION_LINES` lines under `package`, as readable lines."""
    found = []
    for path in sorted(package.rglob("*.py")):
        name = path.relative_to(package).as_posix()
        if name in DATA_TABLES:
            continue
        source = path.read_text(encoding="utf-8")
        lines = len(source.splitlines())
        if lines > MAX_MODULE_LINES:
            found.append(f"module gfxlab/{name}: {lines} lines")
        for node in ast.walk(ast.parse(source, filename=str(path))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    found.append(
                        f"function gfxlab/{name}:{node.lineno} {node.name}: {length} lines"
                    )
    return found


def test_no_module_over_600_and_no_function_over_80_lines():
    assert oversized() == []


def test_the_data_table_list_names_existing_modules():
    missing = sorted(name for name in DATA_TABLES if not (PACKAGE / name).is_file())
    assert missing == []


def test_the_module_map_names_every_module():
    """docs/architecture.md's module map names every module and package of gfxlab/."""
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        dotted = ".".join(("gfxlab",) + parts)
        if parts and f"`{dotted}`" not in text and f"`{parts[-1]}`" not in text:
            missing.append(dotted)
    assert missing == []


def test_the_check_finds_an_oversized_module_and_function(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    (tmp_path / "long.py").write_text(f"def long():\n{body}\n")
    (tmp_path / "big.py").write_text("x = 1\n" * (MAX_MODULE_LINES + 1))
    (tmp_path / "fine.py").write_text("def short():\n    return 1\n")
    found = oversized(tmp_path)
    assert found == [
        f"module gfxlab/big.py: {MAX_MODULE_LINES + 1} lines",
        f"function gfxlab/long.py:1 long: {MAX_FUNCTION_LINES + 1} lines",
    ]


if __name__ == "__main__":
    print("\n".join(oversized()) or "no module over 600 lines, no function over 80 lines")
    sys.exit(bool(oversized()))


def test_every_public_module_has_an_api_page_in_the_navigation():
    """Each `gfxlab.<module>` (and `gfxlab.labs`) has `docs/api/<module>.md`, listed in the
    site's navigation, so the generated API overview (docs/_hooks.py) covers it."""
    import pkgutil

    import gfxlab

    root = PACKAGE.parent
    navigation = (root / "mkdocs.yml").read_text(encoding="utf-8")
    modules = [m.name for m in pkgutil.iter_modules(gfxlab.__path__) if not m.name.startswith("_")]
    assert {"transforms", "render", "labs"} <= set(modules)
    missing = [
        m for m in modules
        if f"- api/{m}.md" not in navigation or not (root / "docs" / "api" / f"{m}.md").is_file()
    ]  # fmt: skip
    assert missing == []
    pages = sorted(p.stem for p in (root / "docs" / "api").glob("*.md"))
    assert pages == sorted(modules), "an API page for a module that is not public"
