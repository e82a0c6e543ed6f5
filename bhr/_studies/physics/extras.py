"""For ``bhr traverse``: the worst colon's 3-D view and, with ``--physics``, the physical robot's replay on it."""
from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["worst_colon_extras"]


def worst_colon_extras(run, folder: Any, physics: bool = False, options: dict[str, Any] | None = None) -> list[str]:
    """The worst colon's 3-D view and, with ``physics``, its replay (:func:`replay_physics` with ``options``, the
    study's and its design's); the file names."""
    from bhr.output._atomic import write_json
    from bhr.output._physics_plot import force_figure
    from bhr.output._figure import save_figure
    from bhr.output._view import save_view
    from bhr._studies.physics.replay import replay_physics

    folder = Path(folder)
    names = []
    contacts = None
    if physics and run.codes is not None and run.trajectory.lumen is not None:
        rep = replay_physics(run, **(options or {}))
        write_json(folder / "worst-colon-physics.json", rep.to_dict())
        save_figure(force_figure(rep, f"{run.trajectory.name}: the worst colon, the physical robot"),
                    folder / "worst-colon-force.png")
        names += ["worst-colon-physics.json", "worst-colon-force.png"]
        contacts = rep.contacts_by_step(run.steps)
    names.append(save_view(run, folder, contacts=contacts, name="worst-colon-view.html").name)
    return names
