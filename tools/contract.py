"""Write docs/contract.md from the code: the commands and their options, the exit codes, every file's
columns and topics. ``tests/test_contract.py`` fails when the page and the code disagree.

    python tools/contract.py            # rewrite docs/contract.md
    python tools/contract.py --check    # exit 1 if it is out of date
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "contract.md"
#: an option without a default (click 8.3 and later; None before): the page reads the same on every click
NO_DEFAULT = getattr(click.core, "UNSET", None)

UNITS = {"_m": "m", "_rad": "rad", "_n": "N", "_nm": "N·m", "_nms": "N·m·s", "_s": "s", "_rad_s": "rad/s",
         "_rad_s2": "rad/s²", "_kg": "kg", "_j": "J", "_hz": "Hz", "_ns": "N·s"}


def unit_of(name: str) -> str:
    """The unit a column's suffix states ('' where it has none)."""
    for suffix, unit in sorted(UNITS.items(), key=lambda kv: -len(kv[0])):
        if name.endswith(suffix):
            return unit
    return ""


def commands_section() -> list[str]:
    from jethr1_plan.cli import main

    out = ["## Commands", "",
           "Every command prints progress and messages on stderr; `--json` prints one JSON document on stdout.", ""]

    def walk(cmd: click.Command, path: list[str]) -> None:
        if isinstance(cmd, click.Group):
            ctx = click.Context(cmd)
            for name in sorted(cmd.list_commands(ctx)):
                sub = cmd.get_command(ctx, name)
                assert sub is not None
                walk(sub, [*path, name])
            return
        ctx = click.Context(cmd, info_name=" ".join(path))
        out.append(f"### `{' '.join(path)}`")
        out.append("")
        out.append(f"`{ctx.command_path} {' '.join(cmd.collect_usage_pieces(ctx))}`")
        out.append("")
        # the first paragraph of the help, its lines joined: the same on every Python (3.13 dedents docstrings)
        out.append(" ".join(inspect.cleandoc(cmd.help or "").split("\n\n")[0].split()))
        out.append("")
        rows = []
        for p in cmd.get_params(ctx):
            if not isinstance(p, click.Option) or p.hidden or "--help" in p.opts:
                continue
            names = ", ".join(f"`{o}`" for o in [*p.opts, *p.secondary_opts])
            no_default = p.default is NO_DEFAULT or p.default in (None, False, ()) or p.is_flag
            default = "" if no_default else f" (default {p.default})"
            rows.append(f"| {names} | {(p.help or '').replace('|', '/')}{default} |")
        if rows:
            out.extend(["| option | meaning |", "|---|---|", *rows, ""])

    walk(main, ["jethr1"])
    return out


def exit_codes_section() -> list[str]:
    from jethr1_plan.errors import EXIT_CODES

    return ["## Exit codes", "", "| code | meaning |", "|---|---|",
            *(f"| {code} | {meaning} |" for code, meaning in EXIT_CODES.items()), ""]


def columns_table(names: list[str]) -> list[str]:
    return ["| column | unit |", "|---|---|", *(f"| `{n}` | {unit_of(n)} |" for n in names), ""]


