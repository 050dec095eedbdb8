"""The lock of the tested set (constraints.txt) against the environment that runs this script.

    python tools/check_lock.py constraints.txt            # exit 1 unless the environment is exactly the lock
    python tools/check_lock.py --report constraints.txt   # print how the environment differs from the lock; exit 0
    python tools/check_lock.py --write constraints.txt    # write the lock from the environment (`make lock`)

The lock is a pip constraints file: one ``name==version`` a line, ``#`` comments, and ``; python_version ...``
after a pin that only some of the supported Pythons (pyproject.toml's classifiers) need: the writer finds
them by following every installed distribution's requirements from the project's, once per supported Python.
Every installed distribution but the project itself is compared, pip, setuptools and wheel included.
Standard library only, but for ``packaging`` (markers and requirements; a dependency of pytest).
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import platform
import re
import sys
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]


def canonical(name: str) -> str:
    """A distribution's name as pip compares it (PEP 503: case, '-', '_' and '.' do not matter)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def _project(root: Path) -> dict:
    with open(root / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["project"]


def project_name(root: Path = ROOT) -> str:
    """The project's own distribution name, never part of its lock."""
    return canonical(_project(root)["name"])


def supported_pythons(root: Path = ROOT) -> list[str]:
    """The Python versions the project supports, as its classifiers name them ("3.11", ...), oldest first."""
    prefix = "Programming Language :: Python :: "
    found = [c.removeprefix(prefix) for c in _project(root).get("classifiers", []) if c.startswith(prefix)]
    return sorted((v for v in found if re.fullmatch(r"3\.\d+", v)), key=lambda v: int(v.split(".")[1]))


def marker_holds(marker: str) -> bool:
    """Whether an environment marker (PEP 508, e.g. ``python_version >= "3.13"``) holds for this Python."""
    from packaging.markers import Marker  # a dependency of pytest, hence of the dev extra

    return Marker(marker).evaluate()


def read_lock(text: str, source: str = "constraints.txt") -> dict[str, str]:
    """The pins of a lock that hold for this Python: canonical name -> version.

    Raises ValueError naming the line for anything but ``name==version [; marker]``.
    """
    pins: dict[str, str] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        requirement, _, marker = line.partition(";")
        m = re.fullmatch(r"([A-Za-z0-9][A-Za-z0-9._-]*)\s*==\s*([^\s=<>!~,;]+)", requirement.strip())
        if m is None:
            raise ValueError(f"{source}:{number}: not a pin 'name==version': {raw.strip()!r}")
        if marker.strip() and not marker_holds(marker.strip()):
            continue
        name = canonical(m.group(1))
        if name in pins:
            raise ValueError(f"{source}:{number}: {m.group(1)} is pinned twice for this Python")
        pins[name] = m.group(2)
    return pins


def installed(exclude: str) -> dict[str, tuple[str, str]]:
    """The distributions this Python imports: canonical name -> (name as published, version); the first on
    sys.path wins, as for an import. ``exclude`` (the project itself) is left out."""
    found: dict[str, tuple[str, str]] = {}
    for dist in importlib.metadata.distributions():
        name = dist.metadata["Name"]
        if name is None:
            continue
        key = canonical(name)
        if key != exclude and key not in found:
            found[key] = (name, dist.version)
    return found


def requirements_of_installed() -> dict[str, list[str]]:
    """Each installed distribution's requirements (Requires-Dist), by canonical name; the first on sys.path."""
    found: dict[str, list[str]] = {}
    for dist in importlib.metadata.distributions():
        name = dist.metadata["Name"]
        if name is not None:
            found.setdefault(canonical(name), list(dist.requires or []))
    return found


def needed_on(requires: Mapping[str, list[str]], root: str, extras: Iterable[str],
              pythons: Iterable[str]) -> dict[str, set[str]]:
    """On which of ``pythons`` ("3.11", ...) each distribution is needed: reached from ``root`` with ``extras``
    through ``requires`` (canonical name -> Requires-Dist), the markers evaluated for that Python. A name
    absent from ``requires`` (not installed here) is a leaf.
    """
    needed: dict[str, set[str]] = {}
    for py in pythons:
        env = {"python_version": py, "python_full_version": f"{py}.0"}
        todo, seen = [(root, frozenset(extras))], set()
        while todo:
            name, active = todo.pop()
            if (name, active) in seen:
                continue
            seen.add((name, active))
            needed.setdefault(name, set()).add(py)
            for line in requires.get(name, []):
                req = _requirement(line)
                if req.marker is None or any(req.marker.evaluate({**env, "extra": e}) for e in active | {""}):
                    todo.append((canonical(req.name), frozenset(req.extras)))
    return needed


def _requirement(line: str) -> Requirement:
    from packaging.requirements import Requirement  # a dependency of pytest, hence of the dev extra

    return Requirement(line)


def python_marker(needed: set[str], pythons: list[str]) -> str:
    """The marker under which a pin holds: '' on every supported Python, else the versions that need it."""
    if set(pythons) <= needed:
        return ""
    if needed == set(pythons[:len(needed)]):
        return f'python_version < "{pythons[len(needed)]}"'
    if needed == set(pythons[-len(needed):]):
        return f'python_version >= "{pythons[-len(needed)]}"'
    return " or ".join(f'python_version == "{v}"' for v in pythons if v in needed)


@dataclass(frozen=True)
class Difference:
    """One package whose installed version is not its locked one (None: absent on that side)."""

    name: str
    locked: str | None
    installed: str | None

    def line(self) -> str:
        locked = self.locked if self.locked is not None else "(not locked)"
        now = self.installed if self.installed is not None else "(not installed)"
        return f"  {self.name:28s} {locked:>22s} -> {now}"


def differences(lock: dict[str, str], env: dict[str, str]) -> list[Difference]:
    """Every package whose version in ``env`` (canonical name -> version) is not the one in ``lock``, by name."""
    return [Difference(name, lock.get(name), env.get(name)) for name in sorted(lock.keys() | env.keys())
            if lock.get(name) != env.get(name)]


def lock_text(env: dict[str, tuple[str, str]], python: str, today: datetime.date,
              markers: Mapping[str, str] | None = None) -> str:
    """The lock written from an environment: a header saying how it was made, then the pins by name, each
    with its marker from ``markers`` (canonical name -> marker; none: every Python)."""
    header = [
        "# The tested set: the exact versions `make install` and CI install (pip install -c constraints.txt",
        "# -e '.[dev]') and that `make test` checks (tools/check_lock.py). pyproject.toml keeps the ranges the",
        "# package accepts.",
        f"# Written by `make lock` (tools/check_lock.py --write) on {today.isoformat()} from the environment in which",
        f"# `make check-latest` passed, on Python {python}. How to move it forward: docs/install.md.",
    ]
    markers = markers or {}
    pins = []
    for key, (name, version) in sorted(env.items()):
        marker = markers.get(key, "")
        pins.append(f"{name}=={version}" + (f" ; {marker}" if marker else ""))
    return "\n".join(header + pins) + "\n"


def write(lock: Path, env: dict[str, tuple[str, str]]) -> int:
    """Write the lock from this environment (``env``: installed(), the project left out), each pin marked with
    the supported Pythons that need it. Exit 1, writing nothing, if another supported Python needs a
    distribution that is not installed here."""
    root, pythons = project_name(), supported_pythons()
    requires = requirements_of_installed()
    extras = importlib.metadata.distribution(root).metadata.get_all("Provides-Extra") or []
    needed = needed_on(requires, root, extras, pythons)
    missing = [f"{name} (Python {', '.join(sorted(needed[name]))})" for name in sorted(needed.keys() - requires.keys())]
    if missing:
        print(f"{lock}: not written: needed, not installed here: {'; '.join(missing)}", file=sys.stderr)
        return 1
    markers = {key: python_marker(needed[key], pythons) for key in env if key in needed}
    tmp = lock.with_name(lock.name + ".tmp")
    tmp.write_text(lock_text(env, platform.python_version(), datetime.date.today(), markers))
    tmp.replace(lock)
    some = sum(1 for m in markers.values() if m)
    print(f"{lock}: {len(env)} packages locked from {sys.prefix} (Python {platform.python_version()}), "
          f"{some} of them for some of Pythons {', '.join(pythons)} only")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("lock", type=Path, help="the lock file (constraints.txt)")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--report", action="store_true", help="print the differences and exit 0")
    mode.add_argument("--write", action="store_true", help="write the lock from this environment")
    args = ap.parse_args(argv)
    env = installed(exclude=project_name())
    if args.write:
        return write(args.lock, env)
    try:
        lock = read_lock(args.lock.read_text(), str(args.lock))
    except (OSError, ValueError) as e:
        print(f"{args.lock}: {e}", file=sys.stderr)
        return 2
    versions = {key: version for key, (_, version) in env.items()}
    diff = differences(lock, versions)
    where = f"{sys.prefix} (Python {platform.python_version()})"
    if not diff:
        print(f"{args.lock}: {where} holds exactly the {len(lock)} locked versions")
        return 0
    lines = [f"{args.lock}: {len(diff)} of {len(lock.keys() | versions.keys())} packages in {where} differ from "
             f"the lock (locked -> installed):", *(d.line() for d in diff)]
    if args.report:
        print("\n".join(lines))
        return 0
    print("\n".join([*lines, "  the tests run on the locked set only: `make clean install` installs it"]),
          file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
