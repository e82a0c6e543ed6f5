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
    "error_figure": "_error_plot", "path_figure": "_path_plot", "chain_figure": "_path_plot",
    "body_figure": "_error_plot", "clearance_figure": "_clearance_plot", "save_run_plots": "_run_plots",
    "save_figure": "_figure", "animate": "_animate", "view_figure": "_view", "view_html": "_view",
    "save_view": "_view", "write_run_files": "_steptable", "plot_pose": "_workspace_plot",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return list(__all__)
