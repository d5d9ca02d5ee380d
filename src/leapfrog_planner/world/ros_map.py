"""ROS map_server maps: the YAML file, the image it names, and nav2's rules from pixels to cells.

The YAML file (``yaml.safe_load`` only) holds ``image`` (a path, relative to the YAML file's
folder unless absolute), ``resolution`` (metres a cell), ``origin`` ``[x, y, yaw]`` (the pose
of the lower-left corner of the lower-left pixel), ``negate``, ``occupied_thresh``,
``free_thresh`` and optionally ``mode`` (``trinary``, the default, ``scale`` or ``raw``, in any
case). Every key but ``mode`` is required, as in nav2; an unknown key is refused (with a
suggestion), and so are thresholds outside ``[0, 1]`` or ``free_thresh >= occupied_thresh``
(nav2 checks those only when saving).

The rules are those of nav2's ``nav2_map_server/src/map_io.cpp`` (``loadMapFromFile``), to the
letter:

* ``shade`` is the mean of a pixel's red, green and blue channels over the channel's maximum
  (a grey pixel is its value: ``v / 255``, ``v / maxval`` for a PGM); in ``trinary`` mode an
  image with an alpha channel has the alpha (opacity) averaged in as a fourth channel;
* ``occ = shade`` if ``negate`` else ``1 - shade``;
* ``trinary``: 100 (occupied) if ``occupied_thresh < occ``, else 0 (free) if
  ``occ < free_thresh``, else -1 (unknown);
* ``scale``: -1 if the pixel is not fully opaque, else as ``trinary`` but a value between the
  thresholds is ``rint(100 (occ - free_thresh) / (occupied_thresh - free_thresh))`` (0..100);
* ``raw``: ``round(255 shade)`` if it is in 0..100, else -1 (``negate`` is ignored);
* the image's top row is the map's last row (the origin is at the lower-left pixel).

ROS 1's map_server differs in ``scale`` (``99 ratio``, unrounded) and ``raw`` (no -1); these are
nav2's. Every fault raises :class:`~leapfrog_planner.errors.ScenarioError` with one line,
``<yaml file>: <key>: <problem>``.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .. import checks
from ..errors import ScenarioError, describe, did_you_mean, short
from .images import Pixels, read_pixels
from .occupancy import FREE, OCCUPIED, RESOLUTION_MAX, UNKNOWN, OccupancyMap

MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
REQUIRED_KEYS = MAP_KEYS[:-1]
BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")  # a key named as it is; any other is quoted
MODES = ("trinary", "scale", "raw")
#: A map's YAML file larger than this is refused (map_server writes some 150 bytes).
MAX_YAML_BYTES = 1 << 20


@dataclass(frozen=True)
class MapYaml:
    """The checked keys of a map's YAML file; ``image`` is the path to open (joined to the
    YAML file's folder when relative), ``mode`` in lower case."""

    image: str
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str = "trinary"


def shown(path: str) -> str:
    """A file's name as messages show it (a NUL character as ``\\0``)."""
    return path.replace("\0", "\\0")


def _fail(source: str, key: str, problem: str) -> NoReturn:
    text = f"{source}: {key}: {problem}" if key else f"{source}: {problem}"
    raise ScenarioError(" ".join(text.split()))


def _named(source: str, check, *args, **kw):
    """``check`` (of :mod:`..checks`) with the file's name in front of its message."""
    try:
        return check(*args, **kw)
    except ScenarioError as exc:
        _fail(source, "", str(exc))


def read_bounded(path: str, source: str, limit: int = MAX_YAML_BYTES) -> bytes:
    """The bytes of a small file, at most ``limit`` (a FIFO without a writer reads as empty
    instead of blocking; a device that never ends hits the cap)."""
    if "\0" in path:
        _fail(source, "", "cannot read file: its name holds a NUL character")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        _fail(source, "", f"cannot read file: {exc.strerror or exc}")
    chunks, size = [], 0
    try:
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            _fail(source, "", "is a directory, not a map's YAML file")
        os.set_blocking(fd, True)
        while size <= limit and (chunk := os.read(fd, 1 << 16)):
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        _fail(source, "", f"cannot read file: {exc.strerror or exc}")
    finally:
        os.close(fd)
    if size > limit:
        _fail(source, "", f"larger than {limit // 1024} kB, not a map's YAML file")
    return b"".join(chunks)


def parse_yaml(raw: bytes, source: str) -> Any:
    """The document of a YAML file (``yaml.safe_load``), any fault as one line."""
    import yaml

    try:
        return yaml.safe_load(raw)
    except RecursionError:
        _fail(source, "", "invalid YAML: values nested too deeply")
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        _fail(source, "", f"invalid YAML: {exc.problem or exc.context or 'unreadable'}{where}")
    except (yaml.YAMLError, ValueError) as exc:  # ValueError: an integer of 5,000 digits
        text = " ".join(str(exc).split())
        _fail(source, "", f"invalid YAML: {text if len(text) <= 120 else text[:117] + '...'}")


def _known_keys(doc: Mapping, source: str) -> None:
    for k in doc:
        if not isinstance(k, str):
            _fail(source, "", f"keys must be strings, got {describe(k)}")
    for k in doc:
        if k not in MAP_KEYS:
            did = did_you_mean(k, MAP_KEYS)
            name = k if BARE_KEY.fullmatch(k) else short(k)
            _fail(source, name, f"unknown key ({did}allowed: {', '.join(MAP_KEYS)})")
    for k in REQUIRED_KEYS:
        if k not in doc:
            _fail(source, k, "missing required key")


def _image_path(value: Any, source: str, folder: str) -> str:
    if not isinstance(value, str):
        _fail(source, "image", f"expected a file name, got {describe(value)}")
    if not value or "\0" in value:
        _fail(source, "image", f"expected a file name, got {describe(value)}")
    return value if os.path.isabs(value) else os.path.join(folder, value)


