"""Maps (ROS map_server YAML + image) and the exact clearance against them: the two shipped
navigation2 maps, nav2's rules from pixels to cells (against a transcription of its loop), every
kind of bad input (one line, a ScenarioError), the yaw, and the clearance against brute force."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.world import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    MapClearance,
    OccupancyMap,
    load_ros_map,
    read_map_yaml,
)
from leapfrog_planner.world.clearance import boundary_cells
from leapfrog_planner.world.images import MAX_PLAIN_CELLS
from leapfrog_planner.world.occupancy import MAX_CELLS

MAPS = Path(__file__).parent / "data" / "maps"
KEYS = {"resolution": 0.5, "origin": [0.0, 0.0, 0.0], "negate": 0}
KEYS |= {"occupied_thresh": 0.65, "free_thresh": 0.25}


def write_pgm(path: Path, pixels, maxval: int = 255, plain: bool = False) -> Path:
    pixels = np.asarray(pixels)
    rows, cols = pixels.shape
    if plain:
        body = "\n".join(" ".join(str(int(v)) for v in row) for row in pixels)
        path.write_bytes(f"P2\n# a comment\n{cols} {rows}\n{maxval}\n{body}\n".encode())
    else:
        dtype = np.uint8 if maxval < 256 else ">u2"
        path.write_bytes(f"P5\n{cols} {rows}\n{maxval}\n".encode() + pixels.astype(dtype).tobytes())
    return path


def write_map(folder: Path, pixels=None, file: str = "m.pgm", **keys) -> Path:
    """A map's YAML file (image ``file``, ``KEYS``, then ``keys``; a key given as None is left
    out) and, if ``pixels`` are given, the image ``file`` (PGM, or by Pillow for a PNG)."""
    if pixels is not None:
        if file.endswith(".pgm"):
            write_pgm(folder / file, pixels)
        else:
            Image.fromarray(np.asarray(pixels, dtype=np.uint8)).save(folder / file)
    doc = {"image": file, **KEYS, **keys}
    path = folder / "m.yaml"
    path.write_text(yaml.safe_dump({k: v for k, v in doc.items() if v is not None}))
    return path


def load_error(path) -> str:
    with pytest.raises(ScenarioError) as info:
        load_ros_map(path)
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    assert "\n" not in message and message.startswith(f"{path}: "), message
    return message


# --------------------------------------------------------------------------- the shipped maps


def test_depot_loads_with_its_sizes_counts_and_places():
    m = load_ros_map(MAPS / "depot.yaml")
    assert m.name == "depot" and m.shape == (307, 604) and m.data.dtype == np.int8
    assert m.resolution == 0.05 and m.origin == (0.0, 0.0, 0.0)
    assert m.extent == pytest.approx((0.0, 30.2, 0.0, 15.35))
    # Its grey 205 (rack interiors) is p = 0.196 < free_thresh 0.25: free by its own YAML.
    assert m.counts() == {"free": 179481, "occupied": 5947, "unknown": 0, "between": 0}
    # The tilted rack in the image's upper half (pixel row 47, column 284 from the top left)
    # is at the top of the world; its mirror image below is open floor.
    assert m.value_at(14.225, 12.975) == OCCUPIED
    assert m.value_at(14.225, 15.35 - 12.975) == FREE
    assert m.value_at(5.0, 8.0) == FREE and m.value_at(0.1, 7.5) == OCCUPIED
    assert not m.data.flags.writeable


def test_tb3_sandbox_loads_with_its_unknown_surroundings():
    m = load_ros_map(MAPS / "tb3_sandbox.yaml")
    assert m.shape == (384, 384) and m.origin == (-10.0, -10.0, 0.0)
    assert m.counts() == {"free": 7903, "occupied": 870, "unknown": 138683, "between": 0}
    assert m.value_at(0.0, 2.5) == OCCUPIED  # the arena's top wall
    assert m.value_at(0.55, 0.55) == FREE  # between the pillars
    assert m.value_at(-8.0, -8.0) == UNKNOWN  # outside the arena
    assert m.value_at(0.0, 0.0) == UNKNOWN  # inside the middle pillar
    assert m.value_at(-10.5, 0.0) == UNKNOWN  # off the map
    assert read_map_yaml(MAPS / "tb3_sandbox.yaml").free_thresh == 0.196


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox"])
def test_cells_are_the_image_rows_reversed(name):
    """Row 0 of the map is the image's bottom row: checked against Pillow's pixels."""
    m = load_ros_map(MAPS / f"{name}.yaml")
    spec = read_map_yaml(MAPS / f"{name}.yaml")
    with Image.open(MAPS / f"{name}.pgm") as image:
        p = (255 - np.asarray(image, dtype=float)) / 255
    expected = np.where(p > spec.occupied_thresh, 100, np.where(p < spec.free_thresh, 0, -1))
    np.testing.assert_array_equal(m.data, expected[::-1])
    i, j = 10, 20  # the centre of a cell is where the cell is
    x, y = m.cell_center(i, j)
    assert m.cell_index(x, y) == (i, j) and m.value_at(x, y) == m.data[i, j]


# --------------------------------------------------------------------------- nav2's rules


def nav2_cell(rgb, alpha, has_alpha, mode, negate, occupied, free, maxval=255):
    """nav2_map_server's loadMapFromFile for one pixel, transcribed (map_io.cpp)."""
    channels = [int(v) for v in rgb]
    if mode == "trinary" and has_alpha:
        channels.append(int(alpha))  # MaxRGB - alphaQuantum(): the opacity
    shade = (sum(channels) / len(channels)) / maxval
    occ = shade if negate else 1.0 - shade
    if mode == "trinary":
        return 100 if occupied < occ else 0 if occ < free else -1
    if mode == "scale":
        if has_alpha and alpha != maxval:
            return -1
        if occupied < occ:
            return 100
        if occ < free:
            return 0
        return int(np.rint((occ - free) / (occupied - free) * 100.0))
    value = math.floor(shade * 255 + 0.5)  # std::round
    return value if 0 <= value <= 100 else -1


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
@pytest.mark.parametrize("thresholds", [(0.65, 0.25), (0.65, 0.196), (0.9, 0.1)])
def test_every_grey_level_follows_nav2(tmp_path, mode, negate, thresholds):
    grey = np.arange(256, dtype=np.uint8).reshape(16, 16)
    occupied, free = thresholds
    path = write_map(tmp_path, grey, mode=mode, negate=negate)
    path.write_text(path.read_text().replace("0.65", str(occupied)).replace("0.25", str(free)))
    m = load_ros_map(path)
    expected = [[nav2_cell((v, v, v), 0, False, mode, negate, occupied, free) for v in row]
                for row in grey.tolist()]  # fmt: skip
    np.testing.assert_array_equal(m.data, np.array(expected)[::-1])


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("channels", ["RGBA", "RGB", "LA"])
def test_colour_and_alpha_follow_nav2(tmp_path, mode, channels):
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, 256, (12, 20, len(channels)), dtype=np.uint8)
    if "A" in channels:
        pixels[..., -1][rng.random((12, 20)) < 0.6] = 255  # mostly opaque
    Image.fromarray(pixels, channels).save(tmp_path / "m.png")
    m = load_ros_map(write_map(tmp_path, image="m.png", mode=mode, negate=0))
    rgb = pixels[..., :3] if channels != "LA" else np.repeat(pixels[..., :1], 3, axis=-1)
    alpha = pixels[..., -1]
    has_alpha = "A" in channels
    expected = [
        [nav2_cell(rgb[r, c].tolist(), alpha[r, c], has_alpha, mode, 0, 0.65, 0.25)
         for c in range(20)] for r in range(12)
    ]  # fmt: skip
    np.testing.assert_array_equal(m.data, np.array(expected)[::-1])


