"""Write an :class:`~.occupancy.OccupancyMap` as a ROS map_server map: a YAML file and a binary
PGM image beside it, which :func:`~.ros_map.load_ros_map` (and nav2's map_server) reads back
to the same cells.

The image is trinary, as nav2's ``map_saver`` writes it: free cells 254, occupied cells 0,
unknown cells 205 (grey), one byte a pixel, the map's last row at the top. The YAML file holds
``image`` (the PGM's name, in the same folder), ``mode: trinary``, ``resolution``, ``origin``
``[x, y, yaw]`` (exact: Python's shortest round-trip digits), ``negate: 0``,
``occupied_thresh: 0.65`` and ``free_thresh: 0.196``.

Why 0.196 and not nav2 map_saver's default 0.25: a pixel of 205 has ``occ = 1 - 205 / 255 =
0.1961``, below 0.25, so with ``free_thresh: 0.25`` nav2 reads the unknown cells it wrote back
as *free* (a known quirk, e.g. SteveMacenski/slam_toolbox#587). 0.196 is ROS 1 map_saver's
value (and that of navigation2's ``tb3_sandbox`` and planner-benchmark maps): 205 then reads as
unknown, 254 as free (``occ = 0.0039``) and 0 as occupied (``occ = 1``).

A trinary image has no room for the values between 1 and 99 (``scale`` maps): such a map is
refused rather than rounded silently. Files are written atomically (a temporary file in the
same folder, then a rename: never half a file), the image first, then the YAML file that names
it; existing files are replaced only with ``overwrite=True``. Every fault raises
:class:`~leapfrog_planner.errors.ScenarioError` with one line.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._atomic import write_atomic
from ..errors import ScenarioError
from .occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap

FREE_PIXEL = 254
OCCUPIED_PIXEL = 0
UNKNOWN_PIXEL = 205
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196  # not 0.25: grey 205 must read back as unknown (module docstring)


def pgm_bytes(occ: OccupancyMap) -> bytes:
    """The binary PGM (``P5``, maxval 255) of a map's cells, trinary (module docstring)."""
    data = occ.data
    between = np.count_nonzero((data != FREE) & (data != OCCUPIED) & (data != UNKNOWN))
    if between:
        raise ScenarioError(
            f"map {occ.name!r}: {between} cells hold values between 1 and 99, which a trinary"
            " image cannot keep (threshold the map first)"
        )
    pixels = np.full(data.shape, UNKNOWN_PIXEL, dtype=np.uint8)
    pixels[data == FREE] = FREE_PIXEL
    pixels[data == OCCUPIED] = OCCUPIED_PIXEL
    rows, cols = data.shape
    header = f"P5\n# CREATOR: leapfrog_planner {occ.resolution:.3f} m/pix\n{cols} {rows}\n255\n"
    return header.encode("ascii") + pixels[::-1].tobytes()  # the image's top row first


def yaml_text(occ: OccupancyMap, image: str) -> str:
    """The map_server YAML document of ``occ`` naming the image file ``image``."""
    import yaml

    doc = {
        "image": image,
        "mode": "trinary",
        "resolution": float(occ.resolution),
        "origin": [float(v) for v in occ.origin],
        "negate": 0,
        "occupied_thresh": OCCUPIED_THRESH,
        "free_thresh": FREE_THRESH,
    }
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)


def _write(path: Path, payload: bytes) -> None:
    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())

    write_atomic(path, write)


def save_ros_map(
    occ: OccupancyMap, yaml_path: str | os.PathLike, *, overwrite: bool = False
) -> tuple[Path, Path]:
    """Write ``occ`` as the map_server YAML file ``yaml_path`` and the PGM image beside it
    (the same name ending in ``.pgm``); returns both paths. Refuses to replace either file
    unless ``overwrite`` (module docstring)."""
    if not isinstance(occ, OccupancyMap):
        raise ScenarioError(f"occ: expected an OccupancyMap, got {type(occ).__name__}")
    yaml_path = Path(yaml_path)
    image = yaml_path.with_suffix(".pgm")
    if image == yaml_path:
        raise ScenarioError(f"{yaml_path}: the YAML file's name must not end in .pgm")
    for path in (image, yaml_path):
        if not overwrite and os.path.lexists(path):
            raise ScenarioError(f"{path}: exists already (pass overwrite=True to replace it)")
    payload = pgm_bytes(occ)  # checks the cells before anything is written
    text = yaml_text(occ, image.name)
    try:
        _write(image, payload)
        _write(yaml_path, text.encode("utf-8"))
    except OSError as exc:
        where = exc.filename or yaml_path
        raise ScenarioError(f"cannot write {where}: {exc.strerror or exc}") from None
    return yaml_path, image
