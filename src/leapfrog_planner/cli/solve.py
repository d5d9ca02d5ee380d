"""Commands on one problem: ``solve`` (Leapfrog on a scenario), ``shoot`` (one simple
shooting), ``derive`` (the Pontryagin equations of a model) and ``scenarios`` (the built-ins)."""

from __future__ import annotations

import json
import math
import shlex
import sys
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._atomic import write_text_atomic
from .common import (
    EXIT_FAILED,
    EXIT_OK,
    console,
    distinct_outputs,
    err,
    figure_options,
    option_items,
    output_path,
    planner_options,
    write_output,
)
from .warmup import ensure_compiled


@click.command()
@click.argument("model")
def derive(model):
    """Print the Hamiltonian, control law and canonical equations derived for MODEL, a
    built-in vehicle model: unicycle, diff-drive or car."""
    from ..model.pmp import derive as derive_system

    click.echo(derive_system(model).describe())
    return EXIT_OK


@click.command()
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
    default=None,
    help="write the result as JSON",
)
def shoot(start, goal, horizon, obstacles, model, method, guess, json_path):
    """Solve one two-point problem by simple shooting (no Leapfrog)."""
    from .. import checks
    from ..bvp.shooting import solve_shooting
    from ..errors import ScenarioError
    from ..planning.scenario import Scenario

    json_out = output_path(json_path, "--json")
    # The same checks as a scenario file's (bounds, a start inside an obstacle).
    sc = Scenario(
        name="shoot",
        horizon=horizon,
        start=start,
        goal=goal,
        obstacles=np.array(obstacles, dtype=float).reshape(-1, 3),
        model=model,
        source="options",
    )
    if guess is not None:
        guess = checks.vector(guess, 3, "options: --guess", error=ScenarioError)
    problem = sc.problem()
    res = solve_shooting(problem, 0.0, sc.start, sc.horizon, sc.goal, method=method, guess=guess)
    clearance = _shot_clearance(problem, sc, res)
    status = str(res.status)
    if res.success and clearance is not None and clearance < 0.0:  # never a success
        status = "collides"
    table = Table(title=f"simple shooting ({method})", show_header=False)
    for k, v in [
        (
            "status",
            status
            if status != "collides"
            else f"collides: the extremal passes through an obstacle (clearance {clearance:.4g})",
        ),
        ("cost", f"{res.cost:.8g}"),
        ("clearance", "n/a (no obstacles)" if clearance is None else f"{clearance:.4g}"),
        ("initial costate", np.array2string(res.costate0, precision=6)),
        ("end-state error", f"{res.end_state_error:.2e}"),
        ("max |dH/du|", f"{res.max_dH_du:.2e}"),
        ("H variation", f"{res.hamiltonian_variation:.2e}"),
        ("Newton iterations", str(res.root.iterations)),
        ("F evaluations", str(res.root.f_evals)),
    ]:
        table.add_row(k, v)
    console.print(table)
    if json_out:
        out = {
            "status": status,
            "message": res.message
            if status != "collides"
            else f"the extremal passes through an obstacle; {res.message}",
            "cost": res.cost,
            "min_clearance": clearance,
            "costate0": res.costate0.tolist(),
            "end_state_error": res.end_state_error,
            "newton_iterations": res.root.iterations,
            "f_evals": res.root.f_evals,
        }
        text = json.dumps(out, indent=2)
        write_output(lambda p: write_text_atomic(p, text), json_out, "--json")
    if status != "converged":
        err.print(
            "hint: simple shooting converges only from a good initial costate (--guess), to"
            " the extremal nearest it, through an obstacle or not; `leapfrog solve` (Leapfrog)"
            " starts from feasible paths round the obstacles instead",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    return EXIT_OK if status == "converged" else EXIT_FAILED


def _shot_clearance(problem, sc, res) -> float | None:
    """The least clearance of the extremal ``res`` found by shooting ``sc``, re-integrated and
    sampled as a plan's answer is (None without obstacles, nan where it did not converge)."""
    from ..planning.results import validate

    if not len(sc.obstacles):
        return None
    if not res.success:
        return float("nan")
    v = validate(problem, 0.0, sc.start, sc.horizon, sc.goal, res.costate0)
    return float(v.clearance.min())


@click.command()
def scenarios():
    """List the built-in scenarios."""
    from ..planning.scenario import builtin_scenarios, load_scenario

    table = Table(title="built-in scenarios")
    for col in ("name", "start", "goal", "T", "obstacles"):
        table.add_column(col)
    for name in builtin_scenarios():
        sc = load_scenario(name)
        fmt = lambda v: "[" + ", ".join(f"{x:.4g}" for x in v) + "]"  # noqa: E731
        table.add_row(name, fmt(sc.start), fmt(sc.goal), f"{sc.horizon:g}", str(len(sc.obstacles)))
    console.print(table)
    return EXIT_OK


@click.command()
@click.argument("scenario")
@click.option(
    "--method",
    type=click.Choice(["newton", "modified-newton", "nleq-err"]),
    default=None,
    help="local Newton method  [default: modified-newton]",
)
@click.option(
    "--partitions",
    type=click.IntRange(min=2, max=1024),
    default=None,
    help="initial q, 2 to 1024  [default: 8]",
)
@click.option(
    "--initial-paths",
    type=click.IntRange(min=1),
    default=None,
    help="initial paths tried, in different homotopy classes  [default: 3]",
)
@click.option(
    "--final",
    type=click.Choice(["auto", "shooting", "multiple-shooting"]),
    default=None,
    help="final solve: simple shooting with multiple-shooting fallback (auto)  [default: auto]",
)
@click.option(
    "--map",
    "map_file",
    default=None,
    help="plan in this ROS map (its map_server YAML), in place of the scenario's [map]",
)
@click.option(
    "--time-limit",
    type=click.FloatRange(min=0.0, min_open=True, max=1e7),
    default=None,
    help="seconds the plan may take: no new run or sweep starts after 0.85 of them, and the"
    " plan ends with the best answer found so far (the runs under way end their sweep)",
)
@click.option(
    "--horizon",
    default=None,
    help='the horizon T in seconds, or "free": the planner chooses T at a price of time'
    " (--cruise-speed or --time-weight, else the scenario's [cost])  [default: the scenario's]",
)
@click.option(
    "--cruise-speed",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="with a free horizon: the speed the robot travels at where no obstacle is near",
)
@click.option(
    "--time-weight",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="with a free horizon: the price k of each second, the cost being the integral of"
    " k + effort + penalty",
)
@click.option("--json", "json_path", default=None, help="write the result as JSON")
@click.option("--npz", "npz_path", default=None, help="write the trajectory arrays as NPZ")
@click.option("--plot", "plot_path", default=None, help="write the path figure (PNG, PDF or SVG)")
@figure_options
@option_items
@click.option("--quiet", is_flag=True, help="no progress bar and no table")
def solve(
    scenario,
    method,
    partitions,
    initial_paths,
    final,
    map_file,
    time_limit,
    horizon,
    cruise_speed,
    time_weight,
    json_path,
    npz_path,
    plot_path,
    dpi,
    title,
    options,
    quiet,
):
    """Plan SCENARIO (a TOML file or a built-in name) with the Leapfrog algorithm. A file wins
    over a built-in of the same name; builtin:NAME is always the built-in.

    Given a saved result in its place (a JSON or NPZ file of `solve --json/--npz`, recognised by
    its content), re-plan the scenario it records with the settings it records, and say in one
    line whether the answer reproduces (the same status, cost and trajectory, bit for bit).
    Exit codes then: 0 it reproduces a converged answer, 1 it reproduces an answer that did
    not converge, 3 it differs from the recorded answer; bad input is 2, as always.
    """
    from ..planning.planner import Planner
    from ..planning.result_files import is_result_file
    from ..planning.scenario import builtin_scenarios, load_scenario

    if plot_path is not None and Path(plot_path).suffix.lower() not in (".png", ".pdf", ".svg"):
        raise click.UsageError("--plot: the file must end in .png, .pdf or .svg")
    inputs = [scenario] + ([map_file] if map_file else [])
    outputs = {
        "--json": output_path(json_path, "--json", inputs),
        "--npz": output_path(npz_path, "--npz", inputs),
        "--plot": output_path(plot_path, "--plot", inputs),
    }
    distinct_outputs(outputs)
    figure = {"dpi": dpi, "title": title}
    if scenario in builtin_scenarios() and Path(scenario).is_file():
        note = f"the file {scenario}, not the built-in scenario (builtin:{scenario} is that one)"
        err.print(f"note: {note}", soft_wrap=True)
    if is_result_file(scenario):
        given = [method, partitions, initial_paths, final, map_file, time_limit, horizon]
        if any(v is not None for v in [*given, cruise_speed, time_weight]) or options:
            raise click.UsageError(
                "a result re-plans with the scenario and settings it records: planning options"
                " are not accepted with it (plan its scenario to change them)"
            )
        return _rerun(scenario, outputs, quiet, figure)
    sc = load_scenario(scenario)
    if (horizon, cruise_speed, time_weight) != (None, None, None):
        sc = with_horizon(sc, horizon, cruise_speed, time_weight)
    if map_file is not None:
        sc = with_map(sc, map_file)
    named = [
        ("method", method),
        ("partitions", partitions),
        ("initial_paths", initial_paths),
        ("final", final),
        ("time_limit", time_limit),
    ]
    settings = {**planner_options(options), **{k: v for k, v in named if v is not None}}
    planner = Planner(sc, **settings)  # settings errors surface here, before any display
    result = _planned(planner, outputs, quiet, figure)
    if quiet and not result.success:
        err.print(
            f"{sc.name}: {result.status}: {result.message}",
            highlight=False,
            soft_wrap=True,
            markup=False,
        )
    return EXIT_OK if result.success else EXIT_FAILED


#: ``leapfrog solve RESULT``: the re-run gave another answer than the recorded one.
EXIT_DIFFERS = 3


def command_line() -> str:
    """The command line as given (a result's provenance records it)."""
    return shlex.join(["leapfrog", *sys.argv[1:]])


def _planned(planner, outputs, quiet: bool, figure: dict):
    """The plan of ``planner``, its outputs written (the figure saved with ``figure``: dpi and
    title) and, unless ``quiet``, its summary shown.
    The kernels are loaded first, so that the time reported is the plan's own."""
    from ..planning.rerun import with_call

    sc = planner.scenario
    ensure_compiled([sc.model], show=not quiet, methods=[planner.settings.leapfrog.method])
    result = planner.plan() if quiet else _plan_with_progress(planner)
    result = with_call(result, command_line())
    _write_outputs(result, sc, outputs, figure)
    if not quiet:
        console.print(_summary(result))
    return result


def _write_outputs(result, sc, outputs, figure: dict) -> None:
    if outputs["--json"]:
        write_output(result.save_json, outputs["--json"], "--json")
    if outputs["--npz"]:
        write_output(result.save_npz, outputs["--npz"], "--npz")
    if outputs["--plot"]:
        from ..viz.plots import plot_path as draw
        from ..viz.plots import save_figure

        ax = draw(result, sc, title=figure["title"])
        write_output(
            lambda p: save_figure(ax.figure, p, dpi=figure["dpi"]), outputs["--plot"], "--plot"
        )


def _rerun(path: str, outputs, quiet: bool, figure: dict) -> int:
    """Re-plan the task the result file ``path`` records and compare the answers."""
    from ..errors import SettingsError
    from ..planning.planner import Planner
    from ..planning.rerun import reproduction
    from ..planning.results import PlanResult

    old = PlanResult.load(path)
    try:
        planner = Planner.from_result(old)
    except SettingsError as e:  # the settings the file records: said with the file's name
        raise SettingsError(f"{path}: {e}") from None
    result = _planned(planner, outputs, quiet, figure)
    check = reproduction(old, result)
    console.print(f"{planner.scenario.name}: {check.summary()}", soft_wrap=True)
    if not check.reproduces:
        return EXIT_DIFFERS
    return EXIT_OK if result.success else EXIT_FAILED


def with_horizon(sc, horizon: str | None, cruise_speed, time_weight):
    """``sc`` with the horizon of ``--horizon`` (seconds, or ``free``) and the price of time of
    ``--cruise-speed`` or ``--time-weight``."""
    from ..planning.scenario import scenario_from_dict

    if cruise_speed is not None and time_weight is not None:
        raise click.UsageError("give --cruise-speed or --time-weight, not both")
    d = sc.to_dict()
    if horizon is not None and horizon.strip().lower() != "free":
        try:
            d["horizon"] = float(horizon)
        except ValueError:
            raise click.BadParameter(
                f"expected seconds or free, got {horizon!r}", param_hint="--horizon"
            ) from None
        if not d["horizon"] > 0:
            raise click.BadParameter(f"must be > 0, got {horizon}", param_hint="--horizon")
        d.pop("cost", None), d.pop("time", None)
    elif horizon is not None:
        d["horizon"] = "free"
        if cruise_speed is None and time_weight is None and "cost" not in d:
            raise click.UsageError(
                "--horizon free needs a price of time: add --cruise-speed or --time-weight"
                " (or a [cost] table in the scenario)"
            )
    if cruise_speed is not None or time_weight is not None:
        if d["horizon"] != "free":
            raise click.UsageError(
                "--cruise-speed and --time-weight price the time of a free horizon: add"
                " --horizon free"
            )
        given = {"cruise_speed": cruise_speed, "time_weight": time_weight}
        d["cost"] = {k: v for k, v in given.items() if v is not None}
    return scenario_from_dict(d, sc.source or "<command line>")


def with_map(sc, map_file: str):
    """``sc`` planned in the map of ``map_file`` (its unknown policy, length scale, polygons
    and walls kept)."""
    from dataclasses import replace

    from ..planning.scenario_map import ScenarioMap

    old = sc.map
    if old is None:
        return replace(sc, map=ScenarioMap(map_file))
    unknown = old.unknown if old.file is not None else "occupied"
    return replace(sc, map=ScenarioMap(map_file, unknown, old.length, shapes=old.shapes))


def _plan_with_progress(planner):
    if not err.is_terminal:  # no bar (and no stray blank line) when stderr is a file or pipe
        return planner.plan()
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    sc = planner.scenario
    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
    ]
    with Progress(*columns, console=err, transient=True) as bar:
        task = bar.add_task(sc.name, total=planner.settings.initial_paths, info="initial paths")

        def on_event(ev):
            if ev.stage == "path":
                bar.update(
                    task,
                    total=ev.paths,
                    completed=ev.path_index,
                    info=f"path {ev.path_index + 1}/{ev.paths} ({ev.label})",
                )
            elif ev.stage == "sweep":
                r = ev.sweep
                bar.update(
                    task,
                    info=f"path {ev.path_index + 1}/{ev.paths}: sweep {r.sweep}, q={r.q}, "
                    f"cost {r.cost:.6g}",
                )
            elif ev.stage == "time":
                bar.update(task, info=ev.label)
            else:
                bar.update(task, completed=ev.paths, info="validating")

        planner.progress = on_event
        return planner.plan()


