"""view.html: an interactive 3-D view of a run (the lumen as a tube, the whole robot at every step, contacts).

One self-contained HTML file built with plotly (plotly.js embedded, so it works
offline): a step slider and a play button move the whole robot (body and head)
along the path; the lumen wall is drawn as a translucent tube from the
centerline and its diameter; where the robot touches the wall (bhr's geometric
clearance, or the contacts of a physics replay) is marked in red. The page is
written from plotly's plotly.js and the figure's JSON, without importing plotly.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from bhr._run.body import whole_robot

__all__ = ["VIEW_NAME", "MAX_FRAMES", "view_figure", "view_html", "save_view", "tube_mesh", "frame_steps"]

#: File name of the view in an output folder.
VIEW_NAME = "view.html"
#: Slider positions at most (longer runs show every k-th step, the last always).
MAX_FRAMES = 150
#: The robot's colours in the view: its body and its head.
BODY_RGB, HEAD_RGB = "rgb(40,90,200)", "rgb(230,140,20)"
#: How far (mm) the view's box reaches beyond the path's wall (the robot behind the entrance is clipped beyond).
VIEW_MARGIN_MM = 40.0
#: Contact marks of all steps drawn at most.
MAX_CONTACTS = 1000
_RING = 10  # vertices around the tube
_TUBE_SPACING = 8.0  # mm of centerline between the view's tube rings


def frame_steps(steps: int, most: int = MAX_FRAMES) -> list[int]:
    """0-based steps shown: every k-th so that at most ``most`` are, and the last step always."""
    k = max(1, math.ceil(steps / most))
    out = list(range(0, steps, k))
    if out[-1] != steps - 1:
        out.append(steps - 1)
    return out


def tube_mesh(points: np.ndarray, diameter: np.ndarray, ring: int = _RING, spacing: float = 4.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (K, 3) and triangles (T, 3) of a tube around ``points`` with the given diameters (mm).

    Rings every ``spacing`` mm of centerline (the ends always), each perpendicular to the local
    direction, with a frame carried along the centerline by parallel transport (no twist).
    """
    P = np.asarray(points, dtype=np.float64)
    D = np.asarray(diameter, dtype=np.float64)
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    keep = [0]
    for i in range(1, len(P)):
        if s[i] - s[keep[-1]] >= spacing or i == len(P) - 1:
            keep.append(i)
    P, D = P[keep], D[keep]
    t = np.gradient(P, axis=0)
    t /= np.linalg.norm(t, axis=1)[:, None]
    ref = np.array([0.0, 0.0, 1.0]) if abs(t[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(t[0], ref)
    u /= np.linalg.norm(u)
    verts = np.empty((len(P), ring, 3))
    ang = np.linspace(0.0, 2.0 * math.pi, ring, endpoint=False)
    for i in range(len(P)):
        u = u - np.dot(u, t[i]) * t[i]
        u /= np.linalg.norm(u)
        v = np.cross(t[i], u)
        verts[i] = P[i] + (D[i] / 2.0) * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * v)
    tri = []
    for i in range(len(P) - 1):
        for j in range(ring):
            a, b = i * ring + j, i * ring + (j + 1) % ring
            c, d = a + ring, b + ring
            tri += [(a, b, c), (b, d, c)]
    return verts.reshape(-1, 3), np.array(tri, dtype=np.int64)


def _r(a: np.ndarray) -> list[float]:
    return np.round(np.asarray(a, dtype=np.float64), 1).tolist()


def _contacts_by_step(result) -> list[np.ndarray]:
    """Where the robot touches the wall at each step (bhr's geometric clearance): each touching module's
    deepest spot."""
    cl = result.clearance
    if cl is None or cl.module_table is None or cl.module_where is None:
        return [np.zeros((0, 3))] * result.steps
    with np.errstate(invalid="ignore"):
        hit = cl.module_table <= 0.0
    return [cl.module_where[i][hit[i]] for i in range(result.steps)]


def view_figure(result, contacts: Sequence[np.ndarray] | None = None, title: str | None = None,
                most: int = MAX_FRAMES) -> dict[str, Any]:
    """The plotly figure of :func:`view_html`, as a plain dict (data, layout, frames).

    Plain dicts, not ``plotly.graph_objects``: validating hundreds of frames of hundreds of points
    took most of the time of building a long run's view.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    contacts : sequence of numpy.ndarray, each shape (K, 3), optional
        Per step, the points (mm) to mark as contacts; default where bhr's geometric clearance finds the
        robot touching the wall.
    title : str, optional
        The page's title; default one naming the trajectory and the solver.
    most : int, default 150
        At most this many steps are frames (every k-th step, and always the last).

    Returns
    -------
    dict of str to object
        ``{"data": [...], "layout": {...}, "frames": [...]}``, plotly's figure JSON: the path, the lumen's
        wall, the contacts and the robot (mm), one frame per shown step; ``plotly.graph_objects.Figure(d)``
        builds the figure.
    """
    tr = result.trajectory
    N = result.steps
    shown = frame_steps(N, most)
    per_step = _contacts_by_step(result) if contacts is None else [np.asarray(c).reshape(-1, 3) for c in contacts]
    robots = [whole_robot(result, i) for i in shown]
    path = np.asarray(tr.points, dtype=np.float64)
    data: list[Any] = []
    if tr.lumen is not None:
        # the tube as bhr's clearance sees it: the centerline, continued straight behind the entrance
        # as far as the robot reaches back
        reach = max(float(np.linalg.norm(rb[0] - path[0])) for rb in robots[:1]) if robots else 0.0
        d0 = np.asarray(tr.start_direction, dtype=np.float64)
        d0 /= np.linalg.norm(d0)
        back = np.arange(math.ceil(reach / 4.0) + 1, 0, -1)[:, None] * 4.0
        ext = path[0] - back * d0
        cl_pts = np.vstack([ext, path])
        dia = np.concatenate([np.full(len(ext), tr.lumen[0]), np.asarray(tr.lumen[:len(path)], dtype=np.float64)])
        verts, tri = tube_mesh(cl_pts, dia, spacing=_TUBE_SPACING)
        data.append(dict(type="mesh3d", x=_r(verts[:, 0]), y=_r(verts[:, 1]), z=_r(verts[:, 2]),
                         i=tri[:, 0].tolist(), j=tri[:, 1].tolist(),
                              k=tri[:, 2].tolist(), color="rgb(214,120,120)", opacity=0.18, name="lumen wall",
                              hoverinfo="skip", showlegend=True, flatshading=True))
    data.append(dict(type="scatter3d", x=_r(path[:, 0]), y=_r(path[:, 1]), z=_r(path[:, 2]), mode="lines",
                             line=dict(color="gray", width=2, dash="dot"), name="centerline", hoverinfo="skip"))
    allc = np.vstack([c for c in per_step if len(c)]) if any(len(c) for c in per_step) else np.zeros((0, 3))
    if len(allc) > MAX_CONTACTS:  # a sample spread over the run keeps the page light
        allc = allc[np.linspace(0, len(allc) - 1, MAX_CONTACTS).astype(np.int64)]
    data.append(dict(type="scatter3d", x=_r(allc[:, 0]), y=_r(allc[:, 1]), z=_r(allc[:, 2]), mode="markers",
                             marker=dict(size=2, color="rgba(220,40,40,0.35)"), name="contacts (all steps)",
                             hoverinfo="skip"))
    from bhr.model._anatomy import path_sections

    sections = path_sections(tr)
    if sections:  # an anatomical colon: its sections named along it
        at = path[[k for _, k in sections]]
        data.append(dict(type="scatter3d", mode="text", text=[name for name, _ in sections], name="sections",
                         textfont=dict(size=11, color="rgb(90,61,51)"), hoverinfo="skip", **{
                             a: _r(at[:, k]) for k, a in enumerate("xyz")}))
    if len(path) > 2:  # the direction of travel: a cone near the start, along the path
        k = min(len(path) - 2, max(1, len(path) // 50))
        d = path[k + 1] - path[k - 1]
        data.append(dict(type="cone", x=[float(path[k, 0])], y=[float(path[k, 1])], z=[float(path[k, 2])],
                         u=[float(d[0])], v=[float(d[1])], w=[float(d[2])], sizemode="absolute",
                         sizeref=float(max(10.0, 0.04 * float(np.ptp(path, axis=0).max()))), anchor="tail",
                         showscale=False, colorscale=[[0, "rgb(40,40,40)"], [1, "rgb(40,40,40)"]],
                         name="direction of travel", showlegend=True, hoverinfo="name"))
    i_robot, i_contact = len(data), len(data) + 1

    def xyz(p: np.ndarray) -> dict[str, Any]:
        return dict(x=_r(p[:, 0]), y=_r(p[:, 1]), z=_r(p[:, 2]))

    # the whole robot is one line (its body blue, its head orange: a two-colour scale over its points); a
    # frame carries only the coordinates of the robot and of the step's contacts (plotly merges a frame's
    # traces into the figure's), so a long robot's frames stay small
    last = len(shown) - 1
    p_last = robots[last]
    n_head = result.modules + 1
    shade = [0] * (len(p_last) - n_head) + [1] * n_head
    data.append(dict(type="scatter3d", mode="lines", name="robot (head orange)", hoverinfo="skip",
                     line=dict(width=7, color=shade, cmin=0, cmax=1,
                               colorscale=[[0, BODY_RGB], [0.5, BODY_RGB], [0.5, HEAD_RGB], [1, HEAD_RGB]]),
                     legendgroup="robot", showlegend=False, **xyz(p_last)))
    data.append(dict(type="scatter3d", mode="markers", name="contact at this step", hoverinfo="skip",
                     marker=dict(size=6, color="red", symbol="diamond"), **xyz(per_step[shown[last]])))
    # plotly draws a line coloured by a scale black in the legend: the robot's legend is two empty lines of
    # its two colours, in its legend group (clicking either hides or shows the robot)
    # (a robot that is its head only has no body to name)
    parts = (("robot: body", BODY_RGB), ("robot: head", HEAD_RGB)) if len(p_last) > n_head else (("robot", HEAD_RGB),)
    for label, rgb in parts:
        data.append(dict(type="scatter3d", mode="lines", name=label, hoverinfo="skip", legendgroup="robot",
                         line=dict(width=7, color=rgb), x=[None], y=[None], z=[None]))
    frames = [dict(name=str(s + 1), data=[xyz(robots[k]), xyz(per_step[s])], traces=[i_robot, i_contact])
              for k, s in enumerate(shown)]
    slider = dict(active=last, currentvalue=dict(prefix="step "), pad=dict(t=40),
                  steps=[dict(method="animate", label=str(s + 1),
                              args=[[str(s + 1)], dict(mode="immediate", frame=dict(duration=0, redraw=True),
                                                       transition=dict(duration=0))]) for s in shown])
    play = dict(type="buttons", showactive=False, x=0.0, y=0.0, xanchor="right", yanchor="top", pad=dict(t=40, r=10),
                buttons=[dict(label="play", method="animate",
                              args=[None, dict(frame=dict(duration=60, redraw=True), fromcurrent=True,
                                               transition=dict(duration=0))]),
                         dict(label="pause", method="animate",
                              args=[[None], dict(mode="immediate", frame=dict(duration=0, redraw=False))])])
    name = title or f"{tr.name}: {result.solver} solver, {len(robots[0]) - 1} modules, {N} steps"
    # the box shown is the path's (and its wall's) with a margin: a long robot reaches metres back behind the
    # entrance, and a box around all of it would leave the colon a speck; what lies outside is clipped
    pad = (float(np.max(tr.lumen)) / 2 if tr.lumen is not None else 0.0) + VIEW_MARGIN_MM
    lo, hi = path.min(axis=0) - pad, path.max(axis=0) + pad
    span = hi - lo
    # ticks in proportion to each axis's share of the box: a flat path's short axis gets two or three, not a
    # crowd of labels on top of each other
    ratio = span / span.max()
    axes = {f"{a}axis": dict(title=dict(text=f"{a} (mm)"), range=[round(float(lo[k]), 1), round(float(hi[k]), 1)],
                             autorange=False, nticks=int(max(2, min(8, round(8 * float(ratio[k]))))))
            for k, a in enumerate("xyz")}
    layout = dict(title=dict(text=name), sliders=[slider], updatemenus=[play], margin=dict(l=0, r=0, t=40, b=0),
                  scene=dict(aspectmode="manual", aspectratio={a: float(ratio[k]) for k, a in enumerate("xyz")},
                             **axes),
                  legend=dict(x=0.0, y=1.0), uirevision="keep")
    return dict(data=data, layout=layout, frames=frames)


def _plotly_js() -> str:
    """plotly.js as plotly ships it (plotly/package_data/plotly.min.js), read without importing plotly."""
    import importlib.util

    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("No module named 'plotly'")
    return (Path(list(spec.submodule_search_locations)[0]) / "package_data" / "plotly.min.js").read_text("utf-8")


def _script_json(obj: Any) -> str:
    """``obj`` as JSON safe inside a <script> element (as plotly.io writes it: <, > and / escaped)."""
    try:
        text = json.dumps(obj, separators=(",", ":"), allow_nan=False)
    except ValueError:  # a NaN: plotly's encoder writes it as null
        from plotly.io.json import to_json_plotly

        return str(to_json_plotly(obj))
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("/", "\\u002f")


#: The page around the plot: the same as ``plotly.io.to_html(fig, include_plotlyjs=True, full_html=True,
#: auto_play=False, div_id=DIV_ID)`` writes (plotly.js inline, the plot filling the window, frames added after).
DIV_ID = "bhr-view"
_PAGE_HEAD = ('<!doctype html>\n<html>\n<head>\n    <meta charset="utf-8" />\n'
              '    <style>html, body {height: 100%;}</style>\n</head>\n<body>\n'
              '    <div style="height:100%; width:100%;">'
              "        <script>window.PlotlyConfig = {MathJaxConfig: 'local'};</script>\n        <script>")
_PAGE_PLOT = ('</script>        <div id="{id}" class="plotly-graph-div" style="height:100%; width:100%;"></div>'
              '        <script>            window.PLOTLYENV=window.PLOTLYENV || {{}};'
              '            if (document.getElementById("{id}")) {{'
              '                Plotly.newPlot("{id}", {data}, {layout}, {config}).then(function(){{\n'
              "                    Plotly.addFrames('{id}', {frames});\n"
              '                }})            }};        </script>    </div>\n</body>\n</html>')


def view_html(result, contacts: Sequence[np.ndarray] | None = None, title: str | None = None) -> str:
    """The view of ``result`` (a :class:`bhr._run.driver.FollowResult`) as one self-contained HTML page.

    ``contacts``: per step, the points (K, 3) to mark as contacts (default: where bhr's
    geometric clearance finds the robot touching the wall). The page is written here from the
    figure's plain JSON and plotly's own plotly.js, as ``plotly.io.to_html`` writes it, without
    importing plotly.io (most of the time the page took; tests/unit/test_view.py compares the two).

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    contacts : sequence of numpy.ndarray, each shape (K, 3), optional
        Per step, the points (mm) to mark as contacts; default where bhr's geometric clearance finds the
        robot touching the wall.
    title : str, optional
        The page's title; default one naming the trajectory and the solver.

    Returns
    -------
    str
        The HTML page, plotly.js included: it opens offline in any browser.
    """
    fig = view_figure(result, contacts, title)
    plot = _PAGE_PLOT.format(id=DIV_ID, data=_script_json(fig["data"]), layout=_script_json(fig["layout"]),
                             config=_script_json(dict(displaylogo=False, responsive=True)),
                             frames=_script_json(fig["frames"]))
    return _PAGE_HEAD + _plotly_js() + plot


def save_view(result, folder: str | Path, contacts: Sequence[np.ndarray] | None = None,
              name: str = VIEW_NAME) -> Path:
    """Write :func:`view_html` into ``folder`` as ``name``; return its path.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    folder : str or pathlib.Path
        An existing folder.
    contacts : sequence of numpy.ndarray, each shape (K, 3), optional
        Per step, the points (mm) to mark as contacts; default where bhr's geometric clearance finds the
        robot touching the wall.
    name : str, default "view.html"
        The file's name.

    Returns
    -------
    pathlib.Path
        The page written (whole or not at all).
    """
    from bhr.output._atomic import write_text

    path = Path(folder) / name
    write_text(path, view_html(result, contacts))
    return path
