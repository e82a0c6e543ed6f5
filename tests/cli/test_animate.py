"""Animations: a colon run animates to a small GIF whose frames show the robot where the run put it.

The frames are read back with Pillow and compared with where the saved run's
points project in the frame (the animation's own axes transform, checked
against the drawn path first): red robot pixels at every point of the robot
at that frame's step and nowhere else in the axes, the green target at the
step's trajectory point, the view zoomed on the robot (the tip drawn as far from
its target as the run's tip error, at the view's scale) and the readout of the
step's errors beside it.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from bhr.output._animate import MAX_FRAMES, default_stride, frame_steps, frame_view
from bhr._run.driver import load_run
from bhr._settings.errors import BhrError
from tests.conftest import bhr_in_process, snapshot

TEN_MB = 10 * 1024 * 1024


def need_tool(name: str) -> str:
    """The tool's path; under CI a missing tool fails the test, elsewhere it skips it."""
    path = shutil.which(name)
    if path is None:
        msg = f"{name} is not installed (tests/run installs it)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def run_cli(*args, cwd: Path, env: dict | None = None, timeout: float = 900):
    """The command in this process (the animation is what is tested, not the process), ``env`` added to the
    environment."""
    e = dict(os.environ)
    e.setdefault("MPLBACKEND", "Agg")
    e.update(env or {})
    return bhr_in_process(*args, cwd=cwd, env=e, timeout=timeout)


# -- reading frames ---------------------------------------------------------------------------
def red_mask(img: np.ndarray) -> np.ndarray:
    """Pixels of the robot's colour (matplotlib tab:red, also blended with white at the disc edges)."""
    r, g, b = (img[:, :, k].astype(int) for k in range(3))
    return (r > 170) & (g < 140) & (b < 140) & (r - g > 80) & (r - b > 80)


def green_mask(img: np.ndarray) -> np.ndarray:
    """Pixels of the target's colour (tab:green)."""
    r, g, b = (img[:, :, k].astype(int) for k in range(3))
    return (g > 120) & (g - r > 60) & (g - b > 60)


def blue_mask(img: np.ndarray) -> np.ndarray:
    """Pixels of the path's colour (tab:blue)."""
    r, g, b = (img[:, :, k].astype(int) for k in range(3))
    return (b > 130) & (b - r > 60)


def near(mask: np.ndarray, xy: np.ndarray, radius: float) -> np.ndarray:
    """For each (x, y) image position: is any pixel of ``mask`` within ``radius`` pixels?"""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return np.zeros(len(xy), dtype=bool)
    pix = np.stack([xs, ys], axis=1).astype(float)
    return np.array([bool(np.min(np.hypot(*(pix - p).T)) <= radius) for p in xy])


def projector(view, step: int):
    """Draw ``step`` on ``view`` and return (to_image(points (k, 3)) -> (k, 2) pixels, axes box in pixels)."""
    view.draw(step)
    view.fig.canvas.draw()
    height = view.fig.canvas.get_width_height()[1]
    ax = view.ax

    def to_image(pts: np.ndarray) -> np.ndarray:
        pts = np.atleast_2d(pts)
        if view.planar:
            xy = pts[:, :2]
        else:
            from mpl_toolkits.mplot3d import proj3d

            x, y, _ = proj3d.proj_transform(pts[:, 0], pts[:, 1], pts[:, 2], ax.get_proj())
            xy = np.stack([x, y], axis=1)
        disp = ax.transData.transform(xy)
        return np.stack([disp[:, 0], height - disp[:, 1]], axis=1)

    bb = ax.get_window_extent()
    box = (bb.x0, height - bb.y1, bb.x1, height - bb.y0)
    return to_image, box


def gif_frame(im: Image.Image, k: int) -> np.ndarray:
    im.seek(k)
    return np.asarray(im.convert("RGB"))


def in_box(img: np.ndarray, box) -> np.ndarray:
    """A mask that keeps only the inside of the axes (the legend below it has red and green samples too)."""
    m = np.zeros(img.shape[:2], dtype=bool)
    x0, y0, x1, y1 = (int(round(v)) for v in box)
    m[y0 + 2:y1 - 1, x0 + 2:x1 - 1] = True
    return m


