"""Robots made on the fly from robots/jethr1/ (data only): every link, joint and fan renamed."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import yaml

from tests.conftest import ROOT


def renamed_jethr1(folder: Path, rename: Callable[[str], str], fan_names: dict[str, str] | None = None) -> Path:
    """A copy of robots/jethr1/ in ``folder`` whose URDF links and joints are all renamed by
    ``rename`` (the robot YAML follows); returns the robot YAML's path."""
    src = ROOT / "robots" / "jethr1"
    folder.mkdir(parents=True, exist_ok=True)
    tree = ET.parse(src / "jethr1.urdf")
    root = tree.getroot()
    for link in root.iter("link"):
        link.set("name", rename(link.get("name")))
    for joint in root.iter("joint"):
        joint.set("name", rename(joint.get("name")))
        for tag in ("parent", "child"):
            el = joint.find(tag)
            el.set("link", rename(el.get("link")))
    tree.write(folder / "robot.urdf")
    doc = yaml.safe_load((src / "jethr1.yaml").read_text())
    doc["urdf"] = "robot.urdf"
    doc["trunk"] = rename(doc["trunk"])
    for leg in doc["legs"].values():
        leg["sole"] = rename(leg["sole"])
        leg["joints"] = {role: rename(name) for role, name in leg["joints"].items()}
    for fan in doc["fans"]:
        fan["frame"], fan["mount"] = rename(fan["frame"]), rename(fan["mount"])
        if fan_names:
            fan["name"] = fan_names[fan["name"]]
    imu = (doc.get("sensors") or {}).get("imu")
    if imu and "frame" in imu:
        imu["frame"] = rename(imu["frame"])
    path = folder / f"{folder.name}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def copy_scenario(name: str, folder: Path, robot_yaml: Path) -> Path:
    """``configs/<name>.yaml`` with ``robot:`` pointing at ``robot_yaml``."""
    doc = yaml.safe_load((ROOT / "configs" / f"{name}.yaml").read_text())
    doc["robot"] = str(robot_yaml)
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    shutil.copymode(ROOT / "configs" / f"{name}.yaml", path)
    return path


def tampered_jethr1(folder: Path, yaml_edit: Callable[[dict], None] | None = None,
                    urdf_edit: Callable[[str], str] | None = None) -> Path:
    """A copy of robots/jethr1/ in ``folder`` with its YAML (as a dict) and URDF (as text) edited;
    returns the robot YAML's path."""
    src = ROOT / "robots" / "jethr1"
    folder.mkdir(parents=True, exist_ok=True)
    urdf = (src / "jethr1.urdf").read_text()
    (folder / "jethr1.urdf").write_text(urdf_edit(urdf) if urdf_edit else urdf)
    doc = yaml.safe_load((src / "jethr1.yaml").read_text())
    if yaml_edit:
        yaml_edit(doc)
    path = folder / f"{folder.name}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def urdf_attribute(urdf: str, element: str, name: str, tag: str, attribute: str, value: str) -> str:
    """``urdf`` with the ``attribute`` of the first ``<tag>`` inside ``<element name="name">`` set to ``value``."""
    import re

    m = re.search(rf'<{element} name="{name}".*?<{tag}\b[^>]*?\b{attribute}="([^"]*)"', urdf, re.S)
    assert m, (element, name, tag, attribute)
    return urdf[:m.start(1)] + value + urdf[m.end(1):]
