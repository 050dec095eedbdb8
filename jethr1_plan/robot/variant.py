"""A robot variant: a base robot folder with other fans and, optionally, a heavier trunk or longer legs,
written as a robot folder of its own (URDF and YAML) that loads through the same checks as any robot.

What a variant changes (SI units):

* **Fans.** Every fan of the base is removed (its link, which must be a leaf fixed to its mount, and its
  entry in the YAML) and the variant's fans are added: each a link ``<name>_fan`` fixed to its mount frame (a
  sole frame or the trunk) at ``offset_m`` in that frame, with the fan's mass as a solid cylinder (the duct:
  radius r, length 2r) centred on the thrust point. A fixed joint merges the link into its mount's body, so
  the fan's mass moves the CoM exactly as mass added to the mount link with the fan's inertia would.
* **Trunk mass.** The trunk link's mass and inertia tensor times ``trunk_mass_scale``.
* **Leg length.** Each leg's knee and ankle-pitch joint origins times ``leg_length_scale`` (thigh and shank
  longer or shorter); the two links between them keep their masses, their inertial origins, visuals and the
  extent of their boxes along the leg are scaled with them, and their inertia tensors by the scale squared (a
  rod of the same mass). The hip joints and the ankle-to-sole offset do not change.

Everything else (joints, limits, servos, sole, controller, twin) is the base's. The files are text made only
from the base's bytes and the design, so the same design gives the same bytes.
"""

from __future__ import annotations

import copy
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import yaml

from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.schema import read_robot_yaml
from jethr1_plan.robot.urdf import MAX_URDF_BYTES

__all__ = ["DUCT_RADIUS_M", "FanDesign", "VariantDesign", "fan_inertia", "variant_files"]

DUCT_RADIUS_M = 0.035  # a 70 mm ducted fan (Jet-HR1's)


@dataclass(frozen=True)
class FanDesign:
    """One fan of a variant: its thrust point ``offset_m`` [m] in the ``mount`` frame (a sole frame or the trunk),
    its maximum thrust [N], its mass [kg] (the whole fan unit: duct, motor, mount), its first-order lag [s]
    and its duct's radius [m] (the inertia and the visual)."""

    name: str
    mount: str
    offset_m: tuple[float, float, float]
    thrust_max_n: float
    mass_kg: float
    lag_s: float = 0.05
    radius_m: float = DUCT_RADIUS_M


@dataclass(frozen=True)
class VariantDesign:
    """A variant of a base robot: its fans (all of them: the base's are replaced) and two scales."""

    fans: tuple[FanDesign, ...]
    trunk_mass_scale: float = 1.0
    leg_length_scale: float = 1.0


def fan_inertia(mass_kg: float, radius_m: float) -> tuple[float, float, float]:
    """(Ixx, Iyy, Izz) [kg·m²] of a solid cylinder of radius r and length 2r about its centre, axis z:
    Ixx = Iyy = m(3r² + (2r)²)/12, Izz = m r²/2."""
    r = radius_m
    side = mass_kg * (3 * r * r + 4 * r * r) / 12.0
    return side, side, mass_kg * r * r / 2.0


def _num(x: float) -> str:
    """A number's shortest round-tripping text (0 as "0")."""
    x = float(x)
    return "0" if x == 0 else repr(x)


def _nums(values) -> str:
    return " ".join(_num(v) for v in values)


def _floats(text: str | None, default: str = "0 0 0") -> list[float]:
    return [float(v) for v in (text if text is not None else default).split()]


def _scale_inertial(link: ET.Element, mass_factor: float, inertia_factor: float, origin_factor: float = 1.0) -> None:
    inertial = link.find("inertial")
    if inertial is None:
        return
    mass = inertial.find("mass")
    if mass is not None and mass_factor != 1.0:
        mass.set("value", _num(float(mass.get("value", "0")) * mass_factor))
    inertia = inertial.find("inertia")
    if inertia is not None and inertia_factor != 1.0:
        for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            if inertia.get(k) is not None:
                inertia.set(k, _num(float(inertia.get(k, "0")) * inertia_factor))
    origin = inertial.find("origin")
    if origin is not None and origin_factor != 1.0:
        origin.set("xyz", _nums(v * origin_factor for v in _floats(origin.get("xyz"))))


