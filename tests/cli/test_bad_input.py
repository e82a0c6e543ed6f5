"""A catalogue of bad input for every command: one clear line, non-zero exit, no files touched.

Each entry runs the `bhr` command in process (click's CliRunner on the same command group the
console script runs) in a fresh folder that already holds a good output file (good.json), a
plain file (afile) that cannot be a folder, and the entry's own input files. The command must
exit non-zero with at most three lines on stderr, no traceback (no exception left uncaught),
and leave every file in the folder as it was (nothing new, nothing changed). That every command
of the real console script refuses bad input in one line is held below, a process per command.

Entries for commands that are not registered in `bhr.cli.main.COMMANDS` skip, so the
catalogue grows as commands land; the rest of the module drives the shared options with
hypothesis, in process.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field

import pytest
from bhr.cli.main import COMMANDS, main
from click.testing import CliRunner
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from tests.conftest import snapshot


@dataclass
class Bad:
    id: str
    command: str
    args: list[str]
    files: dict[str, str | bytes] = field(default_factory=dict)
    expect: str = ""  # a fragment the one line must contain (case-insensitive)
    links: dict[str, str] = field(default_factory=dict)  # symbolic links to make: name -> where it points


GOOD_JSON = '{"good": true}\n'
CODES_OK = "step,m1,m2,m3,m4,m5\n1,0,3,0,0,0\n2,0,6,0,0,0\n"
RUN = "run.json"
T = ["--target", "3", "9", "0"]
SEG = '[[segment]]\ntype = "straight"\nlength = 40.0\n'


def _manifest(files: dict[str, str]) -> str:
    """A bhr manifest.json listing ``files`` (name -> text), as bhr writes it (any machine, any user)."""
    import hashlib
    import json

    listed = {n: {"bytes": len(t.encode()), "sha256": hashlib.sha256(t.encode()).hexdigest()} for n, t in files.items()}
    return json.dumps({"bhr_output": 2, "command": "follow", "run_id": "0" * 32, "files": listed})


def seg(text: str) -> dict[str, str]:
    return {"p.toml": text}


# --- the catalogue ----------------------------------------------------------------------------------------------

ROBOT_BAD = [  # (id, robot file text, expected fragment): tried with every simulating command
    ("robot-garbled", "modules = = 5\n", "not valid TOML"),
    ("robot-binary", b"\x00\xff\xfe\x00", "r.toml"),
    ("robot-unknown-key", "modlues = 5\n", "did you mean 'modules'"),
    ("robot-wrong-type", "module_length = 'ten'\n", "module_length must be a number"),
    ("robot-nan", "alpha = nan\n", "alpha must be a finite number"),
    ("robot-inf", "module_length = inf\n", "finite"),
    ("robot-alpha-90", "alpha = 90\n", "outside (0, 90)"),
    ("robot-alpha-negative", "alpha = -5\n", "outside (0, 90)"),
    ("robot-zero-modules", "modules = 0\n", "modules must be greater than 0"),
    ("robot-negative-length", "module_length = -10\n", "greater than 0"),
    ("robot-other-code-table", "[codes]\n0='rest'\n3='-x'\n6='+y'\n12='+x'\n9='-y'\n15='lift'\n", "code 3 is '-x'"),
    ("robot-bad-link", "[link]\nmodule_order = [1, 1, 2, 3, 4]\n", "appears twice"),
]

CASES: list[Bad] = []
for _cmd, _base in (("solve", T), ("follow", ["--traj", "line", "--out", "o"]), ("fk", ["--codes", "3,0,0,0,0"])):
    CASES.append(Bad(f"{_cmd}-robot-missing", _cmd, _base + ["--robot", "nope.toml"], expect="no such robot file"))
    CASES.append(Bad(f"{_cmd}-robot-folder", _cmd, _base + ["--robot", "."], expect="folder"))
    for _id, _text, _frag in ROBOT_BAD:
        CASES.append(Bad(f"{_cmd}-{_id}", _cmd, _base + ["--robot", "r.toml"], {"r.toml": _text}, _frag))

CASES += [
    # solve: options
    Bad("solve-alpha-95", "solve", T + ["--alpha", "95"], expect="alpha must be between 0 and 90"),
    Bad("solve-alpha-0", "solve", T + ["--alpha", "0"], expect="alpha"),
    Bad("solve-alpha-nan", "solve", T + ["--alpha", "nan"], expect="not a finite number"),
    Bad("solve-alpha-inf", "solve", T + ["--alpha", "inf"], expect="not a finite number"),
    Bad("solve-alpha-text", "solve", T + ["--alpha", "ten"], expect="must be a number written with plain digits"),
    Bad("solve-modules-0", "solve", T + ["--modules", "0"], expect="modules must be greater than 0"),
    Bad("solve-modules-negative", "solve", T + ["--modules", "-3"], expect="modules must be greater than 0"),
    Bad("solve-modules-fraction", "solve", T + ["--modules", "2.5"], expect="must be a whole number"),
    Bad("solve-modules-huge", "solve", T + ["--modules", "99999999"], expect="too large"),
    Bad("solve-length-0", "solve", T + ["--module-length", "0"], expect="module length must be greater than 0"),
    Bad("solve-length-huge", "solve", T + ["--module-length", "1e300"], expect="too large"),
    Bad("solve-target-nan", "solve", ["--target", "nan", "1", "2"], expect="not a finite number"),
    Bad("solve-target-huge", "solve", ["--target", "1e300", "1", "2"], expect="too large"),
    Bad("solve-target-text", "solve", ["--target", "a", "b", "c"], expect="must be a number written with plain digits"),
    Bad("solve-target-short", "solve", ["--target", "1", "2"], expect="--target"),
    Bad("solve-no-target", "solve", [], expect="--target"),
    Bad("solve-orientation-zero", "solve", T + ["--orientation", "0", "0", "0"], expect="non-zero"),
    Bad("solve-tol-pos-negative", "solve", T + ["--tol-pos", "-1"], expect="tol-pos must be greater than 0"),
    Bad("solve-tol-ori-nan", "solve", T + ["--tol-ori", "nan"], expect="finite"),
    Bad("solve-max-iter-0", "solve", T + ["--max-iter", "0"], expect="max-iter must be greater than 0"),
    Bad("solve-weight-negative", "solve", T + ["--weight-pos", "-1"], expect="weight-pos"),
    Bad("solve-stroke-without-lever", "solve", T + ["--stroke", "1"], expect="give both stroke and lever"),
    Bad("solve-stroke-longer", "solve", T + ["--stroke", "5", "--lever", "4"], expect="shorter than lever"),
    Bad("solve-unknown-solver", "solve", T + ["--solver", "nope"], expect="unknown solver 'nope'"),
    Bad("solve-unknown-option", "solve", T + ["--colour", "red"], expect="no such option"),
    Bad("solve-json-under-a-file", "solve", T + ["--json", "afile/out.json"], expect="not a writable folder"),
    Bad("solve-json-is-folder", "solve", T + ["--json", "."], expect="is a directory"),
    Bad("solve-plot-under-a-file", "solve", T + ["--plot", "afile/p.png"], expect="not a writable folder"),
    Bad("solve-bad-keeps-good-json", "solve", ["--target", "nan", "0", "0", "--json", "good.json"], expect="finite"),
    Bad("solve-bad-solver-keeps-good-json", "solve", T + ["--solver", "nope", "--json", "good.json"],
        expect="unknown solver"),
    # fk
    Bad("fk-invalid-code", "fk", ["--codes", "3,7,0"], expect="code 7"),
    Bad("fk-unstable-code", "fk", ["--codes", "5"], expect="not a stable actuator code"),
    Bad("fk-code-text", "fk", ["--codes", "3,a"], expect="not a whole number"),
    Bad("fk-code-float", "fk", ["--codes", "3.5"], expect="not a whole number"),
    Bad("workspace-no-samples", "workspace", ["--modules", "12", "--samples", "0"], expect="samples must be greater"),
    Bad("workspace-figure-format", "workspace", ["--modules", "2", "--plot", "w.jpg"], expect=".png, .svg or .pdf"),
    Bad("workspace-zero-modules", "workspace", ["--modules", "0"], expect="modules must be greater than 0"),
    Bad("import-missing-mesh", "import", ["no-such.stl"], expect="no such surface mesh"),
    Bad("import-start-two-numbers", "import", ["m.stl", "--start", "1,2"], files={"m.stl": "solid x\nendsolid x\n"},
        expect="--start must be three"),
    Bad("import-not-a-mesh", "import", ["m.vtp", "--start", "0,0,0", "--out", "c.csv"], files={"m.vtp": "not a mesh\n"},
        expect="no surface read"),
    Bad("fk-no-codes", "fk", ["--codes", ","], expect="at least one code"),
    Bad("fk-negative-code", "fk", ["--codes", "-3"], expect="code -3"),
    Bad("fk-wrong-count", "fk", ["--codes", "3,0", "--modules", "5"], expect="expected 5 codes"),
    Bad("fk-modules-0", "fk", ["--codes", "3", "--modules", "0"], expect="modules must be greater than 0"),
    Bad("fk-alpha-nan", "fk", ["--codes", "3", "--alpha", "nan"], expect="not a finite number"),
    Bad("fk-json-under-a-file", "fk", ["--codes", "3", "--json", "afile/x.json"], expect="not a writable folder"),
    Bad("fk-bad-keeps-good-json", "fk", ["--codes", "7", "--json", "good.json"], expect="code 7"),
    # follow: names, options and outputs
    Bad("follow-unknown-trajectory", "follow", ["--traj", "stomach"], expect="unknown trajectory 'stomach'"),
    Bad("follow-all-poses-thesis", "follow", ["--traj", "colon", "--all-poses"], expect="drop --all-poses"),
    Bad("follow-all-poses-trail", "follow", ["--traj", "anatomy", "--solver", "lumen", "--body-modules", "20",
                                             "--locomotion", "trail", "--all-poses"], expect="drop --all-poses"),
    Bad("follow-missing-file", "follow", ["--traj", "nope.toml"], expect="unknown trajectory"),
    Bad("follow-alpha-underflows", "follow", ["--traj", "colon", "--alpha", "1e-400"],
        expect="1e-400 is too small to mean anything"),
    Bad("follow-robot-toml-underflows", "follow", ["--traj", "colon", "--robot", "r.toml"],
        files={"r.toml": "modules = 5\nalpha = 1e-400\n"}, expect="r.toml: the number 1e-400 is too small"),
    Bad("follow-robot-json-underflows", "follow", ["--traj", "colon", "--robot", "r.json"],
        files={"r.json": '{"modules": 5, "alpha": 1e-400}'}, expect="r.json: the number 1e-400 is too small"),
    *[Bad(f"{cmd}-out-inside-a-run", cmd, args + ["--out", "run1/sub"],
          files={"run1/run.json": GOOD_JSON, "run1/manifest.json": _manifest({"run.json": GOOD_JSON})},
          expect="is inside") for cmd, args in (("follow", ["--traj", "line"]),
                                                ("compare", ["--traj", "line", "--solver", "thesis"]),
                                                ("sweep", ["--traj", "line", "--grid", "modules=3:4"]))],
    Bad("report-batch-underflows", "report", ["--file", "b.toml"],
        files={"b.toml": '[[run]]\nname = "a"\ntraj = "colon"\ntol_pos = 0.5e-400\n'},
        expect="b.toml: the number 0.5e-400 is too small"),
    Bad("replay-run-underflows", "replay", ["run.json"], files={"run.json": '{"steps": [1e-400]}'},
        expect="run.json: the number 1e-400 is too small"),
    Bad("follow-empty-trajectory", "follow", ["--traj", ""], expect="the trajectory name is empty; give a built-in"),
    Bad("follow-seed-too-large", "follow", ["--traj", "anatomy", "--seed", "99999999999999999999999"],
        expect="99999999999999999999999 is too large; the limit is 4294967295"),
    Bad("follow-folder", "follow", ["--traj", "d.csv"], {"d.csv/x": "x"}, expect="folder"),
    Bad("follow-wrong-extension", "follow", ["--traj", "p.txt"], {"p.txt": "x,y,z\n"}, expect=".toml"),
    Bad("follow-unknown-solver", "follow", ["--traj", "line", "--solver", "nope"], expect="unknown solver"),
    Bad("follow-radius-negative", "follow", ["--traj", "curve", "--radius", "-5"], expect="radius must be greater than 0"),
    Bad("follow-radius-nan", "follow", ["--traj", "curve", "--radius", "nan"], expect="not a finite number"),
    Bad("follow-turns-0", "follow", ["--traj", "spiral", "--turns", "0"], expect="turns must be greater than 0"),
    Bad("follow-turns-negative", "follow", ["--traj", "spiral", "--turns", "-2"], expect="turns must be greater than 0"),
    Bad("follow-turns-huge", "follow", ["--traj", "spiral", "--turns", "100000"], expect="limit"),
    Bad("follow-length-text", "follow", ["--traj", "line", "--length", "long"], expect="must be a number written with plain digits"),
    Bad("follow-line-shorter-than-feed", "follow", ["--traj", "line", "--length", "1"], expect="shorter than one feed"),
    Bad("follow-param-not-of-generator", "follow", ["--traj", "curve", "--pitch", "3"], expect="no parameter 'pitch'"),
    Bad("follow-feed-divisor-0", "follow", ["--traj", "line", "--feed-divisor", "0"], expect="feed divisor"),
    Bad("follow-modules-0", "follow", ["--traj", "line", "--modules", "0"], expect="modules must be greater than 0"),
    Bad("follow-alpha-95", "follow", ["--traj", "line", "--alpha", "95"], expect="alpha"),
    Bad("follow-out-under-a-file", "follow", ["--traj", "line", "--out", "afile/run"], expect="not a writable folder"),
    Bad("follow-default-out-under-a-file", "follow", ["--traj", "line"], {"bhr-out": "a file, not a folder"},
        expect="not a writable folder"),
    Bad("follow-json-under-a-file", "follow", ["--traj", "line", "--out", "o", "--json", "afile/r.json"],
        expect="not a writable folder"),
    Bad("follow-bad-keeps-good-json", "follow", ["--traj", "p.csv", "--json", "good.json", "--out", "o"],
        {"p.csv": "x,y,z\n0,0,0\n"}, expect="two distinct points"),
    Bad("follow-bad-keeps-previous-run", "follow", ["--traj", "curve", "--radius", "0", "--out", "prev"],
        {"prev/run.json": GOOD_JSON, "prev/codes.csv": CODES_OK,
         "prev/manifest.json": _manifest({"run.json": GOOD_JSON, "codes.csv": CODES_OK})},
        expect="radius must be greater than 0"),
    # follow: trajectory files (TOML)
    Bad("traj-toml-garbled", "follow", ["--traj", "p.toml"], seg("[[segment]\ntype = 'straight'\n"), "not valid TOML"),
    Bad("traj-toml-binary", "follow", ["--traj", "p.toml"], {"p.toml": b"\xff\xfe\x00\x01"}, "p.toml"),
    Bad("traj-toml-empty", "follow", ["--traj", "p.toml"], seg(""), "p.toml is empty"),
    Bad("traj-toml-unknown-key", "follow", ["--traj", "p.toml"], seg(SEG + "colour = 'red'\n"), "unknown key 'colour'"),
    Bad("traj-toml-unknown-top-key", "follow", ["--traj", "p.toml"], seg("speed = 3\n" + SEG), "unknown key 'speed'"),
    Bad("traj-toml-wrong-type", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength="40"\n'),
        "must be a number"),
    Bad("traj-toml-nan", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength=nan\n'), "finite"),
    Bad("traj-toml-inf", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength=inf\n'), "finite"),
    Bad("traj-toml-length-0", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength=0\n'),
        "length must be greater than 0"),
    Bad("traj-toml-length-negative", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength=-4\n'),
        "length must be greater than 0"),
    Bad("traj-toml-radius-0", "follow", ["--traj", "p.toml"],
        seg('[[segment]]\ntype="arc"\nradius=0\nangle=90\nturn="left"\n'), "radius must be greater than 0"),
    Bad("traj-toml-angle-negative", "follow", ["--traj", "p.toml"],
        seg('[[segment]]\ntype="arc"\nradius=70\nangle=-9\nturn="left"\n'), "angle must be greater than 0"),
    Bad("traj-toml-bad-turn", "follow", ["--traj", "p.toml"],
        seg('[[segment]]\ntype="arc"\nradius=70\nangle=90\nturn="widdershins"\n'), "turn must be one of"),
    Bad("traj-toml-turns-0", "follow", ["--traj", "p.toml"],
        seg('[[segment]]\ntype="helix"\nradius=70\npitch=10\nturns=0\nturn="left"\n'), "turns must be greater than 0"),
    Bad("traj-toml-turns-negative", "follow", ["--traj", "p.toml"],
        seg('[[segment]]\ntype="helix"\nradius=70\npitch=10\nturns=-1\nturn="left"\n'), "turns must be greater than 0"),
    Bad("traj-toml-unknown-type", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="zigzag"\n'),
        "type must be one of"),
    Bad("traj-toml-no-segments", "follow", ["--traj", "p.toml"], seg('name = "x"\nsegment = []\n'), "no segments"),
    Bad("traj-toml-zero-heading", "follow", ["--traj", "p.toml"], seg("heading = [0, 0, 0]\n" + SEG), "[0, 0, 0]"),
    Bad("traj-toml-start-nan", "follow", ["--traj", "p.toml"], seg("start = [0, nan, 0]\n" + SEG), "finite"),
    Bad("traj-toml-too-short", "follow", ["--traj", "p.toml"], seg('[[segment]]\ntype="straight"\nlength=1\n'),
        "shorter than one feed"),
    Bad("traj-toml-option-on-file", "follow", ["--traj", "p.toml", "--radius", "50"], seg(SEG), "generator"),
    Bad("traj-generator-bad-param", "follow", ["--traj", "p.toml"], seg('generator="curve"\n[params]\nradius=-1\n'),
        "radius must be greater than 0"),
    Bad("traj-generator-unknown", "follow", ["--traj", "p.toml"], seg('generator="zigzag"\n'), "generator must be"),
    Bad("traj-generator-bad-lumen", "follow", ["--traj", "p.toml"], seg('generator="line"\nlumen=-30\n'), "lumen"),
    # follow: trajectory files (CSV)
    Bad("traj-csv-one-point", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n1,2,3\n"}, "two distinct points"),
    Bad("traj-csv-no-points", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n"}, "two distinct points"),
    Bad("traj-csv-empty", "follow", ["--traj", "p.csv"], {"p.csv": ""}, "p.csv is empty"),
    Bad("traj-csv-in-metres", "follow", ["--traj", "p.csv"],
        {"p.csv": "x,y,z,lumen\n0,0,0,0.04\n0.3,0,0,0.04\n0.3,0.2,0,0.04\n"}, "multiplying by 1000"),
    Bad("traj-csv-all-same", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n1,1,1\n1,1,1\n"}, "distinct"),
    Bad("traj-csv-duplicate", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n9,0,0\n9,0,0\n20,0,0\n"},
        "line 4: repeats the point of line 3"),
    Bad("traj-csv-nan", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n9,nan,0\n"}, "line 3"),
    Bad("traj-csv-inf", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n-inf,0,0\n"}, "finite"),
    Bad("traj-csv-text", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n9,nine,0\n"}, "not a number"),
    Bad("traj-csv-short-row", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n9,0\n"}, "2 fields"),
    Bad("traj-csv-no-header", "follow", ["--traj", "p.csv"], {"p.csv": "0,0,0\n9,0,0\n"}, "header"),
    Bad("traj-csv-unknown-column", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z,t\n0,0,0,0\n9,0,0,1\n"},
        "unknown column 't'"),
    Bad("traj-csv-lumen-0", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z,lumen\n0,0,0,30\n9,0,0,0\n"}, "lumen"),
    Bad("traj-csv-binary", "follow", ["--traj", "p.csv"], {"p.csv": b"x,y,z\n\x00\x01\x02\n"}, "p.csv"),
    Bad("traj-csv-latin1", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n9,0,0 \xe9\n".encode("latin-1")},
        "not UTF-8"),
    Bad("traj-csv-huge-coordinate", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n1e308,0,0\n"}, "beyond"),
    Bad("traj-csv-option-on-file", "follow", ["--traj", "p.csv", "--turns", "2"], {"p.csv": "x,y,z\n0,0,0\n9,0,0\n"},
        "generator"),
    # stream (hardware link): the codes file and the options
    Bad("stream-missing-codes", "stream", ["--codes", "nope.csv", "--dry-run"], expect="nope.csv"),
    Bad("stream-invalid-code", "stream", ["--codes", "c.csv", "--dry-run"],
        {"c.csv": "step,m1,m2,m3,m4,m5\n1,0,7,0,0,0\n"}, "7"),
    Bad("stream-code-text", "stream", ["--codes", "c.csv", "--dry-run"],
        {"c.csv": "step,m1,m2,m3,m4,m5\n1,0,x,0,0,0\n"}, "c.csv"),
    Bad("stream-garbled-codes", "stream", ["--codes", "c.csv", "--dry-run"], {"c.csv": b"\xff\xfe\x00garbage"},
        "c.csv"),
    Bad("stream-more-modules-than-a-board", "stream", ["--codes", "c.csv", "--dry-run"],
        {"c.csv": "step," + ",".join(f"m{i}" for i in range(1, 34)) + "\n1" + ",0" * 33 + "\n"},
        "one board drives at most 32"),
    Bad("stream-no-header", "stream", ["--codes", "c.csv", "--dry-run"], {"c.csv": "1,0,3,0,0,0\n"}, "header"),
    Bad("stream-step-two-signs", "stream", ["--codes", "c.csv", "--dry-run"],
        {"c.csv": "step,m1,m2,m3,m4,m5\n1,0,3,0,0,0\n--2,0,6,0,0,0\n"}, "step '--2' is not a whole number"),
    Bad("plan-step-two-signs", "plan", ["--codes", "c.csv"],
        {"c.csv": "step,m1,m2,m3,m4,m5\n+-1,0,3,0,0,0\n"}, "step '+-1' is not a whole number"),
    Bad("stream-rate-0", "stream", ["--codes", "c.csv", "--dry-run", "--rate", "0"], {"c.csv": CODES_OK}, "--rate"),
    Bad("stream-rate-nan", "stream", ["--codes", "c.csv", "--dry-run", "--rate", "nan"], {"c.csv": CODES_OK}, "--rate"),
    Bad("stream-baud-0", "stream", ["--codes", "c.csv", "--port", "loop://", "--baud", "0"], {"c.csv": CODES_OK},
        "--baud"),
    Bad("stream-no-port", "stream", ["--codes", "c.csv"], {"c.csv": CODES_OK}, "--port"),
    Bad("stream-port-missing", "stream", ["--codes", "c.csv", "--port", "/dev/bhr-no-such-port"], {"c.csv": CODES_OK},
        "bhr-no-such-port"),
    # status
    Bad("status-port-missing", "status", ["--port", "/dev/bhr-no-such-port"], expect="bhr-no-such-port"),
    Bad("status-timeout-negative", "status", ["--port", "loop://", "--timeout", "-1"], expect="--timeout"),
    Bad("status-json-under-a-file", "status", ["--port", "/dev/bhr-no-such-port", "--json", "afile/s.json"],
        expect="not a writable folder"),
    Bad("status-no-port", "status", [], expect="--port is required"),
    Bad("status-robot-without-port", "status", ["--robot", "r.toml"], {"r.toml": "modules = 5\n"}, "--port is required"),
    Bad("status-robot-bad-link", "status", ["--robot", "r.toml"], {"r.toml": "[link]\nbaudrate = -1\n"}, "baudrate"),
    Bad("stream-robot-port-missing", "stream", ["--codes", "c.csv", "--robot", "r.toml"],
        {"c.csv": CODES_OK, "r.toml": '[link]\nport = "/dev/bhr-no-such-port"\n'}, "bhr-no-such-port"),
    Bad("stream-robot-order-mismatch", "stream", ["--codes", "c.csv", "--robot", "r.toml", "--dry-run"],
        {"c.csv": CODES_OK, "r.toml": "modules = 3\n[link]\nmodule_order = [3, 2, 1]\n"}, "module_order"),
    # follow --port
    Bad("follow-port-missing", "follow", ["--traj", "line", "--out", "o", "--port", "/dev/bhr-no-such-port"],
        expect="bhr-no-such-port"),
    Bad("follow-port-rate-nan", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--rate", "nan"],
        expect="--rate"),
    Bad("follow-port-rate-0", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--rate", "0"],
        expect="--rate"),
    Bad("follow-baud-without-port", "follow", ["--traj", "line", "--out", "o", "--baud", "9600"], expect="--port"),
    Bad("follow-port-with-body", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--body-modules", "8"],
        expect="--body-modules"),
    Bad("follow-port-no-board", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--timeout", "0.05",
                                          "--retries", "0"], expect="did not answer"),
    # plan
    Bad("plan-missing-codes", "plan", ["--codes", "nope.csv"], expect="nope.csv"),
    Bad("plan-invalid-code", "plan", ["--codes", "c.csv"], {"c.csv": "step,m1\n1,5\n"}, "column m1"),
    Bad("plan-schedule-unknown", "plan", ["--codes", "c.csv", "--schedule", "fast"], {"c.csv": CODES_OK}, "--schedule"),
    Bad("plan-rate-0", "plan", ["--codes", "c.csv", "--rate", "0"], {"c.csv": CODES_OK}, "--rate"),
    Bad("plan-thermal-duty", "plan", ["--codes", "c.csv", "--robot", "r.toml"],
        {"c.csv": CODES_OK, "r.toml": "[thermal]\nhold_duty = 1.2\n"}, "hold_duty"),
    Bad("plan-thermal-unknown-key", "plan", ["--codes", "c.csv", "--robot", "r.toml"],
        {"c.csv": CODES_OK, "r.toml": "[thermal]\nhold_time = 3\n"}, "hold_time"),
    Bad("plan-thermal-text", "plan", ["--codes", "c.csv", "--robot", "r.toml"],
        {"c.csv": CODES_OK, "r.toml": '[thermal]\nrelax_ms = "slow"\n'}, "relax_ms"),
    Bad("plan-too-fast", "plan", ["--codes", "c.csv", "--rate", "50", "--schedule", "rate", "--no-plots"],
        {"c.csv": "step,m1\n" + "".join(f"{i},{3 if i < 60 or i == 64 else 6}\n" for i in range(1, 70))},
        "--schedule auto"),
    Bad("plan-plot-under-a-file", "plan", ["--codes", "c.csv", "--plot", "afile/t.png"], {"c.csv": CODES_OK}, ""),
    Bad("stream-too-fast", "stream", ["--codes", "c.csv", "--port", "/dev/bhr-no-such-port", "--rate", "50",
                                      "--schedule", "rate"],
        {"c.csv": "step,m1\n" + "".join(f"{i},{3 if i < 60 or i == 64 else 6}\n" for i in range(1, 70))},
        "nothing was sent"),
    # replay
    Bad("replay-missing", "replay", ["nope.json"], expect="nope.json"),
    Bad("replay-garbled", "replay", ["r.json"], {"r.json": "{not json"}, "not valid JSON"),
    Bad("replay-not-a-run", "replay", ["r.json"], {"r.json": '{"steps": 3}'}, "r.json"),
    Bad("replay-nan", "replay", ["r.json"], {"r.json": '{"trajectory": {"points": [[NaN, 0, 0]]}, "robot": {}, '
                                                       '"solver": "seed", "steps": [{}]}'}, "r.json"),
    Bad("replay-binary", "replay", ["r.json"], {"r.json": b"\xff\x00\xfe"}, "r.json"),
    Bad("replay-out-under-a-file", "replay", ["good.json", "--out", "afile/x"], expect=""),
    # report
    Bad("report-missing", "report", ["--batch", "nope.toml"], expect="nope.toml"),
    Bad("report-garbled", "report", ["--batch", "b.toml"], {"b.toml": "[[run]\n"}, "b.toml"),
    Bad("report-unknown-key", "report", ["--batch", "b.toml"], {"b.toml": 'colour = "red"\n[[run]]\nname = "a"\ntraj = "line"\n'},
        "colour"),
    Bad("report-no-runs", "report", ["--batch", "b.toml"], {"b.toml": 'title = "x"\n'}, "b.toml"),
    Bad("report-bad-alpha", "report", ["--batch", "b.toml"], {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\nalpha = 95\n'},
        "alpha"),
    Bad("report-out-under-a-file", "report", ["--batch", "b.toml", "--out", "afile/r"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\n'}, "not a writable folder"),
    Bad("report-jobs-0", "report", ["--batch", "b.toml", "--jobs", "0"], {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\n'},
        "--jobs"),
    # sweep
    Bad("sweep-missing-file", "sweep", ["--file", "nope.toml"], expect="nope.toml"),
    Bad("sweep-garbled-file", "sweep", ["--file", "s.toml"], {"s.toml": "[grid\n"}, "s.toml"),
    Bad("sweep-unknown-trajectory", "sweep", ["--traj", "stomach", "--grid", "alpha=8,10"], expect="stomach"),
    Bad("sweep-unknown-solver", "sweep", ["--traj", "line", "--solver", "nope", "--grid", "alpha=8,10"], expect="nope"),
    Bad("sweep-grid-text", "sweep", ["--traj", "line", "--grid", "alpha=abc"], expect="alpha"),
    Bad("sweep-grid-unknown-key", "sweep", ["--traj", "line", "--grid", "colour=1,2"], expect="colour"),
    Bad("sweep-grid-modules-0", "sweep", ["--traj", "line", "--grid", "modules=0,1"], expect="modules"),
    Bad("sweep-out-under-a-file", "sweep", ["--traj", "line", "--grid", "alpha=8,10", "--out", "afile/s"],
        expect="not a writable folder"),
    # compare
    Bad("compare-robot-missing", "compare", ["--traj", "curve", "--robot", "nope.toml"], expect="no such robot file"),
    Bad("compare-unknown-solver", "compare", ["--traj", "curve", "--solver", "seed", "--solver", "nope"],
        expect="unknown solver 'nope'"),
    Bad("compare-unknown-trajectory", "compare", ["--traj", "stomach"], expect="unknown trajectory 'stomach'"),
    Bad("compare-all-poses", "compare", ["--traj", "curve", "--all-poses"], expect="--all-poses"),
    Bad("compare-one-solver", "compare", ["--traj", "curve", "--solver", "seed"], expect="at least two solvers"),
    Bad("compare-solver-twice", "compare", ["--traj", "curve", "--solver", "seed", "--solver", "seed"],
        expect="given twice"),
    Bad("compare-body-too-short", "compare", ["--traj", "curve", "--solver", "seed", "--solver", "optimal",
                                             "--body-modules", "3"], expect="fewer than the 5 head modules"),
    Bad("compare-extra-arguments", "compare", ["nope-a.json", "nope-b.json"], expect="unexpected extra arguments"),
    Bad("compare-unknown-option", "compare", ["--colour", "red"], expect="no such option"),
    Bad("compare-out-under-a-file", "compare", ["--traj", "line", "--solver", "seed", "--solver", "ccd",
                                               "--out", "afile/c"], expect="not a writable folder"),
    # traverse (and the anatomical colons' seed)
    Bad("follow-anatomy-negative-seed", "follow", ["--traj", "anatomy", "--seed", "-1"],
        expect="seed must be a whole number from 0 to 4294967295"),
    Bad("follow-anatomy-fraction-seed", "follow", ["--traj", "anatomy", "--seed", "1.5"], expect="--seed"),
    Bad("follow-seed-on-a-curve", "follow", ["--traj", "curve", "--seed", "3"], expect="no parameter 'seed'"),
    Bad("traverse-colons-backwards", "traverse", ["--colons", "9-2"], expect="runs backwards"),
    Bad("traverse-colons-text", "traverse", ["--colons", "many"], expect="not a seed or a range"),
    Bad("traverse-colons-twice", "traverse", ["--colons", "1-3,2"], expect="twice"),
    Bad("traverse-grid-seed", "traverse", ["--colons", "1", "--grid", "seed=1,2"], expect="--colons"),
    Bad("traverse-grid-trajectory-key", "traverse", ["--colons", "1", "--grid", "radius=50"],
        expect="trajectory option"),
    Bad("traverse-target-above-1", "traverse", ["--colons", "1", "--target-pass", "1.5"], expect="--target-pass"),
    Bad("traverse-unknown-solver", "traverse", ["--colons", "1", "--solver", "nope"], expect="nope"),
    Bad("traverse-heatmap-axis", "traverse", ["--colons", "1", "--x", "seed"], expect="not a design axis"),
    Bad("traverse-out-under-a-file", "traverse", ["--colons", "1", "--out", "afile/t"],
        expect="not a writable folder"),
    # bench
    Bad("bench-unknown-case", "bench", ["--case", "nope"], expect="nope"),
    Bad("bench-repeat-0", "bench", ["--repeat", "0"], expect="--repeat"),
    Bad("bench-json-under-a-file", "bench", ["--json", "afile/b.json"], expect="not a writable folder"),
]

# --- hostile input: every kind of file, number and output path (each must cost one line within seconds) ---------

ZIGZAG = {"z.csv": "x,y,z\n0,0,0\n1,0,0\n0,0,0.5\n1,0,0.5\n0,0,0\n"}  # never one feed away from its start
RUN_OK = ('{"trajectory": {"points": [[0,0,0],[2,0,0]]}, "robot": {"modules": 1}, "solver": "seed", "steps": '
          '[{"points": [[0,0,0],[10,0,0]], "point_errors_mm": [0,0], "module_orientation_errors_deg": [0], '
          '"codes": [0], "iterations": 1}]}')
ONE = ["--codes", "c.csv", "--dry-run"]
CASES += [
    Bad("warmup-extra-argument", "warmup", ["now"], expect="unexpected extra argument"),
    Bad("export-format-unknown", "export", ["--format", "sdf", "--out", "r.urdf"], expect="not a format bhr writes"),
    Bad("export-no-out", "export", ["--format", "urdf"], expect="--out"),
    Bad("export-modules-zero", "export", ["--format", "urdf", "--out", "r.urdf", "--modules", "0"],
        expect="modules must be greater than 0"),
    Bad("physics-run-missing", "physics", ["missing.json", "--out", "p"], expect="no such run file"),
    Bad("physics-not-a-run", "physics", ["bad.json", "--out", "p"], {"bad.json": '{"x": 1}'}, "not a bhr run"),
    Bad("physics-stiffness-negative", "physics", ["bad.json", "--out", "p", "--wall-stiffness", "-1"],
        {"bad.json": '{"x": 1}'}, "wall-stiffness"),
]

CASES += [
    # zig-zag path files (IndexError before): every command that follows a trajectory
    Bad("traj-csv-zigzag", "follow", ["--traj", "z.csv", "--out", "o"], ZIGZAG, "zig-zags"),
    Bad("compare-csv-zigzag", "compare", ["--traj", "z.csv", "--solver", "seed", "--solver", "ccd"], ZIGZAG,
        "zig-zags"),
    Bad("sweep-csv-zigzag", "sweep", ["--traj", "z.csv", "--grid", "alpha=8,10", "--out", "s"], ZIGZAG, "zig-zags"),
    # full devices as outputs (ENOSPC); the device itself is never replaced (checked by test_outputs too)
    Bad("solve-json-dev-full", "solve", T + ["--json", "/dev/full"], expect="no space left"),
    Bad("solve-plot-dev-full", "solve", T + ["--plot", "/dev/full"], expect="no space left"),
    Bad("fk-json-dev-full", "fk", ["--codes", "3,0", "--json", "/dev/full"], expect="no space left"),
    Bad("follow-json-dev-full", "follow", ["--traj", "line", "--no-plots", "--json", "/dev/full"],
        expect="no space left"),
    Bad("compare-json-dev-full", "compare", ["--traj", "line", "--solver", "seed", "--solver", "ccd", "--no-plots",
                                            "--json", "/dev/full"], expect="no space left"),
    Bad("bench-json-dev-full", "bench", ["--case", "fabrik", "--repeat", "1", "--json", "/dev/full"],
        expect="no space left"),
    Bad("replay-animate-dev-full", "replay", ["r.json", "--animate", "/dev/full"], {"r.json": RUN_OK}, ".gif"),
    # figure and animation paths of a format bhr does not draw
    Bad("solve-plot-txt", "solve", T + ["--plot", "x.txt"], expect=".png"),
    Bad("solve-plot-no-folder", "solve", T + ["--plot", "nope/deeper/x.png", "--json", "afile/x"],
        expect="not a writable folder"),
    # outputs that are another output of the same run, the current folder, or a folder of other files
    Bad("follow-json-is-codes", "follow", ["--traj", "line", "--out", "o", "--json", "o/codes.csv"],
        expect="another output"),
    Bad("follow-json-is-figure", "follow", ["--traj", "line", "--out", "o", "--json", "o/path.png"],
        expect="another output"),
    Bad("follow-out-is-cwd", "follow", ["--traj", "line", "--out", "."], expect="is the current folder or holds it"),
    Bad("follow-out-foreign-folder", "follow", ["--traj", "line", "--out", "mine"], {"mine/thesis.tex": "text"},
        "no bhr run wrote"),
    Bad("follow-out-is-file", "follow", ["--traj", "line", "--out", "afile"], expect="is a file"),
    Bad("compare-out-foreign-folder", "compare", ["--traj", "line", "--solver", "seed", "--solver", "ccd",
                                                 "--out", "mine"], {"mine/notes.txt": "x"}, "no bhr run wrote"),
    Bad("sweep-out-foreign-folder", "sweep", ["--traj", "line", "--grid", "alpha=8,10", "--out", "mine"],
        {"mine/notes.txt": "x"}, "no bhr run wrote"),
    Bad("report-out-foreign-folder", "report", ["--batch", "b.toml", "--out", "mine"],
        {"mine/notes.txt": "x", "b.toml": '[[run]]\nname = "a"\ntraj = "line"\n'}, "no bhr run wrote"),
    Bad("follow-out-dev-null", "follow", ["--traj", "line", "--out", "/dev/null"], expect="not a folder"),
    Bad("sweep-out-is-file", "sweep", ["--traj", "line", "--grid", "alpha=8,10", "--out", "afile"],
        expect="not a folder"),
    Bad("report-out-is-file", "report", ["--batch", "b.toml", "--out", "afile"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\n'}, "not a folder"),
    Bad("solve-json-link-to-folder", "solve", T + ["--json", "d.json"], {"d/x": "x"}, "directory",
        links={"d.json": "d"}),
    Bad("replay-out-foreign-folder", "replay", ["r.json", "--out", "mine"], {"r.json": RUN_OK, "mine/a.tex": "x"},
        "no bhr run wrote"),
    Bad("fk-json-dangling-link", "fk", ["--codes", "3", "--json", "l.json"], expect="symbolic link",
        links={"l.json": "missing/x.json"}),
    # huge numbers where a whole number is read
    Bad("stream-baud-huge", "stream", ["--codes", "c.csv", "--port", "loop://", "--baud", "99999999999"],
        {"c.csv": CODES_OK}, "--baud"),
    Bad("status-baud-huge", "status", ["--port", "loop://", "--baud", "99999999999"], expect="--baud"),
    Bad("follow-baud-huge", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--baud",
                                       "99999999999"], expect="--baud"),
    Bad("stream-rate-tiny", "stream", ONE + ["--rate", "1e-300"], {"c.csv": CODES_OK}, "--rate"),
    Bad("follow-port-rate-tiny", "follow", ["--traj", "line", "--out", "o", "--port", "loop://", "--rate", "1e-300"],
        expect="--rate"),
    Bad("stream-timeout-huge", "stream", ["--codes", "c.csv", "--port", "loop://", "--timeout", "1e300"],
        {"c.csv": CODES_OK}, "--timeout"),
    Bad("stream-retries-huge", "stream", ["--codes", "c.csv", "--port", "loop://", "--retries", "10**9"],
        {"c.csv": CODES_OK}, "--retries"),
    Bad("follow-stride-huge", "follow", ["--traj", "line", "--out", "o", "--stride", "99999999999999999999"],
        expect="--stride"),
    Bad("replay-step-huge", "replay", ["r.json", "--step", "99999999999999999999"], {"r.json": RUN_OK}, "--step"),
    Bad("report-jobs-huge", "report", ["--batch", "b.toml", "--jobs", "99999999999"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\n'}, "--jobs"),
    Bad("sweep-jobs-huge", "sweep", ["--traj", "line", "--grid", "alpha=8,10", "--jobs", "99999999999"],
        expect="--jobs"),
    Bad("bench-repeat-huge", "bench", ["--repeat", "99999999999"], expect="--repeat"),
    # digits other than ASCII, and '_' separators, in codes and coordinates
    Bad("fk-code-fullwidth", "fk", ["--codes", "\uff11\uff15"], expect="not a whole number"),
    Bad("fk-code-arabic-indic", "fk", ["--codes", "\u0661\u0665"], expect="not a whole number"),
    Bad("fk-code-underscore", "fk", ["--codes", "1_5"], expect="not a whole number"),
    Bad("stream-code-fullwidth", "stream", ONE, {"c.csv": "step,m1,m2\n1,0,\uff13\n"}, "not a whole number"),
    Bad("stream-code-underscore", "stream", ONE, {"c.csv": "step,m1,m2\n1,0,1_5\n"}, "not a whole number"),
    Bad("stream-step-underscore", "stream", ONE, {"c.csv": "step,m1,m2\n1_0,0,3\n"}, "not a whole number"),
    Bad("solve-target-fullwidth", "solve", ["--target", "\uff13", "9", "0"], expect="must be a number written with plain digits"),
    Bad("solve-target-arabic-indic", "solve", ["--target", "\u0663", "9", "0"], expect="must be a number written with plain digits"),
    Bad("solve-target-underscore", "solve", ["--target", "1_5", "9", "0"], expect="must be a number written with plain digits"),
    Bad("solve-modules-underscore", "solve", T + ["--modules", "1_0"], expect="must be a whole number"),
    Bad("follow-radius-fullwidth", "follow", ["--traj", "curve", "--radius", "\uff17\uff10"],
        expect="must be a number written with plain digits"),
    Bad("stream-rate-fullwidth", "stream", ONE + ["--rate", "\uff11"], {"c.csv": CODES_OK}, "--rate"),
    Bad("traj-csv-fullwidth", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n\uff19,0,0\n"},
        "not a number"),
    Bad("traj-csv-underscore", "follow", ["--traj", "p.csv"], {"p.csv": "x,y,z\n0,0,0\n1_9,0,0\n"}, "not a number"),
    Bad("sweep-grid-fullwidth", "sweep", ["--traj", "line", "--grid", "alpha=\uff18,10"], expect="not a number"),
    # oversized fields, files and runs: refused before memory runs out
    Bad("stream-field-over-csv-limit", "stream", ONE, {"c.csv": "step,m1\n1," + "3" * 140_000 + "\n"},
        "field limit"),
    Bad("stream-code-long", "stream", ONE, {"c.csv": "step,m1\n1," + "3" * 100_000 + "\n"}, "not a whole number"),
    Bad("stream-dev-zero", "stream", ["--codes", "/dev/zero", "--dry-run"], expect="device"),
    Bad("stream-link-to-dev-zero", "stream", ["--codes", "z.csv", "--dry-run"], expect="device",
        links={"z.csv": "/dev/zero"}),
    Bad("traj-csv-link-to-dev-zero", "follow", ["--traj", "z.csv"], expect="device", links={"z.csv": "/dev/zero"}),
    Bad("traj-toml-link-to-dev-zero", "follow", ["--traj", "z.toml"], expect="device", links={"z.toml": "/dev/zero"}),
    Bad("robot-link-to-dev-zero", "solve", T + ["--robot", "r.toml"], expect="device", links={"r.toml": "/dev/zero"}),
    Bad("replay-link-to-dev-zero", "replay", ["r.json"], expect="device", links={"r.json": "/dev/zero"}),
    Bad("report-batch-dev-zero", "report", ["--batch", "b.toml"], expect="device", links={"b.toml": "/dev/zero"}),
    Bad("sweep-file-dev-zero", "sweep", ["--file", "s.toml"], expect="device", links={"s.toml": "/dev/zero"}),
    Bad("traj-csv-too-many-points", "follow", ["--traj", "p.csv", "--out", "o"],
        {"p.csv": "x,y,z\n" + "".join(f"{i},0,0\n" for i in range(500_002))}, "more than 500000 points"),
    Bad("follow-line-too-many-points", "follow", ["--traj", "line", "--length", "1e6", "--feed-divisor", "1000"],
        expect="limit 500000"),
    Bad("follow-body-too-large", "follow", ["--traj", "line", "--length", "10000", "--body-modules", "1000",
                                            "--out", "o"], expect="in memory"),
    Bad("compare-too-large", "compare", ["--traj", "line", "--length", "600000", "--solver", "seed", "--solver",
                                         "ccd", "--no-plots"], expect="in memory"),
    Bad("follow-modules-over-limit", "follow", ["--traj", "line", "--modules", "1001"], expect="too large"),
    # --port with a whole robot: the advice names what works (a board drives 32 modules at most)
    Bad("follow-port-body-over-a-board", "follow", ["--traj", "curve", "--body-modules", "40", "--port", "/dev/pts/999"],
        expect="one board drives at most 32 modules, so the whole robot's 40 cannot be streamed to one"),
    Bad("follow-port-body", "follow", ["--traj", "curve", "--body-modules", "6", "--port", "/dev/pts/999"],
        expect="to a board built for 6 modules (make -C firmware MODULES=6): bhr stream --port PORT"),
    # the robot limits of the command line hold in batch and sweep files too
    Bad("report-modules-huge", "report", ["--batch", "b.toml"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\nmodules = 1000000\n'}, "too large"),
    Bad("report-max-iter-huge", "report", ["--batch", "b.toml"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\nmax_iter = 100000000\n'}, "too large"),
    Bad("report-module-length-huge", "report", ["--batch", "b.toml"],
        {"b.toml": '[[run]]\nname = "a"\ntraj = "line"\nmodule_length = 1e9\n'}, "too large"),
    Bad("sweep-grid-modules-huge", "sweep", ["--traj", "line", "--grid", "modules=1:1000000"], expect="too large"),
    Bad("sweep-grid-max-iter-huge", "sweep", ["--traj", "line", "--grid", "max_iter=10,100000000"],
        expect="too large"),
    Bad("sweep-file-modules-huge", "sweep", ["--file", "s.toml"],
        {"s.toml": 'traj = "line"\n[grid]\nmodules = [5, 1000000]\n'}, "too large"),
    # tampered run.json
    Bad("replay-deep-nesting", "replay", ["r.json"], {"r.json": '{"a":' * 100_000 + "1" + "}" * 100_000},
        "nested too deeply"),
    Bad("replay-huge-integer", "replay", ["r.json"], {"r.json": RUN_OK.replace('"iterations": 1', '"iterations": '
                                                                               + "9" * 5000)}, "r.json"),
    Bad("replay-big-int-iterations", "replay", ["r.json"],
        {"r.json": RUN_OK.replace('"iterations": 1', '"iterations": 99999999999999999999999')}, "iterations"),
    Bad("replay-1e308", "replay", ["r.json"], {"r.json": RUN_OK.replace("[10,0,0]", "[1e308,0,0]")}, "within"),
    Bad("replay-code-huge", "replay", ["r.json"], {"r.json": RUN_OK.replace('"codes": [0]', '"codes": [1e400]')},
        "r.json"),
    Bad("replay-robot-huge", "replay", ["r.json"], {"r.json": RUN_OK.replace('"modules": 1', '"modules": 1e300')},
        "r.json"),
    Bad("replay-robot-huge-int", "replay", ["r.json"],
        {"r.json": RUN_OK.replace('"modules": 1', '"modules": 10000000000000000000000')}, "too large"),
    # misleading messages made plain
    Bad("traj-toml-heading-tiny", "follow", ["--traj", "p.toml"], seg("heading = [1e-320, 0, 0]\n" + SEG), "too small"),
    Bad("traj-toml-deep-nesting", "follow", ["--traj", "p.toml"], seg("a = " + "[" * 5000 + "]" * 5000 + "\n"),
        "p.toml"),
]

# every command, so that none is forgotten when it lands
assert {c.command for c in CASES} >= {"solve", "follow", "fk", "stream", "status", "compare", "report", "sweep",
                                      "replay", "bench"}
assert len({c.id for c in CASES}) == len(CASES)


def _prepare(folder, case: Bad) -> None:
    (folder / "good.json").write_text(GOOD_JSON)
    (folder / "afile").write_text("a plain file\n")
    for name, to in case.links.items():
        (folder / name).symlink_to(to)
    for name, content in case.files.items():
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content, encoding="utf-8")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_costs_one_line_and_touches_nothing(tmp_path, monkeypatch, case):
    if case.command not in COMMANDS:
        pytest.skip(f"'bhr {case.command}' is not registered yet")
    _prepare(tmp_path, case)
    before = snapshot(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    res = CliRunner().invoke(main, [case.command, *case.args])
    err = res.stderr.strip()
    assert res.exit_code != 0, f"exit 0 for bad input; stdout: {res.stdout[-500:]}"
    assert isinstance(res.exception, SystemExit), repr(res.exception)  # an uncaught one is the console's traceback
    assert "Traceback" not in res.stderr, res.stderr
    assert err, "no message on stderr"
    assert len(err.splitlines()) <= 3, res.stderr
    assert case.expect.lower() in err.lower(), err
    assert snapshot(tmp_path) == before, "files were created or changed"
    assert (tmp_path / "good.json").read_text() == GOOD_JSON


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_registered_command_is_in_the_catalogue(command):
    assert any(c.command == command for c in CASES), f"add bad-input entries for 'bhr {command}' to CASES"


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_registered_command_refuses_unknown_options(run_bhr, tmp_path, command):
    before = snapshot(tmp_path)
    res = run_bhr(command, "--no-such-option", timeout=120)
    assert res.returncode != 0 and "Traceback" not in res.stderr
    assert 0 < len(res.stderr.strip().splitlines()) <= 3 and "no-such-option" in res.stderr
    assert snapshot(tmp_path) == before


# --- hypothesis over the shared options, in process -------------------------------------------------------------

HYP = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

number_text = st.one_of(
    st.integers(-5, 50).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["nan", "inf", "-inf", "1e308", "-0", "0", "ten", "", "1,5", "0x10", "1e-320"]),
)
ROBOT_OPTIONS = ["--modules", "--module-length", "--robot-radius", "--alpha", "--tol-pos", "--tol-ori", "--max-iter",
                 "--weight-pos", "--weight-ori"]


def _check(result) -> None:
    """Either success, or a clean exit with at most a few lines on stderr; never an escaped exception."""
    if result.exit_code == 0:
        assert result.exception is None
        return
    assert isinstance(result.exception, SystemExit), repr(result.exception)
    err = result.stderr.strip()
    assert err and len(err.splitlines()) <= 3 and "Traceback" not in err, err


@HYP
@given(opts=st.dictionaries(st.sampled_from(ROBOT_OPTIONS), number_text, max_size=3))
def test_fk_robot_options(tmp_path, opts):
    args = ["fk", "--codes", "3,0,6"]
    if "--modules" not in opts:
        args += ["--modules", "3"]
    for k, v in opts.items():
        args += [k, v]
    with contextlib.chdir(tmp_path):
        result = CliRunner().invoke(main, args + ["--json", "-"])
    _check(result)
    if result.exit_code == 0:
        assert '"points"' in result.stdout


@HYP
@given(opts=st.dictionaries(st.sampled_from(ROBOT_OPTIONS), number_text, max_size=3),
       target=st.tuples(number_text, number_text, number_text),
       solver=st.sampled_from(["fabrik", "ccd", "seed", "constrained", "nope"]))
def test_solve_options(tmp_path, opts, target, solver):
    try:  # a target on the chain's base is pinned by test_target_on_the_base below
        assume(math.hypot(*(float(v) for v in target)) > 1e-100)
    except ValueError:
        pass
    args = ["solve", "--target", *target, "--solver", solver, "--json", "-"]
    for k, v in opts.items():
        args += [k, v]
    result = CliRunner().invoke(main, args)
    _check(result)
    if result.exit_code == 0:
        import json

        doc = json.loads(result.stdout)
        assert all(math.isfinite(v) for p in doc["points"] for v in p)


WEIRD = st.sampled_from(["nan", "inf", "-inf", "0", "-1", "1e9", "x", ""])


def _opt(valid):
    return st.one_of(*([valid] * 7), WEIRD)  # mostly plausible values, so that many runs go all the way


def _f(lo, hi):
    return _opt(st.floats(lo, hi).map(repr))


ROBOT_HYP = {"--feed-divisor": _opt(st.integers(0, 8).map(str)), "--modules": _opt(st.integers(0, 8).map(str)),
             "--alpha": _f(-5, 100), "--tol-pos": _f(-1, 20), "--module-length": _f(-1, 30)}
TRAJ_HYP = {
    "line": {"--length": _f(-5, 300), "--azimuth": _f(-360, 360), "--elevation": _f(-90, 90)},
    "curve": {"--radius": _f(-5, 200), "--angle": _f(-30, 400), "--entry": _f(-5, 60), "--exit": _f(-5, 60)},
    "spiral": {"--radius": _f(-5, 200), "--pitch": _f(-5, 80), "--turns": _f(-0.5, 2.5)},
    "colon": {},
}


@st.composite
def follow_args(draw):
    traj = draw(st.sampled_from(sorted(TRAJ_HYP)))
    opts = draw(st.fixed_dictionaries({}, optional={**TRAJ_HYP[traj], **ROBOT_HYP}))
    return traj, opts


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(args=follow_args(), solver=st.sampled_from(["seed", "fabrik", "ccd"]))
def test_follow_options(tmp_path, args, solver):
    traj, opts = args
    argv = ["follow", "--traj", traj, "--solver", solver, "--no-plots", "--json", "-", "--out", str(tmp_path / "o")]
    for k, v in opts.items():
        argv += [k, v]
    result = CliRunner().invoke(main, argv)
    _check(result)
    if result.exit_code == 0:
        import json

        doc = json.loads(result.stdout)
        assert doc["steps"] and all(math.isfinite(v) for st_ in doc["steps"] for v in st_["point_errors_mm"])


@pytest.mark.parametrize("solver", ["fabrik", "seed", "constrained", "ccd", "optimal"])
@pytest.mark.parametrize("target", [("0", "0", "0"), ("0", "0", "1e-200")])
def test_target_on_the_base(solver, target):
    """A target on (or a hair from) the chain's base is a valid request: an answer or one line, never a crash."""
    result = CliRunner().invoke(main, ["solve", "--target", *target, "--solver", solver, "--json", "-"])
    _check(result)