def _flag(value: Any, source: str, key: str) -> bool:
    """nav2 reads ``negate`` as an integer, else as a boolean: 0, 1, true or false."""
    if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
        return bool(value)
    _fail(source, key, f"expected 0, 1, true or false, got {describe(value)}")


def _mode(value: Any, source: str) -> str:
    if not isinstance(value, str):
        _fail(source, "mode", f"expected one of {', '.join(MODES)}, got {describe(value)}")
    mode = value.lower()
    if mode not in MODES:
        did = did_you_mean(mode, MODES)
        _fail(source, "mode", f"unknown mode {short(value)} ({did}known: {', '.join(MODES)})")
    return mode


def _thresholds(doc: Mapping, source: str) -> tuple[float, float]:
    occupied, free = (
        _named(source, checks.real, doc[key], key) for key in ("occupied_thresh", "free_thresh")
    )
    for key, x in (("occupied_thresh", occupied), ("free_thresh", free)):
        _named(source, checks.in_range, x, key, 0.0, 1.0)
    if not free < occupied:
        _fail(source, "free_thresh", f"must be below occupied_thresh ({occupied!r}), got {free!r}")
    return occupied, free


def map_yaml_from_dict(doc: Any, source: str, folder: str = "") -> MapYaml:
    """The checked keys of a map's YAML document; ``folder`` is where a relative image is."""
    if not isinstance(doc, Mapping):
        keys = ", ".join(REQUIRED_KEYS)
        _fail(source, "", f"expected a mapping of the keys {keys}, got {describe(doc)}")
    _known_keys(doc, source)
    resolution = _named(source, checks.real, doc["resolution"], "resolution", gt=0)
    _named(source, checks.in_range, resolution, "resolution", 0.0, RESOLUTION_MAX)
    x, y, yaw = _named(source, checks.vector, doc["origin"], 3, "origin", " [x, y, yaw]")
    _named(source, checks.magnitude, (x, y), "origin", checks.COORDINATE_MAX)
    if not abs(yaw) <= checks.HEADING_MAX:
        _fail(source, "origin[2]", f"must be at most {checks.HEADING_MAX:g} in size, got {yaw!r}")
    occupied, free = _thresholds(doc, source)
    return MapYaml(
        image=_image_path(doc["image"], source, folder),
        resolution=resolution,
        origin=(float(x), float(y), float(yaw)),
        negate=_flag(doc["negate"], source, "negate"),
        occupied_thresh=occupied,
        free_thresh=free,
        mode=_mode(doc.get("mode", "trinary"), source),
    )


def read_map_yaml(path: str | os.PathLike) -> MapYaml:
    """The checked keys of the map's YAML file ``path``."""
    path = str(path)
    source = shown(path)
    doc = parse_yaml(read_bounded(path, source), source)
    return map_yaml_from_dict(doc, source, os.path.dirname(path))


def rule_table(channels: int, maxval: int, spec: MapYaml) -> np.ndarray:
    """The cell value (``int8``) of every sum ``s`` of ``channels`` channel values
    (``0 <= s <= channels * maxval``), by nav2's rules for ``spec``'s mode (module docstring)."""
    shade = (np.arange(channels * maxval + 1) / channels) / maxval
    if spec.mode == "raw":
        value = np.floor(shade * 255.0 + 0.5)  # std::round: halves away from zero
        return np.where(value <= OCCUPIED, value, UNKNOWN).astype(np.int8)
    occ = shade if spec.negate else 1.0 - shade
    occupied = spec.occupied_thresh < occ
    free = ~occupied & (occ < spec.free_thresh)
    table = np.full(occ.shape, UNKNOWN, dtype=np.int8)
    if spec.mode == "scale":
        low, high = spec.free_thresh, spec.occupied_thresh
        table[:] = np.rint((np.clip(occ, low, high) - low) / (high - low) * 100.0)
    table[occupied] = OCCUPIED
    table[free] = FREE
    return table


def cell_values(pixels: Pixels, spec: MapYaml) -> np.ndarray:
    """The OccupancyGrid values of an image's pixels (``int8``, row 0 at the *bottom*: the
    image's rows reversed), by nav2's rules."""
    colour, alpha, n = pixels.colour, pixels.alpha, pixels.channels
    if spec.mode == "trinary" and alpha is not None:
        key_type = np.uint16 if pixels.maxval < 256 else np.uint32
        colour = colour.astype(key_type) * (3 // n) + alpha  # R, G, B and the opacity
        n = 4
    values = np.take(rule_table(n, pixels.maxval, spec), colour[::-1])
    if spec.mode == "scale" and alpha is not None:
        values[alpha[::-1] != pixels.maxval] = UNKNOWN
    return values


def load_ros_map(
    path: str | os.PathLike, name: str | None = None, image: str | os.PathLike | None = None
) -> OccupancyMap:
    """The map of a ROS map_server YAML file and its image (PGM, PNG, ...), by nav2's rules.

    ``name`` (default: the YAML file's stem) names the map; ``image`` is read instead of the
    image the YAML file names (a file uploaded with it). Any fault of the file, its keys or its
    image raises :class:`~leapfrog_planner.errors.ScenarioError` with one line."""
    spec = read_map_yaml(path)
    if image is not None:
        spec = replace(spec, image=os.fspath(image))
    source = shown(str(path))
    try:
        pixels = read_pixels(spec.image)
    except ScenarioError as exc:
        _fail(source, "image", str(exc))
    data = cell_values(pixels, spec)
    data.setflags(write=False)
    return OccupancyMap(data, spec.resolution, spec.origin, name or Path(source).stem)
