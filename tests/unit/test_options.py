"""One option registry (bhr._settings.options): CLI options, robot files, batch files and sweep grids agree."""
import dataclasses

import pytest

from bhr.model._robot import Robot
from bhr.model._robotfile import ROBOT_KEYS as FILE_KEYS
from bhr._settings.errors import BhrError
from bhr._settings.options import by_group
from bhr.solvers._lumen import DEFAULTS as LUMEN_DEFAULTS
from bhr.solvers._optimal import DEFAULTS
from bhr._studies.report import parse_batch
from bhr._studies.sweep import GRID_KEYS, build_sweep, run_design


def test_robot_defaults_are_the_registry_defaults():
    fields = {f.name: f.default for f in dataclasses.fields(Robot)}
    for o in by_group("robot"):
        assert fields[o.name] == o.default, o.name
    assert set(fields) == {o.name for o in by_group("robot")}
    assert set(FILE_KEYS) == set(fields)
    assert DEFAULTS == {o.name: o.default for o in by_group("solver") if "optimal" in o.solvers}
    assert set(LUMEN_DEFAULTS) == {o.name for o in by_group("solver") if "lumen" in o.solvers}
    assert LUMEN_DEFAULTS["beam"] == 4 and LUMEN_DEFAULTS["lookahead"] == 10  # docs/lumen.md
    assert LUMEN_DEFAULTS["wall_weight"] == 1000.0 and LUMEN_DEFAULTS["racing_weight"] == 0.05


@pytest.mark.parametrize("command", ["follow", "compare"])
def test_cli_options_come_from_the_registry(command):
    import importlib

    cmd = getattr(importlib.import_module(f"bhr.cli.{command}"), command)
    params = {p.name: p for p in cmd.params}
    for o in by_group("robot", "trajectory", "solver"):
        p = params["exit_" if o.name == "exit" else o.name]
        assert p.opts == [o.flag] and p.help == o.help_text()
        if hasattr(p.type, "limit"):
            assert p.type.limit == o.limit


def test_optimal_options_in_batch_and_sweep():
    assert {"lookahead", "beam", "ori_weight", "point_weights"} <= GRID_KEYS
    b = parse_batch({"run": [{"name": "a", "traj": "line", "solver": "optimal", "lookahead": 0, "beam": 4}]}, "b")
    assert b.runs[0].solver_options == {"lookahead": 0, "beam": 4}
    with pytest.raises(BhrError, match="lookahead 300 is more than 200"):
        parse_batch({"run": [{"name": "a", "traj": "line", "solver": "optimal", "lookahead": 300}]}, "b")
    s = build_sweep(["line"], ["optimal", "thesis"], [("lookahead", (0, 5)), ("length", (20.0,))])
    rows = [run_design(d, s.traj_sources[d["traj"]]) for d in s.designs()]
    assert [r["status"] for r in rows] == ["ok"] * 4




def test_lumen_end_is_a_key_of_batch_runs_and_sweep_grids_as_documented():
    """docs/lumen.md promises `lumen_end = "open"` in a batch or sweep table; both refused it as unknown."""
    from bhr._settings.errors import BhrError
    from bhr._studies.sweep import parse_values

    b = parse_batch({"run": [{"name": "a", "traj": "anatomy-short", "lumen_end": "open"},
                             {"name": "b", "traj": "colon", "lumen_end": "closed"}]}, "b")
    assert [r.traj_params for r in b.runs] == [{"lumen_end": "open"}, {"lumen_end": "closed"}]
    with pytest.raises(BhrError, match="lumen_end must be one of closed, open, got 'ajar'"):
        parse_batch({"run": [{"name": "a", "traj": "colon", "lumen_end": "ajar"}]}, "b")
    assert parse_values("lumen_end", "open, closed", "--grid") == ("open", "closed")
    assert parse_values("lumen_end", ["open"], "t") == ("open",)
    with pytest.raises(BhrError, match="lumen_end must be one of closed, open"):
        parse_values("lumen_end", "ajar", "--grid")
