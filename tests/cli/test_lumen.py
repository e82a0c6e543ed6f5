"""--solver lumen (bhr/solvers/_lumen.py): exact head search, planning, options, and that it keeps off the wall: the tests that run the bhr command."""
from __future__ import annotations

from bhr._bench.lumen import tight_colon


def test_cli_options_go_to_the_solver_they_belong_to(run_bhr_in_process, tmp_path):
    csv = tmp_path / "tight.csv"
    tr = tight_colon(2)
    csv.write_text("x,y,z,lumen\n" + "".join(f"{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{d:.4f}\n"
                                             for p, d in zip(tr.points[:90], tr.lumen[:90])))
    out = run_bhr_in_process("follow", "--traj", csv, "--solver", "lumen", "--lookahead", "4", "--wall-weight", "500",
                  "--no-plots", "--out", tmp_path / "o")
    assert out.returncode == 0, out.stderr
    assert "Lumen clearance: minimum" in out.stdout
    bad = run_bhr_in_process("follow", "--traj", csv, "--solver", "seed", "--wall-weight", "500", "--no-plots")
    assert bad.returncode != 0 and bad.stderr.strip().splitlines() == [
        "Error: --wall-weight is an option of --solver lumen; drop it or use --solver lumen"]
    bad = run_bhr_in_process("follow", "--traj", csv, "--solver", "lumen", "--drift-weight", "3", "--no-plots")
    assert bad.returncode != 0 and "is an option of --solver optimal" in bad.stderr


def test_racing_weight_reaches_the_cli_and_bad_values_are_refused(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--racing-weight", "0.05",
                  "--center-weight", "0", "--no-plots", "--out", tmp_path / "o")
    assert out.returncode == 0, out.stderr
    assert "Lumen clearance: minimum" in out.stdout
    for bad in ("-1", "abc"):
        r = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--racing-weight", bad,
                    "--no-plots")
        lines = r.stderr.strip().splitlines()
        assert r.returncode != 0 and len(lines) == 1 and "racing-weight" in lines[0], r.stderr
    r = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "seed", "--racing-weight", "1", "--no-plots")
    assert r.returncode != 0 and r.stderr.strip().splitlines() == [
        "Error: --racing-weight is an option of --solver lumen; drop it or use --solver lumen"]
