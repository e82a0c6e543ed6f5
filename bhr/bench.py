"""Benchmarks: bhr's compiled kernels against plain numpy implementations of the same algorithms.

Each case times bhr and a reference in the same process, takes medians over
repeats, checks both give the same numbers, and reports the ratio. The numpy
references live here, written the straightforward way (numpy vector maths per
point, Python loops over points and iterations), so anyone can read what is
being compared. Run with ``bhr bench`` or ``python -m bhr.bench``; the same
cases run under pytest-benchmark with ``pytest tests/benchmarks``.
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np

__all__ = ["CASES", "BenchResult", "run_case", "run_all", "numpy_fabrik", "numpy_ccd", "numpy_seed_follow"]


@dataclass
class BenchResult:
    """Medians in seconds (per unit), their ratio, and the requirement checked."""

    case: str
    unit: str
    bhr_s: float
    reference_s: float
    reference: str
    ratio: float
    requirement: str = ""
    ok: bool | None = None
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _median_time(fn: Callable[[], Any], repeat: int, number: int = 1) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return float(np.median(times))


# ---------------------------------------------------------------------------
# numpy references (same algorithms as bhr.solvers.*, written plainly)


def numpy_fabrik(points: np.ndarray, target: np.ndarray, length: float, tol: float, max_iter: int):
    """Unconstrained FABRIK (thesis ch. 5.1.1) with numpy vector operations."""
    P = points.copy()
    n = len(P) - 1
    base = P[0].copy()
    if np.linalg.norm(target - base) > n * length:
        for i in range(n):
            lam = length / np.linalg.norm(target - P[i])
            P[i + 1] = (1 - lam) * P[i] + lam * target
        return P, 0, float(np.linalg.norm(target - P[-1]))
    err = np.linalg.norm(P[-1] - target)
    k = 0
    while err > tol and k < max_iter:
        P[-1] = target
        for i in range(n - 1, -1, -1):  # the textbook (Aristidou) update, as the thesis writes it
            lam = length / np.linalg.norm(P[i + 1] - P[i])
            P[i] = (1 - lam) * P[i + 1] + lam * P[i]
        P[0] = base
        for i in range(n):
            lam = length / np.linalg.norm(P[i + 1] - P[i])
            P[i + 1] = (1 - lam) * P[i] + lam * P[i + 1]
        err = np.linalg.norm(P[-1] - target)
        k += 1
    return P, k, float(err)


def _np_rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Quaternion sandwich r v r* with numpy (same maths as bhr.dualquat.k_rotate)."""
    c, s = math.cos(angle / 2), math.sin(angle / 2)
    w, q = c, s * axis
    t_w = -np.dot(q, v)
    t_v = w * v + np.cross(q, v)
    return -t_w * q + w * t_v - np.cross(t_v, q)


def numpy_ccd(points: np.ndarray, target: np.ndarray, tol: float, max_iter: int):
    """CCD, tip to base (thesis ch. 5.1.2), with numpy vector operations."""
    P = points.copy()
    n = len(P) - 1
    err = np.linalg.norm(P[-1] - target)
    k = 0
    while err > tol and k < max_iter:
        for j in range(n - 1, -1, -1):
            ve, vt = P[-1] - P[j], target - P[j]
            cr = np.cross(ve, vt)
            if np.linalg.norm(cr) == 0:
                continue
            theta = math.acos(max(-1.0, min(1.0, np.dot(ve, vt) / (np.linalg.norm(ve) * np.linalg.norm(vt)))))
            axis = cr / np.linalg.norm(cr)
            for m in range(j + 1, n + 1):
                P[m] = P[j] + _np_rotate(P[m] - P[j], axis, theta)
        err = np.linalg.norm(P[-1] - target)
        k += 1
    return P, k, float(err)


