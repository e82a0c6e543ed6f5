"""The insufflated lumen of a real colon: a literature-based model of the lumen at colonoscopy (an idealisation).

Colonoscopy is done with the colon distended by gas; a CT surface of a colon that was not insufflated
(gca:E60, gca:E90) shows it collapsed, as narrow as 3 mm in places. ``--lumen-model insufflated`` replaces
the lumen of a trajectory with named sections by

    D(s) = max(D_ct(s), k * c(s))

where ``c(s)`` is the section's typical calibre (:data:`CALIBRE_MM`: the midpoints of the generated colons'
lumen ranges, docs/anatomy.md, smoothed over +-20 mm of arc length across the sections' joins) and ``k`` is
chosen for each colon so that its mean cross-section, over its length, is the mean length-adjusted volume
of colons distended with CO2 at screening CT colonography: 11.6 mL/cm (:data:`AREA_MM2` = 1160 mm^2, an
equivalent diameter of 38.4 mm; Patrick JL, Bakke JR, Bannas P, Kim DH, Lubner MG, Pickhardt PJ. Objective
volumetric comparison of room air versus carbon dioxide for colonic distention at screening CT colonography;
150 adults with CO2, 9.9 mL/cm in 150 with room air; figures from its abstract). Where the CT lumen is
wider (an inflated scan, the cecum) it is kept. The course of the centerline is not changed (an insufflated colon also
lengthens and straightens a little), and the lumen is a tube (the CT surface no longer is the wall): an
idealisation, labelled as such in every output, never the default.
"""
from __future__ import annotations

import math

import numpy as np

from bhr._settings.errors import BhrError

__all__ = ["LUMEN_MODELS", "CALIBRE_MM", "AREA_MM2", "insufflated_lumen"]

#: ``ct``: the lumen as measured (the default); ``insufflated``: this module's model.
LUMEN_MODELS = ("ct", "insufflated")
#: Mean cross-section (mm^2) of a colon distended with CO2 at CT colonography: 11.6 mL/cm (Patrick et al.).
AREA_MM2 = 1160.0
#: Typical calibre of each section (mm), relative sizes: the midpoints of docs/anatomy.md's lumen ranges; a
#: section "rectum and sigmoid" is their length-weighted mean (9.5 : 25 of the colon).
CALIBRE_MM = {"rectum": 37.5, "sigmoid": 28.0, "rectum and sigmoid": (37.5 * 9.5 + 28.0 * 25.0) / 34.5,
              "descending": 30.0, "splenic flexure": 35.0, "transverse": 42.5, "hepatic flexure": 44.0,
              "ascending": 47.5, "cecum": 55.0}
#: Half-width (mm of arc length) of the moving average that joins the sections' calibres.
BLEND_MM = 20.0


def insufflated_lumen(lumen: np.ndarray, sections, spacing: float) -> tuple[np.ndarray, float]:
    """The insufflated lumen diameters (one per point) and the scale ``k``, from the CT ``lumen`` and the
    ``sections`` ((name, first, one past last) over the points, ``spacing`` mm apart)."""
    n = len(lumen)
    calibre = np.full(n, np.nan)
    for name, a, b in sections:
        if name not in CALIBRE_MM:
            raise BhrError(f"the insufflated lumen model knows the sections {', '.join(CALIBRE_MM)}; this trajectory "
                           f"has {name!r}")
        calibre[a:b] = CALIBRE_MM[name]
    if not sections or np.isnan(calibre).any():
        raise BhrError("the insufflated lumen model needs a colon whose every point lies in a named section (a real "
                       "colon, gca:NAME, or a CSV with a section column); use --lumen-model ct")
    m = max(int(round(BLEND_MM / spacing)), 1)
    kernel = np.ones(2 * m + 1) / (2 * m + 1)
    smooth = np.convolve(np.pad(calibre, m, mode="edge"), kernel, mode="valid")
    k = math.sqrt(AREA_MM2 * 4.0 / math.pi / float(np.mean(smooth ** 2)))
    return np.maximum(np.asarray(lumen, dtype=np.float64), k * smooth), k
