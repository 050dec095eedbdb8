"""The lock of the tested set (constraints.txt, tools/check_lock.py): every requirement of pyproject.toml is
pinned inside its range, and the check names every package whose installed version is not its locked one."""

from __future__ import annotations

import datetime
import importlib.util
import sys
import tomllib

import pytest
from packaging.requirements import Requirement

from tests.conftest import ROOT

_spec = importlib.util.spec_from_file_location("check_lock", ROOT / "tools" / "check_lock.py")
assert _spec is not None and _spec.loader is not None
check_lock = sys.modules.setdefault("check_lock", importlib.util.module_from_spec(_spec))
_spec.loader.exec_module(check_lock)

LOCK = ROOT / "constraints.txt"


def _requirements() -> list[Requirement]:
    """The project's requirements: the core and every extra, each once per (name, specifier)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    lines = [*project["dependencies"], *(r for extra in project["optional-dependencies"].values() for r in extra)]
    return [Requirement(line) for line in dict.fromkeys(lines)]


def test_every_requirement_is_locked_inside_its_range():
    lock = check_lock.read_lock(LOCK.read_text())
    checked = 0
    for req in _requirements():
        if req.marker is not None and not req.marker.evaluate():
            continue
        name = check_lock.canonical(req.name)
        assert name in lock, f"{req} is not in {LOCK.name}"
        assert req.specifier.contains(lock[name], prereleases=True), f"{LOCK.name} pins {name}=={lock[name]}: not {req}"
        checked += 1
    assert checked >= 20  # the core and the dev, view and dask extras


def test_the_lock_pins_every_extra_s_own_dependencies():
    """dask[distributed] brings distributed: the lock pins it too, so `make install` is the tested set whole."""
    lock = check_lock.read_lock(LOCK.read_text())
    assert {"distributed", "dask", "rerun-sdk", "placo", "pin", "pip", "setuptools", "wheel"} <= lock.keys()
    assert lock["placo"] == "0.10.2"


def test_a_lock_reads_pins_only_and_skips_those_of_other_pythons():
    text = ('# header\n\nPyYAML==6.0.4  # a comment\nruamel.yaml==0.19.1\n'
            'tomli==2.0.1 ; python_version < "3.0"\nnumpy==2.3.5 ; python_version >= "3.0"\n')
    assert check_lock.read_lock(text) == {"pyyaml": "6.0.4", "ruamel-yaml": "0.19.1", "numpy": "2.3.5"}
    with pytest.raises(ValueError, match=r"lock.txt:2: not a pin"):
        check_lock.read_lock("numpy==2.3.5\nscipy>=1.15\n", "lock.txt")
    with pytest.raises(ValueError, match=r"lock.txt:2: NumPy is pinned twice"):
        check_lock.read_lock("numpy==2.3.5\nNumPy==2.4.0\n", "lock.txt")


def test_differences_name_each_changed_added_and_removed_package():
    lock = {"numpy": "2.3.5", "scipy": "1.17.1", "mujoco": "4.0.0"}
    env = {"numpy": "2.4.1", "scipy": "1.17.1", "jax": "0.9.0"}
    assert check_lock.differences(lock, env) == [
        check_lock.Difference("jax", None, "0.9.0"),
        check_lock.Difference("mujoco", "4.0.0", None),
        check_lock.Difference("numpy", "2.3.5", "2.4.1"),
    ]
    assert check_lock.differences(lock, dict(lock)) == []


def test_a_written_lock_reads_back_as_the_environment_it_was_written_from():
    env = check_lock.installed(exclude=check_lock.project_name())
    text = check_lock.lock_text(env, "3.11.7", datetime.date(2026, 11, 28))
    assert check_lock.read_lock(text) == {key: version for key, (_, version) in env.items()}
    assert "jethr1-plan" not in check_lock.read_lock(text)
    assert "2026-11-28" in text and "Python 3.11.7" in text


def test_the_check_fails_on_one_changed_pin_and_reports_it(tmp_path, capsys):
    env = check_lock.installed(exclude=check_lock.project_name())
    exact = tmp_path / "exact.txt"
    exact.write_text(check_lock.lock_text(env, "3.11.7", datetime.date(2026, 11, 28)))
    assert check_lock.main([str(exact)]) == 0
    name, version = env["numpy"]
    changed = tmp_path / "changed.txt"
    changed.write_text(exact.read_text().replace(f"{name}=={version}\n", f"{name}=={version}.1\n"))
    capsys.readouterr()
    assert check_lock.main([str(changed)]) == 1
    err = capsys.readouterr().err
    assert "1 of" in err and f"{version}.1 -> {version}" in err
    assert check_lock.main(["--report", str(changed)]) == 0  # `make check-latest` reports and goes on
    assert f"{version}.1 -> {version}" in capsys.readouterr().out
    bad = tmp_path / "bad.txt"
    bad.write_text("numpy>=2\n")
    assert check_lock.main([str(bad)]) == 2
    assert "bad.txt:1: not a pin" in capsys.readouterr().err
