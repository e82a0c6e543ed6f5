"""bhr follow with a whole robot: the wires' motion by default, every pose in poses.npz beside run.json."""
from __future__ import annotations

import json

import numpy as np


def test_a_whole_robot_writes_its_poses(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--alpha", "25",
                  "--module-length", "5", "--body-modules", "12", "--no-plots", "--out", "run")
    assert res.returncode == 0, res.stderr
    assert "Wires: rigid modules driven by their wires" in res.stdout and "poses.npz" in res.stdout
    # one procedure time in the summary: the board's schedule of codes.csv, as bhr plan gives it
    timed = [ln for ln in res.stdout.splitlines() if "pace" in ln or "procedure" in ln.lower()]
    assert len(timed) == 1 and timed[0].startswith("Procedure time on the board:"), timed
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    s = doc["summary"]
    assert s["locomotion"] == "wires" and s["poses_file"] == "poses.npz"
    d = np.load(tmp_path / "run" / "poses.npz")
    assert d["points_mm"].shape == (s["poses"], 13, 3) and d["tilts_rad"].shape == (s["poses"], 12, 2)
    assert d["step"].max() <= len(doc["steps"]) and np.all(np.diff(d["t_s"]) > 0)
    seg = np.linalg.norm(np.diff(d["points_mm"], axis=1), axis=2)
    assert np.max(np.abs(seg - 5.0)) <= 1e-6


def test_the_trail_model_is_still_there_and_labelled(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--alpha", "25",
                  "--module-length", "5", "--body-modules", "12", "--locomotion", "trail", "--no-plots", "--out",
                  "run")
    assert res.returncode == 0, res.stderr
    assert not (tmp_path / "run" / "poses.npz").exists()
    assert json.loads((tmp_path / "run" / "run.json").read_text())["summary"]["locomotion"] == "trail"


def test_a_damaged_poses_file_beside_a_run_is_one_line(run_bhr_in_process, tmp_path):
    """bhr physics reads poses.npz beside run.json: a damaged archive (zipfile's BadZipFile), a pose at 1e308 mm
    (an overflow in the replay's substeps), a code that is not stable or text where numbers go is one line naming
    the file or the array, never a traceback."""
    import shutil

    (tmp_path / "t.csv").write_text("# lumen_end: open\nx,y,z,lumen\n" + "".join(f"{2 * k},0,0,30\n" for k in range(25)))
    res = run_bhr_in_process("follow", "--traj", "t.csv", "--solver", "lumen", "--body-modules", "8", "--no-plots",
                             "--out", "run")
    assert res.returncode == 0 and (tmp_path / "run" / "poses.npz").is_file(), res.stderr
    good = dict(np.load(tmp_path / "run" / "poses.npz"))
    raw = (tmp_path / "run" / "poses.npz").read_bytes()
    second = raw.index(b"PK\x03\x04", 4)  # the second array's local header: its magic damaged
    far = dict(good, points_mm=good["points_mm"].copy())
    far["points_mm"][3, 2, 0] = 1e308
    cases = {"truncated": ("bytes", raw[:len(raw) // 2], "not a poses file"),
             "member": ("bytes", raw[:second] + b"XX" + raw[second + 2:], "not a poses file"),
             "far": ("arrays", far, "points_mm holds 1e+308"),
             "code": ("arrays", dict(good, codes=np.full_like(good["codes"], 5)), "codes holds 5, not a stable code"),
             "text": ("arrays", dict(good, t_s=good["t_s"].astype("U8")), "t_s holds <U8 values, not numbers"),
             "flat": ("arrays", dict(good, tilts_rad=good["tilts_rad"].ravel()), "tilts_rad has shape ("),
             "huge": ("arrays", dict(good, codes=np.full(good["codes"].shape, 1e300)), "codes holds a value that is "
                      "not a whole number")}
    for name, (kind, what, expect) in cases.items():
        d = tmp_path / name
        shutil.copytree(tmp_path / "run", d)
        if kind == "bytes":
            (d / "poses.npz").write_bytes(what)
        else:
            np.savez(d / "poses.npz", **what)
        r = run_bhr_in_process("physics", f"{name}/run.json", "--out", f"{name}-physics")
        lines = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("Compiling bhr's")]
        assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, (name, r.stderr[-1500:])
        assert expect in lines[0], (name, lines[0])
        assert not (tmp_path / f"{name}-physics").exists()