def _free_time_rows(f) -> list[tuple[str, str]]:
    """The rows of a free final time: the ``T`` chosen, its price, Pontryagin's condition."""
    if f is None:
        return []
    price = f"{f.time_weight:.6g} per second"
    if f.cruise_speed is not None:
        price += f" (a cruise speed of {f.cruise_speed:g})"
    rest = f"on its {f.bound} bound" if f.bound else f"k + H = {f.condition:.1e}"
    return [("final time", f"T = {f.horizon:.8g} chosen at a price of {price}; {rest}")]


def _clearance_text(r) -> str:
    """The least clearance of the returned motion, "n/a (no obstacles)" in free space only."""
    if r.min_clearance is None:
        sc = r.task
        free = sc is None or (sc.obstacles.shape[0] == 0 and sc.map is None)
        return "n/a (no obstacles)" if free else "n/a"
    text = f"{r.min_clearance:.4g}"
    if r.task is not None and r.task.robot_radius:
        text += f"  (of the footprint, radius {r.task.robot_radius:g})"
    return text


def _levels(history) -> str:
    """The arcs of the answer's first and last sweeps ("  (levels of 8 down to 4 arcs)"); ""
    without sweeps."""
    if not history:
        return ""
    first, last = history[0].q, history[-1].q
    return f"  (levels of {first} down to {last} arcs)" if first != last else f"  ({first} arcs)"


