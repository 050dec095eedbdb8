"""Write the map of the house from ``LAYERS`` and ``WHAT`` in tools/check_imports.py: the layer table of
docs/architecture.md and the layer list of the package's docstring (jethr1_plan/__init__.py).
``tests/test_architecture.py`` fails when either disagrees with them.

    python tools/architecture.py            # rewrite both
    python tools/architecture.py --check    # exit 1 (naming the file) if either is out of date
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from check_imports import LAYERS, WHAT

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
PACKAGE = ROOT / "jethr1_plan" / "__init__.py"
BEGIN = "<!-- the layers: written by tools/architecture.py from tools/check_imports.py; do not edit here -->"
END = "<!-- end of the layers -->"
DOC_START = "The package is layered, lowest first"


def place(root: Path, unit: str) -> str:
    """A unit as the table names it: ``io/`` for a subpackage, ``errors.py`` for a module."""
    return f"{unit}/" if (root / "jethr1_plan" / unit).is_dir() else f"{unit}.py"


def table(layers: list[tuple[str, ...]], what: dict[str, str], root: Path = ROOT) -> str:
    """The layer table (markdown), one row per unit, lowest layer first; ``__init__`` left out."""
    rows = ["| layer | folder or module | what lives there |", "|---|---|---|"]
    for k, layer in enumerate(layers):
        for unit in layer:
            if unit != "__init__":
                rows.append(f"| {k} | `{place(root, unit)}` | {what[unit]} |")
    return "\n".join(rows)


def few_words(text: str) -> str:
    """The few words of a :data:`WHAT` entry (before its first colon), as reStructuredText: no bold, literals in
    double backquotes."""
    words = text.split(": ")[0].replace("**", "")
    return re.sub(r"(?<!`)`([^`]+)`(?!`)", r"``\1``", words)


def docstring_layers(layers: list[tuple[str, ...]], what: dict[str, str], width: int = 110) -> str:
    """The package docstring's list of the layers: each unit with the few words of its :data:`WHAT`."""
    out = [f"{DOC_START}; a layer imports only its own and the layers below",
           "(``tools/check_imports.py`` holds them, ``make lint`` checks them, docs/architecture.md explains them):",
           ""]
    for k, layer in enumerate(layers):
        units = [f":mod:`.{u}` — {few_words(what[u])}" for u in layer if u != "__init__"]
        if not units:
            continue
        line, lines = f"{k}. ", []
        for i, part in enumerate(units):
            for j, word in enumerate(part.split(" ")):
                piece = word + (";" if i < len(units) - 1 and j == len(part.split(" ")) - 1 else "")
                if len(line) + 1 + len(piece) > width and line.strip():
                    lines.append(line.rstrip())
                    line = "   "
                line += ("" if line.endswith((". ", "   ")) else " ") + piece
        lines.append(line.rstrip())
        out += lines
    return "\n".join(out)


def render_page(text: str, layers: list[tuple[str, ...]], what: dict[str, str], root: Path = ROOT) -> str:
    """docs/architecture.md with its table between :data:`BEGIN` and :data:`END` written anew."""
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{BEGIN}\n{table(layers, what, root)}\n{END}{tail}"


def render_package(text: str, layers: list[tuple[str, ...]], what: dict[str, str]) -> str:
    """jethr1_plan/__init__.py with its docstring's layer list (from :data:`DOC_START` to the docstring's end)
    written anew."""
    head, rest = text.split(DOC_START, 1)
    end = rest.index('"""')
    return f"{head}{docstring_layers(layers, what)}\n{rest[end:]}"


def stale(root: Path = ROOT, layers: list[tuple[str, ...]] = LAYERS, what: dict[str, str] = WHAT) -> list[Path]:
    """The files whose map differs from ``layers``; a unit of ``layers`` without a description is an error."""
    missing = [u for layer in layers for u in layer if u not in what]
    if missing:
        raise SystemExit(f"tools/check_imports.py: WHAT has no description of {', '.join(missing)}")
    page, package = root / "docs" / "architecture.md", root / "jethr1_plan" / "__init__.py"
    out = []
    for path, render in ((page, lambda t: render_page(t, layers, what, root)),
                         (package, lambda t: render_package(t, layers, what))):
        text = path.read_text(encoding="utf-8")
        if render(text) != text:
            out.append(path)
    return out


def main(argv: list[str]) -> int:
    if "--check" in argv:
        for path in stale():
            print(f"{path.relative_to(ROOT)} is out of date with LAYERS and WHAT in tools/check_imports.py: run "
                  "python tools/architecture.py")
        return 1 if stale() else 0
    PAGE.write_text(render_page(PAGE.read_text(encoding="utf-8"), LAYERS, WHAT), encoding="utf-8")
    PACKAGE.write_text(render_package(PACKAGE.read_text(encoding="utf-8"), LAYERS, WHAT), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
