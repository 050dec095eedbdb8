"""What a path given to ``jethr1 view`` holds: its kind (a plan, a route, a walk, a balance space, a rehearsal)
from the topics of its MCAP files, and the files to show, each under its entity path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import check_belongs, rehearsal_of
from jethr1_plan.io.input_file import check_input_path

__all__ = ["ViewFiles", "kind_of", "view_files"]


@dataclass
class ViewFiles:
    """What a path holds: its kind (``plan``, ``route``, ``walk``, ``balance space``, ``rehearsal``) and the
    MCAP files to show, each with the entity path its content goes under."""

    kind: str
    files: list[tuple[Path, str]] = field(default_factory=list)


def _topics(path: Path) -> set[str]:
    """The topics of an MCAP file."""
    from mcap.reader import make_reader

    try:
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
    except Exception as exc:  # the mcap reader raises many kinds on a corrupt file
        raise InputError(str(path), "", f"not a valid MCAP file ({type(exc).__name__})") from None
    return set() if summary is None else {c.topic for c in summary.channels.values()}


def kind_of(path: Path) -> str:
    """What an MCAP file jethr1 wrote holds, by a topic only that kind of file has."""
    topics = _topics(path)
    for topic, kind in (("/thrust", "plan"), ("/walk_analysis", "walk"), ("/sim/thrust", "rehearsal"),
                        ("/balance_space/cells", "balance space"), ("/route/footsteps", "route")):
        if topic in topics:
            return kind
    raise InputError(str(path), "", "not an MCAP file jethr1 writes (no /thrust, /walk_analysis, /sim/thrust, "
                     "/balance_space/cells or /route/footsteps)")


def view_files(path: Path) -> ViewFiles:
    """The MCAP files of a plan folder (``trajectory.mcap`` and ``simulation.mcap`` if present), a route
    folder (its plan's and ``route.mcap``), a walk folder, a balance-space folder, or one of those files.

    Raises:
        InputError: no such path, or nothing jethr1 writes there.
    """
    path = Path(path)
    check_input_path(path, "a plan, route, walk or balance-space folder, or one of their MCAP files")
    if path.is_file():
        kind = kind_of(path)
        return ViewFiles(kind, [(path, "rehearsal" if kind == "rehearsal" else kind.replace(" ", "_"))])
    if not path.is_dir():
        raise InputError(str(path), "", "no such file or folder")
    if (path / "balance_space.mcap").is_file():
        return ViewFiles("balance space", [(path / "balance_space.mcap", "balance_space")])
    trajectory, route = path / "trajectory.mcap", path / "route.mcap"
    if not trajectory.is_file():
        if route.is_file():
            return ViewFiles(kind_of(route), [(route, "route")])
        raise InputError(str(path), "", "no trajectory.mcap, route.mcap or balance_space.mcap in this folder")
    kind = kind_of(trajectory)
    summary = check_belongs(path) if kind == "plan" else {}  # a plan folder is one thing: its MCAP is the one
    out = ViewFiles(kind, [(trajectory, kind)])                 # its summary.json records
    if kind == "plan" and (path / "simulation.mcap").is_file() and rehearsal_of(path, summary):
        out.files.append((path / "simulation.mcap", "rehearsal"))
    if kind == "plan" and route.is_file():
        if kind_of(route) != "route":
            raise InputError(str(route), "", "not a route.mcap jethr1 writes (no /route/footsteps)")
        out.kind = "route"
        out.files.append((route, "route"))
    return out
