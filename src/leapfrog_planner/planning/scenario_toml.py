"""TOML text of a scenario's values: strings escaped, floats written to read back exactly, and
headings that are fractions of pi marked in a comment (``start = [0.0, 0.0, 1.5707963267948966]
# pi/2``)."""

from __future__ import annotations

import math
import re
from typing import Any

BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def toml_string(s: str) -> str:
    short = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f"}
    short["\r"] = "\\r"
    out = []
    for ch in s:
        if ch in short:
            out.append(short[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(k: str) -> str:
    return k if BARE_KEY.fullmatch(k) else toml_string(k)


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest text that reads back to the same double
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")  # pragma: no cover


def pi_fraction(theta: float) -> str | None:
    """``"pi/2"``, ``"-3pi/4"``... when ``theta`` is exactly that double, else ``None``."""
    if theta == 0.0 or not abs(theta) <= 8 * math.pi:
        return None
    for q in (1, 2, 3, 4, 6, 8, 12):
        p = round(theta * q / math.pi)
        if p and math.gcd(p, q) == 1 and abs(p) <= 8 * q and p * math.pi / q == theta:
            sign = "-" if p < 0 else ""
            num = "" if abs(p) == 1 else str(abs(p))
            return f"{sign}{num}pi" + ("" if q == 1 else f"/{q}")
    return None


def toml_state(key: str, state: list[float]) -> str:
    line = f"{key} = {toml_value(state)}"
    frac = pi_fraction(state[2])
    return line + f"  # {frac}" if frac else line
