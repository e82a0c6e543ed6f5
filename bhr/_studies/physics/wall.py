"""The colon's wall as the replay meets it: a foundation around bhr's lumen, the same whatever robot enters it.

The wall is where bhr's geometry puts it (:mod:`bhr.model._tube`: the lumen is the tube of the trajectory's
diameters around its centerline, capped at the cecum). A point of the robot's axis at distance ``d`` from the
centerline, where the lumen's radius is ``R``, pushes the wall out by ``pen = d + r - R`` (``r`` the robot's
radius) when that is positive, and the wall pushes back with ``k pen`` newtons per millimetre of robot length
in contact (a linear foundation along the robot: stiffness ``k`` in N/mm per mm, N/mm^2). ``pen`` is also how
far the wall has been pushed out of place there. docs/physics.md gives the figures and their sources.
"""
from __future__ import annotations

import math

from bhr._settings.errors import BhrError

__all__ = ["PROBE_DIAMETER_MM", "INDENTATION_N_PER_MM", "WALL_STIFFNESS_RANGE", "DEFAULT_WALL_STIFFNESS",
           "FORCE_LINES_N", "DEFAULT_MAX_WALL_FORCE", "SAMPLE_MM", "check_wall_stiffness", "samples_per_module"]

#: Porcine colon pressed by printed models of colonoscope heads: linear stiffness 0.7-2.4 N/mm over the
#: configurations and loading directions (Johnson et al., J Mech Behav Biomed Mater 91:139-148, 2019).
INDENTATION_N_PER_MM = (0.7, 2.4)
#: The width of wall those heads pressed: a colonoscope's distal end, about 13 mm across (adult colonoscopes are
#: 12.8-13.2 mm). The indentation stiffness spread over that much wall gives the stiffness per mm of contact.
PROBE_DIAMETER_MM = 13.0
#: The wall's stiffness per mm of robot in contact, N/mm per mm (N/mm^2): the published range and its middle.
WALL_STIFFNESS_RANGE = (INDENTATION_N_PER_MM[0] / PROBE_DIAMETER_MM, INDENTATION_N_PER_MM[1] / PROBE_DIAMETER_MM)
DEFAULT_WALL_STIFFNESS = round(sum(INDENTATION_N_PER_MM) / 2 / PROBE_DIAMETER_MM, 4)  # 0.1192 N/mm^2
#: Published force levels, N: colonoscopists push with more than 1 kg only 5 % of the time (Appleyard et al.,
#: Gastrointest Endosc 52:237-240, 2000); a porcine colon perforates at 14.1 N under a colonoscope's head
#: (Johnson et al. 2019, the lowest of their groups).
FORCE_LINES_N = (9.8, 14.1)
#: The wall load a colon is taken to bear without harm (``bhr traverse --max-wall-force``): 9.8 N, the push that
#: colonoscopists exceed only 5 % of the time (Appleyard 2000), below the 14.1 N that perforates (Johnson 2019).
DEFAULT_MAX_WALL_FORCE = 9.8
#: Largest spacing (mm) of the points along a module at which the wall acts (the foundation's discretisation).
SAMPLE_MM = 0.5


def check_wall_stiffness(value: float) -> float:
    """``value`` (N/mm per mm) if within ten times the published range either way; BhrError otherwise."""
    lo, hi = WALL_STIFFNESS_RANGE[0] / 10, WALL_STIFFNESS_RANGE[1] * 10
    if not (math.isfinite(value) and lo <= value <= hi):
        raise BhrError(f"--wall-stiffness {value:g} N/mm^2 is far outside the published "
                       f"{WALL_STIFFNESS_RANGE[0]:.3f}-{WALL_STIFFNESS_RANGE[1]:.3f} N/mm per mm of contact; give a "
                       f"value between {lo:.4g} and {hi:.4g}")
    return value


def samples_per_module(module_length: float, sample_mm: float = SAMPLE_MM) -> int:
    """How many points of a module's axis the wall acts on: spaced at most ``sample_mm`` apart, at the middles
    of equal pieces (each stands for its piece's length of robot)."""
    return max(1, int(math.ceil(module_length / sample_mm - 1e-9)))
