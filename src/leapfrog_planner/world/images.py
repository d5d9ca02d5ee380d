"""The pixels of a map image, as ROS's map_server reads them: the colour channels and the
alpha channel, row 0 at the *top* (the image's own order).

PGM (binary ``P5`` and plain ``P2``, any ``maxval`` up to 65535) is read here, exactly: a
value ``v`` is ``v / maxval`` of white. Every other format (PNG, BMP, ...) is read by Pillow.
The size is checked from the header before any pixel is decoded (:data:`.MAX_CELLS`).
Every fault raises :class:`~leapfrog_planner.errors.ScenarioError` with one line.
"""

from __future__ import annotations

import os
import stat
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ScenarioError, short
from .occupancy import MAX_CELLS

#: A plain (ASCII) PGM takes some 50 bytes of memory a cell to parse: it is held to fewer cells.
MAX_PLAIN_CELLS = 10**7
PLAIN_BYTES_PER_VALUE = 12  # the raster read of a plain PGM: up to 12 bytes a value
#: The formats Pillow may open (PGM is read here): PNG, the rest of Netpbm, BMP, TIFF, GIF, JPEG.
PILLOW_FORMATS = ("PNG", "PPM", "BMP", "TIFF", "GIF", "JPEG")
HEADER_BYTES = 1 << 16  # a PGM header (with its comments) longer than this is refused
WHITESPACE = b" \t\n\v\f\r"


@dataclass(frozen=True, eq=False)
class Pixels:
    """An image's pixels. ``colour`` is the sum of the colour channels of each pixel
    (``channels`` of them: 1 for grey, 3 for colour), ``alpha`` the opacity channel (None when
    the image has none), both ``(rows, columns)`` integer arrays, row 0 at the top; a channel
    runs from 0 to ``maxval`` (white, opaque)."""

    colour: np.ndarray
    channels: int
    maxval: int
    alpha: np.ndarray | None = None


