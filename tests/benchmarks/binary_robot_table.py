"""What a binary robot can and cannot do (docs/binary-robot.md): the ideal (trail) and the physical (wires)
verdicts side by side, per design and robot length, over anatomical colons.

    python tests/benchmarks/binary_robot_table.py --colons 1-20 --alpha 20,25,30 --module 5,6 \
        --length 0.3,0.7,1.5,cecum [--stop-at-wall] [--json out.json]

Prints a Markdown table: per design, the colons traversed (no module touching the wall at any moment, the tip
reaching the cecum: a robot shorter than the colon does not traverse it) by the
ideal follow-the-leader (not buildable) and by the rigid robot driven by its wires, the worst penetration of
each, and the wires' largest distance from the trail; and the CPU seconds it took.

``--stop-at-wall``: each run of the wires ends where the robot leaves the lumen (the verdict is the same: it
touched the wall; no pose after it is scored). The table then gives, for the wires, on how many colons the robot
left the lumen and how far along the colon it got first (the median over the colons, % of the colon's length);
its penetration and distance from the trail are those up to there.
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics
import warnings


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def traversed(run: dict) -> bool:
    """No module touched the wall, and the robot was long enough for its tip to reach the cecum."""
    return not run["touch"] and not run["short"] and run["left_lumen_step"] is None


def _range(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def main() -> None:
    import bhr
    from bhr._run.driver import BhrWarning, follow

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--colons", default="1-20")
    ap.add_argument("--alpha", default="20,25,30")
    ap.add_argument("--module", default="5,6")
    ap.add_argument("--length", default="0.3,0.7,1.5,cecum")
    ap.add_argument("--stop-at-wall", action="store_true", help="end each wires run where the robot leaves the lumen")
    ap.add_argument("--json")
    a = ap.parse_args()
    rows = []
    t0 = _cpu()
    for alpha in (float(v) for v in a.alpha.split(",")):
        for L in (float(v) for v in a.module.split(",")):
            for length in a.length.split(","):
                for model in ("trail", "wires"):
                    res = []
                    for seed in _range(a.colons):
                        tr = bhr.trajectory("anatomy", seed=seed)
                        kw = {"reach": "cecum"} if length == "cecum" else \
                            {"body_modules": int(round(float(length) * 1000 / L))}
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore", BhrWarning)
                            run = follow(tr, solver="lumen", alpha=alpha, module_length=L, locomotion=model,
                                         stop_at_wall=a.stop_at_wall and model == "wires", **kw)
                        s = run.summary.extra
                        left = s.get("left_lumen_step")
                        path = s.get("path_steps", run.steps)
                        short = float(s.get("cecum_shortfall_mm", 0.0)) if s.get("too_short_for_cecum") else 0.0
                        # the tip got as far as where the robot left the lumen, or where the feeder stopped a robot
                        # too short to reach the cecum (as bhr traverse counts reach)
                        ends = [k for k in (left, s.get("feeder_stop_step") if short else None) if k is not None]
                        res.append({"colon": seed, "touch": bool(s.get("wall_touch_steps")),
                                    "pen": float(s.get("max_penetration_mm", 0.0)),
                                    "offset": float(s.get("max_trail_offset_mm", 0.0)),
                                    "short": short, "left_lumen_step": left,
                                    "reach_pct": 100.0 * (min(ends) - 1) / (path - 1) if ends else 100.0})
                    rows.append({"alpha": alpha, "module_mm": L, "length": length, "model": model, "colons": res})
                    ok = sum(traversed(r) for r in res)
                    print(f"alpha {alpha:g} module {L:g} length {length} {model}: {ok}/{len(res)} traversed, worst "
                          f"pen {max(r['pen'] for r in res):.2f} mm, offset {max(r['offset'] for r in res):.1f} mm "
                          f"({_cpu() - t0:.0f} s CPU so far)", flush=True)
    print()
    if a.stop_at_wall:
        print("| α | module | robot | ideal (trail): traversed | worst pen | physical (wires): traversed | left the "
              "lumen | median reach | off the trail |")
        print("|---|---|---|---|---|---|---|---|---|")
    else:
        print("| α | module | robot | ideal (trail): traversed | worst pen | physical (wires): traversed | worst pen | "
              "off the trail |")
        print("|---|---|---|---|---|---|---|---|")
    for i in range(0, len(rows), 2):
        t, w = rows[i], rows[i + 1]
        n = len(t["colons"])

        def ok(r):
            return sum(traversed(c) for c in r["colons"])

        def pen(r):
            return max(c["pen"] for c in r["colons"])

        length = t["length"] if t["length"] == "cecum" else f"{float(t['length']):g} m"
        off = f"{max(c['offset'] for c in w['colons']):.0f} mm"
        if a.stop_at_wall:
            left = sum(c["left_lumen_step"] is not None for c in w["colons"])
            reach = statistics.median(c["reach_pct"] for c in w["colons"])
            print(f"| {t['alpha']:g}° | {t['module_mm']:g} mm | {length} | {ok(t)}/{n} | {pen(t):.1f} mm | "
                  f"{ok(w)}/{n} | {left}/{n} | {reach:.0f} % | {off} |")
        else:
            print(f"| {t['alpha']:g}° | {t['module_mm']:g} mm | {length} | {ok(t)}/{n} | {pen(t):.1f} mm | "
                  f"{ok(w)}/{n} | {pen(w):.1f} mm | {off} |")
    print(f"\n{_cpu() - t0:.0f} s CPU")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"rows": rows, "cpu_s": _cpu() - t0}, fh, indent=1)


if __name__ == "__main__":
    main()
