"""``jethr1 verify``: an independent re-check of a written plan or walk."""

from __future__ import annotations

from pathlib import Path

import click

from jethr1_plan.cli.common import err_console, print_json
from jethr1_plan.errors import EXIT_VERIFY_FINDING

__all__ = ["verify"]


@click.command()
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--scenario", type=click.Path(dir_okay=False, path_type=Path),
              help="Also check the feet against this scenario (default: the one named in summary.json).")
@click.option("--json", "as_json", is_flag=True, help="Print the verdict as JSON on stdout.")
def verify(path: Path, scenario: Path | None, as_json: bool) -> None:
    """Re-check a trajectory (CSV, MCAP or an output folder) with PlaCo, independently of the planner.

    Exit 0 when every row holds, 5 when any fails (one line per failing row on stderr, the first 50
    failures in row order and the first of every other check; then how many rows fail in all).
    """
    from jethr1_plan.verify.folder import verify_path

    n, failures, what, checked = verify_path(path, scenario)
    if as_json:
        print_json({"file": what, "rows": n, "ok": not failures, "checked": [str(p) for p in checked],
                    "failing_rows": len(failures.rows), "failures": [f.__dict__ for f in failures]})
    by_row: dict[int, list] = {}
    for f in failures:
        by_row.setdefault(f.row, []).append(f)
    for row, fs in by_row.items():
        checks = "; ".join(f"{f.check}: {f.detail}" for f in fs)
        err_console.print(f"{what}: row {row} (t = {fs[0].time_s:.3f} s): {checks}", markup=False, soft_wrap=True)
    err_console.print(f"checked {_names(checked)}", markup=False, highlight=False, soft_wrap=True)
    if failures:
        cut = f" (the first {len(by_row)} listed)" if len(failures.rows) > len(by_row) else ""
        err_console.print(f"[red]verify: {len(failures.rows)} failing rows of {n}{cut}[/]")
        raise click.exceptions.Exit(EXIT_VERIFY_FINDING)
    err_console.print(f"[green]verify: all {n} rows of {what} hold[/]")


def _names(paths: list[Path]) -> str:
    """The files read: those of the first one's folder by name, the others (a scenario) by path."""
    folder = paths[0].parent
    here = [p.name for p in paths if p.parent == folder]
    others = [str(p) for p in paths if p.parent != folder]
    return f"{', '.join(here)} in {folder}/" + (f"; and {', '.join(others)}" if others else "")
