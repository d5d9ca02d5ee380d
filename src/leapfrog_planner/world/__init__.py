"""The world the robot moves in: maps (ROS map_server occupancy grids) and the exact clearance
against them.

- :mod:`.occupancy`: :class:`OccupancyMap`, the cells of a map and their place in the world.
- :mod:`.images`: the pixels of a map image (PGM read here, other formats by Pillow).
- :mod:`.ros_map`: :func:`load_ros_map`, a map_server YAML file and its image by nav2's rules.
- :mod:`.clearance`: :class:`MapClearance`, the exact distance from points to the blocked cells
  (closed squares) less the robot's radius.

This layer imports only the package's root modules (``errors``, ``checks``), NumPy, SciPy,
PyYAML and Pillow. The disc obstacles' penalty is still in :mod:`..model.penalty`.
"""

from .clearance import MapClearance, PathClearance
from .occupancy import FREE, MAX_CELLS, OCCUPIED, UNKNOWN, OccupancyMap
from .ros_map import MapYaml, load_ros_map, read_map_yaml

__all__ = [
    "FREE",
    "MAX_CELLS",
    "OCCUPIED",
    "UNKNOWN",
    "MapClearance",
    "MapYaml",
    "OccupancyMap",
    "PathClearance",
    "load_ros_map",
    "read_map_yaml",
]
