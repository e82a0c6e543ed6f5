"""The code table: what each stable actuator code does to the next module (thesis Tables 4.1 and 4.2).

Each module carries four nitinol actuators numbered 1-4 around its axis,
actuator ``k`` at azimuth ``45 deg + (k-1) 90 deg`` from the local ``x`` axis
toward ``y``. A module's code is a 4-bit number with bit ``k-1`` set when
actuator ``k`` is on. Raising two neighbouring actuators raises that side,
which tips the next module away from it: a right-hand rotation by alpha about
one signed local axis. All four raise it straight by the actuator stroke (the
lift). Only these six codes are stable.

:data:`TABLE` is written once, here; everything else is derived from it: the
constants and lookup arrays below (the compiled kernels index them), the
checks and CSV reading of :mod:`bhr.model._codes`, the table in the documentation
(:func:`markdown_table`, held equal to ``docs/conventions.md`` by a test) and
the firmware's header (:mod:`bhr._hardware.firmware_header`).

The kernels number the five shapes a joint can take in *search order*: 0 rest,
then the tilts about +x, +y, -x, -y (1..4); :data:`SEARCH_CODES` maps that
index to the code and :data:`SEARCH_INDEX` back.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

__all__ = ["CodeRow", "TABLE", "REST", "LIFT", "VALID_CODES", "TILT_CODES", "CODE_AXIS", "SEARCH_CODES",
           "SEARCH_INDEX", "SEARCH_AXIS", "SEARCH_SIGN", "SEARCH_INVERSE", "LIFT_OF", "markdown_table"]


@dataclass(frozen=True)
class CodeRow:
    """One stable code: the actuators it switches on and the motion of the next module."""

    actuators: tuple[int, ...]  # 1-4, in order around the module
    motion: str  # "rest", "tilt" or "lift"
    axis: int = -1  # tilts: 0 = local x, 1 = local y
    sign: int = 0  # tilts: +1 or -1

    @property
    def code(self) -> int:
        return sum(1 << (k - 1) for k in self.actuators)


#: The stable codes in search order: rest, tilt about +x, +y, -x, -y, lift.
TABLE: tuple[CodeRow, ...] = (
    CodeRow((), "rest"),
    CodeRow((1, 2), "tilt", 0, +1),
    CodeRow((2, 3), "tilt", 1, +1),
    CodeRow((3, 4), "tilt", 0, -1),
    CodeRow((4, 1), "tilt", 1, -1),
    CodeRow((1, 2, 3, 4), "lift"),
)

REST: int = next(r.code for r in TABLE if r.motion == "rest")
LIFT: int = next(r.code for r in TABLE if r.motion == "lift")
#: The stable codes, in the order of :data:`TABLE`.
VALID_CODES: tuple[int, ...] = tuple(r.code for r in TABLE)
#: Tilt codes by signed axis: +x, +y, -x, -y.
TILT_CODES: tuple[int, ...] = tuple(r.code for r in TABLE if r.motion == "tilt")
#: For each tilt code, (axis index 0 = x / 1 = y, sign +1 / -1).
CODE_AXIS: dict[int, tuple[int, int]] = {r.code: (r.axis, r.sign) for r in TABLE if r.motion == "tilt"}

_SHAPES = tuple(r for r in TABLE if r.motion != "lift")  # what a joint can do, in search order

if TYPE_CHECKING:
    #: Search index (0 rest, 1..4 tilt about +x, +y, -x, -y) -> code.
    SEARCH_CODES: np.ndarray
    #: Code (0..15) -> search index; the lift bends nothing (0); unstable codes -1.
    SEARCH_INDEX: np.ndarray
    #: Search index -> tilt axis (0 x, 1 y; -1 for rest) and sign (+1.0, -1.0; 0.0 for rest).
    SEARCH_AXIS: np.ndarray
    SEARCH_SIGN: np.ndarray
    #: Search index -> the index of the opposite tilt (same axis, other sign); rest stays rest.
    SEARCH_INVERSE: np.ndarray
    #: Code (0..15) -> 1.0 when it lifts the next module by the stroke, else 0.0.
    LIFT_OF: np.ndarray

_ARRAYS = ("SEARCH_CODES", "SEARCH_INDEX", "SEARCH_AXIS", "SEARCH_SIGN", "SEARCH_INVERSE", "LIFT_OF")


def _arrays() -> dict[str, Any]:
    """The kernels' read-only arrays of the table (numpy imported for them on first use: a code check needs none)."""
    import numpy as np

    search_index = np.full(16, -1, dtype=np.int64)
    for k, row in enumerate(_SHAPES):
        search_index[row.code] = k
    search_index[LIFT] = 0
    lift_of = np.zeros(16, dtype=np.float64)
    lift_of[LIFT] = 1.0
    out = {
        "SEARCH_CODES": np.array([r.code for r in _SHAPES], dtype=np.int64),
        "SEARCH_INDEX": search_index,
        "SEARCH_AXIS": np.array([r.axis for r in _SHAPES], dtype=np.int64),
        "SEARCH_SIGN": np.array([float(r.sign) for r in _SHAPES], dtype=np.float64),
        "SEARCH_INVERSE": np.array([next((j for j, o in enumerate(_SHAPES) if o.motion == "tilt" and o.axis == r.axis
                                          and o.sign == -r.sign), k) for k, r in enumerate(_SHAPES)], dtype=np.int64),
        "LIFT_OF": lift_of,
    }
    for a in out.values():
        a.setflags(write=False)
    return out


def __getattr__(name: str) -> Any:  # PEP 562: the arrays are made on first use
    if name in _ARRAYS:
        globals().update(_arrays())
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

_AXIS_NAMES = ("x", "y")


def markdown_table() -> str:
    """The code table as it appears in the documentation (a Markdown table)."""
    lines = ["| code | binary | actuators on | motion of the next module | rotation |",
             "| --- | --- | --- | --- | --- |"]
    for r in TABLE:
        on = "none" if not r.actuators else ("all" if len(r.actuators) == 4 else ", ".join(map(str, r.actuators)))
        motion = {"rest": "rest, straight", "tilt": "tilt by α",
                  "lift": "lift: straight, longer by the actuator stroke"}[r.motion]
        rotation = "none" if r.motion != "tilt" else \
            f"about local **{'+' if r.sign > 0 else '−'}{_AXIS_NAMES[r.axis]}**"
        lines.append(f"| {r.code} | {r.code:04b} | {on} | {motion} | {rotation} |")
    return "\n".join(lines) + "\n"
