"""The URDF of a robot, read and checked before any C++ parser sees it.

:func:`check_urdf` parses the XML and checks what the planner, PlaCo and MuJoCo take from it: one tree
of links under one root; every number finite; masses positive where a link has an inertial (the
root's too) and inertia tensors physically valid (symmetric, positive semi-definite, principal
moments obeying the triangle inequality); joints of a known type with existing parent and child
links, a non-zero axis, and for revolute and prismatic joints ordered limits and a positive effort;
visual boxes and cylinders of positive size. Every problem is one
:class:`~jethr1_plan.errors.RobotModelError` naming the file, the element and what is wrong.

What is physical, and what the model takes: every link with an ``<inertial>`` has a mass between
:data:`MIN_LINK_MASS_KG` and :data:`MAX_LINK_MASS_KG` and an inertia tensor that is positive definite
(every principal moment above zero) and obeys the triangle inequality; every joint is revolute (with
its limits) or fixed (:data:`MODEL_JOINT_TYPES`: the legs' closed form and the statics count one angle
a joint); no document type or entity declarations (nothing expands the file); every mesh a regular
file beside the URDF, of at most :data:`MAX_MESH_BYTES`. The file itself is a regular file of at most
:data:`MAX_URDF_BYTES` (``io.input_file``).

PlaCo (pinocchio) parses the file next; what it prints on the C stderr goes to a temporary file
(:func:`quiet_stderr`) and its first line into the message if it fails, so nothing of it reaches
the terminal.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError, RobotModelError
from jethr1_plan.io.input_file import check_input_file, read_input

__all__ = ["MAX_LINK_MASS_KG", "MAX_MESH_BYTES", "MAX_URDF_BYTES", "MIN_LINK_MASS_KG", "MODEL_JOINT_TYPES", "UrdfJoint",
           "UrdfModel", "check_urdf", "geometry_boxes", "quiet_stderr", "urdf_joints"]

MAX_URDF_BYTES = 20_000_000  # a URDF without meshes is tens of kilobytes
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MODEL_JOINT_TYPES = ("revolute", "fixed")  # what jethr1's robot model takes
MIN_LINK_MASS_KG = 1e-6  # a link with an <inertial> weighs at least a milligram ...
MAX_LINK_MASS_KG = 1e4  # ... and at most ten tonnes: anything else is a typo (1e30, 1e-30)
MAX_MESH_BYTES = 50_000_000  # a mesh of a robot's link: a few megabytes
MESH_SUFFIXES = (".stl", ".obj", ".dae")


@dataclass(frozen=True)
class UrdfJoint:
    """A URDF joint as written: origin (xyz [m], rpy [rad]) and axis, for /tf."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]


@dataclass(frozen=True)
class UrdfModel:
    """What the checks read from a URDF: the root link, each link's mass [kg], the joints."""

    root: str
    masses: dict[str, float]  # links with an inertial
    joints: tuple[UrdfJoint, ...]

    @property
    def total_mass_kg(self) -> float:
        return float(sum(self.masses.values()))


def _fail(urdf: Path, where: str, problem: str) -> RobotModelError:
    return RobotModelError(str(urdf), where, problem)


def _attr(el: ET.Element | None, key: str, urdf: Path, where: str) -> str:
    """An attribute the URDF must have."""
    value = el.get(key) if el is not None else None
    if value is None:
        raise _fail(urdf, where, f"missing {key}=")
    return value


def _numbers(el: ET.Element | None, key: str, default: str, count: int, urdf: Path, where: str) -> list[float]:
    """``count`` finite numbers of an attribute (``default`` where the element or attribute is absent)."""
    text = el.get(key, default) if el is not None else default
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        raise _fail(urdf, where, f"{key}={text[:40]!r}: expected {count} numbers") from None
    if len(values) != count:
        raise _fail(urdf, where, f"{key}={text[:40]!r}: expected {count} numbers")
    if not all(math.isfinite(v) for v in values):
        raise _fail(urdf, where, f"{key}={text[:40]!r}: not a finite number")
    return values


