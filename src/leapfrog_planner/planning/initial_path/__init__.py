"""Initial feasible paths for the Leapfrog method (spec section 2, step 1).

Leapfrog needs a collision-free path from start to goal, split into ``q`` segments. The initial
path decides which local optimum Leapfrog converges to (spec section 5), so this module returns
several paths that pass the obstacles on different sides, one per homotopy class, shortest first.

Method
------
1. Every obstacle disc ``[cx, cy, r]`` is inflated by ``margin`` (less for a disc that the start
   or goal lies closer to than ``margin``, so that neither end is ever inside an inflated disc).
   Discs inside other inflated discs are dropped.
2. The exact *tangent graph* of the inflated discs: its nodes are the tangent points of the
   lines from start and goal to each circle and of the four common tangents of each pair of
   circles; tangent points inside another inflated disc are dropped. Edges are the tangent
   segments that no inflated disc cuts (a vectorised segment-against-disc test) and the arcs
   between neighbouring tangent points on each circle that no other inflated disc covers. Each
   tangent point is two graph nodes, one per direction of travel round its circle (counter-
   clockwise or clockwise), and segments only join compatible directions, so every path of the
   directed graph is tangent-continuous (G1) and its shortest path from start to goal is the
   exact shortest path round the inflated discs. The search is Dijkstra's algorithm with the
   straight-line distance to the goal as (consistent) A* bound, compiled with numba: one search
   costs a few tens of microseconds, where a call of :func:`scipy.sparse.csgraph.dijkstra`
   costs about 0.1 ms of overhead alone, and step 3 needs up to 65 searches.
3. Other homotopy classes: for the (at most six) obstacles most relevant to the chord and the
   shortest path (centre projecting inside the chord, and ordered by the distance of the
   inflated disc to the chord or the shortest path, which must be less than that path's length),
   two barrier rays start at the centre, perpendicular to the chord, one to each side. Blocking
   one ray of each relevant obstacle, for all ``2**r`` sign patterns, and searching the remaining
   edges gives the shortest path that passes each relevant obstacle on the chosen side. The
   shortest path per *signature* is kept; paths longer than three times the shortest are
   dropped; the ``k`` shortest classes are returned, sorted by the length of their smoothed
   curves. A free straight chord is the graph's shortest path, so it comes first ("straight").
   When no path exists at all, the margin is halved (four times) and finally set to 0 before
   giving up; the label then says which margin was used.
4. Smoothing: the polyline (arcs sampled every 10 degrees) becomes a C1 cubic Hermite spline over
   cumulative chord length. The end derivatives are the unit heading vectors (so the curve leaves
   along the start heading and arrives along the goal heading, with a turn scaled by the first and
   last leg), the interior ones are Catmull-Rom central differences. A start (goal) heading more
   than 90 degrees off the first (last) leg gets a turning arc of radius a quarter of that leg
   first, since the cubic would turn very sharply there (and have a cusp at 180 degrees); the
   arc goes to the side that keeps the homotopy class. The spline's arclength is integrated by
   Gauss-Legendre quadrature on a dense grid and :meth:`InitialPath.curve` is parametrised by
   normalised arclength. When smoothing cuts into an obstacle (negative clearance), mid-leg
   points are inserted (twice at most) and the class is re-planned with twice and four times the
   margin (a tangent graph of the obstacles near the class's path only, five times the new
   margin at most away; the new path's class and clearance are checked against all obstacles);
   when nothing helps, the path with the best clearance is kept and its
   ``min_clearance`` shows the problem.

Signature
---------
``signature[j]`` is the winding number round obstacle ``j``'s centre of the closed loop "path,
then the straight chord back from goal to start": 0 when the path passes ``j`` on the same side as
the chord, +1 or -1 when it passes on the other side. For a centre exactly on the chord (where
the winding number is a half-integer) the half turn is rounded away from zero, so the two sides
give +1 and -1.
"""

from __future__ import annotations

from .ends import FORWARD, EndModes, end_modes, points_away
from .path import InitialPath
from .search import initial_paths, plot_initial_paths

__all__ = [
    "FORWARD",
    "EndModes",
    "InitialPath",
    "end_modes",
    "initial_paths",
    "plot_initial_paths",
    "points_away",
]
