"""Output: a run's figures, animations, the interactive 3-D view and its files.

The supported names are listed in ``__all__`` and loaded on first use (PEP 562); matplotlib and plotly are imported
only when a figure is drawn. Figures are :class:`matplotlib.figure.Figure` objects (no pyplot state), so they can be
saved, shown or embedded by the caller. The modules inside this package are not part of the API.

>>> import bhr
>>> from bhr.output import error_figure
>>> fig = error_figure(bhr.follow(bhr.trajectory("curve", radius=70, angle=90)), "position")
>>> fig.axes[0].get_ylabel()
'position error (mm)'
"""
from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module of this package that defines it.
_API = {
    "error_figure": "error_plot", "path_figure": "path_plot", "chain_figure": "path_plot", "body_figure": "error_plot",
    "clearance_figure": "clearance_plot", "save_run_plots": "run_plots", "save_figure": "figure",
    "animate": "animate", "view_figure": "view", "view_html": "view", "save_view": "view",
    "write_run_files": "steptable", "plot_pose": "workspace_plot",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return list(__all__)
