"""The plan's vocabulary, checked (``make lint``):

* every plan CSV column name is spelled, as a string literal, in one module of ``jethr1_plan``
  (:data:`HOME`: ``records/plan_columns.py``); at most :data:`MAX_STRAYS` literals of those names elsewhere
  (docstrings aside; the names that are also ordinary words of other records, ``SHARED_WORDS`` there, are
  not counted);
* ``files/`` serialises records and imports none of the planner's packages (:data:`PLANNER`);
* the thrust limit has one spelling, ``thrust_max_n`` (a fan's and a scenario's), and the largest thrust a
  plan uses is ``peak_thrust_n``: the retired spelling (:data:`RETIRED`) appears nowhere in the package, the
  shipped robots or configs, but where the input reader names it as renamed (:data:`RETIRED_HOME`).
"""

from __future__ import annotations

import ast
import re
import sys
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

HOME = "jethr1_plan/records/plan_columns.py"
MAX_STRAYS = 10
#: what ``files/`` may not import: the planner and the scenario it plans
PLANNER = ("planning", "walking", "balance_space", "route", "scenario")
RETIRED = ("max_thrust_n", "max_thrust_per_fan_n")
RETIRED_HOME = "jethr1_plan/io/yaml_input.py"
#: where the retired spellings are looked for: the package's code and data, the shipped robots and configs
RETIRED_SCOPE = (("jethr1_plan", ("*.py", "*.json")), ("robots", ("*.yaml",)), ("configs", ("*.yaml",)))


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the string constants that are statements (docstrings, bare strings)."""
    return {id(n.value) for n in ast.walk(tree) if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}


def stray_literals(root: Path, vocabulary: Iterable[str]) -> list[tuple[str, int, str]]:
    """(module, line, name) of every literal of a ``vocabulary`` name outside :data:`HOME`."""
    names = set(vocabulary)
    out = []
    for p in sorted((root / "jethr1_plan").rglob("*.py")):
        rel = p.relative_to(root).as_posix()
        if rel == HOME:
            continue
        tree = ast.parse(p.read_text(encoding="utf-8"))
        skip = _docstrings(tree)
        for n in ast.walk(tree):
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value in names and id(n) not in skip:
                out.append((rel, n.lineno, n.value))
    return out


def home_names(root: Path, vocabulary: Iterable[str]) -> set[str]:
    """The ``vocabulary`` names spelled as literals in :data:`HOME`."""
    tree = ast.parse((root / HOME).read_text(encoding="utf-8"))
    names = set(vocabulary)
    return {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and n.value in names}


def planner_imports(root: Path) -> list[tuple[str, int, str]]:
    """(module, line, imported module) of every import of a :data:`PLANNER` package in ``jethr1_plan/files``."""
    out = []
    banned = tuple(f"jethr1_plan.{u}" for u in PLANNER)
    for p in sorted((root / "jethr1_plan" / "files").rglob("*.py")):
        rel = p.relative_to(root).as_posix()
        package = ".".join(p.relative_to(root).with_suffix("").parts[:-1])
        for n in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(n, ast.Import):
                targets = [a.name for a in n.names]
            elif isinstance(n, ast.ImportFrom):
                base = package.split(".")[: len(package.split(".")) - (n.level - 1)] if n.level else []
                mod = ".".join([*base, n.module] if n.module else base) if n.level else (n.module or "")
                targets = [mod, *(f"{mod}.{a.name}" for a in n.names)]
            for t in targets:
                if any(t == b or t.startswith(b + ".") for b in banned):
                    out.append((rel, n.lineno, t))
                    break
    return out


def retired_spellings(root: Path) -> list[tuple[str, int, str]]:
    """(file, line, word) of every use of a :data:`RETIRED` spelling outside :data:`RETIRED_HOME`."""
    word = re.compile(r"\b(" + "|".join(RETIRED) + r")\b")
    out = []
    for folder, patterns in RETIRED_SCOPE:
        for pattern in patterns:
            for p in sorted((root / folder).rglob(pattern)):
                rel = p.relative_to(root).as_posix()
                if rel == RETIRED_HOME or "__pycache__" in rel:
                    continue
                for k, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
                    out += [(rel, k, m.group(1)) for m in word.finditer(line)]
    return out


def problems(root: Path, vocabulary: Iterable[str], max_strays: int = MAX_STRAYS) -> list[str]:
    vocabulary = set(vocabulary)
    out = []
    missing = sorted(vocabulary - home_names(root, vocabulary))
    if missing:
        out.append(f"{HOME} does not spell the columns {', '.join(missing)}")
    strays = stray_literals(root, vocabulary)
    if len(strays) > max_strays:
        per = Counter(m for m, _, _ in strays)
        out.append(f"{len(strays)} literals of plan column names outside {HOME} (at most {max_strays}): "
                   + ", ".join(f"{m} ({k})" for m, k in per.most_common()))
        out += [f"  {m}:{line}: {name!r}" for m, line, name in strays]
    for m, line, t in planner_imports(root):
        out.append(f"{m}:{line}: imports {t}: files/ serialises records and imports none of {', '.join(PLANNER)}")
    for m, line, w in retired_spellings(root):
        out.append(f"{m}:{line}: {w}: the thrust limit is thrust_max_n, the plan's largest thrust peak_thrust_n")
    return out


def main(root: Path) -> int:
    sys.path.insert(0, str(root))
    from jethr1_plan.records.plan_columns import FIXED_COLUMNS, SHARED_WORDS

    vocabulary = set(FIXED_COLUMNS) - set(SHARED_WORDS)
    found = problems(root, vocabulary)
    for p in found:
        print(p)
    strays = len(stray_literals(root, vocabulary))
    print(f"vocabulary: {len(vocabulary)} plan column names, {strays} literals outside {HOME}, "
          "files/ imports no planner, one spelling of the thrust limit: "
          + ("ok" if not found else f"{len(found)} problems"))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(Path(__file__).resolve().parents[1]))
