"""bhr report: batch files, the chapter 7 set, failed runs, outputs (CSV, JSON, HTML)."""
from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._generators import load_trajectory
from bhr._run.driver import follow
from bhr._settings.errors import BhrError
from bhr._studies.report import (
    ROW_FIELDS,
    RunSpec,
    execute_run,
    format_table,
    load_batch,
    parse_batch,
    run_batch,
    summary_row,
)
from tests.conftest import snapshot

REPO = Path(__file__).resolve().parents[2]
CHAPTER7 = REPO / "docs" / "examples" / "chapter7.toml"
PNG = b"\x89PNG\r\n\x1a\n"
FIGURES = ("path.png", "position_errors.png", "orientation_errors.png", "global_errors.png")


def read_csv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


@pytest.fixture(scope="module")
def chapter7(tmp_path_factory):
    """`bhr report` on the chapter 7 example, run once for the tests below."""
    import os

    from tests.conftest import bhr_exe

    out = tmp_path_factory.mktemp("ch7") / "report"
    proc = subprocess.run(bhr_exe() + ["report", "--file", str(CHAPTER7), "--out", str(out)], capture_output=True,
                          text=True, timeout=900, env=dict(os.environ, MPLBACKEND="Agg"), cwd=out.parent)
    return proc, out


def test_chapter7_batch_reproduces_the_thesis(chapter7):
    proc, out = chapter7
    assert proc.returncode == 0, proc.stderr
    rows = {r["name"]: r for r in read_csv(out / "summary.csv")}
    assert list(rows) == ["line", "curve 90", "curve 360", "spiral", "colon"]
    assert list(read_csv(out / "summary.csv")[0]) == list(ROW_FIELDS)
    assert all(r["status"] == "ok" for r in rows.values())
    # the published figures (thesis 7.1.1-7.1.3), as `bhr follow --solver seed` gives them
    assert float(rows["line"]["points_max_error_mm"]) == 0.0 and float(rows["line"]["orientation_max_deg"]) == 0.0
    assert round(float(rows["curve 90"]["tip_final_error_mm"]), 4) == 0.9099
    assert round(float(rows["curve 360"]["tip_max_error_mm"]), 3) == 4.995
    assert round(float(rows["curve 360"]["tip_final_error_mm"]), 4) == 0.9813
    assert round(float(rows["spiral"]["tip_max_error_mm"]), 3) == 6.596
    assert round(float(rows["spiral"]["orientation_max_deg"]), 2) == 17.94
    assert round(float(rows["spiral"]["tip_final_error_mm"]), 3) == 5.247
    assert [int(rows[k]["steps"]) for k in rows] == [36, 85, 250, 505, 827]
    # only the colon has a lumen (30 mm rectum, 45 mm elsewhere): its clearance is known, the others' not
    assert [r["min_clearance_mm"] == "" for r in rows.values()] == [True, True, True, True, False]
    assert 0 < float(rows["colon"]["min_clearance_mm"]) < 15 - 5
    assert all(float(r["wall_time_s"]) >= float(r["solve_time_s"]) > 0 for r in rows.values())
    # the printed table names every run
    assert [line.split()[0] for line in proc.stdout.splitlines()[1:6]] == ["line", "curve", "curve", "spiral",
                                                                          "colon"]


def test_chapter7_rows_equal_a_direct_follow(chapter7):
    """The report's numbers are the library's: rerun one run with bhr.follow and compare every metric."""
    _, out = chapter7
    doc = json.loads((out / "summary.json").read_text())
    row = next(r for r in doc["runs"] if r["name"] == "spiral")
    s = follow(load_trajectory("spiral", radius=80, pitch=40, turns=2), solver="seed").summary.to_dict()
    for key in ("steps", "tip_max_error_mm", "tip_final_error_mm", "points_max_error_mm", "orientation_max_deg",
                "global_max"):
        assert row[key] == s[key], key
    assert row["stats"]["points"] == s["points"]
    colon = next(r for r in doc["runs"] if r["name"] == "colon")
    sc = follow(load_trajectory("colon"), solver="seed").summary.to_dict()
    assert colon["min_clearance_mm"] == sc["min_clearance_mm"]
    assert colon["clearance"]["min_clearance_step"] == sc["min_clearance_step"]
    assert doc["runs_total"] == 5 and doc["runs_failed"] == 0
    csv_rows = read_csv(out / "summary.csv")
    for r, c in zip(doc["runs"], csv_rows):
        assert c["name"] == r["name"] and float(c["global_max"]) == r["global_max"]