def check_frame(img: np.ndarray, result, view, step: int, *, other_far_step: bool = True) -> None:
    """The frame shows the robot of ``step`` (red at each of its points, no red elsewhere) and its target."""
    to_image, box = projector(view, step)
    inside = in_box(img, box)
    red = red_mask(img) & inside
    robot = to_image(result.points[step])
    hit = near(red, robot, 3.0)
    assert hit.all(), f"step {step + 1}: no robot pixels at points {np.nonzero(~hit)[0] + 1} ({robot[~hit]})"
    # every red pixel belongs to this step's robot: within a disc radius (plus line width) of its points
    scale = np.linalg.norm(to_image(result.points[step][:1] + [[result.robot.robot_radius, 0, 0]]) - robot[:1])
    ys, xs = np.nonzero(red)
    pix = np.stack([xs, ys], axis=1).astype(float)
    seg = _dist_to_polyline(pix, robot)
    assert seg.max() <= scale + 4.0, f"step {step + 1}: red pixels {seg.max():.1f} px away from the robot"
    tgt = to_image(result.trajectory.points[step])
    assert near(green_mask(img) & inside, tgt, 4.0).all(), f"step {step + 1}: no target marker"
    if other_far_step:
        # the robot of a step far from this one is not drawn in this frame: where it would be in this
        # frame's view (the view follows the robot, so only far robots inside the window can be checked)
        x0, y0, x1, y1 = box
        far = [j for j in range(result.steps)
               if np.min(np.linalg.norm(result.points[j][:, None] - result.points[step][None], axis=2)) > 40.0]
        seen = [j for j in far
                if ((to_image(result.points[j]) > [x0, y0]) & (to_image(result.points[j]) < [x1, y1])).all()]
        if seen:
            j = seen[len(seen) // 2]
            assert not near(red, to_image(result.points[j]), 1.5).any(), \
                f"frame of step {step + 1} shows the robot of step {j + 1}"


def _dist_to_polyline(pix: np.ndarray, poly: np.ndarray) -> np.ndarray:
    best = np.full(len(pix), np.inf)
    for a, b in zip(poly[:-1], poly[1:]):
        ab = b - a
        t = np.clip(((pix - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        d = np.hypot(*(pix - (a + t[:, None] * ab)).T)
        best = np.minimum(best, d)
    return best


# -- the colon GIF ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def colon_gif(tmp_path_factory):
    folder = tmp_path_factory.mktemp("colon")
    res = run_cli("follow", "--traj", "colon", "--no-plots", "--out", "run", "--animate", "colon.gif", cwd=folder)
    assert res.returncode == 0, res.stderr
    return folder, res


def test_colon_gif_is_small_and_has_one_frame_per_stride(colon_gif):
    folder, res = colon_gif
    gif = folder / "colon.gif"
    result = load_run(folder / "run" / "run.json")
    assert result.steps == 827
    size = gif.stat().st_size
    assert 0 < size <= TEN_MB, f"colon GIF is {size / 1e6:.2f} MB"
    m = re.search(r"Animation: (\d+) frames \(every (\d+) steps? of 827\), ([\d.]+) MB", res.stdout)
    assert m, res.stdout
    frames, stride = int(m.group(1)), int(m.group(2))
    assert stride == default_stride(827) > 1
    with Image.open(gif) as im:
        assert im.format == "GIF"
        assert im.n_frames == frames == len(frame_steps(827, stride)) <= MAX_FRAMES
        assert im.size == frame_view(result).fig.canvas.get_width_height()
    assert "Rendering" not in res.stderr  # piped: no progress bar (only on a terminal, as every bar of bhr)


def test_colon_gif_frames_show_the_robot_at_the_right_steps(colon_gif):
    folder, _ = colon_gif
    result = load_run(folder / "run" / "run.json")
    steps = frame_steps(result.steps, default_stride(result.steps))
    view = frame_view(result)
    with Image.open(folder / "colon.gif") as im:
        # The transform used for the checks maps the trajectory onto the blue path drawn in the frame:
        # the path's points inside the window that follows the robot (and only those) are drawn.
        for k in (0, len(steps) // 2):
            img = gif_frame(im, k)
            to_image, box = projector(view, steps[k])
            x0, x1 = view.ax.get_xlim()
            y0, y1 = view.ax.get_ylim()
            p = result.trajectory.points
            inside = (p[:, 0] > x0 + 3) & (p[:, 0] < x1 - 3) & (p[:, 1] > y0 + 3) & (p[:, 1] < y1 - 3)
            assert inside.sum() >= 10 and not inside.all()  # zoomed on the robot: part of the path in view
            # ...where the robot (its discs), the target and the start and end marks do not cover it
            cover = np.vstack([result.points[steps[k]], result.trajectory.points[[steps[k], 0, -1]]])
            inside &= np.linalg.norm(p[:, None] - cover[None], axis=2).min(axis=1) > result.robot.robot_radius + 3.0
            assert inside.sum() >= 5
            assert near(blue_mask(img) & in_box(img, box), to_image(p[inside]), 2.5).all()
        # Frames at the start, in each bend and straight, and the last (the final pose).
        picks = sorted({0, 1, 2, len(steps) // 5, len(steps) // 3, len(steps) // 2, 2 * len(steps) // 3,
                        len(steps) - 2, len(steps) - 1})
        for k in picks:
            check_frame(gif_frame(im, k), result, view, steps[k])
        # ...and the robot is where the run put it against its target: at each of those steps the tip is
        # drawn as far from the target's point as the run's tip error says (the view's scale, 3 px).
        for k in picks:
            s = steps[k]
            to_image, _ = projector(view, s)
            tip_px, tgt_px = to_image(result.points[s][-1]), to_image(result.trajectory.points[s])
            scale = np.linalg.norm(to_image(result.trajectory.points[s] + [10.0, 0, 0]) - tgt_px) / 10.0
            assert scale > 3.0  # zoomed: more than 3 pixels a millimetre (the whole colon would give ~1)
            assert abs(np.linalg.norm(tip_px - tgt_px) - scale * result.point_errors_mm[s, -1]) <= 3.0
        # The readout beside the view names the step and its errors; it changes from frame to frame.
        view.draw(steps[3])
        view.fig.canvas.draw()
        bb = view.readout.get_window_extent()
        height = view.fig.canvas.get_width_height()[1]
        rows = slice(int(height - bb.y1), int(height - bb.y0) + 1)
        cols = slice(int(bb.x0), int(bb.x1) + 1)
        a, b = gif_frame(im, 3)[rows, cols], gif_frame(im, 4)[rows, cols]
        assert (a.max(axis=2) < 100).sum() > 200  # dark text
        assert not np.array_equal(a, b)
        assert f"step {steps[3] + 1} of 827" in view.readout.get_text()


def test_frames_shifted_by_one_do_not_match(colon_gif):
    """The check above can fail: frame k does not pass for the step of frame k+40."""
    folder, _ = colon_gif
    result = load_run(folder / "run" / "run.json")
    steps = frame_steps(result.steps, default_stride(result.steps))
    view = frame_view(result)
    with Image.open(folder / "colon.gif") as im:
        with pytest.raises(AssertionError):
            check_frame(gif_frame(im, 100), result, view, steps[140], other_far_step=False)


# -- 3D and MP4 ---------------------------------------------------------------------------------
def test_spiral_animates_in_3d_with_the_robot_at_each_frame(tmp_path):
    res = run_cli("follow", "--traj", "spiral", "--turns", "0.5", "--no-plots", "--out", "run", "--animate",
                  "spiral.gif", "--stride", "7", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    result = load_run(tmp_path / "run" / "run.json")
    view = frame_view(result)
    assert not view.planar
    steps = frame_steps(result.steps, 7)
    with Image.open(tmp_path / "spiral.gif") as im:
        assert im.n_frames == len(steps)
        for k in (0, len(steps) // 2, len(steps) - 1):
            img = gif_frame(im, k)
            to_image, box = projector(view, steps[k])
            red = red_mask(img) & in_box(img, box)
            assert near(red, to_image(result.points[steps[k]]), 3.0).all()
            assert near(green_mask(img), to_image(result.trajectory.points[steps[k]]), 4.0).all()


def test_mp4_through_ffmpeg(tmp_path):
    need_tool("ffmpeg")
    ffprobe = need_tool("ffprobe")
    res = run_cli("follow", "--traj", "curve", "--no-plots", "--out", "run", "--animate", "curve.mp4",
                  "--stride", "2", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    result = load_run(tmp_path / "run" / "run.json")
    probe = subprocess.run([ffprobe, "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                            "stream=codec_name,width,height,nb_read_frames", "-of", "default=nw=1",
                            str(tmp_path / "curve.mp4")], capture_output=True, text=True, check=True).stdout
    info = dict(line.split("=", 1) for line in probe.split())
    assert info["codec_name"] == "h264"
    assert (int(info["width"]), int(info["height"])) == frame_view(result).fig.canvas.get_width_height()
    assert int(info["nb_read_frames"]) == len(frame_steps(result.steps, 2))


# -- refusals before any work ---------------------------------------------------------------------
@pytest.mark.parametrize("args, env, message", [
    (["--animate", "run.avi"], {}, "give a file ending in .gif (Pillow) or .mp4 (ffmpeg)"),
    (["--animate", "run"], {}, "give a file ending in .gif"),
    (["--animate", "run.mp4"], {"BHR_FFMPEG": "/nonexistent/ffmpeg"}, ".mp4 needs the ffmpeg program"),
    (["--animate", "blocker/run.gif"], {}, "not a writable folder"),
    (["--animate", "x.gif", "--stride", "0"], {}, "Invalid value for '--stride'"),
])
def test_animation_refused_with_one_line_before_any_work(tmp_path, args, env, message):
    (tmp_path / "blocker").write_text("a file where a folder should be\n")
    before = snapshot(tmp_path)
    res = run_cli("follow", "--traj", "colon", "--out", "out", *args, cwd=tmp_path, env=env, timeout=60)
    assert res.returncode != 0
    assert message in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before  # no output folder, nothing solved or written


def test_failed_render_leaves_the_old_file_untouched(tmp_path):
    from bhr.model._generators import load_trajectory
    from bhr.output._animate import animate
    from bhr._run.driver import follow

    result = follow(load_trajectory("line", length=30))
    target = tmp_path / "anim.gif"
    target.write_bytes(b"precious")

    def interrupt(done, total):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        animate(result, target, stride=1, progress=interrupt)
    assert target.read_bytes() == b"precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["anim.gif"]
    done = []
    anim = animate(result, target, stride=4, progress=lambda k, n: done.append((k, n)))
    assert done == [(k, anim.frames) for k in range(1, anim.frames + 1)]
    assert anim.steps == frame_steps(result.steps, 4) and anim.bytes == target.stat().st_size
    with Image.open(target) as im:
        assert im.n_frames == anim.frames


# -- frame selection --------------------------------------------------------------------------------
@given(steps=st.integers(1, 5000), stride=st.integers(1, 400))
def test_frame_steps_cover_the_run(steps, stride):
    fs = frame_steps(steps, stride)
    assert fs[0] == 0 and fs[-1] == steps - 1
    gaps = np.diff(fs)
    assert np.all(gaps >= 1) and np.all(gaps <= stride)
    assert all(s % stride == 0 for s in fs[:-1])
    assert len(fs) == -(-steps // stride) + (1 if (steps - 1) % stride else 0)


@given(steps=st.integers(1, 100000))
def test_default_stride_is_the_smallest_within_the_frame_budget(steps):
    s = default_stride(steps)
    assert len(frame_steps(steps, s)) <= MAX_FRAMES
    if s > 1:
        assert len(frame_steps(steps, s - 1)) > MAX_FRAMES


@pytest.mark.parametrize("stride", [0, -1, 1.5, True, "2"])
def test_bad_stride_is_a_clear_error(stride):
    with pytest.raises(BhrError, match="stride must be a whole number"):
        frame_steps(10, stride)
