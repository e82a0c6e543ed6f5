"""The one number checker, the one did-you-mean, CSV escaping and the bounded procedure-time estimate."""
from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bhr._settings.errors import BhrError
from bhr._settings.options import LIMITS, MIN_MAGNITUDE, check_number, check_run_name, did_you_mean, parse_number
from bhr._studies.study import csv_safe, csv_text


@pytest.mark.parametrize("value, fragment", [
    (10 ** 400, "401-digit whole number"), (-(10 ** 400), "401-digit"), (float("nan"), "finite"),
    (float("inf"), "finite"), (1e-320, "too small"), (True, "boolean"), ("12", "the text '12'"),
    (2e6, "too large"),
], ids=["int400", "negint400", "nan", "inf", "denormal", "bool", "text", "large"])
def test_the_checker_refuses_in_one_line(value, fragment):
    with pytest.raises(BhrError) as e:
        check_number(value, "k", limit=1e6)
    assert fragment in str(e.value) and "\n" not in str(e.value) and len(str(e.value)) < 200


def test_integers_of_any_length_are_never_converted():
    for digits in (20, 400, 4000, 10000):  # int() of more than 4300 digits from text raises; from TOML it is an int
        with pytest.raises(BhrError, match="too large|must be at most"):
            check_number(10 ** digits, "k", integer=True, maximum=1000, limit=1e300)


@pytest.mark.parametrize("text", ["１２", "\u0663", "1_5", "12a", "", "0x10", "9" * 41, "1e", "--1"])
def test_text_numbers_are_plain_ascii_only(text):
    with pytest.raises(BhrError):
        parse_number(text, "k")


@pytest.mark.parametrize("text, value", [("15", 15.0), ("-2.5e3", -2500.0), (".5", 0.5), ("+7", 7.0)])
def test_plain_numbers_parse(text, value):
    assert parse_number(text, "k") == value


def test_whole_numbers():
    assert parse_number("5", "k", integer=True) == 5 and parse_number("-7", "k", integer=True) == -7
    for text in ("2.5", "5.0", "1e3", "1E3", "5.", "nan", "inf"):  # whole numbers as text are digits only
        with pytest.raises(BhrError, match="whole number"):
            parse_number(text, "k", integer=True)
    with pytest.raises(BhrError, match="whole number"):
        check_number(2.5, "k", integer=True)


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_every_float_is_accepted_finite_and_normal_or_refused(v):
    try:
        out = check_number(v, "k", limit=1e300)
    except BhrError as exc:
        assert "\n" not in str(exc)
        assert not math.isfinite(v) or abs(v) > 1e300 or 0 < abs(v) < MIN_MAGNITUDE
    else:
        assert math.isfinite(out) and (out == 0 or abs(out) >= MIN_MAGNITUDE)


def test_run_names():
    assert check_run_name("  a  ", "b") == "a"
    for bad, frag in [("a" * 300, "300 characters"), ("", "empty"), ("a\nb", "control character"), (5, "text")]:
        with pytest.raises(BhrError, match=frag):
            check_run_name(bad, "b")


@pytest.mark.parametrize("char", ["\u202e", "\u200b", "\ufeff", "\u2066", "\ue000", "\u00a0"])
def test_run_names_with_an_invisible_or_formatting_character_are_refused(char):
    # a right-to-left override (U+202E) shows 'a<RLO>fdp.exe' as 'aexe.pdf' in the page and the table
    with pytest.raises(BhrError, match=f"holds U\\+{ord(char):04X}, an invisible or formatting character"):
        check_run_name(f"a{char}b", "b")
    assert check_run_name("Ré Ω 左 run-1 (α=10°)", "b") == "Ré Ω 左 run-1 (α=10°)"


def test_one_did_you_mean():
    assert did_you_mean("modlues", ["modules", "alpha"]) == "did you mean 'modules'? "
    assert did_you_mean("module-length", ["module_length"]) == "did you mean 'module_length'? "
    assert did_you_mean("zzz", ["modules"]) == ""
    import bhr._settings.inputs
    import bhr._studies.study

    assert bhr._settings.inputs.did_you_mean is did_you_mean  # one function, re-exported
    assert "did you mean 'modules'?" in bhr._studies.study.suggest("modlues", ["modules"])


@pytest.mark.parametrize("cell", ["=HYPERLINK(\"http://x\",\"y\")", "@SUM(A1)", "+1+1", "-1+1", "\tx", "\rx"])
def test_formula_cells_are_escaped(cell):
    text = csv_text([{"name": cell, "v": -1.5}], ["name", "v"])
    row = list(csv.reader(io.StringIO(text, newline="")))[1]
    assert row[0] == "'" + cell.replace("\r", "\n") and row[1] == "-1.5"  # numbers stay numbers
    assert csv_safe("plain") == "plain"