def test_chapter7_page_and_figures(chapter7):
    _, out = chapter7
    page = (out / "index.html").read_text()
    doc = json.loads((out / "summary.json").read_text())
    assert page.index('id="summary"') < page.index("<section")  # summary table on top
    for r in doc["runs"]:
        extra = ["clearance.png"] if r["name"] == "colon" else []  # the colon has a lumen
        assert sorted(r["figures"]) == sorted([*FIGURES, *extra])
        for f in [*FIGURES, *extra]:
            p = out / r["folder"] / f
            assert p.read_bytes()[:8] == PNG and p.stat().st_size > 10_000
            assert f'src="{r["folder"]}/{f}"' in page
        run = json.loads((out / r["folder"] / "run.json").read_text())  # replayable with `bhr replay`
        assert len(run["steps"]) == r["steps"]
    assert "http://" not in page and "https://" not in page and "<script" not in page
    # no temporary files left behind
    assert not [p for p in out.rglob(".*") if p.is_file()]


BATCH_MIXED = """
title = "mixed"
[[run]]
name = "good"
traj = "line"
length = 20
[[run]]
name = "bad file"
traj = "stomach.toml"
[[run]]
name = "no file"
traj = "missing.toml"
[[run]]
name = "fabrik"
traj = "curve"
solver = "fabrik"
angle = 45
"""


def test_a_failed_run_is_recorded_and_the_others_run(run_bhr_in_process, tmp_path):
    (tmp_path / "b.toml").write_text(BATCH_MIXED)
    (tmp_path / "stomach.toml").write_text('generator = "stomach"\n')
    proc = run_bhr_in_process("report", "--file", "b.toml", "--out", "out", "--jobs", "1")
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == "Error: 2 of 4 runs failed; see out/summary.csv"
    rows = read_csv(tmp_path / "out" / "summary.csv")
    status = {r["name"]: r["status"] for r in rows}
    assert status["good"] == "ok" and status["fabrik"] == "ok"
    assert status["bad file"].startswith("failed: ") and "stomach.toml" in status["bad file"]
    assert "generator must be one of" in status["bad file"].replace("'generator'", "generator")
    assert status["no file"].startswith("failed: unknown trajectory") and "missing.toml" in status["no file"]
    assert rows[1]["steps"] == "" and rows[1]["tip_max_error_mm"] == ""
    doc = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert doc["runs_failed"] == 2 and doc["runs"][1]["tip_max_error_mm"] is None
    page = (tmp_path / "out" / "index.html").read_text()
    assert "failed: unknown trajectory" in page
    for f in FIGURES:
        assert (tmp_path / "out" / "runs" / "good" / f).exists()
        assert (tmp_path / "out" / "runs" / "fabrik" / f).exists()
    # a binary solver's run has the codes bhr plan and bhr stream take; fabrik (no actuators) has none
    good = tmp_path / "out" / "runs" / "good"
    codes = (good / "codes.csv").read_text().splitlines()
    run = json.loads((good / "run.json").read_text())
    assert codes[0] == "step,m1,m2,m3,m4,m5" and len(codes) == len(run["steps"]) + 1
    assert codes[1] == "1," + ",".join(str(c) for c in run["steps"][0]["codes"])
    assert not (tmp_path / "out" / "runs" / "fabrik" / "codes.csv").exists()
    assert len((good / "steps.csv").read_text().splitlines()) == len(run["steps"]) + 1
    assert not (tmp_path / "out" / "runs" / "bad-file").exists()
    assert "FAILED" in proc.stdout and "no file: failed: unknown trajectory" in proc.stdout


