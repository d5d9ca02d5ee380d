"""What every command shares: exit codes, the consoles, the checks of output paths.

Outputs never destroy inputs or system files: an output path is checked before any work, and
refused (exit 2) when it is an input, a folder, a special file (device, FIFO, socket), too long
a name, or in a folder where no file can be created. A symbolic link is followed: its target is
what gets replaced.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

import click
from rich.console import Console

from ..viz.options import DPI, DPI_MAX, DPI_MIN

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2

# User strings (scenario names, file names, messages) are printed as text: never as rich's
# markup (a name "[/]" or "[link=...]"), emoji codes or highlighting.
console = Console(markup=False, emoji=False, highlight=False)
err = Console(stderr=True, markup=False, emoji=False, highlight=False)

# An atomic write first creates ".<stem>.<8 random characters><suffix>" beside the file.
_TEMP_EXTRA = 10


def _fail(option: str, message: str):
    raise click.UsageError(f"{option}: {message}")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _probe_folder(folder: Path, option: str) -> None:
    """Create and remove a file in ``folder``: the only sure test that outputs can be written
    there (permissions, a read-only file system, ``/proc``)."""
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".leapfrog-probe-")
    except OSError as exc:
        _fail(option, f"cannot write in folder {str(folder)!r} ({exc.strerror or exc})")
    os.close(fd)
    os.unlink(tmp)


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def _parent(path: Path, option: str, what: str) -> Path:
    """The folder an output goes in: it must exist, and hold the output's temporary name."""
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        _fail(option, f"folder {str(parent)!r} does not exist")
    if len(path.name.encode()) + _TEMP_EXTRA > _name_max(parent):
        _fail(option, f"{what} name too long ({len(path.name)} characters)")
    return parent


def output_path(value: str | None, option: str, inputs: Iterable = ()) -> Path | None:
    """Check an output file before any work is done, so bad output paths fail fast with exit 2.

    Returns the path to write (a symbolic link's target), or None when ``value`` is None.
    """
    if value is None:
        return None
    if not value or "\0" in value:
        _fail(option, "expected a file name")
    path = Path(value)
    try:
        if path.is_symlink():
            path = path.resolve()  # the link's target is replaced, the link kept
        exists = path.exists()
    except (OSError, RuntimeError) as exc:  # a loop of links, a name too long
        _fail(option, f"cannot use {value!r} ({getattr(exc, 'strerror', None) or exc})")
    parent = _parent(path, option, "file")
    if exists:
        mode = path.stat().st_mode
        if stat.S_ISDIR(mode):
            _fail(option, f"{value!r} is a folder")
        if not stat.S_ISREG(mode):
            _fail(option, f"{value!r} is not a regular file (a device, FIFO or socket)")
        for given in inputs:
            if given is not None and _same_file(path, Path(given)):
                _fail(option, f"{value!r} is an input of this command; choose another file")
    _probe_folder(parent, option)
    return path


def distinct_outputs(outputs: dict[str, Path | None]) -> None:
    """Refuse two options that name the same file (one would overwrite the other)."""
    seen: dict[str, str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        key = os.path.abspath(path)
        if key in seen:
            _fail(option, f"same file as {seen[key]}")
        seen[key] = option


def output_folder(value: str, option: str, inputs: Iterable = ()) -> Path:
    """Check an output folder before any work is done and create it if needed (its parent must
    exist). Files already in it may be replaced; an input inside it is refused by name later."""
    if not value or "\0" in value:
        _fail(option, "expected a folder name")
    path = Path(value)
    try:
        exists = path.exists()
    except OSError as exc:
        _fail(option, f"cannot use {value!r} ({exc.strerror or exc})")
    if exists and not path.is_dir():
        _fail(option, f"{value!r} exists and is not a folder")
    for given in inputs:
        if given is not None and _same_file(path, Path(given)):
            _fail(option, f"{value!r} is an input of this command")
    parent = path.parent if str(path.parent) else Path(".")
    if not exists:
        if not parent.is_dir():
            _fail(option, f"folder {str(parent)!r} does not exist")
        _probe_folder(parent, option)
        try:
            path.mkdir(exist_ok=True)  # another command may create it at the same moment
        except OSError as exc:
            _fail(option, f"cannot create folder {value!r} ({exc.strerror or exc})")
    _probe_folder(path, option)
    return path


def new_folder(value: str | None, option: str) -> Path | None:
    """Check a folder the command will create whole (a ROS bag) before any work: it must not
    exist (never replaced: it may hold a recording), its parent must and be writable."""
    if value is None:
        return None
    if not value or "\0" in value:
        _fail(option, "expected a folder name")
    path = Path(value)
    if os.path.lexists(path):
        _fail(option, f"{value!r} exists; give a new folder (it is never replaced)")
    _probe_folder(_parent(path, option, "folder"), option)
    return path


def refuse_inputs_in(folder: Path, names: Iterable[str], inputs: Iterable, option: str) -> None:
    """Refuse an output ``folder`` whose fixed file ``names`` would replace an input."""
    for name in names:
        for given in inputs:
            if given is not None and _same_file(folder / name, Path(given)):
                _fail(option, f"{str(folder / name)!r} would replace an input of this command")


class OutputError(OSError):
    """An output that could not be written after the work was done (a full disk, a folder
    gone): one line and exit 1, as a failure, not exit 2: the input was good."""


def write_output(write, path: Path, option: str) -> None:
    """``write(path)``, with a failure (a full disk, a folder gone) as one line and exit 1
    (:class:`OutputError`); the file is written atomically, so nothing half-written stays."""
    try:
        write(path)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"{option}: cannot write {str(path)!r} ({exc.strerror or exc})") from None


def figure_options(command):
    """``--dpi N`` and ``--no-title``: how the figures of ``plot`` and ``solve --plot`` are
    saved (the command receives ``dpi`` and ``title``)."""
    command = click.option(
        "--no-title",
        "title",
        flag_value=False,
        default=True,
        help="figures without titles (for a paper, whose captions say it)",
    )(command)
    return click.option(
        "--dpi",
        type=click.IntRange(DPI_MIN, DPI_MAX),
        default=DPI,
        show_default=True,
        help="pixels per inch of a PNG figure",
    )(command)


#: ``--option KEY=VALUE``: any planner or Leapfrog setting, repeatable (sweep and solve).
option_items = click.option(
    "--option",
    "options",
    multiple=True,
    metavar="KEY=VALUE",
    help="another planner option, e.g. partitions=16 (repeatable)",
)


def planner_options(items) -> dict:
    """``--option`` items as settings: values read as JSON where they parse, else as text
    (``final=auto``); dashes in keys become underscores. Unknown keys are the planner's to
    refuse."""
    opts = {}
    for item in items:
        if "=" not in item:
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", param_hint="--option")
        k, v = item.split("=", 1)
        try:
            opts[k.strip().replace("-", "_")] = json.loads(v)
        except (ValueError, RecursionError):  # not JSON (or too deep, or too many digits)
            opts[k.strip().replace("-", "_")] = v  # a bare string, e.g. final=auto
    return opts
