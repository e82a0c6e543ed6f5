"""bhr sweep: grids, local processes, a real Dask LocalCluster on loopback, heat-maps, numba cache reuse."""
from __future__ import annotations

import csv
import io
import json
import math
import os
import socket
import subprocess
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr.model._generators import load_trajectory
from bhr.model._robot import Robot
from bhr._run.driver import follow
from bhr._settings.errors import BhrError
from bhr._studies.sweep import (
    Sweep,
    build_sweep,
    heatmap_axes,
    heatmap_cells,
    parse_grid_option,
    parse_values,
    run_sweep,
    sweep_from_toml,
)
from tests.conftest import bhr_exe, bhr_in_process, cli_install_command, snapshot

REPO = Path(__file__).resolve().parents[2]
PNG = b"\x89PNG\r\n\x1a\n"
GRID = ["--grid", "modules=4:6", "--grid", "alpha=8,10,12", "--grid", "angle=90,180"]


def rows_of(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def run_cli(*args, cwd: Path, timeout: float = 600):
    """The command in this process (what it does with its input and its files)."""
    return bhr_in_process(*args, cwd=cwd, timeout=timeout)


def run_cli_process(*args, cwd: Path, env: dict | None = None, timeout: float = 600):
    """The real ``bhr`` process: for what is read as Python starts (NUMBA_*, PYTHONPATH), and a Dask client that
    lives and ends with the command."""
    e = dict(os.environ, MPLBACKEND="Agg")
    e.update(env or {})
    return subprocess.run(bhr_exe() + [str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=e)


# ---------------------------------------------------------------------------------------------- grids


def test_values_lists_ranges_and_scalars():
    assert parse_values("modules", "4,5,6", "t") == (4, 5, 6)
    assert parse_values("modules", "3:6", "t") == (3, 4, 5, 6)
    assert parse_values("alpha", "8:10:0.5", "t") == (8.0, 8.5, 9.0, 9.5, 10.0)
    assert parse_values("alpha", "0.1:0.3:0.1", "t") == (0.1, 0.2, 0.3)  # no 0.30000000000000004
    assert parse_values("module_length", "8:13:2", "t") == (8, 10, 12)  # STOP only when a step lands on it
    assert parse_values("alpha", [8, 9.5], "t") == (8, 9.5)
    assert parse_values("modules", 5, "t") == (5,)
    assert parse_values("limit", "binary,continuous", "t") == ("binary", "continuous")
    assert parse_grid_option("module-length=8,10") == ("module_length", (8, 10))


@pytest.mark.parametrize("text, msg", [
    ("modlues=4", "'modlues' is not a parameter a sweep can vary; did you mean 'modules'?"),
    ("modules", "must be KEY=VALUES"),
    ("modules=4.5", "modules must be a whole number"),
    ("modules=", "modules has no values"),
    ("alpha=8:4", "runs backwards"),
    ("alpha=8:12:0", "step must be positive"),
    ("alpha=8:12:-1", "step must be positive"),
    ("alpha=a,b", "'a' is not a number"),
    ("alpha=1:2:3:4", "must be START:STOP or START:STOP:STEP"),
    ("alpha=8,8", "lists 8 twice"),
    ("limit=binary,bogus", "limit must be one of binary, continuous, none"),
    ("traj=curve", "'traj' is not a parameter a sweep can vary"),
])
def test_bad_grid_values(text, msg):
    with pytest.raises(BhrError, match=msg.replace("(", r"\(").replace("?", r"\?")):
        parse_grid_option(text)


@settings(max_examples=200, deadline=None)
@given(st.integers(-50, 50), st.integers(0, 60), st.integers(1, 9))
def test_integer_ranges_are_python_ranges(start, span, step):
    got = parse_values("warmup", f"{start}:{start + span}:{step}", "t")
    assert got == tuple(range(start, start + span + 1, step))


@settings(max_examples=200, deadline=None)
@given(st.floats(0.5, 50), st.floats(0, 20), st.floats(0.05, 5))
def test_float_ranges_step_from_start_and_stop_at_stop(start, span, step):
    start, span, step = round(start, 3), round(span, 3), round(step, 3)
    got = parse_values("alpha", f"{start}:{start + span}:{step}", "t")
    assert math.isclose(got[0], start)
    assert all(math.isclose(b - a, step, rel_tol=1e-6, abs_tol=1e-6) for a, b in zip(got, got[1:]))
    assert got[-1] <= start + span + 1e-6 and got[-1] + step > start + span - 1e-6
    assert len(set(got)) == len(got)


def test_designs_are_the_product_in_order():
    s = build_sweep(["curve", "spiral"], ["seed", "fabrik"], [("modules", (4, 5)), ("radius", (80, 90))])
    d = s.designs()
    assert len(d) == len(s) == 16
    assert d[0] == {"traj": "curve", "solver": "thesis", "modules": 4, "radius": 80}
    assert d[1] == {"traj": "curve", "solver": "thesis", "modules": 4, "radius": 90}
    assert d[-1] == {"traj": "spiral", "solver": "fabrik", "modules": 5, "radius": 90}
    assert len({tuple(x.values()) for x in d}) == 16


@pytest.mark.parametrize("args, msg", [
    ((["curve"], ["nope"], []), "unknown solver 'nope'"),
    ((["spiral"], ["seed"], [("angle", (90,))]), "'angle' is not a parameter of the spiral trajectory"),
    ((["curve"], ["seed"], [("alpha", (10, 95))]), "alpha = 95: alpha must be between 0 and 90"),
    ((["curve"], ["seed"], [("radius", (70, -5))]), "trajectory curve with radius = -5: .*radius must be greater than 0"),
    ((["missing.toml"], ["seed"], []), "trajectory missing.toml: unknown trajectory"),
    ((["curve"], ["seed"], [("modules", (4,)), ("modules", (5,))]), "given twice"),
    ((["curve"], ["seed"], [("modules", (4, 7)), ("body_modules", (6, 40))]),
     "body_modules 6 is fewer than the 7 head modules"),
])
def test_sweeps_are_checked_before_running(args, msg):
    with pytest.raises(BhrError, match=msg):
        build_sweep(*args)


def test_sweep_files(tmp_path):
    (tmp_path / "t.toml").write_text('generator = "curve"\n[params]\nradius = 80\n')
    s = sweep_from_toml({"title": "T", "traj": ["curve", "t.toml"], "grid": {"modules": "4:5", "alpha": [9, 11]}},
                        "f.toml", tmp_path)
    assert s.trajs == ("curve", "t.toml") and s.traj_sources["t.toml"] == str(tmp_path / "t.toml")
    assert s.grid == (("modules", (4, 5)), ("alpha", (9, 11))) and s.title == "T"
    with pytest.raises(BhrError, match="f.toml: unknown key 'modules'.*\\[grid\\]"):
        sweep_from_toml({"modules": [4]}, "f.toml")
    with pytest.raises(BhrError, match="f.toml: \\[grid\\]: 'alfa' is not a parameter"):
        sweep_from_toml({"grid": {"alfa": [4]}}, "f.toml")
    with pytest.raises(BhrError, match="traj must be a name or a list of names"):
        sweep_from_toml({"traj": 3}, "f.toml")


# ---------------------------------------------------------------------------------------------- running


def test_rows_are_what_follow_gives():
    s = build_sweep(["curve"], ["seed", "fabrik"], [("modules", (4, 6)), ("alpha", (9, 12))])
    res = run_sweep(s, jobs=1)
    assert [r["design"] for r in res.rows] == list(range(1, 9))
    for r in res.rows:
        robot = Robot(modules=r["modules"], alpha=r["alpha"])
        direct = follow(load_trajectory("curve", feed=robot.feed), solver=r["solver"], robot=robot).summary.to_dict()
        assert r["status"] == "ok"
        for k in ("steps", "tip_max_error_mm", "points_max_error_mm", "orientation_max_deg", "global_max"):
            assert r[k] == direct[k]
        assert r["min_turn_radius_mm"] == robot.min_turn_radius and r["min_clearance_mm"] is None


@pytest.mark.filterwarnings("ignore::bhr._run.driver.BhrWarning")
def test_designs_start_from_a_robot_file(tmp_path):
    """--robot / robot = "FILE": every design is the file's robot with its grid values on top."""
    (tmp_path / "r.toml").write_text("modules = 4\nmodule_length = 12\nstroke = 1\nlever = 6\n")
    s = build_sweep(["curve"], ["seed"], [("alpha", (8, 12)), ("module_length", (10, 12))],
                    robot_file=tmp_path / "r.toml")
    res = run_sweep(s, jobs=1)
    for r in res.rows:
        robot = Robot(modules=4, module_length=r["module_length"], alpha=r["alpha"])
        direct = follow(load_trajectory("curve", feed=robot.feed), robot=robot).summary.to_dict()
        assert r["status"] == "ok" and r["points_max_error_mm"] == direct["points_max_error_mm"]
    # without alpha in the grid the file's stroke and lever give it
    s = build_sweep(["curve"], ["seed"], [("modules", (4,))], robot_file=tmp_path / "r.toml")
    assert run_sweep(s, jobs=1).rows[0]["min_turn_radius_mm"] == Robot(module_length=12, stroke=1,
                                                                       lever=6).min_turn_radius
    (tmp_path / "s.toml").write_text('robot = "r.toml"\n[grid]\nalpha = [8, 12]\n')
    r = run_cli("sweep", "--file", "s.toml", "--jobs", "1", "--no-plots", "--out", "o", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert doc["robot"]["modules"] == 4 and doc["robot_file"].endswith("r.toml")
    assert [row["points_max_error_mm"] for row in doc["rows"]] == [
        row["points_max_error_mm"] for row in res.rows if row["module_length"] == 12]
    bad = run_cli("sweep", "--traj", "line", "--grid", "alpha=8", "--robot", "nope.toml", cwd=tmp_path)
    assert bad.returncode != 0 and "nope.toml" in bad.stderr and "Traceback" not in bad.stderr


def test_local_processes_equal_in_process(tmp_path):
    a = run_cli("sweep", *GRID, "--jobs", "1", "--out", "one", cwd=tmp_path)
    b = run_cli("sweep", *GRID, "--out", "many", cwd=tmp_path)  # default: parallel processes
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    assert "in-process" in a.stdout and "2 processes" in b.stdout or os.cpu_count() != 2
    one = (tmp_path / "one" / "results.csv").read_bytes()
    assert one == (tmp_path / "many" / "results.csv").read_bytes()
    rows = rows_of(tmp_path / "one" / "results.csv")
    assert len(rows) == 18 and all(r["status"] == "ok" for r in rows)
    assert list(rows[0])[:6] == ["design", "traj", "solver", "modules", "alpha", "angle"]
    doc = json.loads((tmp_path / "many" / "results.json").read_text())
    assert doc["designs"] == 18 and doc["failed"] == 0 and doc["heatmap"] == {"x": "modules", "y": "alpha"}
    assert [r["points_max_error_mm"] for r in doc["rows"]] == [float(r["points_max_error_mm"]) for r in rows]
    png = (tmp_path / "many" / "heatmap.png").read_bytes()
    assert png[:8] == PNG and len(png) > 10_000
    page = (tmp_path / "many" / "index.html").read_text()
    best = page[page.index('id="best"'):page.index("</table>", page.index('id="best"'))]
    # every design's row in the results, and the best 10 designs ranked
    assert 'src="heatmap.png"' in page and page.count("<tr class=\"ok\">") == 18 and best.count("<tr>") == 10  # the header row and the ranked designs


def test_failed_designs_are_recorded(tmp_path):
    # a 1 mm entry straight has no point once the feed (module length / 5) passes 2 mm
    proc = run_cli("sweep", "--grid", "entry=1", "--grid", "module_length=5,20", "--grid", "modules=4,5",
                   "--out", "o", "--jobs", "1", cwd=tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == "Error: 2 of 4 designs failed; see o/results.csv"
    rows = rows_of(tmp_path / "o" / "results.csv")
    assert [r["status"] for r in rows[:2]] == ["ok", "ok"]
    assert all(r["status"].startswith("failed: curve too short for the feed") for r in rows[2:])
    assert rows[2]["points_max_error_mm"] == "" and rows[2]["min_turn_radius_mm"] != ""
    assert (tmp_path / "o" / "heatmap.png").exists()
    assert "2 x failed: curve too short" in proc.stdout


def test_heatmap_axes_and_worst_case_cells():
    s = build_sweep(["curve"], ["seed"], [("modules", (4, 5)), ("alpha", (9, 10, 11)), ("angle", (90, 180))])
    assert heatmap_axes(s) == ("modules", "alpha")  # the two biggest axes, in sweep order
    assert heatmap_axes(s, x="angle") == ("angle", "alpha")
    assert heatmap_axes(s, y="modules") == ("alpha", "modules")
    with pytest.raises(BhrError, match="'nope' is not an axis of this sweep"):
        heatmap_axes(s, x="nope")
    res = run_sweep(s, jobs=1)
    cells = heatmap_cells(res, "modules", "alpha", "points_max_error_mm", max)
    for j, a in enumerate((9, 10, 11)):
        for i, m in enumerate((4, 5)):
            want = max(r["points_max_error_mm"] for r in res.rows if r["modules"] == m and r["alpha"] == a)
            assert cells[j][i] == want
    assert heatmap_axes(build_sweep(["curve"], ["seed"], [])) == (None, None)
    # the ranking ranks what the cells show: each robot design by its worst over the trajectory's angle
    from bhr._studies.sweep import best_designs, format_summary

    ranked = best_designs(res, None)
    assert len(ranked) == 6 and {(d["modules"], d["alpha"]) for d in ranked} == {(m, a) for m in (4, 5)
                                                                                 for a in (9, 10, 11)}
    for d in ranked:
        i, j = (4, 5).index(d["modules"]), (9, 10, 11).index(d["alpha"])
        assert d["points_max_error_mm"] == cells[j][i] and d["trajectories"] == 2
    assert [d["points_max_error_mm"] for d in ranked] == sorted(d["points_max_error_mm"] for d in ranked)
    lines = format_summary(res, count=5)
    # the first line counts what ran as the ranking counts designs: 12 runs are 6 designs on 2 trajectories
    assert lines[0].startswith("12 runs (6 designs x 2 trajectories) on "), lines[0]
    from bhr._studies.sweep import heatmap_figure
    from bhr._studies.sweep.pages import _html

    assert heatmap_figure(res, "modules", "alpha")._suptitle.get_text().endswith(": 12 runs (6 designs x 2 trajectories)")
    assert "12 runs (6 designs x 2 trajectories), 0 failed" in _html(res, None)
    assert lines[1] == "Best 5 of 6 designs by worst point error over the trajectories (mm), as the heat-map shows:"
    assert lines[2].startswith(f"  #{ranked[0]['design']}: modules={ranked[0]['modules']}, alpha={ranked[0]['alpha']}: "
                               f"{ranked[0]['points_max_error_mm']:.3f}")


def test_bad_command_lines_are_one_line(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "results.csv").write_text("keep")
    before = snapshot(out)
    for args, msg in [
        (["--grid", "modlues=4"], "did you mean 'modules'?"),
        (["--grid", "modules=4", "--x", "alpha"], "heat-map x axis 'alpha' is not an axis"),
        (["--solver", "nope"], "unknown solver 'nope'"),
        (["--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "--jobs and --scheduler exclude each other"),
        (["--file", "nope.toml"], "no such sweep file nope.toml"),
        (["--traj", "spiral", "--grid", "angle=90"], "not a parameter of the spiral trajectory"),
    ]:
        proc = run_cli("sweep", *args, "--out", "o", cwd=tmp_path)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode != 0 and len(lines) == 1 and lines[0].startswith("Error: "), (args, proc.stderr)
        assert msg in lines[0], (msg, lines[0])
    assert snapshot(out) == before


def test_example_file_with_command_line_override(tmp_path):
    """The documented 1,000-design file parses to 1,000 designs; --grid replaces one of its keys."""
    ex = REPO / "docs" / "examples" / "sweep1000.toml"
    from bhr._studies.sweep import load_sweep

    assert len(load_sweep(ex)) == 1000
    proc = run_cli("sweep", "--file", ex, "--grid", "modules=4", "--grid", "alpha=10", "--grid", "module_length=10",
                   "--jobs", "1", "--no-plots", "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = rows_of(tmp_path / "o" / "results.csv")
    assert [(r["angle"], r["modules"], r["alpha"]) for r in rows] == [("90", "4", "10"), ("360", "4", "10")]
    assert not (tmp_path / "o" / "heatmap.png").exists()


# ---------------------------------------------------------------------------------------------- numba cache


def test_worker_processes_load_the_kernels_from_the_disk_cache(tmp_path):
    """With a warm cache, worker processes compile nothing and load each kernel once per worker (and the command
    once, warming up before it starts them), not per design."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    warm = run_cli_process("sweep", "--grid", "modules=4", "--jobs", "1", "--no-plots", "--out", "w", cwd=tmp_path, env=env)
    assert warm.returncode == 0, warm.stderr
    assert any((tmp_path / "cache").rglob("*.nbc"))
    proc = run_cli_process("sweep", "--grid", "modules=3:8", "--grid", "alpha=8:12", "--jobs", "2", "--no-plots",
                   "--out", "p", cwd=tmp_path, env={**env, "NUMBA_DEBUG_CACHE": "1"})
    assert proc.returncode == 0, proc.stderr
    assert "30 designs on 2 processes" in proc.stdout
    events = [line for line in proc.stdout.splitlines() if line.startswith("[cache]")]
    assert not [e for e in events if "saved" in e], events  # nothing compiled
    loads = [e for e in events if e.startswith("[cache] data loaded")]
    assert loads and all(str(tmp_path / "cache") in e for e in loads), events
    # each kernel a design runs is loaded once in the command and in each of the 2 workers at most, not once per
    # design (30)
    per_kernel = Counter(os.path.basename(e.rstrip("'")) for e in loads)
    assert max(per_kernel.values()) <= 3, per_kernel


# ---------------------------------------------------------------------------------------------- Dask


def _free_loopback_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def dask_cluster():
    """A real Dask distributed LocalCluster: 2 worker processes, loopback only, no dashboard."""
    import distributed  # a test dependency (pyproject's test extra)

    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       scheduler_port=0, dashboard_address=None, memory_limit="1GiB",
                                       silence_logs=40)
    try:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        yield cluster
    finally:
        cluster.close()


def test_dask_cluster_gives_the_local_results(dask_cluster, tmp_path):
    import distributed

    local = run_cli_process("sweep", *GRID, "--solver", "seed", "--solver", "fabrik", "--out", "local", cwd=tmp_path)
    remote = run_cli_process("sweep", *GRID, "--solver", "seed", "--solver", "fabrik", "--out", "dask", "--scheduler",
                     dask_cluster.scheduler_address, cwd=tmp_path)
    assert local.returncode == 0 and remote.returncode == 0, local.stderr + remote.stderr
    assert f"36 runs (18 designs x 2 trajectories) on dask {dask_cluster.scheduler_address}" in remote.stdout
    assert (tmp_path / "local" / "results.csv").read_bytes() == (tmp_path / "dask" / "results.csv").read_bytes()
    doc = json.loads((tmp_path / "dask" / "results.json").read_text())
    assert doc["runner"] == f"dask {dask_cluster.scheduler_address}" and doc["workers"] == 2

    def kernel_stats():  # runs on each worker: did the seed kernel come from the disk cache?
        import os as _os

        from bhr.solvers import _thesis as thesis

        st_ = thesis.follow_constrained_kernel.stats
        return {"hits": sum(st_.cache_hits.values()), "misses": sum(st_.cache_misses.values()),
                "dir": _os.environ.get("NUMBA_CACHE_DIR")}

    with distributed.Client(dask_cluster.scheduler_address, set_as_default=False) as client:
        stats = client.run(kernel_stats)
        hosts = [addr.split("://", 1)[1].rsplit(":", 1)[0] for addr in client.scheduler_info()["workers"]]
    assert set(hosts) == {"127.0.0.1"}
    assert len(stats) == 2
    assert all(s["misses"] == 0 for s in stats.values()), stats  # nothing compiled on the workers
    assert sum(s["hits"] for s in stats.values()) >= 1


def test_library_dask_path_equals_local(dask_cluster):
    s = build_sweep(["curve", "spiral"], ["seed"], [("modules", (4, 5)), ("radius", (80, 100))])
    seen = []
    remote = run_sweep(s, scheduler=dask_cluster.scheduler_address, progress=lambda d, t: seen.append((d, t)))
    local = run_sweep(s, jobs=1)
    assert remote.rows == local.rows and remote.workers == 2
    assert seen[-1] == (8, 8) and all(a <= b for (a, _), (b, _) in zip(seen, seen[1:]))


def test_unreachable_scheduler_is_one_line(tmp_path):
    port = _free_loopback_port()
    proc = run_cli("sweep", "--grid", "modules=4", "--scheduler", f"tcp://127.0.0.1:{port}", "--out", "o",
                   cwd=tmp_path, timeout=120)
    assert proc.returncode != 0
    assert proc.stderr.strip() == (f"Error: cannot connect to the Dask scheduler at tcp://127.0.0.1:{port} "
                                   "(Connection refused); check the address (e.g. tcp://127.0.0.1:8786) and that "
                                   "the scheduler is running")
    assert not (tmp_path / "o").exists()
    proc = run_cli("sweep", "--grid", "modules=4", "--scheduler", "localhost", "--out", "o", cwd=tmp_path)
    assert proc.returncode != 0 and len(proc.stderr.strip().splitlines()) == 1
    assert "missing port number" in proc.stderr


def test_a_port_that_is_not_a_scheduler_times_out():
    """A listening socket that never speaks Dask fails after the timeout instead of hanging."""
    from bhr._studies.sweep import connect_scheduler

    with socket.socket() as srv:
        srv.bind(("127.0.0.1", 0))
        srv.listen(4)
        port = srv.getsockname()[1]
        with pytest.raises(BhrError, match=f"tcp://127.0.0.1:{port} \\(no Dask handshake within 2 s"):
            connect_scheduler(f"tcp://127.0.0.1:{port}", timeout=2)


def test_scheduler_without_dask_installed_is_one_line(tmp_path):
    """With the distributed package unimportable, --scheduler says how to install it, in one line."""
    block = tmp_path / "block"
    block.mkdir()
    (block / "distributed.py").write_text("raise ImportError('No module named distributed')\n")
    env = {"PYTHONPATH": os.pathsep.join([str(block), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    proc = run_cli_process("sweep", "--grid", "modules=4", "--scheduler", "tcp://127.0.0.1:1", "--out", "o", cwd=tmp_path,
                   env=env)
    assert proc.returncode != 0
    assert proc.stderr.strip() == ("Error: --scheduler needs Dask's distributed package, which is not installed; "
                                   f"install it with: {cli_install_command('dask')}")
    # the local path does not need it
    ok = run_cli_process("sweep", "--grid", "modules=4", "--jobs", "1", "--no-plot", "--out", "o", cwd=tmp_path, env=env)
    assert ok.returncode == 0, ok.stderr


def test_sweep_object_is_plain_data():
    s = Sweep(("curve",), ("seed",), (("modules", (4, 5)),))
    assert s.keys == ["traj", "solver", "modules"] and len(s) == 2


def test_clearance_where_the_trajectory_has_a_lumen(tmp_path):
    """A path with a lumen fills min_clearance_mm (worst = smallest per cell) and adds a heat-map panel."""
    (tmp_path / "tube.toml").write_text('generator = "curve"\nlumen = 30.0\n')
    s = build_sweep(["tube.toml", "curve"], ["seed"], [("modules", (4, 5)), ("alpha", (9, 11))], base_dir=tmp_path)
    res = run_sweep(s, jobs=1)
    tube = [r for r in res.rows if r["traj"] == "tube.toml"]
    assert all(r["min_clearance_mm"] is not None for r in tube)
    assert all(r["min_clearance_mm"] is None for r in res.rows if r["traj"] == "curve")
    r0 = tube[0]
    robot = Robot(modules=r0["modules"], alpha=r0["alpha"])
    direct = follow(load_trajectory(tmp_path / "tube.toml", feed=robot.feed), robot=robot).summary.to_dict()
    assert r0["min_clearance_mm"] == direct["min_clearance_mm"]
    cells = heatmap_cells(res, "modules", "alpha", "min_clearance_mm", min)
    assert cells[0][0] == min(r["min_clearance_mm"] for r in tube if r["modules"] == 4 and r["alpha"] == 9)
    from bhr._studies.sweep import heatmap_figure

    fig = heatmap_figure(res)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert any("minimum clearance" in t for t in titles) and any("worst point error" in t for t in titles)
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_heatmap_has_a_panel_per_third_axis_units_over_tolerance_and_the_thesis_design():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bhr._studies.sweep import heatmap_figure, heatmap_panels

    s = build_sweep(["curve"], ["seed"], [("angle", (90, 360)), ("modules", (4, 5, 6)), ("alpha", (6, 10, 14)),
                                          ("module_length", (10, 16))])
    assert heatmap_axes(s) == ("modules", "alpha") and heatmap_panels(s, "modules", "alpha") == "module_length"
    res = run_sweep(s, jobs=1)
    fig = heatmap_figure(res)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.images]
    assert [ax.get_title().splitlines()[0] for ax in panels] == ["module length 10 mm", "module length 16 mm"]
    for ax, length in zip(panels, (10, 16)):
        assert ax.get_xlabel() == "modules" and ax.get_ylabel() == "alpha (deg)"
        assert "worst over turned angle (deg)" in ax.get_title()
        assert [t.get_text() for t in ax.get_xticklabels()] == ["4", "5", "6"]
        # each cell is its module length's worst case over the angle, not over every module length
        cells = heatmap_cells(res, "modules", "alpha", "points_max_error_mm", max, {"module_length": length})
        texts = {(round(t.get_position()[0]), round(t.get_position()[1])): t.get_text() for t in ax.texts}
        for j in range(3):
            for i in range(3):
                assert texts[(i, j)] == f"{cells[j][i]:.2f}"
        # hatched exactly where the cell's worst error is over the 8 mm tolerance
        hatched = {(round(p.get_x() + 0.5), round(p.get_y() + 0.5)) for p in ax.patches if p.get_hatch()}
        assert hatched == {(i, j) for j in range(3) for i in range(3) if cells[j][i] > 8.0}
        # the thesis design (5 modules of 10 mm, alpha 10) is framed in red, in its own panel only
        framed = [(p.get_x() + 0.5, p.get_y() + 0.5) for p in ax.patches
                  if not p.get_hatch() and p.get_edgecolor()[:3] == (1.0, 0.0, 0.0)]
        assert framed == ([(1.0, 1.0)] if length == 10 else [])
    thesis = max(r["points_max_error_mm"] for r in res.rows
                 if (r["modules"], r["alpha"], r["module_length"]) == (5, 10, 10))
    assert [t.get_text() for t in panels[0].texts if t.get_position() == (1, 1)] == [f"{thesis:.2f}"]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[0] == "over the position tolerance (8 mm)"
    assert legend[1] == "thesis design (modules 5, alpha 10, module length 10)"
    plt.close(fig)


def test_sweep_page_headers_are_words_and_ranking_comes_first(tmp_path):
    from bhr._studies.sweep import write_outputs

    s = build_sweep(["curve"], ["seed"], [("modules", (4, 5)), ("module_length", (8, 10))])
    res = run_sweep(s, jobs=1)
    write_outputs(res, tmp_path, plot=False)
    page = (tmp_path / "index.html").read_text()
    import re

    heads = re.findall(r"<th[^>]*>([^<]*)</th>", page)
    assert heads and not [h for h in heads if "_" in h]
    best = page[page.index('id="best"'):page.index("</table>", page.index('id="best"'))]
    best_heads = re.findall(r"<th[^>]*>([^<]*)</th>", best)
    # one row per robot design, ranked by its worst over the trajectories, as the heat-map shows
    assert best_heads == ["rank", "solver", "modules", "module length (mm)", "worst point error (mm)",
                          "min clearance (mm)"]
    assert (tmp_path / "results.csv").read_text().splitlines()[0].split(",")[:4] == ["design", "traj", "solver",
                                                                                     "modules"]


def test_heatmap_names_the_thesis_design_only_where_it_frames_it():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bhr._studies.sweep import heatmap_figure

    res = run_sweep(build_sweep(["curve"], ["seed"], [("modules", (4, 5)), ("alpha", (9, 11))]), jobs=1)
    fig = heatmap_figure(res)  # alpha 10 is not on the grid: nothing to frame, nothing to name
    assert not any(t.get_text().startswith("thesis design") for t in fig.legends[0].get_texts())
    assert not [p for ax in fig.axes for p in ax.patches if p.get_edgecolor()[:3] == (1.0, 0.0, 0.0)]
    plt.close(fig)


def test_whole_number_grid_keys_take_first_last_as_colons_do():
    from bhr._studies.sweep import parse_values

    assert parse_values("seed", "1-3", "x") == parse_values("seed", "1:3", "x") == (1, 2, 3)
    assert parse_values("modules", "4-6", "x") == (4, 5, 6)
    # every key takes both syntaxes (it was refused for decimal keys: "'10-20' is not a number", with no fix)
    assert parse_values("alpha", "10-20", "x") == parse_values("alpha", "10:20", "x")


@pytest.mark.parametrize("text, values", [
    ("8-12", (8, 9, 10, 11, 12)),  # FIRST-LAST of decimals' keys too, not only whole numbers'
    ("8.5-10", (8.5, 9.5)),
    ("3,5:6", (3, 5, 6)),  # mixes, as --colons takes them
    ("4-5,7", (4, 5, 7)),
    ("8:9:0.5,12", (8.0, 8.5, 9.0, 12)),
])
def test_one_range_syntax_for_grids_and_colons(text, values):
    key = "modules" if "." not in text and text in ("3,5:6", "4-5,7") else "alpha"
    assert parse_values(key, text, "--grid") == values


@pytest.mark.parametrize("text, message", [
    ("5-4", "--grid: modules range '5-4' runs backwards; give START:STOP[:STEP] or FIRST-LAST with the smaller first"),
    ("x", "--grid: modules value 'x' is not a number; give numbers and ranges such as modules=4,5,6, "
          "modules=4:8:0.5 or modules=4-8"),
    ("3,,4", "--grid: modules has an empty value; give e.g. modules=4,5,6, modules=4:8 or modules=4-8"),
    ("3,3-4", "--grid: modules lists 3 twice; give each value once"),
])
def test_a_bad_grid_value_says_what_to_write(text, message):
    with pytest.raises(BhrError) as err:
        parse_values("modules", text, "--grid")
    assert str(err.value) == message


def test_a_heatmap_panel_title_names_one_quantity_and_how_a_cell_shows_it():
    """The panel's title read "module length 10 mm / worst point error (mm), worst over turned angle (deg)": two
    quantities to a reader. It names the metric once, then what a cell holding several designs shows."""
    import matplotlib

    matplotlib.use("Agg")
    from bhr._studies.sweep import build_sweep, heatmap_figure, run_sweep

    s = build_sweep(["curve"], ["thesis"], [("angle", (90, 180)), ("modules", (4, 5)), ("alpha", (8, 10)),
                                            ("module_length", (10, 12))])
    fig = heatmap_figure(run_sweep(s, jobs=1))
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.images]
    for ax in panels:
        lines = ax.get_title().splitlines()
        metric, _, how = lines[1].partition(": ")
        assert metric == "worst point error (mm)" and how.startswith("each cell the worst over "), lines
        assert "," not in lines[1]  # one quantity, not two
