"""The physics replay's figure (force.png): the wall's load along the run, the stretch, the published lines.

Drawn on a :class:`matplotlib.figure.Figure` (no pyplot state). ``rep`` is a
:class:`bhr._studies.physics.PhysicsReplay`; the figure reads only its arrays and summary.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["STEPS_IDEALISATION", "force_figure"]

#: What a replay of a run's written steps (``poses_replayed`` "steps") says of itself: on force.png and the line
#: ``bhr physics`` prints.
STEPS_IDEALISATION = "replayed from the run's steps, joints moved linearly between codes: an idealisation"


def force_figure(rep: Any, title: str = "", lines_n: tuple[float, float] = (9.8, 14.1)) -> Any:
    """Total normal force on the wall and the largest module's per step (crosses: poses whose equilibrium was not
    reached, whose force is an estimate), the stretch below, with the 9.8 N and 14.1 N lines."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 6.5), constrained_layout=True)
    a1, a2 = fig.subplots(2, 1, sharex=True)
    x = np.arange(1, len(rep.total_force_n) + 1)
    a1.plot(x, rep.total_force_n, color="tab:red", lw=1.2, label="total normal force on the wall")
    a1.plot(x, rep.module_force_n.max(axis=1, initial=0.0), color="tab:purple", lw=0.9,
            label="largest single module's force")
    missed = None if rep.equilibrium_reached is None else ~np.asarray(rep.equilibrium_reached, dtype=bool)
    if missed is not None and missed.any():
        a1.plot(x[missed], rep.total_force_n[missed], ls="none", marker="x", ms=4, color="0.3",
                label=f"equilibrium not reached: an estimate ({int(missed.sum())} of {missed.size} poses)")
    a1.axhline(lines_n[0], color="tab:orange", ls="--", lw=1,
               label="9.8 N: colonoscopists push harder 5 % of the time (Appleyard 2000)")
    a1.axhline(lines_n[1], color="black", ls="--", lw=1, label="14.1 N: porcine colon perforates (Johnson 2019)")
    s = rep.summary()
    a1.set_ylabel("force on the wall (N)")
    peak = float(rep.total_force_n.max(initial=0.0))
    # room above the published lines (or the peak) for the legend, which then covers neither
    a1.set_ylim(0, 1.6 * max(lines_n[1], peak))
    a1.grid(alpha=0.3)
    a1.legend(loc="upper left", fontsize=8, ncol=2)
    reached = s["reached_cecum_step"]
    a1.set_title(title or "the wall's load along the run", fontsize=10)
    a2.plot(x, rep.stretch_mm, color="tab:blue", lw=1.0, label="wall pushed out of place (largest, mm)")
    a2.plot(x, np.maximum(rep.feeder_lag_mm, 0.0), color="tab:gray", lw=1.0,
            label="feeder behind the run's insertion (mm)")
    a2.set_ylabel("mm")
    a2.set_xlabel("pose (the run's steps in order)")
    a2.grid(alpha=0.3)
    a2.legend(loc="upper left", fontsize=8)
    a2.set_title(f"peak {s['max_total_force_n']:.2f} N"
                 + ("" if s["max_total_force_equilibrium_reached"] else ", an estimate")
                 + f" (module {s['max_module_force_n']:.2f} N, "
                 f"{s['max_pressure_kpa']:.0f} kPa), stretch {s['max_stretch_mm']:.1f} mm; "
                 + (f"tip at the cecum from step {reached}" if reached else "tip never at the cecum")
                 + ("\n" + STEPS_IDEALISATION if s.get("poses_replayed") == "steps" else ""),
                 fontsize=9)
    return fig
