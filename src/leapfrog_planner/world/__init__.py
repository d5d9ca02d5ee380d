"""The world the robot moves in: maps (ROS map_server occupancy grids), their smooth penalty
fields and the exact clearance against them.

- :mod:`.occupancy`: :class:`OccupancyMap`, the cells of a map and their place in the world.
- :mod:`.images`: the pixels of a map image (PGM read here, other formats by Pillow).
- :mod:`.ros_map`: :func:`load_ros_map`, a map_server YAML file and its image by nav2's rules;
  :mod:`.ros_map_write`: :func:`save_ros_map`, the other way.
- :mod:`.clearance`: :class:`MapClearance`, the exact distance from points to the blocked cells
  (closed squares) less the robot's radius.
- :mod:`.distance`: the exact signed distance transform of the blocked cells (squares);
  :mod:`.shapes`: :class:`Shapes`, polygons and walls and their exact signed distance.
- :mod:`.field`: the map's penalty field (smoothed, calibrated distance as a quintic B-spline)
  and its compiled evaluator; :mod:`.obstacle_map`: :class:`ObstacleMap`, a map's field and
  clearance for a robot's footprint.
- :mod:`.queries`: random start and goal pairs by the ROS 2 navigation stack's
  planner-benchmark protocol; :mod:`.synthetic`: seeded office, warehouse and shape-field maps.

This layer imports only the package's root modules (``errors``, ``checks``), NumPy, SciPy,
numba, PyYAML and Pillow. The disc obstacles' penalty is in :mod:`..model.penalty`, which adds
a map's field to the discs' sum.
"""

from .clearance import MapClearance, PathClearance
from .obstacle_map import ObstacleMap
from .occupancy import FREE, MAX_CELLS, OCCUPIED, UNKNOWN, OccupancyMap
from .queries import FreeSpace, MapQuery, random_queries
from .ros_map import MapYaml, load_ros_map, read_map_yaml
from .ros_map_write import save_ros_map
from .shapes import Shapes
from .synthetic import nonconvex_field, office_maze, warehouse

__all__ = [
    "FREE",
    "MAX_CELLS",
    "OCCUPIED",
    "UNKNOWN",
    "FreeSpace",
    "MapClearance",
    "MapQuery",
    "MapYaml",
    "ObstacleMap",
    "OccupancyMap",
    "PathClearance",
    "Shapes",
    "load_ros_map",
    "nonconvex_field",
    "office_maze",
    "random_queries",
    "read_map_yaml",
    "save_ros_map",
    "warehouse",
]