def test_the_hand_made_scale_map():
    m = load_ros_map(MAPS / "scale.yaml")
    # Bottom row: grey 150 -> 40; alpha 0 and alpha 128 -> unknown; grey 30 -> occupied.
    # Top row: 255 and 200 -> free (p < 0.25); 100 -> p = 0.608 -> 89; 0 -> occupied.
    np.testing.assert_array_equal(m.data, [[40, -1, -1, 100], [0, 0, 89, 100]])
    assert m.counts()["between"] == 2


def test_other_pgm_depths_plain_pgm_and_case_of_the_mode(tmp_path):
    grey = np.array([[0, 5, 10, 15], [3, 4, 11, 12]])
    raw = [[nav2_cell((v, v, v), 0, False, "raw", 0, 0.65, 0.25, 15) for v in row]
           for row in grey.tolist()]  # fmt: skip
    assert np.array(raw).tolist() == [[0, 85, -1, -1], [51, 68, -1, -1]]  # v * 17 up to 100
    for plain in (False, True):
        write_pgm(tmp_path / "m.pgm", grey, maxval=15, plain=plain)
        m = load_ros_map(write_map(tmp_path, mode="Raw"))  # nav2 lowers the mode's case
        np.testing.assert_array_equal(m.data, np.array(raw)[::-1])
    wide = np.array([[0, 65535, 20000], [40000, 1, 65534]])
    write_pgm(tmp_path / "m.pgm", wide, maxval=65535)
    m = load_ros_map(write_map(tmp_path, negate=True))
    expected = [[nav2_cell((v, v, v), 0, False, "trinary", 1, 0.65, 0.25, 65535) for v in row]
                for row in wide.tolist()]  # fmt: skip
    np.testing.assert_array_equal(m.data, np.array(expected)[::-1])


