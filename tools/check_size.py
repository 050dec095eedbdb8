"""The size of the rooms of ``jethr1_plan``, checked (``make lint``): no module over :data:`MAX_MODULE_LINES`
lines, no function or method over :data:`MAX_FUNCTION_LINES` (from its ``def`` line, decorators excluded,
to its last line, nested functions included).

    python tools/check_size.py           # exit 1 and one line per room too big
    python tools/check_size.py --report  # every module and function over the limits, and the counts
    python tools/check_size.py --root DIR  # the package under DIR/jethr1_plan instead of this checkout's
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from pathlib import Path

MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80

#: files allowed over the limits (a path, or a folder ending in "/", relative to the repository root): none
ALLOWED: frozenset[str] = frozenset()


def functions(tree: ast.AST) -> Iterator[tuple[str, int, int]]:
    """(qualified name, first line, number of lines) of every function and method of a module's tree."""

    def visit(node: ast.AST, prefix: str) -> Iterator[tuple[str, int, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                yield name, child.lineno, (child.end_lineno or child.lineno) - child.lineno + 1
                yield from visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                yield from visit(child, prefix + child.name + ".")
            else:
                yield from visit(child, prefix)

    yield from visit(tree, "")


def problems(root: Path, allowed: frozenset[str] = ALLOWED) -> tuple[list[str], list[str]]:
    """(modules over the limit, functions over the limit), each as ``path:line name (n lines)``, allowed files
    left out."""
    big_modules, big_functions = [], []
    for path in sorted((root / "jethr1_plan").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if any(rel == a or (a.endswith("/") and rel.startswith(a)) for a in allowed):
            continue
        text = path.read_text(encoding="utf-8")
        n = len(text.splitlines())
        if n > MAX_MODULE_LINES:
            big_modules.append(f"{rel} has {n} lines (at most {MAX_MODULE_LINES})")
        for name, line, length in functions(ast.parse(text)):
            if length > MAX_FUNCTION_LINES:
                big_functions.append(f"{rel}:{line} {name} has {length} lines (at most {MAX_FUNCTION_LINES})")
    return big_modules, big_functions


def main(argv: list[str]) -> int:
    root = Path(argv[argv.index("--root") + 1]) if "--root" in argv else Path(__file__).resolve().parents[1]
    report = "--report" in argv
    big_modules, big_functions = problems(root, frozenset() if report else ALLOWED)
    for line in big_modules + big_functions:
        print(line)
    if report:
        print(f"{len(big_modules)} modules over {MAX_MODULE_LINES} lines, "
              f"{len(big_functions)} functions over {MAX_FUNCTION_LINES} lines")
        return 0
    return 1 if big_modules or big_functions else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
