"""Command-line interface. Bad input: one line on stderr, exit 2. Solver failure: exit 1."""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from .errors import LeapfrogError

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2

_console = Console()
_err = Console(stderr=True)


def _write_atomic(path: Path, text: str) -> None:
    """Write through a temporary file and a rename, so readers never see half a file."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="leapfrog-planner")
def cli():
    """Optimal trajectories for mobile robots: Pontryagin's principle, shooting, Leapfrog."""


@cli.command()
@click.argument("model")
def derive(model):
    """Print the Hamiltonian, control law and canonical equations derived for MODEL."""
    from .pmp import derive as derive_system

    click.echo(derive_system(model).describe())
    return EXIT_OK


@cli.command()
@click.option(
    "--start",
    nargs=3,
    type=float,
    default=(-1.0, 2.0, float(np.pi / 2)),
    show_default=True,
    help="start state x y heading (paper case 1 by default)",
)
@click.option(
    "--goal",
    nargs=3,
    type=float,
    default=(1.0, 2.0, float(np.pi / 2)),
    show_default=True,
    help="goal state x y heading",
)
@click.option("--horizon", type=float, default=1.0, show_default=True, help="time horizon T")
@click.option(
    "--obstacle",
    "obstacles",
    nargs=3,
    type=float,
    multiple=True,
    metavar="CX CY R",
    help="a disc obstacle (repeatable)",
)
@click.option("--model", default="unicycle", show_default=True)
@click.option(
    "--method",
    type=click.Choice(["newton", "modified-newton", "nleq-err"]),
    default="modified-newton",
    show_default=True,
)
@click.option(
    "--guess",
    nargs=3,
    type=float,
    default=None,
    help="initial costate (default: affine approximation)",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="write the result as JSON",
)
def shoot(start, goal, horizon, obstacles, model, method, guess, json_path):
    """Solve one two-point problem by simple shooting (no Leapfrog)."""
    from .problem import OptimalControlProblem
    from .shooting import solve_shooting

    problem = OptimalControlProblem.create(model, list(obstacles))
    res = solve_shooting(problem, 0.0, start, horizon, goal, method=method, guess=guess)
    table = Table(title=f"simple shooting ({method})", show_header=False)
    for k, v in [
        ("status", str(res.status)),
        ("cost", f"{res.cost:.8g}"),
        ("initial costate", np.array2string(res.costate0, precision=6)),
        ("end-state error", f"{res.end_state_error:.2e}"),
        ("max |dH/du|", f"{res.max_dH_du:.2e}"),
        ("H variation", f"{res.hamiltonian_variation:.2e}"),
        ("Newton iterations", str(res.root.iterations)),
        ("F evaluations", str(res.root.f_evals)),
    ]:
        table.add_row(k, v)
    _console.print(table)
    if json_path:
        out = {
            "status": str(res.status),
            "message": res.message,
            "cost": res.cost,
            "costate0": res.costate0.tolist(),
            "end_state_error": res.end_state_error,
            "newton_iterations": res.root.iterations,
            "f_evals": res.root.f_evals,
        }
        _write_atomic(Path(json_path), json.dumps(out, indent=2))
    return EXIT_OK if res.success else EXIT_FAILED


def main(argv=None) -> None:
    """Entry point: maps errors to one line and an exit code instead of a traceback."""
    try:
        code = cli.main(args=argv, prog_name="leapfrog", standalone_mode=False)
    except click.exceptions.Abort:
        _err.print("aborted")
        sys.exit(130)
    except click.UsageError as e:
        _err.print(f"error: {e.format_message()}", highlight=False, soft_wrap=True)
        sys.exit(EXIT_BAD_INPUT)
    except click.ClickException as e:
        _err.print(f"error: {e.format_message()}", highlight=False, soft_wrap=True)
        sys.exit(EXIT_BAD_INPUT)
    except LeapfrogError as e:
        _err.print(f"error: {e}", highlight=False, soft_wrap=True)
        sys.exit(EXIT_BAD_INPUT)
    sys.exit(code if isinstance(code, int) else EXIT_OK)


if __name__ == "__main__":
    main()
