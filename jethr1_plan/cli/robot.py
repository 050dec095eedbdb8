"""``jethr1 robot show``: a robot model's mass, joints, fans and sole."""

from __future__ import annotations

import click
from rich.console import Console
from rich.table import Table

from jethr1_plan.cli.common import print_json, stdout_errors

__all__ = ["robot"]


@click.group()
def robot() -> None:
    """Robot models."""



@robot.command("show")
@click.argument("name", default="jethr1")
@click.option("--json", "as_json", is_flag=True, help="Print the model summary as JSON on stdout.")
def robot_show(name: str, as_json: bool) -> None:
    """Mass, height, leg length, joints, fans and sole of robot NAME (a name, folder or YAML path)."""
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.robot.summary import robot_summary

    summary = robot_summary(load_robot(name))
    if as_json:
        print_json(summary)
        return
    with stdout_errors():
        _print_robot(summary)


def _print_robot(summary: dict) -> None:
    out = Console()
    out.print(f"[bold]{summary['name']}[/]  {summary['urdf']}")
    out.print(f"mass {summary['mass_kg']:.3f} kg   height {summary['height_m']:.3f} m   "
              f"leg {summary['leg_length_m']:.3f} m   hip width {summary['hip_width_m']:.3f} m   "
              f"sole {summary['sole']['length_m']:.3f} x {summary['sole']['width_m']:.3f} m")
    t = Table(title="joints")
    for col in ("joint", "lower [rad]", "upper [rad]", "effort [N·m]", "servo limit [N·m]"):
        t.add_column(col, justify="right" if col != "joint" else "left")
    for j in summary["joints"]:
        t.add_row(j["name"], f"{j['lower_rad']:+.3f}", f"{j['upper_rad']:+.3f}", f"{j['effort_nm']:.3f}",
                  f"{j['servo_limit_nm']:.3f}")
    out.print(t)
    f = Table(title="fans")
    for col in ("fan", "frame", "on", "max thrust [N]", "offset in its mount [m]"):
        f.add_column(col)
    for fan in summary["fans"]:
        f.add_row(fan["name"], fan["frame"], fan["mount"], f"{fan['thrust_max_n']:.1f}",
                  ", ".join(f"{v:+.3f}" for v in fan["offset_m"]))
    out.print(f)
    sensors = [name for name in ("imu", "encoders", "soles") if summary["sensors"][name] is not None]
    out.print(f"sensors: {', '.join(sensors) or 'none declared'}; feedback law: {summary['feedback_law'] or 'none'}"
              + (f"; measured landing error {1000 * summary['landing_error_m']:.1f} mm"
                 if summary["landing_error_m"] is not None else ""))

