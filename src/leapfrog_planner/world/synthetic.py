"""Synthetic maps for benchmarks: an office floor plan, a warehouse, a field of non-convex shapes.

Each generator returns an :class:`~.occupancy.OccupancyMap` of ``size x size`` cells (1000 by
default, at least 1000, e.g. ``size=2000``) of ``resolution`` metres (0.05 by default: a
1000-cell map is 50 m square), origin ``(0, 0, 0)``, cells :data:`.FREE` or :data:`.OCCUPIED`
(no unknown ones). Every map has a closed outer wall, and every wall is ``wall`` metres thick
(0.15 m by default), at least 2 cells. Dimensions are given in metres and rounded to cells, so
a map at another resolution has the same layout in metres.

The same ``seed`` gives the same map, cell for cell (``numpy.random.default_rng(seed)``); a
2000 x 2000 map takes some tens of milliseconds.

Sizes. The defaults let a disc robot of radius 0.2 m (0.4 m wide) pass every opening with
room to spare: doors 1.0 m wide, aisles and cross aisles 2.4 m or more, gaps between shapes
at least 1.2 m. Narrower openings may be asked for, down to :data:`MIN_OPENING` (0.6 m).

* :func:`office_maze`: corridors 2 m wide cross the building and cut it into blocks; each
  block is cut into rooms by walls with a door (binary space partition), and each block has
  doors onto the corridors. Every room is reachable: the doors of a block's partition join its
  rooms, at least one door joins each block to a corridor, and the corridors cross each other.
* :func:`warehouse`: long rows of back-to-back racks with aisles between them, a few cross
  aisles cut through every row, a main aisle round the racks and a dock area along the bottom
  with building columns and pallets.
* :func:`nonconvex_field`: L, U and T shapes, stars and rings with gaps, turned at random, one
  per cell of a jittered grid (a few cells left empty), each inside a disc that keeps ``gap``
  from every other disc and from the outer wall: no two shapes touch, and a path may pass each
  one on either side (many homotopy classes). Slivers thinner than 2 cells (a star's tips,
  the rounding at a ring's edges) are shaved off: every obstacle is at least 2 cells thick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..errors import ScenarioError, require_integer
from .occupancy import OCCUPIED, OccupancyMap

DEFAULT_SIZE = 1000
MIN_SIZE = 1000
MAX_SIZE = 8000  # 64 million cells (the map's limit is 10^8)
RESOLUTION_RANGE = (0.01, 0.1)  # metres a cell: a 0.2 m robot spans at least 2 cells
MIN_OPENING = 0.6  # metres: the narrowest door, aisle or gap a generator accepts
MIN_WALL_CELLS = 2
SHAPES = ("L", "U", "T", "star", "ring")


# --------------------------------------------------------------------------- common


@dataclass
class _Canvas:
    """The occupied cells of a map being drawn (``occ[i, j]``, row 0 at the bottom), its
    resolution and wall thickness in cells, and the random generator."""

    occ: np.ndarray
    res: float
    wall: int
    rng: np.random.Generator

    def cells(self, metres: float) -> int:
        """A length in whole cells (at least 1)."""
        return max(1, int(round(metres / self.res)))

    def block(self, r0: int, r1: int, c0: int, c1: int) -> None:
        self.occ[r0:r1, c0:c1] = True

    def clear(self, r0: int, r1: int, c0: int, c1: int) -> None:
        self.occ[r0:r1, c0:c1] = False


def _canvas(size, resolution, seed, wall) -> _Canvas:
    """A map's empty canvas with its outer wall, every argument checked."""
    n = require_integer("size", size, MIN_SIZE, MAX_SIZE, error=ScenarioError)
    res = checks.real(resolution, "resolution", gt=0)
    checks.in_range(res, "resolution", *RESOLUTION_RANGE)
    seed = require_integer("seed", seed, 0, error=ScenarioError)
    wall = checks.real(wall, "wall", gt=0)
    checks.in_range(wall, "wall", 0.0, 1.0)
    t = max(MIN_WALL_CELLS, int(round(wall / res)))
    occ = np.zeros((n, n), dtype=bool)
    occ[:t, :] = occ[-t:, :] = occ[:, :t] = occ[:, -t:] = True
    return _Canvas(occ, res, t, np.random.default_rng(seed))