def _number(el: ET.Element, key: str, urdf: Path, where: str, default: str | None = None) -> float:
    if default is None:
        _attr(el, key, urdf, where)
    return _numbers(el, key, default or "0", 1, urdf, where)[0]


def _check_inertial(link: ET.Element, name: str, urdf: Path) -> float | None:
    """The link's mass [kg] (None without an inertial), its inertia checked."""
    inertial = link.find("inertial")
    if inertial is None:
        return None
    where = f"link {name} inertial"
    _numbers(inertial.find("origin"), "xyz", "0 0 0", 3, urdf, f"{where} origin")
    _numbers(inertial.find("origin"), "rpy", "0 0 0", 3, urdf, f"{where} origin")
    mass_el = inertial.find("mass")
    if mass_el is None:
        raise _fail(urdf, where, "missing <mass>")
    mass = _number(mass_el, "value", urdf, f"{where} mass")
    if mass < 0:
        raise _fail(urdf, f"{where} mass", f"{mass:g} kg: a mass is not negative")
    if not MIN_LINK_MASS_KG <= mass <= MAX_LINK_MASS_KG:
        raise _fail(urdf, f"{where} mass", f"{mass:g} kg: a link with an <inertial> weighs between "
                    f"{MIN_LINK_MASS_KG:g} and {MAX_LINK_MASS_KG:g} kg (a massless frame has no <inertial>)")
    el = inertial.find("inertia")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    vals = dict.fromkeys(keys, 0.0) if el is None else {k: _number(el, k, urdf, f"{where} inertia") for k in keys}
    inertia = np.array([[vals["ixx"], vals["ixy"], vals["ixz"]], [vals["ixy"], vals["iyy"], vals["iyz"]],
                        [vals["ixz"], vals["iyz"], vals["izz"]]])
    moments = np.linalg.eigvalsh(inertia)
    scale = max(float(np.abs(moments).max()), 1e-12)
    if moments.min() < -1e-9 * scale:
        raise _fail(urdf, f"{where} inertia", f"not positive semi-definite (principal moments "
                    f"{', '.join(f'{m:.3g}' for m in moments)} kg·m²)")
    if moments[2] > moments[0] + moments[1] + 1e-9 * scale:
        raise _fail(urdf, f"{where} inertia", f"principal moments {', '.join(f'{m:.3g}' for m in moments)} kg·m² "
                    "break the triangle inequality (no body has them)")
    if not moments.min() > 0:
        raise _fail(urdf, f"{where} inertia", f"principal moments {', '.join(f'{m:.3g}' for m in moments)} kg·m²: "
                    "a body of positive mass has positive moments (positive definite)")
    return mass


def _check_meshes(link: ET.Element, name: str, urdf: Path) -> None:
    """Every mesh a link names: a regular file beside the URDF (or at an absolute path), bounded in size."""
    for kind in ("visual", "collision"):
        for k, el in enumerate(link.iter(kind)):
            for mesh in el.iter("mesh"):
                where = f"link {name} {kind} {k} mesh"
                filename = _attr(mesh, "filename", urdf, where)
                if "://" in filename:
                    raise _fail(urdf, where, f"filename={filename[:60]!r}: a URI is not resolved (give a path "
                                "relative to the URDF's folder)")
                path = Path(filename) if os.path.isabs(filename) else urdf.parent / filename
                if path.suffix.lower() not in MESH_SUFFIXES:
                    raise _fail(urdf, where, f"filename={filename[:60]!r}: expected a mesh file "
                                f"({', '.join(MESH_SUFFIXES)})")
                try:
                    check_input_file(path, MAX_MESH_BYTES, "a mesh")
                except InputError as exc:
                    raise _fail(urdf, where, f"{filename[:60]}: {exc.problem}") from None