def _acosd(c: float) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _numpy_seed_solve(T, D, E1, E2, P0, h, tol_pos, tol_ori, alpha, max_iter, warmup=10):
    """The thesis's constrained FABRIK (binary, local axes) with numpy, as the MATLAB reads."""
    P = P0.copy()
    n = len(P) - 1
    before = P[0] - h * _unit(P[1] - P[0])
    base = P[0].copy()
    ep = np.linalg.norm(T - P[-1])
    eo = _acosd(np.dot(D, _unit(P[-1] - P[-2])))
    A1, A2 = E1.copy(), E2.copy()
    k = 0
    while ep > tol_pos or eo > tol_ori or k < warmup + 1:
        P[-1] = T
        P[-2] = T - h * D
        for i in range(n - 2, -1, -1):
            lam = h / np.linalg.norm(P[i + 1] - P[i])
            P[i] = (1 - lam) * P[i + 1] + lam * P[i]
        P[0] = base
        A1, A2 = E1.copy(), E2.copy()
        for i in range(n):
            if k < warmup:
                lam = h / np.linalg.norm(P[i + 1] - P[i])
                P[i + 1] = (1 - lam) * P[i] + lam * P[i + 1]
                continue
            A1[i:] -= P[i]
            A2[i:] -= P[i]
            g = [_unit(A1[i]), _unit(A2[i])]
            g += [-g[0], -g[1]]
            lam = h / np.linalg.norm(P[i + 1] - P[i])
            v2 = (1 - lam) * P[i] + lam * P[i + 1] - P[i]
            v1 = (before if i == 0 else P[i - 1]) - P[i]
            cr = np.cross(v2, v1)
            theta = 180 - _acosd(np.dot(v2, v1) / (np.linalg.norm(v2) * np.linalg.norm(v1)))
            if np.linalg.norm(cr) == 0:
                axis = g[0]
            else:
                vr = cr / np.linalg.norm(cr)
                axis = g[int(np.argmin([_acosd(np.dot(vr, a)) for a in g]))]
            theta = alpha if theta > alpha / 2 else 0.0
            rad = math.radians(theta)
            P[i + 1] = _np_rotate(-v1, axis, rad) + P[i]
            for j in range(i, n):
                A1[j] = _np_rotate(A1[j], axis, rad) + P[i]
            for j in range(i, n):
                A2[j] = _np_rotate(A2[j], axis, rad) + P[i]
        ep = np.linalg.norm(T - P[n])
        eo = _acosd(np.dot(D, _unit(P[-1] - P[-2])))
        k += 1
        if k >= max_iter:
            break
    return P, A1, A2, ep, eo


def numpy_seed_follow(path: np.ndarray, n: int = 5, h: float = 10.0, alpha: float = 10.0, tol_pos: float = 8.0,
                      tol_ori: float = 20.0, max_iter: int = 30, f: int = 5) -> np.ndarray:
    """The thesis's trajectory loop with the numpy solver; returns the tip error of each step."""
    feed = h / f
    P = np.zeros((n + 1, 3))
    for i in range(n - 1, -1, -1):
        P[i] = P[i + 1] - [h, 0, 0]
    E1, E2 = P[:n] + [0, 1, 0], P[:n] + [0, 0, 1]
    dirs = np.array([_unit(path[i + 1] - path[i]) for i in range(len(path) - 1)])
    tip = np.zeros(len(path))
    for i in range(len(path)):
        d = dirs[-1] if i == len(path) - 1 else dirs[i]
        P, E1, E2, ep, _ = _numpy_seed_solve(path[i], d, E1, E2, P, h, tol_pos, tol_ori, alpha, max_iter)
        tip[i] = ep
        ob = _unit(P[1] - P[0])
        P, E1, E2 = P + feed * ob, E1 + feed * ob, E2 + feed * ob
        for E in (E1, E2):
            d0 = _unit(E[0] - P[0])
            for j in range(1, n):
                E[j] = P[0] + ob * h * j + d0
    return tip


# ---------------------------------------------------------------------------
# cases


def case_fabrik(repeat: int = 7) -> BenchResult:
    """Unconstrained FABRIK, 10-module chapter 5 chain, target (15, 6, 0) (Table 5.7)."""
    from bhr.robot import straight_chain
    from bhr.solvers.fabrik import fabrik_kernel

    P0 = straight_chain(10, 2.0, (0, 1, 0))
    t = np.array([15.0, 6.0, 0.0])
    zero = np.zeros(3)

    def run_bhr():
        P = P0.copy()
        return P, fabrik_kernel(P, t, 2.0, 0.01, 30, zero, False, 20.0)

    P_b, (k_b, e_b, _) = run_bhr()
    P_n, k_n, e_n = numpy_fabrik(P0, t, 2.0, 0.01, 30)
    assert k_b == k_n == 12 and abs(e_b - e_n) < 1e-12, "bhr and numpy FABRIK disagree"
    tb = _median_time(run_bhr, repeat, 2000)
    tn = _median_time(lambda: numpy_fabrik(P0, t, 2.0, 0.01, 30), repeat, 20)
    return BenchResult("fabrik-ch5-10", "per solve", tb, tn, "numpy FABRIK", tn / tb,
                       ">= 200x faster than numpy", tn / tb >= 200, {"iterations": int(k_b)})


