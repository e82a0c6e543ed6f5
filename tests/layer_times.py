"""The suite's cost per layer, from the rows that BHR_TEST_CPU=FILE makes tests/conftest.py write (README, "Tests").

    BHR_TEST_CPU=/tmp/cpu.csv bash tests/run     # one row per test: nodeid, layer, CPU seconds, wall seconds, outcome
    python tests/layer_times.py /tmp/cpu.csv      # a Markdown table per layer; --top N lists the N costliest tests

CPU seconds are user+sys of the test process and of the commands it started and waited for, from setup to
teardown: they hold on a busy machine, where wall time does not.
"""
from __future__ import annotations

import argparse
import csv
from collections import defaultdict

LAYERS = ("unit", "run", "thesis", "cli", "integration")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", help="the file BHR_TEST_CPU named")
    ap.add_argument("--top", type=int, default=0, help="also list the N tests of most CPU seconds")
    args = ap.parse_args()
    with open(args.csv, newline="") as f:
        rows = [(r[0], r[1], float(r[2]), float(r[3]), r[4] if len(r) > 4 else "") for r in csv.reader(f) if r]
    count: dict[str, int] = defaultdict(int)
    cpu: dict[str, float] = defaultdict(float)
    for _, layer, c, _w, _o in rows:
        count[layer] += 1
        cpu[layer] += c
    print("| layer | tests | CPU s | CPU s per test |")
    print("| --- | ---: | ---: | ---: |")
    for layer in [*LAYERS, *sorted(set(count) - set(LAYERS))]:
        if count[layer]:
            print(f"| {layer} | {count[layer]} | {cpu[layer]:.0f} | {cpu[layer] / count[layer]:.2f} |")
    print(f"| all | {len(rows)} | {sum(cpu.values()):.0f} | {sum(cpu.values()) / max(1, len(rows)):.2f} |")
    for nodeid, _layer, _c, _w, outcome in rows:
        if outcome in ("failed", "error"):
            print(f"{outcome}: {nodeid}")
    if args.top:
        print()
        for nodeid, _layer, c, _w, _o in sorted(rows, key=lambda r: -r[2])[:args.top]:
            print(f"{c:8.1f}  {nodeid}")


if __name__ == "__main__":
    main()