def test_procedure_time_estimate_memory_does_not_grow_with_steps():
    from bhr._hardware.thermal import ThermalParams, auto_schedule, check_schedule

    p = ThermalParams()
    rng = np.random.default_rng(1)
    rows = rng.choice([0, 3, 6, 9, 12, 15], size=(400, 5))
    full = auto_schedule(p, rows, 10.0)
    lean = auto_schedule(p, rows, 10.0, trace=False)
    assert lean.sim.theta.shape[0] == 1 and full.sim.theta.shape[0] > 100
    assert lean.total_s == full.total_s and np.array_equal(lean.times_ms, full.times_ms)
    assert lean.faults == full.faults
    a, b = check_schedule(p, rows, 10.0), check_schedule(p, rows, 10.0, trace=False)
    assert a.faults == b.faults and a.total_s == b.total_s and b.sim.theta.shape[0] == 1


def test_limits_come_from_the_registry():
    from bhr._settings.inputs import MAX_POINTS, MAX_STEP_POINTS

    assert MAX_POINTS == LIMITS["points"] and MAX_STEP_POINTS == LIMITS["step_points"]


def test_codes_csv_module_limit(tmp_path):
    from bhr.model._codes import read_codes_csv

    n = LIMITS["code_modules"] + 1
    f = tmp_path / "c.csv"
    f.write_text("step," + ",".join(f"m{j + 1}" for j in range(n)) + "\n1," + ",".join("3" * n) + "\n")
    with pytest.raises(BhrError, match="module columns"):
        read_codes_csv(f)


@pytest.mark.parametrize("kind", ["fifo", "socket"])
def test_non_regular_inputs_are_refused_before_opening(tmp_path, kind):
    import os
    import socket

    from bhr._settings.inputs import read_text

    p = tmp_path / "in.toml"
    if kind == "fifo":
        os.mkfifo(p)
    else:
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(p))
    with pytest.raises(BhrError, match="FIFO|socket"):
        read_text(p, "robot file", "give a file")  # would block forever on a FIFO if it were opened


def test_a_missing_codes_file_under_latest_says_where_latest_points(tmp_path):
    """After `bhr traverse`, bhr-out/latest is the study's folder, which has no codes.csv: the line says so."""
    from bhr.model._codes import read_codes_csv

    (tmp_path / "traverse-1234").mkdir()
    (tmp_path / "latest").symlink_to("traverse-1234")
    with pytest.raises(BhrError) as e:
        read_codes_csv(tmp_path / "latest" / "codes.csv")
    msg = str(e.value)
    assert "\n" not in msg and "latest points to traverse-1234" in msg and "give the codes.csv" in msg
    with pytest.raises(BhrError) as e:
        read_codes_csv(tmp_path / "traverse-1234" / "codes.csv")
    assert "points to" not in str(e.value)
    (tmp_path / "data").symlink_to("traverse-1234")  # a user's own link is not bhr-out/latest
    with pytest.raises(BhrError) as e:
        read_codes_csv(tmp_path / "data" / "codes.csv")
    assert "points to" not in str(e.value)


@pytest.mark.parametrize("target, words", [("self", "is a symbolic link that loops"),
                                            ("nowhere.csv", "is a symbolic link to 'nowhere.csv', which does not exist")])
def test_an_input_that_is_a_broken_symbolic_link_is_named_as_one(tmp_path, target, words):
    from bhr.model._codes import read_codes_csv
    from bhr.model._trajnames import check_trajectory_name
    from bhr._settings.inputs import read_text

    link = tmp_path / "in.csv"
    link.symlink_to(link if target == "self" else target)
    for call in (lambda: read_codes_csv(link), lambda: check_trajectory_name(str(link)),
                 lambda: read_text(link, "robot file", "give a robot file")):
        with pytest.raises(BhrError, match=words):
            call()


def test_a_codes_file_that_is_not_utf8_or_a_folder_says_so(tmp_path):
    from bhr.model._codes import read_codes_csv

    (tmp_path / "c.csv").write_bytes(b"step,m1\n1,3\n2,\xe9\n")
    with pytest.raises(BhrError, match=r"c.csv, line 3: not UTF-8 text"):
        read_codes_csv(tmp_path / "c.csv")
    with pytest.raises(BhrError, match="is a folder, not a codes file"):
        read_codes_csv(tmp_path)


@given(st.lists(st.lists(st.sampled_from(["0", "3", "6", "9", "12", "15", " 3", "+6", "03", "7", "5", "x", "", "1_5",
                                          "１２", "-0", "9 "]), min_size=2, max_size=2), min_size=1, max_size=4))
def test_codes_csv_cells_are_read_as_check_code_reads_them(rows):
    """The fast path for cells written as bhr writes them agrees with check_code on every cell (value or refusal)."""
    import tempfile
    from pathlib import Path

    from bhr.model._codes import check_code, read_codes_csv

    expected: list[list[int]] | None = []
    for r in rows:
        try:
            expected.append([check_code(c) for c in r])  # type: ignore[union-attr]
        except BhrError:
            expected = None
            break
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "c.csv"
        f.write_text("step,m1,m2\n" + "".join(f"{i + 1},{r[0]},{r[1]}\n" for i, r in enumerate(rows)),
                     encoding="utf-8")
        if expected is None:
            with pytest.raises(BhrError):
                read_codes_csv(f)
        else:
            assert read_codes_csv(f)[1].tolist() == expected
