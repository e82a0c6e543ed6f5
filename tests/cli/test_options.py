"""One option registry (bhr._settings.options): CLI options, robot files, batch files and sweep grids agree: the tests that run the bhr command."""
import re

import pytest

from bhr._settings.errors import BhrError
from bhr._settings.options import OPTIONS
from bhr._studies.report import parse_batch
from bhr._studies.sweep import parse_values


# the physics replay's options belong to bhr physics, not to batch runs
@pytest.mark.parametrize("o", [o for o in OPTIONS if o.maximum is not None and o.group != "physics"], ids=lambda o: o.name)
def test_batch_refuses_what_the_command_line_refuses(o, run_bhr_in_process, tmp_path):
    too_big = int(o.maximum) + 1 if o.kind is int else o.maximum * 2
    # a whole number and its limit are written out (seed: 4294967296 and 4294967295, not 4.29497e+09)
    shown, limit = (str(too_big), str(int(o.limit))) if o.kind is int else (f"{too_big:g}", f"{o.limit:g}")
    with pytest.raises(BhrError, match=re.escape(f"{o.name} = {shown} is too large; the limit is {limit}")):
        parse_batch({"run": [{"name": "a", "traj": "curve", o.name: too_big}]}, "b")
    with pytest.raises(BhrError, match="is too large"):
        parse_values(o.name, [too_big], "sweep")
    if o.group == "robot" and o.name != "feed_divisor":  # bhr fk has no feed, and solves nothing
        from bhr.cli._options import SOLVING_ONLY

        args = ("solve", "--target", "1", "1", "1") if o.name in SOLVING_ONLY else ("fk", "--codes", "0")
        r = run_bhr_in_process(*args, o.flag, str(too_big))
        assert r.returncode == 2 and f"the limit is {limit}" in r.stderr


def test_fk_lists_no_solver_options_and_old_spellings_stay_hidden(run_bhr_in_process):
    fk = run_bhr_in_process("fk", "--help").stdout
    assert "--module-length" in fk and not any(f in fk for f in ("--tol-pos", "--tol-ori", "--max-iter", "--weight"))
    sweep, report = run_bhr_in_process("sweep", "--help").stdout, run_bhr_in_process("report", "--help").stdout
    assert "--no-plots" in sweep and "--no-plot " not in sweep
    assert "--file" in report and "--no-plots" in report and "--batch" not in report