def _check_visuals(link: ET.Element, name: str, urdf: Path) -> None:
    _check_meshes(link, name, urdf)
    for k, vis in enumerate(link.iter("visual")):
        where = f"link {name} visual {k}"
        _numbers(vis.find("origin"), "xyz", "0 0 0", 3, urdf, f"{where} origin")
        _numbers(vis.find("origin"), "rpy", "0 0 0", 3, urdf, f"{where} origin")
        geom = vis.find("geometry")
        box = geom.find("box") if geom is not None else None
        cyl = geom.find("cylinder") if geom is not None else None
        sizes = (_numbers(box, "size", "", 3, urdf, f"{where} box") if box is not None else
                 [_number(cyl, "radius", urdf, f"{where} cylinder"), _number(cyl, "length", urdf, f"{where} cylinder")]
                 if cyl is not None else [])
        if any(v <= 0 for v in sizes):
            raise _fail(urdf, where, "a box or cylinder of zero or negative size")


def _check_joint(j: ET.Element, urdf: Path, links: set[str]) -> UrdfJoint:
    name = _attr(j, "name", urdf, "joint")
    where = f"joint {name}"
    kind = _attr(j, "type", urdf, where)
    if kind not in JOINT_TYPES:
        raise _fail(urdf, where, f"type {kind!r}: expected one of {', '.join(JOINT_TYPES)}")
    if kind not in MODEL_JOINT_TYPES:
        raise _fail(urdf, where, f"type {kind!r}: jethr1's robot model takes revolute joints (with their limits) and "
                    "fixed joints")
    parent = _attr(j.find("parent"), "link", urdf, f"{where} parent")
    child = _attr(j.find("child"), "link", urdf, f"{where} child")
    for role, link in (("parent", parent), ("child", child)):
        if link not in links:
            raise _fail(urdf, f"{where} {role}", f"no link {link!r} in the URDF")
    org = j.find("origin")
    xyz = _numbers(org, "xyz", "0 0 0", 3, urdf, f"{where} origin")
    rpy = _numbers(org, "rpy", "0 0 0", 3, urdf, f"{where} origin")
    axis = _numbers(j.find("axis"), "xyz", "1 0 0", 3, urdf, f"{where} axis")
    if kind in ("revolute", "continuous", "prismatic") and math.hypot(*axis) < 1e-9:
        raise _fail(urdf, f"{where} axis", "a zero axis")
    if kind in ("revolute", "prismatic"):
        limit = j.find("limit")
        if limit is None:
            raise _fail(urdf, where, "missing <limit> (a revolute or prismatic joint needs one)")
        lower = _number(limit, "lower", urdf, f"{where} limit", "0")
        upper = _number(limit, "upper", urdf, f"{where} limit", "0")
        effort = _number(limit, "effort", urdf, f"{where} limit")
        _number(limit, "velocity", urdf, f"{where} limit", "0")
        if not lower < upper:
            raise _fail(urdf, f"{where} limit", f"lower {lower:g} is not below upper {upper:g} (swapped?)")
        if effort <= 0:
            raise _fail(urdf, f"{where} limit", f"effort {effort:g}: a joint's effort limit is positive")
    return UrdfJoint(name, kind, parent, child, (xyz[0], xyz[1], xyz[2]), (rpy[0], rpy[1], rpy[2]),
                     (axis[0], axis[1], axis[2]))