def _summary(r) -> Table:
    from ..planning.status import listed_alternatives

    table = Table(title=f"{r.scenario}: Leapfrog ({r.method})", show_header=False)
    clearance = _clearance_text(r)
    cost = f"{r.cost:.8g}  (energy {r.energy:.6g} + penalty {r.penalty:.6g}"
    f = r.free_time
    cost += ")" if f is None else f" + time {f.time_cost:.6g})"
    what = r.message.split("; returned: ")[0]  # the returned trajectory has its own row
    rows = [("status", str(r.status) + ("" if r.success else f": {what}"))]
    if r.optimal:
        rows += [
            ("cost", cost),
            ("min clearance", clearance),
            ("end-state error", f"{r.end_state_error:.2e}"),
            *_free_time_rows(f),
            ("final solve", f"{r.final_solver} from initial path {r.initial_path}"),
        ]
        raised = [part for part in r.message.split("; ") if "weight was raised" in part]
        rows += [("obstacle weight", part) for part in raised]
        if math.isfinite(r.cheaper_motion):
            rows.append(("warning", r.message.split("; but ", 1)[1]))
    elif r.trajectory is None:  # no cost, no clearance: nothing to measure
        rows.append(("returned", "no motion (none was found)"))
    else:
        rows += [
            ("returned", f"the {r.trajectory_source} (from initial path {r.initial_path})"),
            ("its cost", cost),
            ("its clearance", clearance),
        ]
    rows += [("time limit", part) for part in r.message.split("; ") if "time limit" in part]
    rows += [("initial paths", part) for part in r.message.split("; ") if "initial path" in part]
    rows += [
        ("sweeps", str(r.sweeps) + _levels(r.history)),
        ("Newton iterations", f"{r.newton_iterations}  ({r.f_evals} F evaluations)"),
        (
            "time",
            f"{r.wall_time_s * 1e3:.0f} ms  (paths {r.time_initial_path_s * 1e3:.0f}, sweeps "
            f"{r.time_sweeps_s * 1e3:.0f}, final {r.time_final_s * 1e3:.0f}, check "
            f"{r.time_validation_s * 1e3:.0f})",
        ),
    ]
    listed, failed = listed_alternatives(r.alternatives, r)
    for a in listed:
        what = f"{a.status}, cost {a.cost:.8g}" if math.isfinite(a.cost) else f"{a.status}"
        if a.weight != r.weight:
            what += f" (obstacle weight {a.weight:g})"
        rows.append((f"other path {a.label}", what))
    if failed:
        rows.append((f"{failed} other paths", "failed (the JSON result has each one's message)"))
    for k, v in rows:
        table.add_row(k, v)
    return table
