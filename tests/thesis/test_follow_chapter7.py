"""Chapter 7: `bhr follow --solver seed` reproduces the thesis's published trajectory results."""
import contextlib
import json
from pathlib import Path

import numpy as np
import pytest
from bhr.cli.main import main
from click.testing import CliRunner

import bhr
from bhr.model._generators import load_trajectory
from bhr._run.driver import BhrWarning, follow

DATA = Path(__file__).resolve().parents[1] / "data"


def tip(result):
    return result.point_errors_mm[:, -1], result.orientation_errors_deg[:, -1]


def test_straight_line_has_zero_error():
    r = follow(bhr.trajectory("line", length=70))
    assert r.steps == 36
    assert np.all(r.point_errors_mm == 0) and np.all(r.orientation_errors_deg == 0)
    assert np.all(r.codes == 0)


def test_curve_90_section_7_1_2():
    r = follow(load_trajectory("curve", radius=70, angle=90, entry=30, exit=30))
    pos, ori = tip(r)
    assert round(pos[-1], 4) == 0.9099
    assert round(ori[-1], 4) == 0.0
    assert pos.max() < 8 and ori.max() < 20  # within tolerance all along, as the thesis reports


def test_curve_360_section_7_1_2():
    r = follow(load_trajectory("curve", radius=70, angle=360, entry=30, exit=30))
    pos, ori = tip(r)
    assert round(pos.max(), 3) == 4.995
    assert int(np.argmax(pos)) + 1 == 124
    assert round(pos[-1], 4) == 0.9813
    assert round(ori[-1], 4) == 0.0
    assert r.point_errors_mm.max() == pos.max()  # the peak is at the last point


def test_spiral_section_7_1_3():
    r = follow(load_trajectory("spiral", radius=80, pitch=40, turns=2))
    pos, ori = tip(r)
    assert round(pos.max(), 3) == 6.596 and int(np.argmax(pos)) + 1 == 325
    assert round(ori.max(), 2) == 17.94 and int(np.argmax(ori)) + 1 == 325
    assert round(pos[-1], 3) == 5.247
    assert round(ori[-1], 3) == 9.108


@pytest.mark.parametrize("key", ["curve90", "curve360", "spiral", "colon"])
def test_pinned_per_step_values(key):
    """Every listed step's errors, codes and iterations are a deterministic function of the inputs."""
    pinned = json.loads((DATA / "pinned_steps.json").read_text())[key]
    r = follow(load_trajectory(pinned["trajectory"], **pinned["params"]))
    assert r.steps == pinned["steps"]
    for row in pinned["rows"]:
        i = row["step"] - 1
        np.testing.assert_allclose(r.point_errors_mm[i], row["point_errors_mm"], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(r.orientation_errors_deg[i], row["module_orientation_errors_deg"], rtol=1e-9,
                                   atol=1e-7)
        assert r.codes[i].tolist() == row["codes"]
        assert int(r.iterations[i]) == row["iterations"]


@pytest.mark.parametrize("name, params", [("curve", {"angle": 360}), ("spiral", {}), ("colon", {})])
def test_compiled_loop_equals_step_by_step_driver(name, params):
    tr = load_trajectory(name, **params)
    a = follow(tr)
    b = follow(tr, compiled=False)
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.point_errors_mm, b.point_errors_mm)
    assert np.array_equal(a.orientation_errors_deg, b.orientation_errors_deg)
    assert np.array_equal(a.codes, b.codes) and np.array_equal(a.iterations, b.iterations)


def test_tight_curve_warns_and_completes():
    tr = load_trajectory("curve", radius=40)
    with pytest.warns(BhrWarning, match="57.15 mm"):
        r = follow(tr)
    assert r.steps == len(tr.points)
    assert any("57.15" in w for w in r.warnings)
    assert r.summary.warnings


def test_cli_tight_curve_warning_line(run_bhr, tmp_path):
    res = run_bhr("follow", "--traj", "curve", "--radius", "40", "--no-plots", "--out", "o")
    assert res.returncode == 0, res.stderr
    assert "minimum turn radius 57.15 mm" in res.stderr
    assert "Traceback" not in res.stderr
    assert (tmp_path / "o" / "codes.csv").exists()


def test_json_document_contract():
    r = follow(bhr.trajectory("curve"), solver="seed")
    doc = json.loads(r.to_json())
    assert set(doc) >= {"steps", "summary"}
    steps = doc["steps"]
    assert len(steps) == r.steps and [s["step"] for s in steps] == list(range(1, r.steps + 1))
    s = steps[-1]
    assert set(s) >= {"target", "points", "point_errors_mm", "module_orientation_errors_deg", "codes", "iterations"}
    assert len(s["points"]) == 6 and len(s["points"][0]) == 3
    assert len(s["point_errors_mm"]) == 6 and len(s["module_orientation_errors_deg"]) == 5
    assert all(isinstance(v, float) for v in s["point_errors_mm"])
    assert round(s["point_errors_mm"][-1], 4) == 0.9099
    assert doc["summary"]["tip_final_error_mm"] == s["point_errors_mm"][-1]


def test_trajectory_api_and_feed():
    pts = bhr.trajectory("curve", radius=70, angle=90)
    assert pts.shape == (85, 3)
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert 1.7 < step.min() and step.max() < 2.3  # spaced by the 2 mm feed (printed generator)
    assert np.all(pts[:, 2] == 0)
    sp = bhr.trajectory("spiral")
    assert sp.shape == (505, 3) and sp[:, 2].max() > 79


def test_cli_follow_writes_everything(tmp_path):
    runner = CliRunner()
    with contextlib.chdir(tmp_path):
        res = runner.invoke(main, ["follow", "--traj", "curve", "--json", "run.json"])
        assert res.exit_code == 0, res.output
        (out,) = Path("bhr-out").glob("curve-thesis-*")  # one folder, named for the run's settings
        assert Path("bhr-out/latest").resolve() == out.resolve()
        for name in ("position_errors.png", "orientation_errors.png", "global_errors.png", "path.png"):
            data = (out / name).read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20000, name
        lines = (out / "codes.csv").read_text().splitlines()
        assert lines[0] == "step,m1,m2,m3,m4,m5" and len(lines) == 86
        doc = json.loads(Path("run.json").read_text())
        assert len(doc["steps"]) == 85
        assert "Position error (mm)" in res.output and "point 6 (tip)" in res.output
        assert "0.9099" in res.output


def test_console_script_colon_with_defaults(run_bhr, tmp_path):
    """The README's main job: `bhr follow --traj colon` with no other option."""
    res = run_bhr("follow", "--traj", "colon")
    assert res.returncode == 0, res.stderr
    (out,) = (tmp_path / "bhr-out").glob("colon-thesis-*")
    names = {"position_errors.png", "orientation_errors.png", "global_errors.png", "path.png", "codes.csv", "run.json",
             "manifest.json"}
    assert names <= {p.name for p in out.iterdir()}
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary files left behind
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]  # no staging folder left behind
    doc = json.loads((out / "run.json").read_text())
    assert len(doc["steps"]) == 827
    rows = (out / "codes.csv").read_text().splitlines()
    assert len(rows) == 828
    assert "Worst step: 76" in res.stdout
