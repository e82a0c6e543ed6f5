"""Options and result columns named in words, with their units, for table headers and figure axes.

The units come from the option registry (:mod:`bhr._settings.options`): ``alpha (deg)``,
``module length (mm)``; result columns name their unit in their key
(``tip_max_error_mm`` is ``tip max error (mm)``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from bhr._settings.options import BY_NAME

__all__ = ["label", "AXIS_NAMES", "axis_label", "axis_value", "COLUMN_TITLES", "column_title"]


def label(v: Any) -> str:
    """A value as a table cell or tick shows it: ``10`` not ``10.0``, a trajectory file by its name."""
    if isinstance(v, float):
        return f"{v:g}"
    s = str(v)
    return Path(s).stem if ("/" in s or s.endswith(".toml")) else s


#: Heat-map axis and table names of the grid keys, in words (the unit comes from bhr._settings.options).
AXIS_NAMES = {
    "module_length": "module length", "robot_radius": "robot radius", "tol_pos": "position tolerance",
    "tol_ori": "orientation tolerance", "max_iter": "iterations (at most)", "feed_divisor": "feed divisor",
    "weight_pos": "position weight", "weight_ori": "orientation weight", "radius": "path radius",
    "angle": "turned angle", "entry": "entry straight", "exit": "exit straight", "traj": "trajectory",
    "warmup": "warm-up iterations", "limit": "rotation limit", "axes": "rotation axes",
}


def axis_label(key: str | None) -> str:
    """An option's name with its unit, e.g. ``alpha (deg)``, for heat-map axes and table headers."""
    if key is None:
        return ""
    name = AXIS_NAMES.get(key, key.replace("_", " "))
    unit = BY_NAME[key].unit if key in BY_NAME else ""
    return f"{name} ({unit})" if unit else name


def axis_value(key: str, value: Any) -> str:
    """An axis value with its name and unit, e.g. ``module length 10 mm``."""
    name = axis_label(key)
    if name.endswith(")") and " (" in name:
        name, unit = name[:-1].split(" (", 1)
        return f"{name} {label(value)} {unit}"
    return f"{name} {label(value)}"


#: Headers of the result columns whose name says less than it should (the others: :func:`column_title`).
COLUMN_TITLES = {
    "name": "run", "points_max_error_mm": "worst point error (mm)",
    "orientation_max_deg": "worst orientation error (deg)", "global_max": "global max (1 = tolerance)",
    "tip_rmse_mm": "tip RMSE (mm)", "tip_orientation_rmse_deg": "tip orientation RMSE (deg)",
    "tolerance_exceeded": "over tolerance", "worst_colon": "worst colon (seed)",
}
_UNITS = (("_mm", "mm"), ("_deg", "deg"), ("_s", "s"), ("_pct", "% of the colon"))


def column_title(key: str) -> str:
    """A friendly header for a result column or an option: ``tip max error (mm)``, ``alpha (deg)``."""
    if key in COLUMN_TITLES:
        return COLUMN_TITLES[key]
    if key in BY_NAME or key in AXIS_NAMES:
        return axis_label(key)
    for suffix, unit in _UNITS:
        if key.endswith(suffix):
            return f"{key[:-len(suffix)].replace('_', ' ')} ({unit})"
    return key.replace("_", " ")