def test_sixteen_bit_png_and_a_palette_with_a_transparent_entry(tmp_path):
    wide = np.array([[0, 65535, 20000], [40000, 1, 30000]], dtype=np.uint16)
    Image.fromarray(wide).save(tmp_path / "m.png")  # 16-bit grey
    m = load_ros_map(write_map(tmp_path, file="m.png"))
    expected = [[nav2_cell((v, v, v), 0, False, "trinary", 0, 0.65, 0.25, 65535) for v in row]
                for row in wide.tolist()]  # fmt: skip
    np.testing.assert_array_equal(m.data, np.array(expected)[::-1])
    palette = Image.fromarray(np.array([[0, 1, 2]], dtype=np.uint8), "P")
    palette.putpalette([0, 0, 0, 255, 255, 255, 120, 120, 120])
    palette.save(tmp_path / "m.png", transparency=1)  # white, but transparent
    scale = load_ros_map(write_map(tmp_path, file="m.png", mode="scale"))
    assert scale.data.tolist() == [[100, -1, round((135 / 255 - 0.25) / 0.4 * 100)]]
    # Trinary averages the opacity in: black (0 * 3 + 255) / 4 is occupied; transparent white
    # (255 * 3 + 0) / 4 gives occ = 0.25 exactly, not below free_thresh: unknown.
    trinary = load_ros_map(write_map(tmp_path, file="m.png"))
    assert trinary.data.tolist() == [[100, -1, -1]]


