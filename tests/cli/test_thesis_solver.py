"""`--solver thesis` is the thesis's algorithm; `seed`, its former name, gives the same results bit for bit: the tests that run the bhr command."""
import json


def test_cli_follow_thesis_equals_seed(tmp_path, run_bhr_in_process):
    docs = []
    for name in ("thesis", "seed"):
        r = run_bhr_in_process("follow", "--traj", "curve", "--solver", name, "--no-plots", "--json", str(tmp_path / f"{name}.json"),
                    "--out", str(tmp_path / name))
        assert r.returncode == 0, r.stderr
        docs.append(json.loads((tmp_path / f"{name}.json").read_text()))
    assert docs[0]["steps"] == docs[1]["steps"]
    assert docs[0]["summary"]["tip_final_error_mm"] == docs[1]["summary"]["tip_final_error_mm"]