@functools.lru_cache(maxsize=16)
def check_urdf(urdf: Path) -> UrdfModel:
    """Parse and check the URDF file (see the module).

    Raises:
        RobotModelError: unreadable, not XML, or the first problem found.
    """
    urdf = Path(urdf)
    try:
        data = read_input(urdf, MAX_URDF_BYTES, "a URDF")
    except InputError as exc:
        raise _fail(urdf, exc.key, exc.problem) from None
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise _fail(urdf, "", "a document type or entity declaration (<!DOCTYPE, <!ENTITY): a URDF declares none, "
                    "and nothing in it is expanded")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        line, col = getattr(exc, "position", (0, 0))
        raise _fail(urdf, f"line {line}", f"not valid XML ({str(exc).split(':')[0]}, column {col})") from None
    if root.tag != "robot":
        raise _fail(urdf, "", f"the root element is <{root.tag}>, expected <robot>")
    links: dict[str, ET.Element] = {}
    for link in root.iter("link"):
        name = _attr(link, "name", urdf, "link")
        if name in links:
            raise _fail(urdf, f"link {name}", "defined twice")
        links[name] = link
    if not links:
        raise _fail(urdf, "", "no <link>")
    masses = {}
    for name, link in links.items():
        mass = _check_inertial(link, name, urdf)
        if mass is not None:
            masses[name] = mass
        _check_visuals(link, name, urdf)
    joints: list[UrdfJoint] = []
    names: set[str] = set()
    parent_of: dict[str, str] = {}
    for j in root.iter("joint"):
        joint = _check_joint(j, urdf, set(links))
        if joint.name in names:
            raise _fail(urdf, f"joint {joint.name}", "defined twice")
        if joint.child in parent_of:
            raise _fail(urdf, f"joint {joint.name}", f"link {joint.child!r} already has a parent (joint "
                        f"{parent_of[joint.child]})")
        names.add(joint.name)
        parent_of[joint.child] = joint.name
        joints.append(joint)
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        raise _fail(urdf, "", f"expected one root link, found {len(roots)} ({', '.join(roots[:4]) or 'a loop'})")
    children: dict[str, list[str]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    seen, stack = set(), [roots[0]]
    while stack:
        name = stack.pop()
        seen.add(name)
        stack.extend(c for c in children.get(name, []) if c not in seen)
    if len(seen) != len(links):
        raise _fail(urdf, "", f"links not connected to the root {roots[0]!r} (a loop?): "
                    f"{', '.join(sorted(set(links) - seen)[:4])}")
    if not masses.get(roots[0], 0.0) > 0:
        raise _fail(urdf, f"link {roots[0]} inertial mass", "the root link (the trunk) needs a positive mass")
    return UrdfModel(roots[0], masses, tuple(joints))


def urdf_joints(urdf: Path) -> tuple[UrdfJoint, ...]:
    """Every joint of the URDF file, in file order."""
    return check_urdf(Path(urdf)).joints


def geometry_boxes(urdf: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(link, origin xyz [m], half extents [m]) of every visual box and cylinder (as its bounding box)."""
    out = []
    for link in ET.parse(urdf).getroot().iter("link"):
        for vis in link.iter("visual"):
            org = vis.find("origin")
            xyz = np.array([float(v) for v in (org.get("xyz", "0 0 0") if org is not None else "0 0 0").split()])
            geom = vis.find("geometry")
            box = geom.find("box") if geom is not None else None
            cyl = geom.find("cylinder") if geom is not None else None
            if box is not None:
                half = np.array([float(v) for v in box.get("size", "0 0 0").split()]) / 2
            elif cyl is not None:
                r, ln = float(cyl.get("radius", "0")), float(cyl.get("length", "0"))
                half = np.array([r, r, ln / 2])
            else:
                continue
            out.append((str(link.get("name")), xyz, half))
    return out


@contextmanager
def quiet_stderr() -> Iterator[list[str]]:
    """Send what C and C++ code print on file descriptor 2 to a temporary file for the block; the
    list yielded holds its lines afterwards (for a message)."""
    lines: list[str] = []
    fd = 2  # what C and C++ write to, whatever Python's sys.stderr is
    try:
        saved = os.dup(fd)
    except OSError:  # no file descriptor 2 (a daemon): nothing to hide
        yield lines
        return
    with contextlib.suppress(AttributeError, ValueError, OSError):
        sys.stderr.flush()
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), fd)
        try:
            yield lines
        finally:
            with contextlib.suppress(AttributeError, ValueError, OSError):
                sys.stderr.flush()
            os.dup2(saved, fd)
            os.close(saved)
            tmp.seek(0)
            lines.extend(ln for ln in tmp.read(100_000).decode("utf-8", "replace").splitlines() if ln.strip())
