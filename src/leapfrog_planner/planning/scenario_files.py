"""Reading a scenario file: its bytes (bounded, never blocking), its text, and what a file that
is not TOML holds when that can be told (a planning result), for a message that says so."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

from .scenario_checks import ScenarioCheck

#: A scenario file larger than this is refused (10,000 obstacles take about 600 kB).
MAX_FILE_BYTES = 16 * 2**20


def read_scenario_file(path: Path, name: str) -> bytes:
    """The bytes of a scenario file, at most :data:`MAX_FILE_BYTES`. A FIFO without a writer
    reads as empty instead of blocking; a device that never ends (``/dev/zero``) hits the cap."""
    c = ScenarioCheck(name)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        c.fail("", f"cannot read file: {exc.strerror or exc}")
    chunks, size = [], 0
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            c.fail("", "is a directory, not a scenario file")
        os.set_blocking(fd, True)
        while size <= MAX_FILE_BYTES and (chunk := os.read(fd, 1 << 20)):
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        c.fail("", f"cannot read file: {exc.strerror or exc}")
    finally:
        os.close(fd)
    if size > MAX_FILE_BYTES:
        c.fail("", f"larger than {MAX_FILE_BYTES // 2**20} MB, not a scenario file")
    return b"".join(chunks)


def path_exists(path: Path) -> bool:
    try:
        return path.exists() or path.is_symlink()
    except OSError:  # e.g. a name too long for the file system: not a file we can read
        return False


def decode_text(raw: bytes, source: str) -> str:
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        ScenarioCheck(source).fail(
            "", f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})"
        )


def not_toml(text: str) -> str | None:
    """What ``text`` (which is not TOML) holds when it is JSON: a planning result or other
    JSON; ``None`` otherwise."""
    if not text.lstrip().startswith(("{", "[")):
        return None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        return None
    if isinstance(data, dict) and "schema" in data and "status" in data:
        return "a planning result (JSON), not a scenario (TOML)"
    return "JSON, not TOML (a scenario is TOML)"
