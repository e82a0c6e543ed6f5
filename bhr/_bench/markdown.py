"""The Markdown table of docs/performance.md from ``bhr bench --json`` output.

    bhr bench --json bench.json && python -m bhr._bench.markdown bench.json
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path


def _t(s: float) -> str:
    return f"{s * 1e6:.2f} µs" if s < 1e-3 else (f"{s * 1e3:.2f} ms" if s < 1 else f"{s:.2f} s")


def table(rows: list[dict], when: float) -> str:
    """The heading line (date, machine, versions) and the table, one row per case of ``rows``."""
    import numba
    import numpy

    from bhr import __version__

    try:
        model = next(ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                     if ln.startswith("model name"))
    except (OSError, StopIteration):
        model = platform.machine()
    lines = [f"Measured {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(when))}: bhr {__version__}, Python "
             f"{platform.python_version()}, numba {numba.__version__}, numpy {numpy.__version__}, {os.cpu_count()} "
             f"cores ({model}); CPU seconds, the ratio is reference ÷ bhr.", "",
             "| case | unit | bhr | reference | reference time | ratio | requirement | met |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        met = "" if r["ok"] is None else ("yes" if r["ok"] else "**no**")
        req = r["requirement"].replace("<=", "≤").replace(">=", "≥").replace(" us", " µs").replace("0x ", "0× ")
        ratio = f"{r['ratio']:,.0f}" if r["ratio"] >= 100 else f"{r['ratio']:.3g}"
        lines.append(f"| `{r['case']}` | {r['unit']} | {_t(r['bhr_s'])} | {r['reference']} | {_t(r['reference_s'])} "
                     f"| {ratio}× | {req} | {met} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m bhr._bench.markdown BENCH.json (written by bhr bench --json)", file=sys.stderr)
        return 2
    path = Path(args[0])
    print(table(json.loads(path.read_text(encoding="utf-8")), path.stat().st_mtime))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
