"""Whole-body follow-the-leader (bhr/body.py): the modules behind the head: the tests that run the bhr command."""
from __future__ import annotations

import json


def test_follow_cli_body(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("follow", "--traj", "curve", "--solver", "optimal", "--body-modules", "12", "--out", tmp_path / "o",
                  "--json", tmp_path / "run.json")
    assert out.returncode == 0, out.stderr
    assert "Whole body: 12 modules" in out.stdout
    doc = json.loads((tmp_path / "run.json").read_text())
    assert doc["summary"]["body_modules"] == 12
    st = doc["steps"][-1]
    assert len(st["body_points"]) == 7 and len(st["body_codes"]) == 7 and len(st["body_point_errors_mm"]) == 7
    assert (tmp_path / "o" / "body_errors.png").read_bytes()[:4] == b"\x89PNG"
    # codes.csv holds every module the board drives: the whole robot, rear first, the head's codes last
    rows = (tmp_path / "o" / "codes.csv").read_text().splitlines()
    assert rows[0] == "step," + ",".join(f"m{k}" for k in range(1, 13))
    assert rows[-1].split(",")[8:] == [str(c) for c in st["codes"]]
    assert rows[-1].split(",")[1:8] == ["0"] + [str(c) for c in st["body_codes"][:-1][::-1]]
    plan = run_bhr_in_process("plan", "--codes", tmp_path / "o" / "codes.csv", "--no-plots")
    assert plan.returncode == 0, plan.stderr
    last = [ln for ln in plan.stdout.splitlines() if ln.strip().startswith(str(len(rows) - 1) + " ")][-1]
    assert len(last.split()[-1].split(",")) == 12  # the schedule's rows carry the whole robot's 12 codes
    bad = run_bhr_in_process("follow", "--traj", "curve", "--body-modules", "3", "--no-plots", "--out", tmp_path / "b")
    assert bad.returncode != 0 and len(bad.stderr.strip().splitlines()) == 1 and "--body-modules" in bad.stderr
    assert not (tmp_path / "b" / "run.json").exists()
