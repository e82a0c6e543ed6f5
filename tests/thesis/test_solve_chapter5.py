"""Tables 5.1-5.12 of the thesis, reproduced by `bhr solve` (iterations equal, error to 5 decimals)."""
import json

import pytest
from bhr.cli.main import main
from click.testing import CliRunner

# (table, modules, target, FABRIK iterations, FABRIK error, CCD iterations, CCD error)
TABLES = [
    ("5.1", 5, (3, 9, 0), 12, 0.00874, 16, 0.00907),
    ("5.2", 5, (7, 5, 0), 8, 0.00666, 20, 0.00921),
    ("5.3", 5, (6, -5, 0), 2, 0.00055, 30, 0.00907),
    ("5.4", 5, (4, 2, 7), 7, 0.00496, 15, 0.00775),
    ("5.5", 5, (3, -2, 7), 4, 0.00356, 8, 0.00648),
    ("5.6", 5, (3, -5, -3), 3, 0.00680, 18, 0.00933),
    ("5.7", 10, (15, 6, 0), 12, 0.00890, 12, 0.00646),
    ("5.8", 10, (10, 0, 0), 3, 0.00478, 15, 0.00634),
    ("5.9", 10, (6, -10, 0), 2, 0.00366, 30, 0.01510),
    ("5.10", 10, (6, 10, 4), 3, 0.00620, 4, 0.00299),
    ("5.11", 10, (-7, 10, 7), 6, 0.00954, 7, 0.00289),
    ("5.12", 10, (-11, -5, 3), 3, 0.00670, 30, 0.02937),
]

CASES = []
for table, n, target, fk, fe, ck, ce in TABLES:
    CASES.append(pytest.param(n, target, "fabrik", fk, fe, id=f"table{table}-fabrik"))
    CASES.append(pytest.param(n, target, "ccd", ck, ce, id=f"table{table}-ccd"))


@pytest.mark.parametrize("modules, target, solver, iterations, error", CASES)
def test_table(modules, target, solver, iterations, error):
    args = ["solve", "--modules", str(modules), "--module-length", "2", "--target", *map(str, target),
            "--solver", solver, "--tol-pos", "0.01", "--max-iter", "30", "--json", "-"]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)  # the compile notice of a cold cache goes to stderr
    assert doc["iterations"] == iterations
    assert round(doc["position_error"], 5) == error
    assert len(doc["points"]) == modules + 1
    assert doc["points"][0] == [0.0, 0.0, 0.0]
    assert doc["codes"] is None  # continuous solvers return no codes


def test_console_script_table_5_1(run_bhr, tmp_path):
    res = run_bhr("solve", "--modules", "5", "--module-length", "2", "--target", "3", "9", "0",
                  "--plot", "chain.png", "--json", "out.json")
    assert res.returncode == 0, res.stderr
    assert "iterations" in res.stdout and "12" in res.stdout
    assert "0.00874" in res.stdout
    doc = json.loads((tmp_path / "out.json").read_text())
    assert set(doc) == {"bhr_version", "iterations", "position_error", "orientation_error_deg", "points", "codes",
                        "success", "status", "reason"}
    assert doc["status"] == "reached" and "reached (within tolerance 0.01)" in res.stdout
    png = (tmp_path / "chain.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
