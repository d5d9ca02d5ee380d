"""Commands on a saved result: ``plot`` (its figures) and ``export`` (CSV, a ROS path, a ROS 2
bag). A result file carries its scenario, so nothing else is needed. ``schema``: the JSON Schema
of a result file."""

from __future__ import annotations

from pathlib import Path

import click

from .common import (
    EXIT_OK,
    console,
    distinct_outputs,
    figure_options,
    new_folder,
    output_path,
    write_output,
)

FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def bag_options(command):
    """How ``export --bag`` writes its bag: storage, the twist message, the start time."""
    command = click.option(
        "--start-time",
        type=click.FloatRange(0, 9.2e9),
        default=0.0,
        show_default=True,
        help="bag time of the start, in seconds since the epoch",
    )(command)
    command = click.option(
        "--twist-stamped",
        is_flag=True,
        help="/cmd_vel as geometry_msgs/TwistStamped in frame base_link (as ros2_control's "
        "diff_drive_controller requires from Jazzy on) instead of Twist",
    )(command)
    return click.option(
        "--bag-storage",
        type=click.Choice(["sqlite3", "mcap"]),
        default="sqlite3",
        show_default=True,
        help="sqlite3 plays on every ROS 2 from Humble on; mcap from Iron on (Humble: a plugin)",
    )(command)


def _write_bag(res, path, dt, frame, settings):
    from ..planning.ros_bag import write_bag

    write_bag(
        res, path, dt, frame, start=settings["start_time"],
        stamped=settings["twist_stamped"], storage=settings["bag_storage"],
    )  # fmt: skip


def _load(path: str):
    from ..planning.results import PlanResult

    if not Path(path).is_file():
        raise click.UsageError(f"{path!r}: no such file")
    result = PlanResult.load(path)
    if result.task is None:  # a file of schema 1
        raise click.UsageError(f"{path!r}: the result does not hold its scenario (schema 1)")
    return result


def _figure_option(value: str | None, option: str, inputs) -> Path | None:
    if value is not None and Path(value).suffix.lower() not in FIGURE_SUFFIXES:
        raise click.UsageError(f"{option}: the file must end in .png, .pdf or .svg")
    return output_path(value, option, inputs)


@click.command()
@click.argument("result")
@click.option(
    "--out",
    default=None,
    help="the path figure (PNG, PDF or SVG)  [default: RESULT.png when no other figure is asked]",
)
@click.option("--controls", default=None, help="the controls and costates against time")
@click.option("--convergence", default=None, help="the junctions and cost sweep by sweep")
@click.option("--animate", default=None, help="an animated GIF of the sweeps")
@figure_options
def plot(result, out, controls, convergence, animate, dpi, title):
    """Draw the figures of a RESULT file written by `solve --json` or `--npz`."""
    inputs = [result]
    if out is None and controls is None and convergence is None and animate is None:
        out = str(Path(result).with_suffix(".png"))  # only what was asked is written
    if animate is not None and Path(animate).suffix.lower() != ".gif":
        raise click.UsageError("--animate: the file must end in .gif")
    outputs = {
        "--out": _figure_option(out, "--out", inputs),
        "--controls": _figure_option(controls, "--controls", inputs),
        "--convergence": _figure_option(convergence, "--convergence", inputs),
        "--animate": output_path(animate, "--animate", inputs),
    }
    distinct_outputs(outputs)
    res = _load(result)
    from ..viz.animation import animate_sweeps
    from ..viz.plots import plot_controls, plot_convergence, plot_path, save_figure

    sc = res.task
    draw = {
        "--out": lambda p: save_figure(plot_path(res, sc, title=title), p, dpi=dpi),
        "--controls": lambda p: save_figure(plot_controls(res, title=title), p, dpi=dpi),
        "--convergence": lambda p: save_figure(plot_convergence(res, sc, title=title), p, dpi=dpi),
        "--animate": lambda p: animate_sweeps(res, sc, p),
    }
    for option, path in outputs.items():
        if path is not None:
            write_output(draw[option], path, option)
            console.print(f"wrote {path}", markup=False, highlight=False)
    return EXIT_OK


@click.command()
@click.argument("result")
@click.option(
    "--csv",
    "csv_path",
    default=None,
    help="t, states, controls and velocities (linear_x m/s, angular_z rad/s) every --dt, as CSV",
)
@click.option(
    "--ros-path",
    "ros_path",
    default=None,
    help="a nav_msgs/Path (YAML for .yaml/.yml, JSON otherwise), one pose every --dt",
)
@click.option(
    "--bag",
    default=None,
    metavar="DIR",
    help="a ROS 2 bag (a new folder): /plan, /pose and /cmd_vel every --dt (needs rosbags)",
)
@click.option(
    "--dt",
    type=click.FloatRange(min=0, min_open=True),
    default=0.01,
    show_default=True,
    help="time step of the uniform resampling",
)
@click.option("--frame", default="map", show_default=True, help="frame_id of the ROS poses")
@bag_options
def export(result, csv_path, ros_path, bag, dt, frame, **bag_settings):
    """Resample the trajectory of a RESULT file uniformly and write it for other tools."""
    from ..planning.export import ExportError, write_csv, write_ros_path

    if csv_path is None and ros_path is None and bag is None:
        raise click.UsageError("nothing to export: give --csv FILE, --ros-path FILE or --bag DIR")
    inputs = [result]
    outputs = {
        "--csv": output_path(csv_path, "--csv", inputs),
        "--ros-path": output_path(ros_path, "--ros-path", inputs),
        "--bag": new_folder(bag, "--bag"),
    }
    distinct_outputs(outputs)
    writers = {
        "--csv": lambda p: write_csv(res, p, dt),
        "--ros-path": lambda p: write_ros_path(res, p, dt, frame),
        "--bag": lambda p: _write_bag(res, p, dt, frame, bag_settings),
    }
    try:
        if bag is not None:
            from ..planning.ros_bag import require_rosbags

            require_rosbags()
        res = _load(result)
        for option, path in outputs.items():
            if path is not None:
                write_output(writers[option], path, option)
    except ExportError as e:
        raise click.UsageError(str(e)) from None
    for path in outputs.values():
        if path is not None:
            console.print(f"wrote {path}", markup=False, highlight=False)
    return EXIT_OK


@click.command()
@click.option("--out", default=None, help="write it to this file  [default: print it]")
def schema(out):
    """Print the JSON Schema of a result file (of `solve --json`), or write it with --out."""
    import json

    from ..planning.result_schema import result_schema

    path = output_path(out, "--out")
    text = json.dumps(result_schema(), indent=2) + "\n"
    if path is None:
        click.echo(text, nl=False)
    else:
        from .._atomic import write_text_atomic

        write_output(lambda p: write_text_atomic(p, text), path, "--out")
    return EXIT_OK
