"""Time whole commands as the documentation quotes them: CPU (user + system) and wall, with the machine's load.

    python -m bhr._bench.commands                 # every command below, a Markdown table on stdout
    python -m bhr._bench.commands --only follow   # the rows whose name contains "follow"
    python -m bhr._bench.commands --repeat 3      # each command three times (median and range)

Each command runs in a fresh temporary folder with a warm numba cache (one untimed run of
``bhr follow --traj colon`` first), from the repository's root for the example files. The "first run"
rows have an empty cache of their own (NUMBA_CACHE_DIR in that folder): they compile what they run. The
table states the load average before and after and the machine; on a shared machine the CPU
times are the steady figures (waiting for a core is not a command's cost), the wall times
are what a user waited. Sizes of written files (the animation) are measured too.
"""
from __future__ import annotations

import argparse
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]

#: name -> (arguments of bhr, a file whose size the row reports or None)
COMMANDS: dict[str, tuple[list[str], str | None]] = {
    "follow colon (figures)": (["follow", "--traj", "colon", "--out", "o"], None),
    "follow colon --no-plots": (["follow", "--traj", "colon", "--no-plots", "--out", "o"], None),
    "follow --traj colonn (refused)": (["follow", "--traj", "colonn"], None),
    "follow colon --animate colon.gif": (["follow", "--traj", "colon", "--no-plots", "--out", "o", "--animate",
                                          "colon.gif"], "colon.gif"),
    "report chapter7.toml": (["report", "--file", str(REPO / "docs/examples/chapter7.toml"), "--out", "r"], None),
    "sweep sweep1000.toml": (["sweep", "--file", str(REPO / "docs/examples/sweep1000.toml"), "--out", "s"], None),
    "bench (every case)": (["bench"], None),
    "plan 300 modules x 1,500 steps": (["plan", "--codes", "long.csv", "--schedule", "auto", "--no-plots"], None),
    "follow --solver thesiss (refused)": (["follow", "--traj", "colon", "--solver", "thesiss"], None),
    "follow --modules -3 (refused)": (["follow", "--traj", "colon", "--modules", "-3"], None),
    "follow --alpha 95 (refused)": (["follow", "--traj", "colon", "--alpha", "95"], None),
    "solve --solver x (refused)": (["solve", "--target", "1", "2", "3", "--solver", "x"], None),
    "sweep --solver x (refused)": (["sweep", "--solver", "x"], None),
    "traverse --colons x (refused)": (["traverse", "--colons", "x"], None),
    "fk --codes 3,0,7 (refused)": (["fk", "--codes", "3,0,7"], None),
    "plan --codes missing.csv (refused)": (["plan", "--codes", "missing.csv"], None),
    "first run: follow colon, empty cache": (["follow", "--traj", "colon", "--out", "o"], None),
    "first run: bhr warmup, empty cache": (["warmup"], None),
}

#: Rows run with an empty numba cache of their own (NUMBA_CACHE_DIR in the row's folder): a first run.
COLD = ("first run: follow colon, empty cache", "first run: bhr warmup, empty cache")


def bhr_command() -> list[str]:
    """How to start the installed bhr: its console script, or `python -m bhr.cli.main` when none is on PATH."""
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-m", "bhr.cli.main"]


def plan_codes_csv(path: str, steps: int = 1500, modules: int = 300, seed: int = 0) -> None:
    """A codes.csv of ``steps`` rows of ``modules`` valid codes, each module changing now and then (a long robot)."""
    rng = np.random.default_rng(seed)
    valid = np.array([0, 3, 6, 12, 9, 15])
    rows = np.zeros((steps, modules), np.int64)
    cur = rng.choice(valid, modules)
    for i in range(steps):
        change = rng.random(modules) < 0.02
        cur = np.where(change, rng.choice(valid, modules), cur)
        rows[i] = cur
    head = "step," + ",".join(f"m{j + 1}" for j in range(modules))
    body = "\n".join(f"{i + 1}," + ",".join(str(int(c)) for c in r) for i, r in enumerate(rows))
    Path(path).write_text(head + "\n" + body + "\n", encoding="utf-8")


def run_once(args: list[str], cwd: Path, cold: bool = False) -> tuple[float, float, int]:
    """CPU seconds (user + system of the command and its children), wall seconds, exit status.

    ``args`` starting with ``-m`` run a module of this Python instead of bhr. ``cold``: an empty numba
    cache in ``cwd`` (a first run, which compiles what it runs).
    """
    env = dict(os.environ, MPLBACKEND="Agg")
    if cold:
        env["NUMBA_CACHE_DIR"] = str(cwd / "numba-cache")
    cmd = [sys.executable] + args if args[:1] == ["-m"] else bhr_command() + args
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, proc.returncode


def measure(names: list[str], repeat: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as warm:
        run_once(COMMANDS["follow colon (figures)"][0], Path(warm))
    for name in names:
        args, size_of = COMMANDS[name]
        cpus, walls, codes, sizes = [], [], [], []
        for _ in range(repeat):
            with tempfile.TemporaryDirectory() as tmp:
                if "long.csv" in args:
                    plan_codes_csv(os.path.join(tmp, "long.csv"))
                cpu, wall, code = run_once(args, Path(tmp), cold=name in COLD)
                cpus.append(cpu)
                walls.append(wall)
                codes.append(code)
                if size_of and (Path(tmp) / size_of).exists():
                    sizes.append((Path(tmp) / size_of).stat().st_size)
        prog = "python " if args[:1] == ["-m"] else "bhr "
        rows.append({"name": name, "command": prog + " ".join(a.replace(str(REPO) + "/", "") for a in args),
                     "cpu": sorted(cpus), "wall": sorted(walls), "exit": codes, "bytes": sizes})
    return rows


def _span(values: list[float]) -> str:
    mid = sorted(values)[len(values) // 2]
    return f"{mid:.2f} s" if len(values) == 1 else f"{mid:.2f} s ({min(values):.2f}–{max(values):.2f})"


def table(rows: list[dict], load_before: tuple[float, ...], load_after: tuple[float, ...]) -> str:
    cpu = os.cpu_count()
    model = ""
    try:
        model = next(ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                     if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    from bhr import __version__

    lines = [f"Measured {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} by `python -m bhr._bench.commands`: "
             f"bhr {__version__}, Python {platform.python_version()}, {cpu} cores ({model or platform.machine()}); "
             f"load average {load_before[0]:.1f} before, {load_after[0]:.1f} after; warm numba cache except the "
             "first-run rows (an empty cache of their own).", "",
             "| command | CPU (user + system) | wall | exit | output size |", "| --- | --- | --- | --- | --- |"]
    for r in rows:
        size = f"{sorted(r['bytes'])[len(r['bytes']) // 2] / 1e6:.1f} MB" if r["bytes"] else ""
        exits = ",".join(sorted({str(c) for c in r["exit"]}))
        lines.append(f"| `{r['command']}` | {_span(r['cpu'])} | {_span(r['wall'])} | {exits} | {size} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="only the commands whose name contains this text")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each command (median and range)")
    a = ap.parse_args(argv)
    names = [n for n in COMMANDS if a.only in n]
    load_before = os.getloadavg()
    rows = measure(names, max(1, a.repeat))
    print(table(rows, load_before, os.getloadavg()))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
