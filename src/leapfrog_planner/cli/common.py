"""What every command shares: exit codes, the consoles, the check of an output path."""

from __future__ import annotations

import os
from pathlib import Path

import click
from rich.console import Console

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2

console = Console()
err = Console(stderr=True)


def output_path(value: str | None, option: str) -> Path | None:
    """Check an output path before any work is done, so bad input fails fast with exit 2."""
    if value is None:
        return None
    path = Path(value)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise click.UsageError(f"{option}: folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise click.UsageError(f"{option}: folder {str(parent)!r} is not writable")
    if path.is_dir():
        raise click.UsageError(f"{option}: {value!r} is a folder")
    return path
