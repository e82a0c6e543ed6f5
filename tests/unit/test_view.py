"""view.html is written by bhr from the figure's JSON and plotly's plotly.js: the same page plotly.io writes."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

pytest.importorskip("plotly")


def _parts(html: str) -> tuple[str, list]:
    """The page without plotly.js and its JSON arguments, and those arguments parsed."""
    import plotly.io as pio  # noqa: F401  (plotly.js's text, as plotly reads it)
    from plotly.offline import get_plotlyjs

    js = get_plotlyjs()
    assert html.count(js) == 1
    rest = html.replace(js, "")
    call = re.search(r'Plotly\.newPlot\(\s*"bhr-view",\s*(.*)\)\.then\(function\(\)\{\s*Plotly\.addFrames\('
                     r"'bhr-view',\s*(.*)\);\s*\}\)", rest, re.S)
    assert call is not None
    args = json.loads("[" + call.group(1) + "]") + [json.loads(call.group(2))]
    skeleton = re.sub(r"\s+", "", rest.replace(call.group(0), "CALL"))
    return skeleton, args


def test_view_page_is_the_page_plotly_writes():
    import plotly.io as pio

    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr.output._view import view_figure, view_html
    from bhr._run.driver import follow

    robot = Robot()
    run = follow(load_trajectory("colon", feed=robot.feed), solver="thesis", robot=robot)
    ours = view_html(run)
    theirs = pio.to_html(view_figure(run), validate=False, include_plotlyjs=True, full_html=True, auto_play=False,
                         div_id="bhr-view", config=dict(displaylogo=False, responsive=True))
    s_ours, a_ours = _parts(ours)
    s_theirs, a_theirs = _parts(theirs)
    assert s_ours == s_theirs
    assert a_ours == a_theirs  # data, layout, config, frames
    assert "</" not in ours[ours.index("Plotly.newPlot"):].replace("</script>", "").replace("</div>", "") \
        .replace("</body>", "").replace("</html>", "")  # no text in the JSON ends the script element


def test_view_json_escapes_script_ends_and_writes_nan_as_null():
    from bhr.output._view import _script_json

    assert json.loads(_script_json({"name": "</script><b>"})) == {"name": "</script><b>"}
    assert "</" not in _script_json({"name": "</script>"})
    assert json.loads(_script_json({"x": [1.0, float(np.nan)]})) == {"x": [1.0, None]}


def test_json_text_reads_back_as_the_document_with_one_line_per_item():
    from bhr.output._atomic import json_text

    doc = {"steps": [{"step": 1, "points": [[0.0, 1.5, -2.0]], "codes": None}, {"step": 2, "points": []}],
           "name": "colon \"x\"", "empty": {}, "n": 3}
    text = json_text(doc)
    assert json.loads(text) == doc
    lines = text.splitlines()
    assert ' {"step": 1, "points": [[0.0, 1.5, -2.0]], "codes": None}'.replace("None", "null") + "," in \
        [ln[1:] for ln in lines]  # a step is one line
    with pytest.raises(ValueError):
        json_text({"x": float("nan")})  # never NaN in a file bhr writes


def test_plots_import_leaves_matplotlibs_kwdoc_as_it_was():
    import matplotlib.artist

    import bhr.output._run_plots  # noqa: F401  (every figure module)

    assert matplotlib.artist.kwdoc.__module__ == "matplotlib.artist"
    assert "Properties" in matplotlib.artist.kwdoc(matplotlib.artist.Artist)


def test_the_legend_names_a_body_only_when_the_robot_has_one():
    """A head-only run's view listed 'robot: body' in its legend beside 'robot: head'."""
    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr.output._view import view_figure
    from bhr._run.driver import follow

    robot = Robot()
    tr = load_trajectory("curve", feed=robot.feed)
    def legend(fig):
        return [d["name"] for d in fig["data"] if d.get("legendgroup") == "robot" and d.get("showlegend", 1)]

    assert legend(view_figure(follow(tr, solver="thesis", robot=robot))) == ["robot"]
    body = follow(tr, solver="thesis", robot=robot, body_modules=12)
    assert legend(view_figure(body)) == ["robot: body", "robot: head"]


def test_a_flat_paths_short_axis_gets_few_tick_labels():
    """The thesis's colon lies in a plane: its z axis is a sliver of the box, so it gets two or three tick labels
    (plotly's default crowds them on top of each other there); the longest axis gets eight."""
    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr.output._view import view_figure
    from bhr._run.driver import follow

    robot = Robot()
    run = follow(load_trajectory("colon", feed=robot.feed), solver="thesis", robot=robot)
    scene = view_figure(run)["layout"]["scene"]
    ratio = scene["aspectratio"]
    assert ratio["z"] < 0.2 and max(ratio.values()) == 1.0
    longest = max(ratio, key=ratio.get)
    assert scene[f"{longest}axis"]["nticks"] == 8
    assert 2 <= scene["zaxis"]["nticks"] <= 3
    for a in "xyz":
        assert scene[f"{a}axis"]["nticks"] == max(2, min(8, round(8 * ratio[a])))