def test_the_image_is_found_next_to_the_yaml_file(tmp_path, monkeypatch):
    (tmp_path / "maps").mkdir()
    write_map(tmp_path / "maps", [[0, 255]])
    monkeypatch.chdir(tmp_path)
    assert load_ros_map("maps/m.yaml").data.tolist() == [[100, 0]]
    absolute = write_map(tmp_path, image=str(tmp_path / "maps" / "m.pgm"))
    assert load_ros_map(absolute).data.tolist() == [[100, 0]]


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("keys", "expected"),
    [
        ({"image": None}, "image: missing required key"),
        ({"resolution": None}, "resolution: missing required key"),
        ({"origin": None}, "origin: missing required key"),
        ({"negate": None}, "negate: missing required key"),
        ({"occupied_thresh": None}, "occupied_thresh: missing required key"),
        ({"free_thresh": None}, "free_thresh: missing required key"),
        ({"resolutoin": 0.1}, "resolutoin: unknown key (did you mean 'resolution'?"),
        ({"mode": "ternary"}, "mode: unknown mode 'ternary' (did you mean 'trinary'?"),
        ({"mode": 3}, "mode: expected one of trinary, scale, raw, got integer 3"),
        ({"image": 5}, "image: expected a file name, got integer 5"),
        ({"image": ""}, "image: expected a file name, got string ''"),
        ({"resolution": "0.05"}, "resolution: expected a number, got string '0.05'"),
        ({"resolution": 0}, "resolution: must be > 0, got 0.0"),
        ({"resolution": -0.05}, "resolution: must be > 0, got -0.05"),
        ({"resolution": float("nan")}, "resolution: must be finite, got nan"),
        ({"resolution": float("inf")}, "resolution: must be finite, got inf"),
        ({"resolution": 1e9}, "resolution: must be between 0 and 1e+06"),
        ({"origin": [0, 0]}, "origin: expected 3 numbers, got 2"),
        ({"origin": [0, 0, float("nan")]}, "origin[2]: must be finite, got nan"),
        ({"origin": "0 0 0"}, "origin: expected an array of 3 numbers [x, y, yaw]"),
        ({"origin": [1e7, 0, 0]}, "origin[0]: must be at most 1e+06 in size"),
        ({"negate": 2}, "negate: expected 0, 1, true or false, got integer 2"),
        ({"occupied_thresh": 1.5}, "occupied_thresh: must be between 0 and 1, got 1.5"),
        ({"free_thresh": -0.1}, "free_thresh: must be between 0 and 1, got -0.1"),
        ({"free_thresh": 0.7}, "free_thresh: must be below occupied_thresh (0.65), got 0.7"),
        ({"free_thresh": 0.65}, "free_thresh: must be below occupied_thresh (0.65), got 0.65"),
        ({"free_thresh": True}, "free_thresh: expected a number, got boolean true"),
    ],
)
def test_a_wrong_key_is_named_in_one_line(tmp_path, keys, expected):
    path = write_map(tmp_path, [[0, 255]], **keys)
    message = load_error(path)
    assert message.startswith(f"{path}: {expected}"), message


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("- image: m.pgm\n", "expected a mapping of the keys image, resolution"),
        ("", "expected a mapping of the keys image, resolution, origin, negate"),
        ("image: [unclosed\n", "invalid YAML: "),
        ("image: m.pgm\n  bad: indentation\n", "invalid YAML: mapping values are not allowed"),
        ("1: m.pgm\n", "keys must be strings, got integer 1"),
        ("origin: " + "[" * 20000 + "]" * 20000 + "\n", "invalid YAML"),
        ("resolution: 1" + "0" * 5000 + "\n", "invalid YAML"),
    ],
)
def test_a_file_that_is_not_a_map_yaml_is_refused(tmp_path, text, expected):
    path = tmp_path / "m.yaml"
    path.write_text(text)
    assert expected in load_error(path)


def test_not_utf8_a_huge_file_a_directory_and_no_file(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_bytes(b"image: \xff\xfe\x00m.pgm\n")
    assert "invalid YAML" in load_error(path)
    path.write_bytes(b"# padding\n" * 200_000)
    assert load_error(path).endswith("larger than 1024 kB, not a map's YAML file")
    assert "is a directory" in load_error(tmp_path)
    assert "cannot read file: No such file or directory" in load_error(tmp_path / "none.yaml")
    with pytest.raises(ScenarioError, match=r"^a\\0b.yaml: cannot read file: its name holds a NUL"):
        load_ros_map("a\0b.yaml")


def test_a_yaml_bomb_is_refused_at_once(tmp_path):
    """Billion laughs: 9^12 entries if the aliases were expanded; safe_load shares them."""
    laughs = ["&a0 [x, x, x, x, x, x, x, x, x]"]
    laughs += [f"&a{k} [{', '.join([f'*a{k - 1}'] * 9)}]" for k in range(1, 12)]
    path = tmp_path / "m.yaml"
    keys = yaml.safe_dump({"image": "m.pgm", **KEYS, "origin": None})
    path.write_text("".join(f"a{k}: {text}\n" for k, text in enumerate(laughs)))
    assert ": a0: unknown key (allowed: image, resolution" in load_error(path)
    path.write_text(keys.replace("origin: null", f"origin: [{', '.join(laughs)}]"))
    assert "origin: expected 3 numbers, got 12" in load_error(path)
    path.write_text(keys.replace("origin: null", f"origin: [{', '.join(laughs[:3])}]"))
    assert "origin[0]: expected a number, got an array of 9" in load_error(path)


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (None, "image: cannot read '{dir}/m.pgm': No such file or directory"),
        (b"not an image at all\n", "m.pgm': not an image of a known format (PGM, PNG"),
        (b"P5\n4 x\n255\n", "m.pgm': not a PGM image (header 'P5 4 x 255')"),
        (b"P5\n4 2\n255\n\x00\x00", "truncated PGM: 8 bytes of pixels expected, got 2"),
        (b"P5\n4 2\n0\n" + bytes(8), "PGM maxval must be 1..65535, got 0"),
        (b"P5\n4 2\n100\n" + bytes([200] * 8), "a pixel value 200 above maxval 100"),
        (b"P5\n0 2\n255\n", "empty image (0 x 2 pixels)"),
        (b"P5\n20000 20000\n255\n", "20000 x 20000 pixels is more than the limit of 1e+08 cells"),
        (b"P2\n2 2\n255\n0 1 2\n", "plain PGM: 4 values expected, found 3"),
        (b"P2\n2 2\n255\n0 1 x 2\n", "plain PGM: not a number at byte 4 of the raster"),
        (b"P2\n2 2\n255\n0 1 2 9999999\n", "plain PGM: a value too long at byte 6"),
        (b"P2\n2 2\n255\n0 1 2 256\n", "a pixel value 256 above maxval 255"),
        (b"P2\n2 2\n65535\n0 1 2 99999\n", "a pixel value 99999 above maxval 65535"),
        (b"P2\n5000 5000\n255\n", "5000 x 5000 pixels is more than the limit of 1e+07 cells"),
    ],
)
def test_a_bad_image_is_named_in_one_line(tmp_path, content, expected):
    if content is not None:
        (tmp_path / "m.pgm").write_bytes(content)
    message = load_error(write_map(tmp_path))
    assert expected.format(dir=tmp_path) in message, message


