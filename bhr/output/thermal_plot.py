"""The figure of ``bhr plan``: each wire's normalised temperature over a planned stream (docs/thermal.md)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from bhr.output.plots import plt, save_figure
from bhr.hardware.thermal import Schedule, format_duration

WIRE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple")


def schedule_figure(schedule: Schedule, title: str = "") -> "plt.Figure":
    """One panel per module: the temperature proxy theta of its 4 wires, with contraction, relax and limit levels."""
    sim = schedule.sim
    p = sim.params
    n_mod = sim.theta.shape[1]
    t = np.arange(sim.theta.shape[0]) * sim.stride / 1000.0
    minutes = t[-1] > 300
    tt = t / 60.0 if minutes else t
    fig, axes = plt.subplots(n_mod, 1, figsize=(10, 1.6 + 1.5 * n_mod), sharex=True, squeeze=False)
    top = max(p.theta_limit * 1.08, float(sim.theta.max()) * 1.05)
    for j, ax in enumerate(axes[:, 0]):
        for k in range(4):  # wires that move together (a tilt drives two) overlap: widest line first
            ax.plot(tt, sim.theta[:, j, k], color=WIRE_COLORS[k], lw=(2.6, 1.9, 1.3, 0.8)[k],
                    label=f"actuator {k + 1}")
        ax.axhline(1.0, color="0.3", lw=0.8, ls="--", label="contracted (1)")
        ax.axhline(p.theta_relax, color="tab:cyan", lw=0.9, ls=":", label=f"relaxed ({p.theta_relax:.2f})")
        ax.axhline(p.theta_limit, color="tab:red", lw=1.0, label=f"board's limit ({p.theta_limit:.2f})")
        ax.set_ylim(0, top)
        ax.set_ylabel(f"module {j + 1}\ntheta")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="lower left", ncol=7, fontsize=7.5, bbox_to_anchor=(0, 1.02, 1, 0.2), mode="expand",
                      frameon=False, handlelength=1.6)
    axes[-1, 0].set_xlabel("time (min)" if minutes else "time (s)")
    how = "at the board's limits" if schedule.mode == "auto" else f"at {schedule.rate:g} Hz"
    fig.suptitle(f"{title + ': ' if title else ''}wire temperatures over {len(schedule.times_ms)} steps, "
                 f"{format_duration(schedule.total_s)} {how}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def save_schedule_figure(schedule: Schedule, path: str | os.PathLike[str], title: str = "") -> Path:
    fig = schedule_figure(schedule, title)
    try:
        return save_figure(fig, path)
    finally:
        plt.close(fig)