def _scale_geometry(link: ET.Element, factor: float, along: int) -> None:
    """Visual and collision origins times ``factor``; boxes' extent along axis ``along`` (0 x, 1 y, 2 z) and
    cylinders' length (along z) too."""
    for tag in ("visual", "collision"):
        for el in link.iter(tag):
            origin = el.find("origin")
            if origin is not None:
                origin.set("xyz", _nums(v * factor for v in _floats(origin.get("xyz"))))
            geom = el.find("geometry")
            box = geom.find("box") if geom is not None else None
            cyl = geom.find("cylinder") if geom is not None else None
            if box is not None:
                size = _floats(box.get("size"), "0 0 0")
                size[along] *= factor
                box.set("size", _nums(size))
            if cyl is not None and along == 2:
                cyl.set("length", _num(float(cyl.get("length", "0")) * factor))


def _joint_named(root: ET.Element, name: str, src: str, key: str) -> ET.Element:
    for j in root.iter("joint"):
        if j.get("name") == name:
            return j
    raise RobotModelError(src, key, f"no joint {name!r} in the URDF")


def _child_of(joint: ET.Element) -> str:
    child = joint.find("child")
    return "" if child is None else child.get("link", "")


def _remove_fan(root: ET.Element, frame: str, src: str, key: str) -> None:
    """Remove the base fan's link ``frame`` and the fixed joint that holds it (it must be a leaf)."""
    links = [link for link in root.findall("link") if link.get("name") == frame]
    holders = [j for j in root.findall("joint") if _child_of(j) == frame]
    carried = [j for j in root.findall("joint") if (j.find("parent") is not None
                                                     and j.find("parent").get("link") == frame)]  # type: ignore[union-attr]
    if len(links) != 1 or len(holders) != 1 or holders[0].get("type") != "fixed" or carried:
        raise RobotModelError(src, key, f"the fan's frame {frame!r} is not a link of its own fixed to its mount with "
                              "nothing on it: a design cannot remove it")
    root.remove(links[0])
    root.remove(holders[0])


def _fan_elements(fan: FanDesign) -> tuple[ET.Element, ET.Element]:
    """The link ``<name>_fan`` (mass, inertia, a cylinder) and its fixed joint to the mount."""
    link = ET.Element("link", {"name": f"{fan.name}_fan"})
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", {"xyz": "0 0 0", "rpy": "0 0 0"})
    ET.SubElement(inertial, "mass", {"value": _num(fan.mass_kg)})
    ixx, iyy, izz = fan_inertia(fan.mass_kg, fan.radius_m)
    ET.SubElement(inertial, "inertia", {"ixx": _num(ixx), "ixy": "0", "ixz": "0", "iyy": _num(iyy), "iyz": "0",
                                        "izz": _num(izz)})
    for tag in ("visual", "collision"):
        el = ET.SubElement(link, tag)
        ET.SubElement(el, "origin", {"xyz": "0 0 0", "rpy": "0 0 0"})
        geom = ET.SubElement(el, "geometry")
        ET.SubElement(geom, "cylinder", {"radius": _num(fan.radius_m), "length": _num(2 * fan.radius_m)})
    joint = ET.Element("joint", {"name": f"{fan.name}_fan_fixed", "type": "fixed"})
    ET.SubElement(joint, "parent", {"link": fan.mount})
    ET.SubElement(joint, "child", {"link": f"{fan.name}_fan"})
    ET.SubElement(joint, "origin", {"xyz": _nums(fan.offset_m), "rpy": "0 0 0"})
    return link, joint


def _scale_legs(root: ET.Element, doc: dict, factor: float, src: str) -> None:
    """Knee and ankle-pitch joint origins times ``factor``; the thigh and shank links with them."""
    for side in ("left", "right"):
        roles = doc["legs"][side]["joints"]
        for upper_joint, lower_joint in (("hip_pitch", "knee"), ("knee", "ankle_pitch")):
            top = _joint_named(root, roles[upper_joint], src, f"legs.{side}.joints.{upper_joint}")
            end = _joint_named(root, roles[lower_joint], src, f"legs.{side}.joints.{lower_joint}")
            origin = end.find("origin")
            if origin is None:
                origin = ET.SubElement(end, "origin", {"xyz": "0 0 0", "rpy": "0 0 0"})
            xyz = _floats(origin.get("xyz"))
            origin.set("xyz", _nums(v * factor for v in xyz))
            along = max(range(3), key=lambda k: abs(xyz[k]))
            link = next((lk for lk in root.findall("link") if lk.get("name") == _child_of(top)), None)
            if link is not None:
                _scale_inertial(link, 1.0, factor * factor, factor)
                _scale_geometry(link, factor, along)


