"""``jethr1 terrain``: terrain files for ``jethr1 route`` (``terrain random``: seeded carton fields)."""

from __future__ import annotations

from pathlib import Path

import click

from jethr1_plan.cli.common import SEED, FiniteFloat, err_console, stdout_errors
from jethr1_plan.errors import InputError

__all__ = ["terrain"]


@click.group("terrain")
def terrain() -> None:
    """Terrain files for jethr1 route."""


def _gaps(text: str) -> tuple[float, float]:
    parts = text.split(":")
    try:
        lo, hi = (float(v) for v in parts)
    except ValueError:
        raise InputError("--gaps", text, "expected LOW:HIGH, two numbers [m]") from None
    if not (0.0 <= lo <= hi <= 1.0):
        raise InputError("--gaps", text, "expected 0 <= LOW <= HIGH <= 1 [m]")
    return lo, hi


@terrain.command("random")
@click.option("--seed", type=SEED, required=True, help="The seed: the same seed (and options) gives the same file.")
@click.option("--cartons", type=click.IntRange(1, 60), default=4, show_default=True,
              help="Cartons between the start and the goal.")
@click.option("--gaps", default="0.05:0.15", show_default=True, metavar="LOW:HIGH",
              help="Widths of the ditches between rows of cartons [m].")
@click.option("--heights", type=FiniteFloat(0.0, 0.1), default=0.04, show_default=True,
              help="Largest change of carton height from one row to the next [m].")
@click.option("--side", type=FiniteFloat(0.0, 0.3), default=0.08, show_default=True,
              help="Largest sideways offset of a carton in its row [m].")
@click.option("--policy", type=click.Choice(["robust", "minimal"]), default="robust", show_default=True,
              help="The terrain's balance policy.")
@click.option("--sole-margin", type=FiniteFloat(0.0, 0.04), default=0.005, show_default=True,
              help="The terrain's balance.sole_margin_m: the ZMP this far inside the support sole [m].")
@click.option("-o", "--output", "output", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="Write the terrain here (default: stdout).")
def random_cmd(seed: int, cartons: int, gaps: str, heights: float, side: float, policy: str, sole_margin: float,
               output: Path | None) -> None:
    """A seeded random carton field: rows of cartons across ditches, with side offsets and height changes."""
    from jethr1_plan.io.atomic import write_text_atomic
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.route.terrain import random_terrain

    text = random_terrain(seed, cartons, _gaps(gaps), heights, side, policy, sole_margin_m=sole_margin)
    if output is None:
        with stdout_errors():
            click.echo(text, nl=False)
        return
    check_writable(Path(output).parent, writes=(Path(output).name,))
    write_text_atomic(output, text)
    err_console.print(f"wrote {output}", markup=False, highlight=False)