# --- output files are replaced whole or not at all --------------------------------------------------------------

@pytest.mark.parametrize("failure", [ValueError("disk full"), KeyboardInterrupt()])
def test_a_failed_write_keeps_the_good_file_and_leaves_no_temporary(tmp_path, failure):
    from bhr.output._atomic import atomic_path, write_json

    target = tmp_path / "run.json"
    write_json(target, {"good": True})
    before = target.read_bytes()
    with pytest.raises(type(failure)):
        with atomic_path(target) as tmp:
            tmp.write_text('{"half": ')  # half-written, then the run fails or is interrupted
            raise failure
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]
    with pytest.raises(ValueError):
        write_json(target, {"bad": float("nan")})  # refused before anything is written
    assert target.read_bytes() == before and len(list(tmp_path.iterdir())) == 1


def test_atomic_outputs_get_the_permissions_a_plain_write_would(tmp_path):
    """mkstemp's 0600 must not leak into outputs: new files follow the umask, replaced ones keep their mode."""
    import os

    from bhr.output._atomic import write_text

    old = os.umask(0o022)
    try:
        write_text(tmp_path / "new.csv", "a\n")
        assert (tmp_path / "new.csv").stat().st_mode & 0o777 == 0o644
        os.umask(0o077)
        write_text(tmp_path / "private.csv", "a\n")
        assert (tmp_path / "private.csv").stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(old)
    (tmp_path / "new.csv").chmod(0o664)
    write_text(tmp_path / "new.csv", "b\n")
    assert (tmp_path / "new.csv").stat().st_mode & 0o777 == 0o664