@pytest.mark.parametrize("body, words", [
    ('[[run]]\nname = "a"\ntraj = "curve"\nmodlues = 5\n', ["b.toml", "run 1 ('a')", "'modlues'", "'modules'"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nmodules = "five"\n', ["b.toml", "run 1", "modules must be a number"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nmodules = 4.5\n', ["run 1", "modules must be a whole number"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nalpha = true\n', ["run 1", "alpha must be a number"]),
    ('[[run]]\nname = "a"\n', ["run 1", "missing key 'traj'"]),
    ('[[run]]\ntraj = "line"\n', ["run 1", "missing key 'name'"]),
    ('[[run]]\nname = "a"\ntraj = "line"\n[[run]]\nname = "a"\ntraj = "curve"\n', ["run 2 ('a')", "also run 1"]),
    ('[[run]]\nname = "a"\ntraj = "spiral"\nangle = 90\n', ["run 1", "spiral trajectory has no parameter 'angle'"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nlimit = "bogus"\n', ["run 1", "limit must be one of binary"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nalpha = 95\n', ["run 1 ('a')", "alpha must be between 0 and 90"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nsolver = "nope"\n', ["run 1", "unknown solver 'nope'"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nradius = -3\n', ["run 1", "radius must be greater than 0"]),
    ('[[run]]\nname = "a"\ntraj = "line"\n[[run]]\nname = "b"\ntraj = "curve"\nentry = 0\n',
     ["run 2 ('b')", "curve too short for the feed"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nmodule-length = 9\n', ["'module-length'", "'module_length'"]),
    ('title = "x"\n', ["b.toml", "no runs"]),
    ('runs = 3\n', ["unknown top-level key 'runs'"]),
    ('[defaults]\nalfa = 3\n[[run]]\nname = "a"\ntraj = "line"\n', ["[defaults]", "'alfa'", "'alpha'"]),
    ('[[run]\nname = "a"\n', ["b.toml", "not valid TOML"]),
    ('[[run]]\nname = "a"\ntraj = "curve"\nbody_modules = 3\n', ["run 1 ('a')", "body_modules 3 is fewer than the 5"]),
])
def test_bad_batch_is_one_line_and_writes_nothing(run_bhr_in_process, tmp_path, body, words):
    (tmp_path / "b.toml").write_text(body)
    out = tmp_path / "out"
    out.mkdir()
    (out / "index.html").write_text("previous report")
    before = snapshot(out)
    proc = run_bhr_in_process("report", "--file", "b.toml", "--out", "out")
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), proc.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert snapshot(out) == before and (out / "index.html").read_text() == "previous report"
    assert proc.stdout == ""


def test_missing_batch_file_and_unwritable_output(run_bhr_in_process, tmp_path):
    proc = run_bhr_in_process("report", "--file", "nope.toml", "--out", "out")
    assert proc.returncode != 0 and proc.stderr.strip() == (
        "Error: no such batch file nope.toml; give a TOML file of [[run]] tables (see docs/report.md)")
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "line"\n')
    (tmp_path / "afile").write_text("x")
    proc = run_bhr_in_process("report", "--file", "b.toml", "--out", "afile/out")
    assert proc.returncode != 0
    assert len(proc.stderr.strip().splitlines()) == 1 and "cannot write report" in proc.stderr
    assert "Running" not in proc.stderr  # refused before any run


def test_defaults_and_relative_paths(tmp_path):
    (tmp_path / "sub").mkdir()
    batch = tmp_path / "sub" / "b.toml"
    batch.write_text('[defaults]\nmodules = 4\nalpha = 12\n[[run]]\nname = "a"\ntraj = "my.toml"\nrobot = "r.toml"\n'
                     '[[run]]\nname = "b"\ntraj = "curve"\nmodules = 6\nangle = 45\nwarmup = 5\n')
    b = load_batch(batch)
    assert b.runs[0].traj == str(tmp_path / "sub" / "my.toml")
    assert b.runs[0].robot_file == str(tmp_path / "sub" / "r.toml")
    assert b.runs[0].robot_params == {"modules": 4, "alpha": 12}
    assert b.runs[1].robot_params == {"modules": 6, "alpha": 12}
    assert b.runs[1].traj_params == {"angle": 45.0} and b.runs[1].solver_options == {"warmup": 5}
    assert b.runs[1].solver == "thesis"


def test_html_is_escaped_and_self_contained(tmp_path):
    b = parse_batch({"title": "<b>T</b> & co", "run": [
        {"name": "<script>alert(1)</script>", "traj": "line", "length": 10, "description": 'say "hi" <i>'},
        {"name": "x & y", "traj": "missing.toml"}]}, "inline", tmp_path)
    rep = run_batch(b, tmp_path / "r", plots=False)
    page = (tmp_path / "r" / "index.html").read_text()
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "&lt;b&gt;T&lt;/b&gt; &amp; co" in page and "say &quot;hi&quot; &lt;i&gt;" in page
    assert "x &amp; y" in page and "failed: unknown trajectory" in page
    assert [r["folder"] for r in rep.rows] == ["runs/script-alert-1-script", "runs/x-y"]
    assert '<link rel="icon" href="data:,">' in page  # no favicon request


def test_parallel_runs_equal_serial_ones(tmp_path):
    b = parse_batch({"run": [{"name": "c90", "traj": "curve"}, {"name": "c180", "traj": "curve", "angle": 180},
                             {"name": "sp", "traj": "spiral", "turns": 1}, {"name": "bad", "traj": "nope.toml"}]},
                    "inline", tmp_path)
    seen = []
    serial = run_batch(b, tmp_path / "s", jobs=1, plots=False, progress=lambda d, t, r: seen.append((d, t)))
    parallel = run_batch(b, tmp_path / "p", jobs=2, plots=False)
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]
    drop = {"wall_time_s", "solve_time_s"}
    assert [{k: v for k, v in r.items() if k not in drop} for r in serial.rows] == \
           [{k: v for k, v in r.items() if k not in drop} for r in parallel.rows]
    assert [r["status"] for r in serial.rows][:3] == ["ok"] * 3
    assert serial.rows[3]["status"].startswith("failed: unknown trajectory")


def test_min_clearance_is_reported_where_known(tmp_path):
    """A trajectory file with a lumen gives a clearance; the same path without one leaves it unknown."""
    (tmp_path / "tube.toml").write_text('generator = "curve"\nlumen = 30.0\n[params]\nangle = 180\n')
    b = parse_batch({"run": [{"name": "tube", "traj": "tube.toml"},
                             {"name": "open", "traj": "curve", "angle": 180}]}, "inline", tmp_path)
    rep = run_batch(b, tmp_path / "r", plots=False)
    tube, open_ = rep.rows
    direct = follow(load_trajectory(tmp_path / "tube.toml"), solver="seed").summary.to_dict()
    assert tube["min_clearance_mm"] == direct["min_clearance_mm"] == summary_row(direct)["min_clearance_mm"]
    assert tube["min_clearance_mm"] < 15 - 5  # radius 15 mm tube minus the 5 mm robot radius
    assert open_["min_clearance_mm"] is None
    assert tube["tip_max_error_mm"] == open_["tip_max_error_mm"]  # the lumen changes the scoring only
    parsed = list(csv.DictReader(io.StringIO((tmp_path / "r" / "summary.csv").read_text())))
    assert float(parsed[0]["min_clearance_mm"]) == tube["min_clearance_mm"] and parsed[1]["min_clearance_mm"] == ""
    doc = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert doc["runs"][1]["min_clearance_mm"] is None
    page = (tmp_path / "r" / "index.html").read_text()
    assert f"{tube['min_clearance_mm']:.3f} mm at step {tube['clearance']['min_clearance_step']}" in page
    assert any(f"{tube['min_clearance_mm']:.2f}" in line for line in format_table(rep.rows))


def test_a_run_with_the_whole_body(tmp_path):
    """body_modules in a run table: the run is bhr.follow with that body, and its page shows the body's errors."""
    b = parse_batch({"run": [{"name": "whole", "traj": "colon", "body_modules": 20}]}, "inline", tmp_path)
    assert b.runs[0].inputs()["body_modules"] == 20
    rep = run_batch(b, tmp_path / "r", plots=True)
    (row,) = rep.rows
    direct = follow(load_trajectory("colon"), solver="thesis", body_modules=20).summary.to_dict()
    assert direct["body_modules"] == 20
    assert row["min_clearance_mm"] == direct["min_clearance_mm"] and row["global_max"] == direct["global_max"]
    run_dir = tmp_path / "r" / "runs" / "whole"
    assert (run_dir / "body_errors.png").stat().st_size > 10_000
    assert json.loads((run_dir / "run.json").read_text())["summary"]["body_modules"] == 20
    assert "body_errors.png" in (tmp_path / "r" / "index.html").read_text()


def test_a_crash_inside_a_run_is_a_failed_row(tmp_path):
    """Any exception in one run (not only BhrError) becomes that run's failure reason."""
    spec = RunSpec(name="c", traj="curve", solver="seed", robot_params={"bogus": 1})
    row = execute_run(spec)
    assert row["status"].startswith("failed: TypeError: ") and "bogus" in row["status"]
    assert "Traceback" in row["traceback"] and row["steps"] is None and row["wall_time_s"] >= 0
    spec = RunSpec(name="c", traj="curve", solver="seed", solver_options={"no_such_option": 1})
    row = execute_run(spec)
    assert row["status"].startswith("failed: solver thesis does not take the option 'no_such_option'")
    assert "traceback" not in row


_NUMERIC = {"modules": st.integers(1, 12), "module_length": st.floats(1, 30), "alpha": st.floats(1, 30),
            "tol_pos": st.floats(0.5, 20), "max_iter": st.integers(11, 60), "feed_divisor": st.integers(1, 8),
            "radius": st.floats(10, 200), "angle": st.floats(1, 720), "entry": st.floats(0, 50, allow_subnormal=False)}


@settings(max_examples=60, deadline=None)
@given(st.fixed_dictionaries({}, optional=_NUMERIC), st.text(st.characters(blacklist_categories=("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp", "Zs")) | st.just(" "),
                 min_size=1, max_size=20).filter(lambda s: s.strip()))  # printable names (run names refuse others)
def test_run_tables_round_trip(values, name):
    """Whatever valid keys a run gives come back, unchanged, as the run's inputs."""
    try:
        b = parse_batch({"run": [{"name": name, "traj": "curve", **values}]}, "prop")
    except BhrError as exc:  # a curve whose straights get no point at this feed is refused: fine
        assume("curve too short for the feed" not in str(exc))
        raise
    spec = b.runs[0]
    assert spec.name == name.strip()
    inputs = spec.inputs()
    assert inputs.pop("traj") == "curve" and inputs.pop("solver") == "thesis"
    assert inputs == values


def test_library_imports_without_matplotlib_or_dask():
    code = ("import sys, bhr._studies.report, bhr._studies.sweep; bad = [m for m in ('matplotlib', 'dask', 'distributed', 'click') "
            "if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_bad_jobs_value():
    b = parse_batch({"run": [{"name": "a", "traj": "line"}]}, "x")
    with pytest.raises(BhrError, match="jobs must be"):
        run_batch(b, "unused", jobs=0)


def test_robot_file_in_a_run(tmp_path):
    """robot = "file.toml" (relative to the batch file); the run's own options override it."""
    (tmp_path / "r.toml").write_text("modules = 4\nalpha = 12\n")
    (tmp_path / "bad.toml").write_text("modules = -1\n")
    b = parse_batch({"run": [{"name": "file", "traj": "curve", "robot": "r.toml"},
                             {"name": "override", "traj": "curve", "robot": "r.toml", "alpha": 9},
                             {"name": "bad", "traj": "curve", "robot": "bad.toml"}]}, "inline", tmp_path)
    rows = run_batch(b, tmp_path / "o", plots=False).rows
    assert rows[0]["robot"]["modules"] == 4 and rows[0]["robot"]["alpha"] == 12
    assert rows[1]["robot"]["modules"] == 4 and rows[1]["robot"]["alpha"] == 9
    direct = follow(load_trajectory("curve"), solver="seed", robot=bhr.Robot(modules=4, alpha=9)).summary.to_dict()
    assert rows[1]["tip_max_error_mm"] == direct["tip_max_error_mm"]
    assert rows[2]["status"].startswith("failed: ") and "bad.toml" in rows[2]["status"]


SECRET = "TOKEN-8f2d9c4e1b7a6d3f"


@pytest.mark.parametrize("files, traj, robot", [
    ({"t.csv": f"x,y,z\n{SECRET},1,2\n3,4,5\n"}, "t.csv", None),  # a cell of line 2
    ({"t.csv": f"x y z\n0 0 0\n1 2 {SECRET}\n"}, "t.csv", None),
    ({"t.csv": f"# points\n{SECRET}\n"}, "t.csv", None),  # line 2 is the header
    ({"t.toml": f"[[segment]]\ntype = '{SECRET}'\n"}, "t.toml", None),
    ({"r.toml": f"modules = 5\nalpha = '{SECRET}'\n"}, "line", "r.toml"),
    ({"r.json": f'{{"modules": 5,\n "{SECRET}": 1}}'}, "line", "r.json"),
], ids=["csv-cell", "csv-blanks", "csv-header", "traj-toml", "robot-toml", "robot-json"])
def test_a_files_second_line_never_reaches_the_report(tmp_path, files, traj, robot):
    """A run whose trajectory or robot file cannot be read is a failed row, whose reason names the file and the
    line but quotes nothing of it: summary.csv, summary.json and index.html are shared."""
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    batch = f'[[run]]\nname = "a"\ntraj = "{traj}"\n' + (f'robot = "{robot}"\n' if robot else "")
    (tmp_path / "b.toml").write_text(batch)
    rep = run_batch(load_batch(tmp_path / "b.toml"), tmp_path / "out", jobs=1, plots=False)
    (row,) = rep.rows
    assert row["status"].startswith("failed: ") and SECRET not in row["status"], row["status"]
    for name in ("summary.csv", "summary.json", "index.html"):
        assert SECRET not in (tmp_path / "out" / name).read_text(), name


def test_a_batch_of_more_runs_than_a_study_may_have_is_refused_up_front(run_bhr_in_process, tmp_path):
    """1,000,001 runs (a sweep or traversability study is refused past 1,000,000 designs): refused in one line
    before any run is checked (the runs here are empty tables, which a check would refuse first) and before the
    TOML is parsed; nothing written."""
    from bhr._settings.options import LIMITS

    n = LIMITS["study_runs"] + 1
    with pytest.raises(BhrError, match=f"^b: {n} runs is more than {n - 1}; use fewer runs$"):
        parse_batch({"run": [{}] * n}, "b")
    (tmp_path / "big.toml").write_text('[[run]]\nname = "a"\n' * n)  # no traj: any check of a run would refuse it
    proc = run_bhr_in_process("report", "--file", "big.toml")
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr == f"Error: big.toml: {n} runs is more than {n - 1}; use fewer runs\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.toml"]
    parse_batch({"run": [{"name": "a", "traj": "line"}]}, "b")  # one run is fine