def case_ccd(repeat: int = 7) -> BenchResult:
    """CCD, 10-module chapter 5 chain, target (15, 6, 0) (Table 5.7)."""
    from bhr.robot import straight_chain
    from bhr.solvers.ccd import ccd_kernel

    P0 = straight_chain(10, 2.0, (0, 1, 0))
    t = np.array([15.0, 6.0, 0.0])

    def run_bhr():
        P = P0.copy()
        return ccd_kernel(P, t, 0.01, 30)

    k_b, e_b = run_bhr()
    _, k_n, e_n = numpy_ccd(P0, t, 0.01, 30)
    assert k_b == k_n == 12 and abs(e_b - e_n) < 1e-9, "bhr and numpy CCD disagree"
    tb = _median_time(run_bhr, repeat, 500)
    tn = _median_time(lambda: numpy_ccd(P0, t, 0.01, 30), repeat, 3)
    return BenchResult("ccd-ch5-10", "per solve", tb, tn, "numpy CCD", tn / tb, "", None, {"iterations": int(k_b)})


def case_seed_colon(repeat: int = 5) -> BenchResult:
    """--solver seed over the whole colon, per step (compiled loop against the numpy loop)."""
    from bhr.follow import follow
    from bhr.trajectory import load_trajectory

    tr = load_trajectory("colon")
    steps = len(tr.points)
    res = follow(tr)
    ref_tip = numpy_seed_follow(tr.points)
    diff = float(np.abs(ref_tip - res.point_errors[:, -1]).max())
    assert diff < 1e-6, f"bhr and numpy seed disagree by {diff} mm"
    tb = _median_time(lambda: follow(tr), repeat) / steps
    tn = _median_time(lambda: numpy_seed_follow(tr.points), max(1, repeat // 2)) / steps
    ok = tb <= 20e-6 and tn / tb >= 100
    return BenchResult("seed-colon", "per step", tb, tn, "numpy seed loop", tn / tb,
                       "<= 20 us/step and >= 100x faster than numpy", ok, {"steps": steps})


def _wall(cmd: list[str], repeat: int, cwd: str) -> float:
    times = []
    env = dict(os.environ, MPLBACKEND="Agg")
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, check=True, capture_output=True, env=env)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _bhr_cmd() -> list[str]:
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-m", "bhr.cli.main"]


def case_cli(repeat: int = 5) -> list[BenchResult]:
    """Wall time of `bhr --help` and of a full colon run (warm cache), against a bare interpreter."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        base = _wall([sys.executable, "-c", "pass"], repeat, tmp)
        subprocess.run(_bhr_cmd() + ["follow", "--traj", "colon", "--out", "w"], cwd=tmp, capture_output=True)
        help_t = _wall(_bhr_cmd() + ["--help"], repeat, tmp)
        nop = _wall(_bhr_cmd() + ["follow", "--traj", "colon", "--no-plots", "--out", "a"], repeat, tmp)
        plots = _wall(_bhr_cmd() + ["follow", "--traj", "colon", "--out", "b"], max(3, repeat // 2), tmp)
    out.append(BenchResult("cli-help", "per command", help_t, base, "python -c pass", help_t / base,
                           "<= 0.3 s", help_t <= 0.3))
    out.append(BenchResult("cli-follow-colon-noplots", "per command", nop, base, "python -c pass", nop / base,
                           "<= 1.5 s", nop <= 1.5))
    out.append(BenchResult("cli-follow-colon-plots", "per command", plots, base, "python -c pass", plots / base,
                           "<= 4 s", plots <= 4.0))
    return out


CASES: dict[str, Callable[..., BenchResult | list[BenchResult]]] = {
    "fabrik": case_fabrik,
    "ccd": case_ccd,
    "seed-colon": case_seed_colon,
    "cli": case_cli,
}


def run_case(name: str, repeat: int | None = None) -> list[BenchResult]:
    fn = CASES[name]
    res = fn() if repeat is None else fn(repeat)
    return res if isinstance(res, list) else [res]


def run_all(names: list[str] | None = None, repeat: int | None = None,
            progress: Callable[[str], None] | None = None) -> list[BenchResult]:
    results: list[BenchResult] = []
    for name in names or list(CASES):
        if progress:
            progress(name)
        results += run_case(name, repeat)
    return results


def format_table(results: list[BenchResult]) -> str:
    def t(s: float) -> str:
        return f"{s * 1e6:.2f} us" if s < 1e-3 else (f"{s * 1e3:.2f} ms" if s < 1 else f"{s:.3f} s")

    rows = [("case", "unit", "bhr", "reference", "ref", "ratio", "requirement", "ok")]
    for r in results:
        rows.append((r.case, r.unit, t(r.bhr_s), r.reference, t(r.reference_s), f"{r.ratio:.1f}x",
                     r.requirement or "-", "-" if r.ok is None else ("yes" if r.ok else "NO")))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows)


if __name__ == "__main__":  # pragma: no cover
    print(format_table(run_all()))
