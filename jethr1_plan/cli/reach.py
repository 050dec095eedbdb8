"""``jethr1 reach``: Paper B's step-length analysis and the robot's numerical reach."""

from __future__ import annotations

import math

import click
from rich.console import Console

from jethr1_plan.cli.common import FiniteFloat, print_json, stdout_errors
from jethr1_plan.errors import InputError

__all__ = ["reach_cmd"]


@click.command("reach")
@click.option("--robot", "robot_name", default="jethr1", show_default=True,
              help="Read l_leg, l_pel from this model (unless given) and search its reach numerically.")
@click.option("--l-leg", type=FiniteFloat(0, 100, lo_open=True), help="Leg length [m] (hip joint to sole).")
@click.option("--z0", type=FiniteFloat(0, 100, lo_open=True), help="Hip height over the soles [m].")
@click.option("--l-pel", type=FiniteFloat(0, 100), help="Pelvis width between the hip joints [m].")
@click.option("--w-step", type=FiniteFloat(0, 100), help="Lateral distance between the feet [m].")
@click.option("--theta-pel-deg", default=45.0, show_default=True, type=FiniteFloat(0, 90),
              help="Pelvic yaw [deg].")
@click.option("--dyros-jet", is_flag=True, help="Use Paper B's Dyros-Jet figures (0.75, 0.68, 0.21, 0.243 m, 45 deg).")
@click.option("--json", "as_json", is_flag=True)
def reach_cmd(robot_name, l_leg, z0, l_pel, w_step, theta_pel_deg, dyros_jet, as_json) -> None:
    """Paper B's step-length analysis (B-1..B-5), and the robot's numerical reach with PlaCo IK."""
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.studies.reach import DYROS_JET, ReachFigures, discrepancy_note, numerical_reach, step_lengths

    numeric = None
    if dyros_jet:
        fig = ReachFigures(**DYROS_JET)
    else:
        robot = load_robot(robot_name)
        leg = l_leg or robot.leg_length_m
        fig = ReachFigures(l_leg=leg, z0=z0 or 0.9 * leg, l_pel=l_pel if l_pel is not None else 2 * robot.hip_offset_m,
                           w_step=w_step if w_step is not None else 0.225, theta_pel_deg=theta_pel_deg)
        if fig.z0 > fig.l_leg:
            raise InputError("--z0", f"{fig.z0}", f"higher than the leg ({fig.l_leg} m)")
        if l_leg is None:
            numeric = {name: numerical_reach(robot_name, fig.z0, fig.w_step, math.radians(yaw))
                       for name, yaw in (("fixed", 0.0), ("turned", -theta_pel_deg))}
    out = {"inputs": fig.__dict__, **step_lengths(fig)}
    out["note"] = discrepancy_note(out) if dyros_jet else None
    if numeric is not None:
        out["numerical"] = numeric
    if as_json:
        print_json(out)
        return
    with stdout_errors():
        _print_reach(out, fig, numeric)


def _print_reach(out: dict, fig, numeric: dict | None) -> None:
    c = Console()
    c.print(f"(B-1) standing, pelvis fixed:    {out['standing_fixed_m']:.4f} m")
    c.print(f"(B-3) kinematic limit:           {out['kinematic_limit_m']:.4f} m")
    c.print(f"(B-4) static, pelvis fixed:      {out['fixed_m']:.4f} m")
    c.print(f"(B-5) static, pelvis turned {fig.theta_pel_deg:g}°: {out['rotating_m']:.4f} m (+{out['gain_pct']:.0f} %)")
    if out["note"]:
        c.print(out["note"])
    for name, n in (numeric or {}).items():
        c.print(f"numerical reach, pelvis {name}: {n['step_m']:.3f} m (PlaCo IK converged: {n['placo_converged']})")

