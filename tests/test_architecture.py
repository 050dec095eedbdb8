"""The map of the house is written once, in tools/check_imports.py (``LAYERS``, ``WHAT``): docs/architecture.md's
layer table and the package docstring are generated from it (tools/architecture.py) and must match it."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import jethr1_plan

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import architecture  # noqa: E402
import check_imports  # noqa: E402


def _copy(tmp_path: Path) -> Path:
    (tmp_path / "docs").mkdir()
    (tmp_path / "jethr1_plan").mkdir()
    shutil.copy(ROOT / "docs" / "architecture.md", tmp_path / "docs" / "architecture.md")
    shutil.copy(ROOT / "jethr1_plan" / "__init__.py", tmp_path / "jethr1_plan" / "__init__.py")
    for unit in {u for layer in check_imports.LAYERS for u in layer}:
        if (ROOT / "jethr1_plan" / unit).is_dir():
            (tmp_path / "jethr1_plan" / unit).mkdir()
    return tmp_path


def test_the_page_and_the_docstring_match_the_layers() -> None:
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "architecture.py"), "--check"], capture_output=True,
                       text=True, check=False)
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_unit_of_the_package_is_in_the_table_once_at_its_layer() -> None:
    units = {check_imports.unit(m) for m in check_imports.modules(ROOT)} - {"__init__"}
    page = (ROOT / "docs" / "architecture.md").read_text()
    rows = re.findall(r"^\| (\d+) \| `([a-z_]+)(?:/|\.py)` \|", page, re.M)
    assert sorted(u for _, u in rows) == sorted(units)
    layer_of = {u: k for k, layer in enumerate(check_imports.LAYERS) for u in layer}
    assert all(layer_of[u] == int(k) for k, u in rows)
    assert "route" in {u for _, u in rows}  # the hand-written table once left route/ out
    doc = jethr1_plan.__doc__ or ""
    assert all(f":mod:`.{u}`" in doc for u in units)


def test_every_unit_has_a_description_and_every_description_a_unit() -> None:
    assert set(check_imports.WHAT) == {u for layer in check_imports.LAYERS for u in layer}


def test_a_unit_left_out_of_the_layers_makes_both_files_stale(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    assert architecture.stale(root) == []
    fewer = [tuple(u for u in layer if u != "route") for layer in check_imports.LAYERS]
    assert architecture.stale(root, [layer for layer in fewer if layer]) == [
        root / "docs" / "architecture.md", root / "jethr1_plan" / "__init__.py"]


def test_a_hand_edit_of_the_table_is_found_and_rewritten(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    page = root / "docs" / "architecture.md"
    k = next(k for k, layer in enumerate(check_imports.LAYERS) if "route" in layer)
    text = page.read_text()
    assert f"| {k} | `route/` |" in text
    page.write_text(text.replace(f"| {k} | `route/` |", f"| {k - 1} | `route/` |"))
    assert architecture.stale(root) == [page]
    page.write_text(architecture.render_page(page.read_text(), check_imports.LAYERS, check_imports.WHAT, root))
    assert architecture.stale(root) == []