def files_section() -> list[str]:
    from jethr1_plan.balance_space.sweep import SweepResult  # noqa: F401  (the balance space's files need it)
    from jethr1_plan.files.balance_space import BALANCE_SPACE_COLUMNS, BALANCE_SPACE_TOPICS
    from jethr1_plan.files.plan_folder import DIGESTS_KEY, PLAN_FILES
    from jethr1_plan.files.plan_mcap import PLAN_TOPICS
    from jethr1_plan.files.plan_steps import OPTIMISED_STEPS
    from jethr1_plan.files.plan_table import columns
    from jethr1_plan.files.route import ROUTE_FILES, ROUTE_TOPICS
    from jethr1_plan.files.simulation import SIMULATION_TOPICS
    from jethr1_plan.files.walk_folder import WALK_FILES, WALK_TOPICS, walk_columns
    from jethr1_plan.io.record import RECORD
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.studies.design_report import COLUMNS as DESIGN_COLUMNS
    from jethr1_plan.studies.design_report import OWN_FILES as DESIGN_FILES

    jethr1, dyros = load_robot("jethr1"), load_robot("dyros_jet_like")
    out = ["## Files", "",
           "Columns are shown for the robots shipped (`<joint>` columns follow the robot's URDF joint names in order, "
           "`<fan>` columns its fans' names). Quaternions are x, y, z, w. Times are seconds from the start; MCAP "
           "messages are logged at 2000-01-01T00:00:00Z plus that time.", "",
           f"Every folder jethr1 writes into holds `{RECORD}`: each file jethr1 wrote there, its size and SHA-256. "
           "A command replaces or removes only a file that record names and that is unchanged; any other file of an "
           "output's name (a user's, an input, a link, a FIFO, a device, a folder) is refused in one line, exit 2, "
           "nothing written (docs/safety.md).", "",
           "### Plan folder (`plan`, `batch`, `route`)", "",
           "Files: " + ", ".join(f"`{f}`" for f in sorted(PLAN_FILES)) + ".", "",
           f"`summary.json` records `{DIGESTS_KEY}`: the size and SHA-256 of `trajectory.csv` and `trajectory.mcap`; "
           "`simulate`, `verify`, `view` and `replan-steps` refuse a folder whose files are not those (and a "
           f"`summary.json` other than the one `{RECORD}` names). `simulation.json` records the same digests of the "
           "plan it rehearsed (`plan_files`).", "",
           f"`{OPTIMISED_STEPS}` (a feasible plan's, written by `plan`, `batch` and `replan-steps`, not by `route`; "
           "`jethr1_plan/files/plan_steps.py`): each step's swing "
           "samples as the planner optimised them (the trunk position, posture, CoM, thrust and its split, ZMP, "
           "tolerance share of each sample), numbers that read back to the bit, bound to the folder's "
           "`trajectory.csv` (`trajectory_sha256`) and keyed (`key`) by the SHA-256 of the scenario's text, its "
           "balance policy and timing mode, the robot YAML and URDF, the optimiser and the seed. `simulate` of a "
           "plan of several steps executes these steps; where the file is missing, of another key or trajectory, "
           "changed since written or unreadable, it says so in one line and optimises the steps again.", "",
           "#### `trajectory.csv` (Jet-HR1)", "", *columns_table(columns(jethr1)),
           "#### `trajectory.mcap`", "", *topics_table(PLAN_TOPICS),
           "#### `simulation.mcap` (`simulate`)", "", *topics_table(SIMULATION_TOPICS),
           "### Route files (`route`, beside its plan folder's files)", "",
           "Files: " + ", ".join(f"`{f}`" for f in sorted(ROUTE_FILES)) + ".", "",
           "#### `route.mcap`", "", *topics_table(ROUTE_TOPICS),
           "### Walk folder (`walk`)", "",
           "Files: " + ", ".join(f"`{f}`" for f in sorted(WALK_FILES)) + ".", "",
           "#### `trajectory.csv` (Dyros-Jet-like)", "", *columns_table(walk_columns(dyros)),
           "#### `trajectory.mcap`", "", *topics_table(WALK_TOPICS),
           "### Balance space (`balance-space`)", "",
           "#### `balance_space.csv`", "", *columns_table(list(BALANCE_SPACE_COLUMNS)),
           "#### `balance_space.mcap`", "", *topics_table(BALANCE_SPACE_TOPICS),
           "### Design sweep (`design`)", "",
           "Files: " + ", ".join(f"`{f}`" for f in sorted(DESIGN_FILES)) + ", and the best variants as robot "
           "folders `robots/<name>/` with their crossings `scenarios/<name>_ditch_whole.yaml`.", "",
           "#### `design.csv` (one row per variant; `<axis>`: a column per axis of the design file)", "",
           *columns_table(["variant", "<axis>", *DESIGN_COLUMNS])]
    return out


def topics_table(topics: dict) -> list[str]:
    return ["| topic | type | latched | what |", "|---|---|---|---|",
            *(f"| `{name}` | `{t.type}` | {'yes' if t.latched else 'no'} | {t.what} |" for name, t in topics.items()),
            ""]


def page() -> str:
    head = ["# The contract: commands, exit codes, files", "",
            "What users and scripts rely on, written from the code by `tools/contract.py` (a test fails when the two "
            "disagree). Change any of it only on purpose.", ""]
    return "\n".join([*head, *exit_codes_section(), *files_section(), *commands_section()]).rstrip() + "\n"


def main(argv: list[str]) -> int:
    text = page()
    if "--check" in argv:
        current = PAGE.read_text(encoding="utf-8") if PAGE.is_file() else ""
        if current != text:
            print(f"{PAGE} is out of date: run python tools/contract.py")
            return 1
        return 0
    PAGE.write_text(text, encoding="utf-8")
    print(f"wrote {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