def test_png_trouble_is_one_line_too(tmp_path):
    noise = np.random.default_rng(0).integers(0, 256, (60, 80), dtype=np.uint8)
    Image.fromarray(noise).save(tmp_path / "m.png")
    raw = (tmp_path / "m.png").read_bytes()
    (tmp_path / "m.png").write_bytes(raw[: len(raw) // 2])
    assert "m.png': cannot decode the image (" in load_error(write_map(tmp_path, image="m.png"))
    (tmp_path / "m.png").write_bytes(huge_png(12_000, 10_000))
    message = load_error(write_map(tmp_path, image="m.png"))
    assert "12000 x 10000 pixels is more than the limit of 1e+08 cells" in message
    (tmp_path / "m.png").write_bytes(huge_png(30_000, 20_000))  # over Pillow's own limit
    message = load_error(write_map(tmp_path, image="m.png"))
    assert "m.png': more pixels than the limit of 1e+08 cells" in message


def huge_png(width: int, height: int) -> bytes:
    """A PNG header claiming ``width x height`` grey pixels, with a tiny (bad) pixel stream."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" * 99))


def test_limits_are_what_the_messages_say():
    assert MAX_CELLS == 10**8 and MAX_PLAIN_CELLS == 10**7


# --------------------------------------------------------------------------- the map record


def test_an_occupancy_map_checks_its_fields_and_owns_its_cells():
    cells = np.array([[0, 100], [-1, 50]], dtype=np.int16)
    m = OccupancyMap(cells, 0.5)
    cells[0, 0] = 100
    assert m.data.dtype == np.int8 and m.data[0, 0] == 0 and not m.data.flags.writeable
    bad = [
        (np.zeros((2, 2, 2), np.int8), 0.5, "data: expected a non-empty 2-D array"),
        (np.zeros((2, 2)), 0.5, "data: expected integers, got dtype float64"),
        (np.array([[101]]), 0.5, "data: values must be -1 (unknown) or 0..100, got 101"),
        (np.array([[-2]]), 0.5, "data: values must be -1 (unknown) or 0..100, got -2"),
        (np.zeros((2, 2), np.int8), 0.0, "resolution: must be > 0, got 0.0"),
    ]
    for data, resolution, expected in bad:
        with pytest.raises(ScenarioError, match=expected.replace("(", r"\(").replace(")", r"\)")):
            OccupancyMap(data, resolution)
    with pytest.raises(ScenarioError, match=r"origin: expected 3 numbers, got 2"):
        OccupancyMap(np.zeros((2, 2), np.int8), 1.0, (0.0, 0.0))
    with pytest.raises(ScenarioError, match=r"threshold: must be an integer >= 1, got 0"):
        m.blocked(threshold=0)
    with pytest.raises(ScenarioError, match=r"threshold: must be at most 100, got 101"):
        m.blocked(threshold=101)
    np.testing.assert_array_equal(m.blocked(), [[False, True], [True, False]])
    np.testing.assert_array_equal(m.blocked(False, threshold=50), [[False, True], [False, True]])


# --------------------------------------------------------------------------- the yaw


def test_the_yaw_turns_the_map_about_its_lower_left_corner():
    m = load_ros_map(MAPS / "tiny_yaw.yaml")
    assert m.origin == (1.0, -2.0, 0.5) and m.resolution == 0.5 and m.shape == (4, 6)
    # The image's bottom-left pixels (0, 0) and (0, 1) are occupied; top right (3, 4), (3, 5)
    # too; grey 128 at (2, 5) is unknown.
    np.testing.assert_array_equal(
        m.data,
        [
            [100, 100, 0, 0, 0, 0],
            [0, 100, 0, 0, 0, 0],
            [0, 100, 0, 0, 0, -1],
            [0, 0, 0, 0, 100, 100],
        ],
    )
    c, s = math.cos(0.5), math.sin(0.5)
    for i in range(4):
        for j in range(6):
            u, v = (j + 0.5) * 0.5, (i + 0.5) * 0.5  # the cell's centre, in the map's frame
            x, y = 1.0 + c * u - s * v, -2.0 + s * u + c * v
            assert m.value_at(x, y) == m.data[i, j]
            assert np.allclose(m.cell_center(i, j), (x, y), rtol=0, atol=1e-15)
    corners = [
        (1.0 + c * u - s * v, -2.0 + s * u + c * v) for u, v in [(0, 0), (3, 0), (3, 2), (0, 2)]
    ]
    xs, ys = zip(*corners, strict=True)
    assert m.extent == pytest.approx((min(xs), max(xs), min(ys), max(ys)), abs=1e-15)
    # 2.9 m along the world's x axis from the origin is under the turned map's bottom edge;
    # unturned, it would be in the bottom row.
    assert m.value_at(3.9, -1.9) == UNKNOWN and not m.contains(3.9, -1.9)
    assert OccupancyMap(m.data, 0.5, (1.0, -2.0, 0.0)).value_at(3.9, -1.9) == FREE


def test_clearance_is_the_same_at_corresponding_points_whatever_the_yaw():
    base = load_ros_map(MAPS / "tb3_sandbox.yaml")
    turned = OccupancyMap(base.data, base.resolution, (3.0, -1.0, 0.7))
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-20, 404, (2, 3000))
    for unknown in (True, False):
        a = MapClearance(base, unknown).distance(*base.grid_to_world(u, v))
        b = MapClearance(turned, unknown).distance(*turned.grid_to_world(u, v))
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-11)


# --------------------------------------------------------------------------- clearance


def polygon_distance(p, corners) -> tuple[np.ndarray, np.ndarray]:
    """For convex counterclockwise polygons ``corners`` (``(n, k, 2)``): whether ``p`` lies in
    each, and its distance to each one's edges."""
    a, b = corners, np.roll(corners, -1, axis=1)
    e, w = b - a, p - a
    inside = (e[..., 0] * w[..., 1] - e[..., 1] * w[..., 0] >= 0).all(axis=1)
    t = np.clip((w * e).sum(axis=-1) / (e * e).sum(axis=-1), 0.0, 1.0)
    gap = np.hypot(*np.moveaxis(a + t[..., None] * e - p, -1, 0)).min(axis=1)
    return inside, gap


def brute_distance(m: OccupancyMap, unknown_is_occupied: bool, x: float, y: float) -> float:
    """Distance from (x, y) to the blocked cells, each a turned square in world coordinates,
    and (unknown blocked) to the world off the map: polygons and segments, no grid frame."""
    x0, y0, yaw = m.origin
    c, s, h = math.cos(yaw), math.sin(yaw), m.resolution

    def world(u, v):
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        return np.stack([x0 + h * (c * u - s * v), y0 + h * (s * u + c * v)], axis=-1)

    p = np.array([x, y])
    best = math.inf
    i, j = np.nonzero(m.blocked(unknown_is_occupied))
    if i.size:
        squares = np.stack([world(j, i), world(j + 1, i), world(j + 1, i + 1), world(j, i + 1)], 1)
        inside, gap = polygon_distance(p, squares)
        best = float(np.where(inside, 0.0, gap).min())
    if unknown_is_occupied:
        rows, cols = m.shape
        rect = world([0, cols, cols, 0], [0, 0, rows, rows])[None]
        inside, gap = polygon_distance(p, rect)
        best = min(best, float(gap[0]) if inside[0] else 0.0)
    return best


def random_map(rng, rows, cols, density) -> OccupancyMap:
    data = np.zeros((rows, cols), np.int8)
    r = rng.random((rows, cols))
    data[r < density] = OCCUPIED
    data[(r >= density) & (r < 1.3 * density)] = UNKNOWN
    yaw = rng.choice([0.0, rng.uniform(-3.2, 3.2)])
    return OccupancyMap(data, rng.choice([1.0, 0.05, 0.37]), (*rng.uniform(-5, 5, 2), yaw))


def query_points(rng, m: OccupancyMap, n: int):
    rows, cols = m.shape
    u = rng.uniform(-3, cols + 3, n)
    v = rng.uniform(-3, rows + 3, n)
    u[: n // 4] = np.round(u[: n // 4])  # on cell edges and corners
    v[: n // 8] = np.round(v[: n // 8])
    u[n // 4 : n // 3] = np.floor(u[n // 4 : n // 3]) + 0.5  # at cell centres
    return m.grid_to_world(u, v)


@pytest.mark.parametrize("seed", range(8))
def test_clearance_matches_brute_force_on_random_maps(seed):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(1, 25, 2)
    m = random_map(rng, rows, cols, rng.choice([0.0, 0.02, 0.1, 0.4, 1.0]))
    x, y = query_points(rng, m, 150)
    for unknown in (True, False):
        got = MapClearance(m, unknown).distance(x, y)
        want = [
            brute_distance(m, unknown, a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)
        ]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_far_points_ask_for_more_neighbours_and_stay_exact():
    """A straight wall 1,000 cells away: many centres lie within the proof's slack, so the
    first eight candidates do not settle it. The distance is the gap to the wall's top side."""
    data = np.zeros((1200, 300), np.int8)
    data[0, :] = OCCUPIED
    m = OccupancyMap(data, 1.0)
    clear = MapClearance(m, unknown_is_occupied=False)
    u = np.linspace(0.5, 299.5, 50)
    v = np.full(50, 1100.25)
    np.testing.assert_array_equal(clear.grid_distance(u, v), v - 1.0)
    far = np.array([150.0, 1e6])
    assert clear.grid_distance(far[:1], far[1:])[0] == pytest.approx(1e6 - 1, rel=1e-15)


def test_footprint_paths_the_map_edge_and_empty_maps():
    data = np.zeros((10, 10), np.int8)
    data[4:6, 4:6] = OCCUPIED
    data[0, 9] = UNKNOWN
    m = OccupancyMap(data, 0.1, (-0.5, -0.5, 0.0))
    clear = MapClearance(m)  # unknown (and the world off the map) is blocked
    assert clear.distance(0.0, 0.0) == 0.0  # in the occupied block
    assert clear.distance(0.0, 0.15) == pytest.approx(0.05, abs=1e-15)
    assert clear.clearance(0.0, 0.15, radius=0.02) == pytest.approx(0.03, abs=1e-15)
    assert clear.distance(-0.45, 0.0) == pytest.approx(0.05, abs=1e-15)  # the map's edge
    assert clear.distance(-0.6, 0.0) == 0.0  # off the map
    assert MapClearance(m, unknown_is_occupied=False).distance(-0.6, 0.0) == pytest.approx(0.5)
    path = np.column_stack([np.linspace(-0.3, 0.3, 7), np.full(7, 0.25)])
    result = clear.path_clearance(path, radius=0.05)  # 0.15 above the block, 0.25 below the top
    assert result.minimum == pytest.approx(0.1) and result.worst in range(2, 5)
    assert result.is_clear() and result.is_clear(margin=0.09) and not result.is_clear(margin=0.2)
    np.testing.assert_allclose(result.values, clear.clearance(path[:, 0], path[:, 1], 0.05))
    free = OccupancyMap(np.zeros((3, 3), np.int8), 1.0)
    assert MapClearance(free, unknown_is_occupied=False).distance(1.0, 1.0) == math.inf
    assert MapClearance(free).distance(1.0, 1.2) == pytest.approx(1.0)
    with pytest.raises(ScenarioError, match="points: coordinates must be finite"):
        clear.distance([0.0, math.nan], 0.0)
    with pytest.raises(ScenarioError, match=r"radius: must be >= 0, got -1.0"):
        clear.clearance(0.0, 0.0, radius=-1.0)
    with pytest.raises(ScenarioError, match=r"points: expected an \(N, 2\) array"):
        clear.path_clearance(np.zeros((3, 3)))


def test_only_cells_with_a_free_side_can_be_nearest():
    blocked = np.zeros((5, 5), bool)
    blocked[1:4, 1:4] = True
    edge = boundary_cells(blocked, outside_blocked=True)
    assert edge.sum() == 8 and not edge[2, 2]
    full = np.ones((3, 3), bool)
    assert boundary_cells(full, outside_blocked=True).sum() == 0
    assert boundary_cells(full, outside_blocked=False).sum() == 8


def test_real_maps_clearance_matches_a_brute_force_over_all_their_cells():
    for name, unknown in (("tb3_sandbox", True), ("tb3_sandbox", False), ("depot", True)):
        m = load_ros_map(MAPS / f"{name}.yaml")
        clear = MapClearance(m, unknown)
        rng = np.random.default_rng(11)
        x0, x1, y0, y1 = m.extent
        x, y = rng.uniform(x0 - 1, x1 + 1, 200), rng.uniform(y0 - 1, y1 + 1, 200)
        x[:50], y[:50] = rng.uniform(-1.5, 1.5, (2, 50))  # among tb3's pillars
        i, j = np.nonzero(m.blocked(unknown))
        h, (ox, oy, _) = m.resolution, m.origin
        want = []
        for a, b in zip(x.tolist(), y.tolist(), strict=True):  # every blocked square
            du = np.maximum(np.abs((a - ox) / h - (j + 0.5)) - 0.5, 0.0)
            dv = np.maximum(np.abs((b - oy) / h - (i + 0.5)) - 0.5, 0.0)
            d = float(np.hypot(du, dv).min()) * h
            if unknown:  # the world off the map
                edge = min(a - x0, x1 - a, b - y0, y1 - b)
                d = min(d, max(edge, 0.0))
            want.append(d)
        np.testing.assert_allclose(clear.distance(x, y), want, rtol=0, atol=1e-12)
    assert clear.distance(14.225, 12.975) == 0.0  # depot's tilted rack


def test_a_large_map_answers_as_its_nearest_cells_say():
    """2000 x 2000 cells (walls and scattered cells): each answer is the distance to the
    nearest blocked square or to the map's edge, checked by brute force among the blocked cells
    near the point.
    (Times: benchmarks/bench_maps.py.)"""
    rng = np.random.default_rng(5)
    data = np.zeros((2000, 2000), np.int8)
    data[::200, :] = OCCUPIED
    data[:, ::250] = OCCUPIED
    data[rng.random((2000, 2000)) < 0.002] = OCCUPIED
    m = OccupancyMap(data, 0.05)
    clear = MapClearance(m)
    x, y = rng.uniform(0, 100, (2, 200))
    got = clear.distance(x, y)
    rows, cols = np.nonzero(data == OCCUPIED)
    cx, cy = (cols + 0.5) * 0.05, (rows + 0.5) * 0.05
    for xi, yi, d in zip(x, y, got, strict=True):
        near = np.hypot(cx - xi, cy - yi) < 12 * 0.05 + d  # every square that could be nearer
        dx = np.maximum(np.abs(cx[near] - xi) - 0.025, 0.0)
        dy = np.maximum(np.abs(cy[near] - yi) - 0.025, 0.0)
        outside = min(xi, 100.0 - xi, yi, 100.0 - yi)  # off the map: unknown, so blocked
        assert d == pytest.approx(min(np.hypot(dx, dy).min(initial=np.inf), outside), abs=1e-12)