def variant_files(base_yaml: Path, design: VariantDesign, name: str, description: str = "") -> dict[str, bytes]:
    """The files of the variant ``design`` of the robot whose YAML is ``base_yaml``: ``{name}.urdf`` and
    ``{name}.yaml`` (their bytes). ``description`` goes into the YAML's description.

    Raises:
        RobotModelError: the base cannot be varied (a fan that is not a leaf link, a mount that is not a sole
            frame or the trunk, a fan name taken by another link; exit 2).
    """
    src = str(base_yaml)
    doc = read_robot_yaml(base_yaml)
    urdf_path = Path(base_yaml).parent / doc["urdf"]
    try:
        data = urdf_path.read_bytes()
    except OSError as exc:
        raise RobotModelError(src, "urdf", f"cannot read {urdf_path}: {exc.strerror or exc}") from None
    if len(data) > MAX_URDF_BYTES:
        raise RobotModelError(str(urdf_path), "", f"larger than {MAX_URDF_BYTES:,} bytes")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise RobotModelError(str(urdf_path), "", f"not valid XML ({exc})") from None
    if root.find(".//mesh") is not None:
        raise RobotModelError(str(urdf_path), "", "a URDF with mesh files: a design variant is written without "
                              "the base's folder, so only boxes, cylinders and spheres can be varied")
    root = copy.deepcopy(root)
    for k, fan in enumerate(doc.get("fans", [])):
        _remove_fan(root, fan["frame"], src, f"fans[{k}].frame")
    mounts = {doc["legs"][s]["sole"] for s in ("left", "right")} | {doc["trunk"]}
    names = {lk.get("name") for lk in root.findall("link")}
    for k, fan in enumerate(design.fans):
        if fan.mount not in mounts:
            raise RobotModelError(src, f"fans[{k}].mount", f"{fan.mount!r}: expected a sole frame or the trunk "
                                  f"({', '.join(sorted(mounts))})")
        if f"{fan.name}_fan" in names:
            raise RobotModelError(src, f"fans[{k}].name", f"the link {fan.name}_fan exists in the URDF already")
        if not (math.isfinite(fan.mass_kg) and fan.mass_kg > 0):
            raise RobotModelError(src, f"fans[{k}].mass", f"{fan.mass_kg:g} kg: a fan's mass is positive")
        link, joint = _fan_elements(fan)
        root.append(link)
        root.append(joint)
        names.add(f"{fan.name}_fan")
    if design.trunk_mass_scale != 1.0:
        trunk = next((lk for lk in root.findall("link") if lk.get("name") == doc["trunk"]), None)
        if trunk is None:
            raise RobotModelError(src, "trunk", f"no link {doc['trunk']!r} in the URDF")
        _scale_inertial(trunk, design.trunk_mass_scale, design.trunk_mass_scale)
    if design.leg_length_scale != 1.0:
        _scale_legs(root, doc, design.leg_length_scale, src)
    root.set("name", name)
    for el in root.iter():  # one layout, whatever the base's
        el.text = None
        el.tail = None
    ET.indent(root, "  ")
    urdf_text = (f'<?xml version="1.0"?>\n<!-- A design variant of {urdf_path.name} written by jethr1 design. -->\n'
                 + ET.tostring(root, encoding="unicode") + "\n")
    out = dict(doc)
    out["urdf"] = f"{name}.urdf"
    if description:
        out["description"] = description
    out["fans"] = [{"name": f.name, "frame": f"{f.name}_fan", "mount": f.mount, "axis": [0.0, 0.0, 1.0],
                    "thrust_max_n": float(f.thrust_max_n), "lag_s": float(f.lag_s)} for f in design.fans]
    yaml_text = yaml.safe_dump(out, sort_keys=False, allow_unicode=True, width=100)
    return {f"{name}.urdf": urdf_text.encode(), f"{name}.yaml": yaml_text.encode()}
