"""The figure of ``bhr plan``: each wire's normalised temperature over a planned stream (docs/thermal.md)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from bhr.output._figure import save_figure, subplots
from bhr._hardware.thermal import Schedule, format_duration

WIRE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple")
#: Colours of wires that move together (one line for the pair or trio), in order of first appearance.
GROUP_COLORS = ("tab:brown", "darkcyan", "tab:pink", "navy", "tab:gray", "darkgoldenrod")


def wire_groups(theta: np.ndarray) -> list[tuple[int, ...]]:
    """The wires (0-based) of one module whose temperature traces are identical over the whole run, grouped.

    ``theta`` is (samples, 4). Two wires of a tilt are always driven together in most runs (code 3 drives
    wires 1 and 2): their lines would lie on each other, so the figure draws one line for the group.
    """
    groups: list[tuple[int, ...]] = []
    for k in range(theta.shape[1]):
        for g, members in enumerate(groups):
            if np.array_equal(theta[:, members[0]], theta[:, k]):
                groups[g] = members + (k,)
                break
        else:
            groups.append((k,))
    return groups


def group_label(members: tuple[int, ...]) -> str:
    """``actuator 3`` or ``actuators 1+2`` (1-based)."""
    names = "+".join(str(k + 1) for k in members)
    return f"actuator{'s' if len(members) > 1 else ''} {names}"


def schedule_figure(schedule: Schedule, title: str = "") -> Figure:
    """One panel per module: the temperature proxy theta of its 4 wires, with contraction, relax and limit levels."""
    sim = schedule.sim
    p = sim.params
    n_mod = sim.theta.shape[1]
    t = np.arange(sim.theta.shape[0]) * sim.stride / 1000.0
    minutes = t[-1] > 300
    tt = t / 60.0 if minutes else t
    fig, axes = subplots(n_mod, 1, figsize=(10, 1.6 + 1.5 * n_mod), sharex=True, squeeze=False)
    top = max(p.theta_limit * 1.08, float(sim.theta.max()) * 1.05)
    colors: dict[tuple[int, ...], str] = {}
    for j, ax in enumerate(axes[:, 0]):
        # wires that move together (a tilt drives two) would lie on each other: one line per group
        for members in wire_groups(sim.theta[:, j, :]):
            if members not in colors:
                colors[members] = WIRE_COLORS[members[0]] if len(members) == 1 else \
                    GROUP_COLORS[sum(len(m) > 1 for m in colors) % len(GROUP_COLORS)]
            ax.plot(tt, sim.theta[:, j, members[0]], color=colors[members], lw=1.6 if len(members) > 1 else 1.2,
                    label=group_label(members))
        ax.axhline(1.0, color="0.3", lw=0.8, ls="--", label="contracted (1)")
        ax.axhline(p.theta_relax, color="tab:cyan", lw=0.9, ls=":", label=f"relaxed ({p.theta_relax:.2f})")
        ax.axhline(p.theta_limit, color="tab:red", lw=1.0, label=f"board's limit ({p.theta_limit:.2f})")
        ax.set_ylim(0, top)
        ax.set_ylabel(f"module {j + 1}\ntheta")
        ax.grid(alpha=0.3)
    # one legend for every panel: each wire group once, in order of first appearance, then the levels
    handles: dict[str, object] = {}
    for ax in axes[:, 0]:
        for h, lb in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lb, h)
    wires = sorted((lb for lb in handles if lb.startswith("actuator")),
                   key=lambda lb: [int(v) for v in lb.split()[1].split("+")])
    order = wires + [lb for lb in handles if not lb.startswith("actuator")]
    axes[0, 0].legend([handles[lb] for lb in order], order, loc="lower left", ncol=min(len(order), 7), fontsize=7.5,
                      bbox_to_anchor=(0, 1.02, 1, 0.2), mode="expand", frameon=False, handlelength=1.6)
    axes[-1, 0].set_xlabel("time (min)" if minutes else "time (s)")
    from bhr._hardware.thermal import pace

    how = pace(schedule, counts=False)
    fig.suptitle(f"{title + ': ' if title else ''}wire temperatures over {len(schedule.times_ms)} steps, "
                 f"{format_duration(schedule.total_s)} {how}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def save_schedule_figure(schedule: Schedule, path: str | os.PathLike[str], title: str = "") -> Path:
    return save_figure(schedule_figure(schedule, title), path)