def read_pixels(path: str) -> Pixels:
    """The pixels of the image file ``path`` (a PGM by its magic number, else by Pillow)."""
    name = short(path, 200)
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ScenarioError(f"cannot read {name}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ScenarioError(f"{name} is not a regular file")
    try:
        with open(path, "rb") as f:
            head = f.read(HEADER_BYTES)
            if head[:2] in (b"P5", b"P2"):
                return _read_pgm(f, head, name)
    except OSError as exc:
        raise ScenarioError(f"cannot read {name}: {exc.strerror or exc}") from None
    return _read_with_pillow(path, name)


def check_size(width: int, height: int, name: str, limit: int = MAX_CELLS) -> None:
    if width <= 0 or height <= 0:
        raise ScenarioError(f"{name}: empty image ({width} x {height} pixels)")
    if width * height > limit:
        raise ScenarioError(
            f"{name}: {width} x {height} pixels is more than the limit of {limit:.0e} cells"
        )


# --------------------------------------------------------------------------- PGM


def _pgm_header(head: bytes, name: str) -> tuple[bytes, int, int, int, int]:
    """``(magic, width, height, maxval, offset of the raster)``; '#' comments are skipped."""
    tokens, pos = [], 0
    while len(tokens) < 4:
        while pos < len(head) and head[pos] in WHITESPACE:
            pos += 1
        if head[pos : pos + 1] == b"#":
            ends = [k for k in (head.find(b"\n", pos), head.find(b"\r", pos)) if k >= 0]
            pos = min(ends) if ends else len(head)
            continue
        start = pos
        while pos < len(head) and head[pos] not in WHITESPACE and head[pos] != ord("#"):
            pos += 1
        if pos == start or pos >= len(head):
            raise ScenarioError(f"{name}: not a PGM image (its header ends early)")
        tokens.append(head[start:pos])
    numbers = tokens[1:]
    if tokens[0] not in (b"P5", b"P2") or not all(t.isdigit() and len(t) <= 9 for t in numbers):
        words = b" ".join(tokens).decode("latin-1")
        raise ScenarioError(f"{name}: not a PGM image (header {short(words)})")
    if head[pos] not in WHITESPACE:
        raise ScenarioError(f"{name}: not a PGM image (no whitespace after maxval)")
    width, height, maxval = (int(t) for t in numbers)
    if not 0 < maxval <= 65535:
        raise ScenarioError(f"{name}: PGM maxval must be 1..65535, got {maxval}")
    return tokens[0], width, height, maxval, pos + 1  # one whitespace byte ends the header


def _read_pgm(f, head: bytes, name: str) -> Pixels:
    magic, width, height, maxval, offset = _pgm_header(head, name)
    limit = MAX_CELLS if magic == b"P5" else MAX_PLAIN_CELLS
    check_size(width, height, name, limit)
    count = width * height
    f.seek(offset)
    if magic == b"P5":
        size = 1 if maxval < 256 else 2
        raw = f.read(count * size)
        if len(raw) < count * size:
            raise ScenarioError(
                f"{name}: truncated PGM: {count * size} bytes of pixels expected, got {len(raw)}"
            )
        values = np.frombuffer(raw, dtype=np.uint8 if size == 1 else ">u2")
    else:
        values = _plain_values(f.read(PLAIN_BYTES_PER_VALUE * count + HEADER_BYTES), count, name)
    if maxval not in (255, 65535) or magic == b"P2":
        if int(values.max()) > maxval:
            raise ScenarioError(f"{name}: a pixel value {int(values.max())} above maxval {maxval}")
    values = values.astype(np.uint8 if maxval < 256 else np.uint16, copy=False)
    return Pixels(values.reshape(height, width), 1, maxval)


def _plain_values(raw: bytes, count: int, name: str) -> np.ndarray:
    """The first ``count`` whitespace-separated decimal values of a plain PGM's raster."""
    b = np.frombuffer(raw, dtype=np.uint8)
    digit = (b >= ord("0")) & (b <= ord("9"))
    other = ~digit & ~np.isin(b, np.frombuffer(WHITESPACE, dtype=np.uint8))
    edges = np.diff(digit.astype(np.int8), prepend=np.int8(0), append=np.int8(0))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size < count:
        if other.any():
            at = int(np.argmax(other))
            raise ScenarioError(f"{name}: plain PGM: not a number at byte {at} of the raster")
        raise ScenarioError(
            f"{name}: plain PGM: {count} values expected, found {starts.size} in {b.size} bytes"
        )
    if other[: ends[count - 1]].any():
        at = int(np.argmax(other))
        raise ScenarioError(f"{name}: plain PGM: not a number at byte {at} of the raster")
    starts, lengths = starts[:count], ends[:count] - starts[:count]
    if lengths.max() > 5:
        at = int(starts[np.argmax(lengths > 5)])
        raise ScenarioError(f"{name}: plain PGM: a value too long at byte {at} of the raster")
    values = np.zeros(count, dtype=np.int64)
    for k in range(int(lengths.max())):
        has = lengths > k
        values[has] = values[has] * 10 + (b[starts[has] + k] - ord("0"))
    return values


# --------------------------------------------------------------------------- Pillow


def _open_with_pillow(path: str, name: str):
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            return Image.open(path, formats=PILLOW_FORMATS)
    except Image.DecompressionBombError:
        raise ScenarioError(
            f"{name}: more pixels than the limit of {MAX_CELLS:.0e} cells"
        ) from None
    except UnidentifiedImageError:
        known = ", ".join(("PGM", *PILLOW_FORMATS))
        raise ScenarioError(f"{name}: not an image of a known format ({known})") from None
    except (OSError, ValueError, SyntaxError, EOFError) as exc:
        raise ScenarioError(f"{name}: not a readable image ({_one_line(exc)})") from None


def _one_line(exc: BaseException) -> str:
    return short(" ".join(str(exc).split()) or type(exc).__name__, 120).strip("'\"")


def _read_with_pillow(path: str, name: str) -> Pixels:
    from PIL import Image

    image = _open_with_pillow(path, name)
    with image:
        width, height = image.size
        check_size(width, height, name)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                image.load()
                return _pillow_pixels(image, name)
        except ScenarioError:
            raise
        except (OSError, ValueError, SyntaxError, EOFError, MemoryError) as exc:
            raise ScenarioError(f"{name}: cannot decode the image ({_one_line(exc)})") from None


def _pillow_pixels(image, name: str) -> Pixels:
    """The channels of a loaded Pillow image: grey or colour, 8 or 16 bits, with or without
    alpha (a palette's or a single colour's transparency is an alpha channel, as for nav2)."""
    mode = image.mode
    if "transparency" in image.info or mode in ("PA", "La"):
        image, mode = image.convert("RGBA"), "RGBA"
    elif mode in ("1", "P"):
        image, mode = image.convert("RGB" if mode == "P" else "L"), "RGB" if mode == "P" else "L"
    if mode.startswith("I"):  # 16-bit grey (I;16 and variants, or I from older Pillow)
        values = np.asarray(image)
        if values.size and (int(values.min()) < 0 or int(values.max()) > 65535):
            raise ScenarioError(f"{name}: pixel values outside 0..65535 (mode {mode})")
        return Pixels(values.astype(np.uint16), 1, 65535)
    if mode not in ("L", "LA", "RGB", "RGBA"):
        if mode == "F":
            raise ScenarioError(f"{name}: floating-point images are not map images")
        image, mode = image.convert("RGB"), "RGB"
    values = np.asarray(image)
    if mode == "L":
        return Pixels(values, 1, 255)
    if mode == "LA":
        return Pixels(values[..., 0].copy(), 1, 255, values[..., 1].copy())
    colour = values[..., :3].sum(axis=-1, dtype=np.uint16)
    alpha = values[..., 3].copy() if mode == "RGBA" else None
    return Pixels(colour, 3, 255, alpha)