def _opening(value, key: str) -> float:
    """A door, aisle or gap width (metres), at least :data:`MIN_OPENING`."""
    x = checks.real(value, key, gt=0)
    return checks.in_range(x, key, MIN_OPENING, 100.0)


def _finish(canvas: _Canvas, name: str) -> OccupancyMap:
    data = canvas.occ.astype(np.int8) * np.int8(OCCUPIED)
    data.setflags(write=False)
    return OccupancyMap(data, canvas.res, (0.0, 0.0, 0.0), name)


# --------------------------------------------------------------------------- office


@dataclass
class _Region:
    """A rectangle of free cells ``[r0, r1) x [c0, c1)`` being cut into rooms, and the rows and
    columns where a wall may not meet its sides (next to a door), as half-open intervals."""

    r0: int
    r1: int
    c0: int
    c1: int
    no_rows: tuple = ()
    no_cols: tuple = ()


def _bands(lo: int, hi: int, spacing: int, width: int, rng) -> list[tuple[int, int]]:
    """Corridors ``[a, b)`` across ``[lo, hi)``: about one every ``spacing`` cells, evenly
    placed and jittered by up to a sixth of the spacing."""
    count = int(round((hi - lo) / spacing)) - 1
    if count <= 0:
        return []
    step = (hi - lo) / (count + 1)
    out = []
    for k in range(1, count + 1):
        centre = lo + k * step + rng.uniform(-step / 6, step / 6)
        a = int(round(centre - width / 2))
        out.append((a, a + width))
    return out


def _blocks(lo: int, hi: int, bands, wall: int) -> list[tuple[int, int, bool, bool]]:
    """The spans ``[s, e)`` of free cells between the corridors (``bands``) inside
    ``[lo, hi)``, less a wall on each side that faces a corridor, with whether the low and the
    high side face one."""
    edges = [(lo, False)] + [(b, True) for _, b in bands]
    ends = [(a, True) for a, _ in bands] + [(hi, False)]
    out = []
    for (s, low_corridor), (e, high_corridor) in zip(edges, ends, strict=True):
        out.append((s + wall * low_corridor, e - wall * high_corridor, low_corridor, high_corridor))
    return out


def _allowed(pos: int, wall: int, forbidden) -> bool:
    """Whether a wall ``[pos, pos + wall)`` misses every forbidden interval."""
    return all(pos + wall <= a or pos >= b for a, b in forbidden)


def _split(canvas: _Canvas, reg: _Region, sizes, across_rows: bool):
    """Cut ``reg`` by a wall with a door (rows if ``across_rows``: a horizontal wall): the two
    halves, or None when no place for the wall keeps the rooms large enough and off the
    doors. ``sizes`` = (smallest room, door width, door's distance from a wall's end)."""
    room_min, door, keep = sizes
    t, rng = canvas.wall, canvas.rng
    lo, hi = (reg.r0, reg.r1) if across_rows else (reg.c0, reg.c1)
    a, b = (reg.c0, reg.c1) if across_rows else (reg.r0, reg.r1)  # the wall's span
    if hi - lo < 2 * room_min + t or b - a < door + 2 * keep:
        return None
    forbidden = reg.no_rows if across_rows else reg.no_cols
    for _ in range(12):
        pos = int(rng.integers(lo + room_min, hi - room_min - t + 1))
        if _allowed(pos, t, forbidden):
            break
    else:
        return None
    d = int(rng.integers(a + keep, b - keep - door + 1))
    near_door = ((d - keep, d + door + keep),)
    if across_rows:
        canvas.block(pos, pos + t, a, b)
        canvas.clear(pos, pos + t, d, d + door)
        cols = reg.no_cols + near_door
        return (
            _Region(reg.r0, pos, a, b, reg.no_rows, cols),
            _Region(pos + t, reg.r1, a, b, reg.no_rows, cols),
        )
    canvas.block(a, b, pos, pos + t)
    canvas.clear(d, d + door, pos, pos + t)
    rows = reg.no_rows + near_door
    return (
        _Region(a, b, reg.c0, pos, rows, reg.no_cols),
        _Region(a, b, pos + t, reg.c1, rows, reg.no_cols),
    )


