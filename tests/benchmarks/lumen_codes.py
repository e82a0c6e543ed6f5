"""Record what ``--solver lumen`` chooses on anatomical colons, to check that a change of its code changes no answer.

    python3 tests/benchmarks/lumen_codes.py record before.json            # colons 1-10
    python3 tests/benchmarks/lumen_codes.py record after.json --seeds 1-3
    python3 tests/benchmarks/lumen_codes.py compare before.json after.json

Each colon is followed as ``bhr follow --traj anatomy --seed N --solver lumen`` does (the thesis's robot, the
solver's default settings), through ``bhr.follow``'s compiled loop and step by step from Python (``compiled=False``,
the path ``bhr bench --case lumen`` times). Per colon and path it records the codes of every step, a SHA-256 of
the points of every step (their bytes), and the run's figures: min clearance, max penetration, wall-touch steps,
the verdict and how the run finished. ``compare`` exits 1 naming the first difference. Not a test: a check to run
by hand before and after a change of the solver (a few CPU seconds per colon).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import warnings
from typing import Any


def record(seeds: list[int]) -> dict[str, Any]:
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    out: dict[str, Any] = {}
    for sd in seeds:
        tr = load_trajectory("anatomy", seed=sd)
        for compiled in (True, False):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = follow(tr, solver="lumen", compiled=compiled)
            s = res.summary.to_dict()
            out[f"{sd}/{'compiled' if compiled else 'stepwise'}"] = {
                "codes": res.codes.tolist(),
                "points_sha256": hashlib.sha256(res.points.tobytes()).hexdigest(),
                "min_clearance_mm": s["min_clearance_mm"], "max_penetration_mm": s["max_penetration_mm"],
                "wall_touch_steps": s["wall_touch_steps"], "verdict": res.status, "finished": res.finished}
        print(f"colon {sd}: {len(out[f'{sd}/compiled']['codes'])} steps, min clearance "
              f"{out[f'{sd}/compiled']['min_clearance_mm']:.4f} mm, {out[f'{sd}/compiled']['verdict']}",
              file=sys.stderr)
    return out


def compare(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    bad = []
    for key in sorted(set(a) | set(b)):
        if key not in a or key not in b:
            bad.append(f"{key}: only in one record")
            continue
        for field in a[key]:
            if a[key][field] != b[key].get(field):
                if field == "codes":
                    x, y = a[key][field], b[key][field]
                    first = next((i for i, (u, v) in enumerate(zip(x, y)) if u != v), min(len(x), len(y)))
                    bad.append(f"{key}: codes differ first at step {first + 1}")
                else:
                    bad.append(f"{key}: {field} {a[key][field]!r} != {b[key].get(field)!r}")
    return bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("out")
    r.add_argument("--seeds", default="1-10", help="a-b or a,b,c [1-10]")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    args = ap.parse_args(argv)
    if args.cmd == "record":
        seeds: list[int] = []
        for part in args.seeds.split(","):
            lo, _, hi = part.partition("-")
            seeds += list(range(int(lo), int(hi or lo) + 1))
        with open(args.out, "w", encoding="utf-8") as fh:
            json.dump(record(seeds), fh)
        return 0
    with open(args.a, encoding="utf-8") as fa, open(args.b, encoding="utf-8") as fb:
        bad = compare(json.load(fa), json.load(fb))
    for line in bad:
        print(line)
    if not bad:
        print("identical: codes, points, clearance, penetration, wall touches, verdicts")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
