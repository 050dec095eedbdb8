"""``jethr1 view``: a plan, a route, a walk or a balance space in Rerun (the optional extra ``view``)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

__all__ = ["view_cmd"]


@click.command("view")
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--save", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the recording to this .rrd file instead of opening a viewer (no display needed).")
def view_cmd(path: Path, save: Path | None) -> None:
    """Show a plan folder (with its rehearsal, if simulated), a route folder (its plan and route.mcap), a walk
    folder or a balance-space folder, or one of their MCAP files, in Rerun: the robot moving, the terrain, the
    swing paths, footholds and footsteps, point clouds, thrust, window and ZMP margin as plots.

    Needs the optional extra: pip install 'jethr1-plan[view]'. Exit 2 on bad input, without it, or without a
    display and --save.
    """
    from jethr1_plan.errors import InputError
    from jethr1_plan.viewer.show import view
    from jethr1_plan.viewer.topics import ViewerMissing

    if save is not None and save.suffix != ".rrd":
        raise InputError(str(save), "--save", "expected a .rrd file name")
    try:
        if save is None:
            message = view(path, None)
        else:  # written as every output is (io.atomic): staged, then committed; a folder made where missing
            from jethr1_plan.io.atomic import staged_directory
            from jethr1_plan.io.record import check_writable

            check_writable(save.parent, writes=(save.name,))
            with staged_directory(save.parent, frozenset({save.name})) as staging:
                staged = staging.path / save.name
                message = view(path, staged).replace(str(staged), str(save))
    except ViewerMissing as exc:
        print(exc, file=sys.stderr)
        raise click.exceptions.Exit(2) from None
    print(message, file=sys.stderr)