def _partition(canvas: _Canvas, block: _Region, sizes, room_max: int) -> list[_Region]:
    """Cut a block into rooms (binary space partition): a region longer than ``room_max``
    is always cut, one that could hold two rooms is cut half the time; the longer side is
    cut. Returns the rooms."""
    rooms, todo = [], [block]
    room_min = sizes[0]
    while todo:
        reg = todo.pop()
        h, w = reg.r1 - reg.r0, reg.c1 - reg.c0
        longest = max(h, w)
        want = longest > room_max or (
            longest >= 2 * room_min + canvas.wall and canvas.rng.random() < 0.5
        )
        halves = _split(canvas, reg, sizes, across_rows=h >= w) if want else None
        if halves is None:
            rooms.append(reg)
        else:
            todo.extend(halves)
    return rooms


def _corridor_doors(canvas: _Canvas, rooms, block: _Region, faces, sizes) -> None:
    """Doors from the rooms of ``block`` onto the corridors beside it: one for the first room
    (in random order) with a side on a corridor, and for each other such room with odds 3 in 5.
    ``faces`` says which block sides face a corridor: (bottom, top, left, right)."""
    _, door, keep = sizes
    t, rng = canvas.wall, canvas.rng
    first = True
    for k in rng.permutation(len(rooms)).tolist():
        room = rooms[k]
        on_block = {
            "bottom": room.r0 == block.r0,
            "top": room.r1 == block.r1,
            "left": room.c0 == block.c0,
            "right": room.c1 == block.c1,
        }
        sides = [side for side, on in on_block.items() if on and faces[side]]
        if not sides or not (first or rng.random() < 0.6):
            continue
        side = sides[int(rng.integers(len(sides)))]
        horizontal = side in ("bottom", "top")
        a, b = (room.c0, room.c1) if horizontal else (room.r0, room.r1)
        if b - a < door + 2 * keep:
            continue
        d = int(rng.integers(a + keep, b - keep - door + 1))
        at = {"bottom": room.r0 - t, "top": room.r1, "left": room.c0 - t, "right": room.c1}[side]
        if horizontal:
            canvas.clear(at, at + t, d, d + door)
        else:
            canvas.clear(d, d + door, at, at + t)
        first = False


def office_maze(
    size: int = DEFAULT_SIZE,
    resolution: float = 0.05,
    seed: int = 0,
    *,
    corridor_width: float = 2.0,
    corridor_spacing: float = 16.0,
    room_min: float = 3.5,
    room_max: float = 8.0,
    door_width: float = 1.0,
    wall: float = 0.15,
) -> OccupancyMap:
    """An office floor plan (module docstring): corridors ``corridor_width`` wide about every
    ``corridor_spacing`` metres both ways, rooms from ``room_min`` to about ``room_max``
    metres a side, doors ``door_width`` wide; every room is reachable from every other."""
    canvas = _canvas(size, resolution, seed, wall)
    cw = canvas.cells(_opening(corridor_width, "corridor_width"))
    door = canvas.cells(_opening(door_width, "door_width"))
    small = canvas.cells(checks.real(room_min, "room_min", gt=0))
    large = canvas.cells(checks.real(room_max, "room_max", gt=0))
    spacing = canvas.cells(checks.real(corridor_spacing, "corridor_spacing", gt=0))
    keep = max(canvas.wall, canvas.cells(0.3))  # a door keeps 0.3 m from a wall's end
    if small < door + 2 * keep or large < 2 * small:
        raise ScenarioError(
            "office_maze: room_min must exceed door_width + 0.6 m and room_max be at least "
            f"twice room_min, got room_min {room_min!r}, room_max {room_max!r}"
        )
    if spacing < 2 * small + cw:
        raise ScenarioError("corridor_spacing: must be at least 2 room_min + corridor_width")
    n, t = canvas.occ.shape[0], canvas.wall
    row_spans = _blocks(t, n - t, _bands(t, n - t, spacing, cw, canvas.rng), t)
    col_spans = _blocks(t, n - t, _bands(t, n - t, spacing, cw, canvas.rng), t)
    sizes = (small, door, keep)
    for r0, r1, low_r, high_r in row_spans:
        for c0, c1, low_c, high_c in col_spans:
            block = _Region(r0, r1, c0, c1)
            canvas.block(r0 - t, r1 + t, c0 - t, c1 + t)  # the block's walls ...
            canvas.clear(r0, r1, c0, c1)  # ... round its floor
            rooms = _partition(canvas, block, sizes, large)
            faces = {"bottom": low_r, "top": high_r, "left": low_c, "right": high_c}
            _corridor_doors(canvas, rooms, block, faces, sizes)
    return _finish(canvas, f"office_maze_{n}_s{seed}")


