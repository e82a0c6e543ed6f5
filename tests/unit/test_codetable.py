"""The one code table (bhr._kinematics.codetable) and everything derived from it."""
import math
import re
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._kinematics import codetable as T
from bhr._kinematics.frames import TILT_AXES, tilt_frame, tilt_reference
from bhr.model import _codes as codes
from bhr.model._robot import base_frame

DOCS = Path(__file__).resolve().parents[2] / "docs" / "conventions.md"


def test_the_documented_table_is_the_code_table():
    text = DOCS.read_text(encoding="utf-8")
    assert T.markdown_table() in text, "docs/conventions.md's code table differs from bhr._kinematics.codetable"
    m = re.search(r"Every other code \(([\d, ]+)\) is unstable", text)
    assert m, "docs/conventions.md no longer lists the unstable codes"
    assert sorted(int(c) for c in m.group(1).split(",")) == sorted(set(range(16)) - set(T.VALID_CODES))


def test_codes_bits_are_the_actuators_on():
    for row in T.TABLE:
        assert [k for k in range(1, 5) if row.code & (1 << (k - 1))] == sorted(row.actuators)
        assert codes.actuators(row.code) == tuple(sorted(row.actuators))
    assert (T.REST, T.LIFT) == (0, 15)
    assert sorted(T.VALID_CODES) == [0, 3, 6, 9, 12, 15]


def test_every_part_of_bhr_uses_the_one_table():
    from bhr._run.body import _CODE, _INVERSE
    from bhr.solvers._optimal import CODE_OF

    assert codes.VALID_CODES is T.VALID_CODES and codes.TILT_CODES is T.TILT_CODES
    assert CODE_OF is T.SEARCH_CODES and _CODE is T.SEARCH_CODES and _INVERSE is T.SEARCH_INVERSE
    assert TILT_AXES == {c: (a, float(s)) for c, (a, s) in T.CODE_AXIS.items()}
    for k, code in enumerate(T.SEARCH_CODES):
        assert T.SEARCH_INDEX[code] == k
    assert T.SEARCH_INDEX[T.LIFT] == 0 and T.LIFT_OF[T.LIFT] == 1.0 and T.LIFT_OF.sum() == 1.0
    assert [c for c in range(16) if T.SEARCH_INDEX[c] < 0] == sorted(set(range(16)) - set(T.VALID_CODES))
    assert not T.SEARCH_CODES.flags.writeable  # the kernels read them as constants


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(T.TILT_CODES), st.floats(1.0, 60.0))
def test_a_tilt_tips_the_next_module_away_from_the_raised_side(seed, code, alpha_deg):
    """Actuator k sits at azimuth 45 deg + (k-1) 90 deg from local x toward y; the two that are on raise that side."""
    F = base_frame(np.random.default_rng(seed).normal(size=3))
    row = next(r for r in T.TABLE if r.code == code)
    az = [math.radians(45.0 + (k - 1) * 90.0) for k in row.actuators]
    side = sum(math.cos(a) for a in az) * F[0] + sum(math.sin(a) for a in az) * F[1]  # toward the raised side
    k = int(T.SEARCH_INDEX[code])
    a = math.radians(alpha_deg)
    out = np.empty((3, 3))
    tilt_frame(F, k, math.cos(a), math.sin(a), out)
    assert out[2] @ side < 0  # the next module leans away from the raised side
    axis_vec = F[row.axis] * row.sign
    np.testing.assert_allclose(out[2] @ axis_vec, 0.0, atol=1e-12)  # about the table's axis
    assert np.cross(F[2], out[2]) @ axis_vec > 0  # right-hand rotation about it


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 4), st.floats(0.5, 80.0))
def test_the_inverse_tilt_undoes_a_tilt(seed, k, alpha_deg):
    F = base_frame(np.random.default_rng(seed).normal(size=3))
    a = math.radians(alpha_deg)
    back = tilt_reference(tilt_reference(F, k, a), int(T.SEARCH_INVERSE[k]), a)
    np.testing.assert_allclose(back, F, atol=1e-12)