def test_a_killed_follow_leaves_only_whole_files(tmp_path):
    """Kill `bhr follow` at random moments: every run.json/codes.csv present is the old one or a complete new one."""
    import json
    import os
    import signal
    import subprocess
    import time

    from tests.conftest import bhr_exe

    out = tmp_path / "o"
    out.mkdir()
    (out / "run.json").write_text(GOOD_JSON)
    (out / "codes.csv").write_text(CODES_OK)
    env = dict(os.environ, MPLBACKEND="Agg")
    for delay in (0.3, 0.8, 1.3, 1.8, 2.5):
        proc = subprocess.Popen(bhr_exe() + ["follow", "--traj", "colon", "--out", str(out)], cwd=tmp_path, env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        text = (out / "run.json").read_text()
        assert text == GOOD_JSON or len(json.loads(text)["steps"]) == 827
        codes = (out / "codes.csv").read_text()
        assert codes == CODES_OK or codes.count("\n") == 828


def test_plan_refuses_a_run_folder_it_cannot_replace_before_printing_the_schedule(run_bhr, tmp_path):
    """A run folder holding a file of the user's (its manifest does not list it): `bhr plan --codes run/codes.csv`
    would put thermal.png there and replace the folder; it is refused in one line that names a fix plan has,
    before any schedule is printed."""
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "codes.csv").write_text(CODES_OK)
    (tmp_path / "run" / "manifest.json").write_text(_manifest({"codes.csv": CODES_OK}))
    (tmp_path / "run" / "notes.txt").write_text("mine")
    import os

    before = snapshot(tmp_path)
    res = run_bhr("plan", "--codes", "run/codes.csv")
    assert res.returncode == 1 and res.stdout == "", res.stdout
    assert res.stderr.count("\n") == 1 and "holds notes.txt, which no bhr run wrote" in res.stderr, res.stderr
    run = os.path.realpath(tmp_path / "run")
    assert "--out" not in res.stderr and "--force" not in res.stderr and res.stderr.endswith(f"move it out of {run}\n")
    assert snapshot(tmp_path) == before