# --------------------------------------------------------------------------- warehouse


def _fits(occ: np.ndarray, r0: int, r1: int, c0: int, c1: int, gap: int) -> bool:
    """Whether the box ``[r0, r1) x [c0, c1)`` widened by ``gap`` cells is on the map and free."""
    rows, cols = occ.shape
    a, b, c, d = r0 - gap, r1 + gap, c0 - gap, c1 + gap
    return a >= 0 and c >= 0 and b <= rows and d <= cols and not occ[a:b, c:d].any()


def _rack_rows(canvas: _Canvas, lo: int, hi: int, depth: int, aisle: int) -> list[int]:
    """The bottom rows of the rack rows between rows ``lo`` and ``hi``: an aisle, a rack, an
    aisle, ... each aisle jittered by up to a tenth of its width (never narrower)."""
    starts, y = [], lo
    while True:
        y += aisle + int(canvas.rng.integers(0, aisle // 10 + 1))
        if y + depth + aisle > hi:
            return starts
        starts.append(y)
        y += depth


def _dock(canvas: _Canvas, top: int, left: int, right: int, gap: int) -> None:
    """The dock area (rows below ``top``): building columns (0.4 m square) every 8 m, and
    pallets (1.2 x 1.0 m) where each keeps ``gap`` cells from everything else."""
    t, rng = canvas.wall, canvas.rng
    col, step = canvas.cells(0.4), canvas.cells(8.0)
    if top - t > 2 * gap + col:
        mid = (t + top - col) // 2
        for c in range(left + step // 2, right - col, step):
            canvas.block(mid, mid + col, c, c + col)
    a, b = canvas.cells(1.2), canvas.cells(1.0)
    area = (top - t) * (right - left) * canvas.res**2
    for _ in range(int(area / 12.0)):
        h, w = (a, b) if rng.random() < 0.5 else (b, a)
        if top - h <= t or right - w <= left:
            return
        r = int(rng.integers(t, top - h))
        c = int(rng.integers(left, right - w))
        if _fits(canvas.occ, r, r + h, c, c + w, gap):
            canvas.block(r, r + h, c, c + w)


def warehouse(
    size: int = DEFAULT_SIZE,
    resolution: float = 0.05,
    seed: int = 0,
    *,
    aisle: float = 2.6,
    rack_depth: float = 1.2,
    cross_aisles: int | None = None,
    cross_width: float = 2.6,
    main_aisle: float = 3.0,
    dock: float = 8.0,
    wall: float = 0.15,
) -> OccupancyMap:
    """A warehouse (module docstring): rows of racks ``rack_depth`` deep (two shelves back to
    back) across the map, ``aisle`` metres apart, cut by ``cross_aisles`` cross aisles
    ``cross_width`` wide (default: one about every 15 m of rack); a main aisle ``main_aisle``
    wide along the walls and a dock area ``dock`` metres deep along the bottom."""
    canvas = _canvas(size, resolution, seed, wall)
    gap = canvas.cells(_opening(aisle, "aisle"))
    cross = canvas.cells(_opening(cross_width, "cross_width"))
    main = canvas.cells(_opening(main_aisle, "main_aisle"))
    depth = canvas.cells(checks.real(rack_depth, "rack_depth", gt=0))
    bay = canvas.cells(checks.real(dock, "dock", ge=0))
    n, t, rng = canvas.occ.shape[0], canvas.wall, canvas.rng
    left, right = t + main, n - t - main
    if cross_aisles is None:  # one about every 15 m of rack
        cross_aisles = max(1, math.ceil((right - left) * canvas.res / 15.0) - 1)
    count = require_integer("cross_aisles", cross_aisles, 0, 50, error=ScenarioError)
    top = t + bay
    if right - left < (count + 1) * 2 * cross:
        raise ScenarioError(f"cross_aisles: {count} do not fit in a {n}-cell map")
    step = (right - left) / (count + 1)
    jitter = rng.uniform(-step / 6, step / 6, size=count)
    xs = [int(round(left + (k + 1) * step + jitter[k] - cross / 2)) for k in range(count)]
    for y in _rack_rows(canvas, top, n - t - main + gap, depth, gap):
        canvas.block(y, y + depth, left, right)
        for x in xs:
            canvas.clear(y, y + depth, x, x + cross)
    if bay:
        _dock(canvas, top, left, right, canvas.cells(_opening(1.2, "gap")))
    return _finish(canvas, f"warehouse_{n}_s{seed}")


# --------------------------------------------------------------------------- field of shapes


def _bars(kind: str, r: float, w: float) -> list[tuple[float, float, float, float]]:
    """The rectangles ``(x0, x1, y0, y1)`` of an L, U or T inside the disc of radius ``r``
    (metres, about its centre), arms ``w`` thick."""
    h = r / math.sqrt(2.0)  # the corners (+-h, +-h) lie on the disc
    if kind == "L":
        return [(-h, h, -h, -h + w), (-h, -h + w, -h, h)]
    if kind == "U":
        return [(-h, h, -h, -h + w), (-h, -h + w, -h, h), (h - w, h, -h, h)]
    return [(-h, h, h - w, h), (-w / 2, w / 2, -h, h)]  # T


def _star(x: np.ndarray, y: np.ndarray, r: float, points: int) -> np.ndarray:
    """Whether points lie in a star of ``points`` tips of radius ``r`` and notches at ``r/2``
    (its outline joins tips and notches by straight sides)."""
    sector = math.pi / points
    phi = np.mod(np.arctan2(y, x), 2 * math.pi)
    k = np.floor(phi / sector)
    r_a = np.where(k % 2 == 0, r, 0.5 * r)  # tips at even multiples of the sector
    r_b = np.where(k % 2 == 0, 0.5 * r, r)
    ax, ay = r_a * np.cos(k * sector), r_a * np.sin(k * sector)
    bx, by = r_b * np.cos((k + 1) * sector), r_b * np.sin((k + 1) * sector)
    side = (bx - ax) * (y - ay) - (by - ay) * (x - ax)  # > 0: on the centre's side
    return side >= 0


def _ring(x: np.ndarray, y: np.ndarray, r: float, w: float, gaps, opening: float) -> np.ndarray:
    """Whether points lie in a ring of outer radius ``r``, ``w`` thick, open at the angles
    ``gaps`` by openings at least ``opening`` wide at the inner edge."""
    rho = np.hypot(x, y)
    inner = r - w
    half = math.asin(min(1.0, opening / (2.0 * inner)))  # half the angle of an opening
    inside = (rho >= inner) & (rho <= r)
    phi = np.arctan2(y, x)
    for g in gaps:
        inside &= np.abs(np.angle(np.exp(1j * (phi - g)))) > half
    return inside


def _shape(canvas: _Canvas, centre, r: float, w: float, gap: float) -> None:
    """Draw a random shape (of :data:`SHAPES`) of radius ``r`` about ``centre`` (metres)."""
    rng, res = canvas.rng, canvas.res
    kind = SHAPES[int(rng.integers(len(SHAPES)))]
    turn = rng.uniform(0.0, 2 * math.pi)
    points = int(rng.integers(5, 8))
    n_gaps = int(rng.integers(1, 4))
    gaps = turn + 2 * math.pi * np.arange(n_gaps) / n_gaps
    cx, cy = centre
    i0, i1 = int((cy - r) / res), int(math.ceil((cy + r) / res))
    j0, j1 = int((cx - r) / res), int(math.ceil((cx + r) / res))
    jj, ii = np.meshgrid(np.arange(j0, j1), np.arange(i0, i1))
    dx, dy = (jj + 0.5) * res - cx, (ii + 0.5) * res - cy
    c, s = math.cos(turn), math.sin(turn)
    x, y = c * dx + s * dy, c * dy - s * dx  # in the shape's own frame
    if kind == "star":
        mask = _star(x, y, r, points)
    elif kind == "ring":
        mask = _ring(x, y, r, w, gaps, gap)
    else:
        mask = np.zeros(x.shape, dtype=bool)
        for x0, x1, y0, y1 in _bars(kind, r, w):
            mask |= (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    from scipy import ndimage  # only here: SciPy's image module takes 0.15 s to import

    mask &= np.hypot(dx, dy) <= r  # never beyond the disc, whatever the rounding
    mask = ndimage.binary_opening(mask, structure=np.ones((2, 2), dtype=bool))  # no slivers
    canvas.occ[i0:i1, j0:j1] |= mask


def nonconvex_field(
    size: int = DEFAULT_SIZE,
    resolution: float = 0.05,
    seed: int = 0,
    *,
    gap: float = 1.2,
    radius: tuple[float, float] = (1.5, 2.5),
    thickness: float = 0.4,
    empty: float = 0.15,
    wall: float = 0.15,
) -> OccupancyMap:
    """A field of non-convex shapes (module docstring): radii drawn in ``radius`` (metres),
    arms and rings ``thickness`` thick, at least ``gap`` between any two and from the outer
    wall; a share ``empty`` of the grid's places is left empty."""
    canvas = _canvas(size, resolution, seed, wall)
    gap = _opening(gap, "gap")
    r_lo, r_hi = (checks.real(v, f"radius[{k}]", gt=0) for k, v in enumerate(radius))
    w = checks.real(thickness, "thickness", gt=0)
    checks.in_range(checks.real(empty, "empty", ge=0), "empty", 0.0, 1.0)
    if not (2 * canvas.res <= w and 2 * w + gap <= math.sqrt(2.0) * r_lo and r_lo <= r_hi):
        raise ScenarioError(
            "nonconvex_field: need thickness >= 2 cells, radius[0] <= radius[1], and a U's"
            " pocket (radius[0] * sqrt(2) - 2 thickness) at least gap wide, got radius"
            f" {tuple(radius)!r}, thickness {w!r}, gap {gap!r}"
        )
    n, rng = canvas.occ.shape[0], canvas.rng
    inner = (n - 2 * canvas.wall) * canvas.res  # metres of floor across
    pitch = 2 * r_hi + gap
    count = int((inner - gap) // pitch)
    if count < 1:
        raise ScenarioError(f"radius: shapes of {r_hi!r} m do not fit in a {n}-cell map")
    start = canvas.wall * canvas.res + gap / 2 + (inner - gap - count * pitch) / 2
    for a in range(count):
        for b in range(count):
            r = rng.uniform(r_lo, r_hi)
            slack = r_hi - r  # how far the centre may move and keep the gap
            jitter = rng.uniform(-slack, slack, size=2)
            if rng.random() < empty:
                continue
            centre = (start + (b + 0.5) * pitch + jitter[0], start + (a + 0.5) * pitch + jitter[1])
            _shape(canvas, centre, r, w, gap)
    return _finish(canvas, f"nonconvex_field_{n}_s{seed}")
