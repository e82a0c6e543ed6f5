"""Animate a run off-screen: the frames of the live view, to a GIF (Pillow) or an MP4 (ffmpeg).

Each frame is :class:`bhr.output._stepview.StepView` drawing one step (a view that
follows the robot: path, lumen wall, target, robot with a disc per module;
an overview of the whole path; a readout of the step's errors) on an
off-screen Agg figure, so an animation shows exactly what ``bhr follow
--show`` shows.
Every ``stride``-th step becomes a frame, and the last step always does.

GIF frames share one palette (taken from the first frame) and Pillow stores
each frame as the rectangle that changed since the previous one, so a long
run stays small. MP4 needs the ``ffmpeg`` program; :func:`check_target`
refuses a ``.mp4`` without it (and any other extension) before any work.

Only :func:`check_target`, :func:`default_stride` and :func:`frame_steps`
run without matplotlib; rendering imports it.
"""
from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from bhr._settings.errors import BhrError
from bhr.output._atomic import atomic_path

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
    from bhr.output._stepview import StepView

__all__ = ["animate", "check_target", "default_stride", "frame_steps", "frame_view", "ffmpeg_program",
           "Animation", "FORMATS", "DEFAULT_FPS", "MAX_FRAMES", "FRAME_INCHES", "FRAME_DPI"]

#: Supported file extensions and what writes them.
FORMATS = {".gif": "Pillow", ".mp4": "ffmpeg"}
#: Frames per second of the animation.
DEFAULT_FPS = 20
#: The default stride keeps an animation at or under this many frames.
MAX_FRAMES = 300
#: Frame size: inches and dots per inch (1000 x 700 pixels; the live view's too, bhr.output._scene.FRAME_INCHES).
FRAME_INCHES = (10.0, 7.0)
FRAME_DPI = 100
#: How long the last frame stays before a GIF loops (ms).
LAST_FRAME_MS = 1500
#: Colours of the shared GIF palette.
GIF_COLOURS = 256


@dataclass(frozen=True)
class Animation:
    """What :func:`animate` wrote."""

    path: Path
    format: str  # "gif" or "mp4"
    frames: int
    stride: int
    steps: list[int]  # 0-based run steps, one per frame
    bytes: int


def ffmpeg_program() -> str | None:
    """The ffmpeg program bhr uses for MP4 (``$BHR_FFMPEG`` or ``ffmpeg`` on PATH), or None."""
    name = os.environ.get("BHR_FFMPEG") or "ffmpeg"
    return shutil.which(name)


def check_target(path: str | os.PathLike[str]) -> str:
    """The format (``"gif"`` or ``"mp4"``) for ``path``; a :class:`BhrError` when it cannot be written."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise BhrError(f"cannot animate to {path}: give a file ending in .gif (Pillow) or .mp4 (ffmpeg)")
    if suffix == ".mp4" and ffmpeg_program() is None:
        raise BhrError(f"cannot write {path}: .mp4 needs the ffmpeg program, which is not on PATH; "
                       "install ffmpeg (Debian: apt-get install ffmpeg) or animate to a .gif")
    return suffix[1:]


def default_stride(steps: int) -> int:
    """Smallest stride that keeps a run of ``steps`` at or under :data:`MAX_FRAMES` frames."""
    return max(1, math.ceil((steps - 1) / (MAX_FRAMES - 1))) if steps > MAX_FRAMES else 1


def frame_steps(steps: int, stride: int) -> list[int]:
    """The 0-based steps drawn as frames: 0, stride, 2 stride, ... and always the last step."""
    if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
        raise BhrError(f"stride must be a whole number of steps, 1 or more, got {stride!r}")
    if steps < 1:
        raise BhrError("the run has no steps to animate")
    out = list(range(0, steps, stride))
    if out[-1] != steps - 1:
        out.append(steps - 1)
    return out


def frame_view(result: "FollowResult") -> "StepView":
    """A :class:`bhr.output._stepview.StepView` on an off-screen figure of the animation's frame size."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from bhr.output._stepview import StepView

    fig = Figure(figsize=FRAME_INCHES, dpi=FRAME_DPI)
    FigureCanvasAgg(fig)
    return StepView(result, fig=fig)


def _rgb(view: "StepView") -> Any:
    import numpy as np

    view.render()
    return np.asarray(view.fig.canvas.buffer_rgba())[:, :, :3]  # type: ignore[attr-defined]  # the Agg canvas


def _palette(first: Any) -> Any:
    """The GIF palette: the drawing's colours blended with white (robot, path, target, text), then the
    colours of the first frame (median cut) up to 256."""
    from matplotlib.colors import to_rgb
    from PIL import Image

    colours: list[tuple[int, int, int]] = []
    for name in ("white", "black", "tab:red", "tab:blue", "tab:green", "tab:gray"):
        rgb = to_rgb(name)
        for t in (1.0, 0.85, 0.7, 0.55, 0.4, 0.25, 0.12):
            r_, g_, b_ = (int(round(255 * (t * v + (1 - t)))) for v in rgb)
            c = (r_, g_, b_)
            if c not in colours:
                colours.append(c)
    adaptive = first.quantize(colors=GIF_COLOURS - len(colours), method=Image.Quantize.MEDIANCUT,
                              dither=Image.Dither.NONE)
    extra = adaptive.getpalette()[:3 * (GIF_COLOURS - len(colours))]
    flat = [v for c in colours for v in c] + extra
    pal = Image.new("P", (1, 1))
    pal.putpalette(flat + [255] * (3 * 256 - len(flat)))
    return pal


def _write_gif(view: "StepView", steps: list[int], tmp: Path, fps: int,
               tick: Callable[[], None]) -> None:
    from PIL import Image

    palette_img: list[Any] = []

    def frames() -> Any:
        for i in steps:
            view.draw(i)
            im = Image.fromarray(_rgb(view), "RGB")
            if not palette_img:
                palette_img.append(_palette(im))
            yield im.quantize(palette=palette_img[0], dither=Image.Dither.NONE)
            tick()

    it = frames()
    first = next(it)
    frame_ms = max(20, round(1000 / fps))
    durations = [frame_ms] * len(steps)
    durations[-1] = max(frame_ms, LAST_FRAME_MS)
    first.save(tmp, format="GIF", save_all=True, append_images=it, duration=durations, loop=0,
               optimize=False, disposal=1)


def _write_mp4(view: "StepView", steps: list[int], tmp: Path, fps: int, tick: Callable[[], None]) -> None:
    import subprocess

    import matplotlib
    from matplotlib.animation import FFMpegWriter

    program = ffmpeg_program()
    if program is None:
        raise BhrError(f"cannot write {tmp}: .mp4 needs the ffmpeg program; install ffmpeg or animate to a .gif")
    with matplotlib.rc_context({"animation.ffmpeg_path": program}):
        writer = FFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
        try:
            with writer.saving(view.fig, str(tmp), FRAME_DPI):
                for i in steps:
                    view.draw(i)
                    writer.grab_frame()
                    tick()
        except (subprocess.CalledProcessError, BrokenPipeError, OSError) as exc:
            raise BhrError(f"ffmpeg could not write {tmp.name}: {exc.__class__.__name__}: "
                           f"{str(exc).splitlines()[0] if str(exc) else ''}; try a .gif") from None


def animate(result: "FollowResult", path: str | os.PathLike[str], stride: int | None = None,
            fps: int = DEFAULT_FPS, progress: Callable[[int, int], None] | None = None) -> Animation:
    """Render ``result`` to ``path`` (``.gif`` or ``.mp4``), one frame every ``stride`` steps.

    ``stride`` defaults to :func:`default_stride` (at most :data:`MAX_FRAMES`
    frames). ``progress(done, total)`` is called after each frame. The file
    is written atomically: an interrupted render leaves nothing behind and
    replaces nothing.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    path : str or os.PathLike
        The file: ``.gif`` (Pillow) or ``.mp4`` (needs the ffmpeg program).
    stride : int, optional
        Draw every ``stride``-th step (and always the last), 1 or more; default the smallest that keeps
        the animation at 300 frames or fewer.
    fps : int, default 20
        Frames per second, 1 to 50.
    progress : callable ``progress(done, total)``, optional
        Called after each frame with the frames drawn and the frames in all.

    Returns
    -------
    Animation
        What was written: ``path``, ``format`` (``"gif"`` or ``"mp4"``), ``frames``, ``stride``, ``steps``
        (the 0-based run steps drawn) and ``bytes`` (the file's size).

    Raises
    ------
    BhrError
        A file that is not .gif or .mp4, .mp4 without ffmpeg, or a ``stride`` or ``fps`` out of range.
    """
    fmt = check_target(path)
    if isinstance(fps, bool) or not isinstance(fps, int) or not 1 <= fps <= 50:
        raise BhrError(f"fps must be a whole number from 1 to 50, got {fps!r}")
    s = default_stride(result.steps) if stride is None else stride
    steps = frame_steps(result.steps, s)
    total = len(steps)
    done = [0]

    def tick() -> None:
        done[0] += 1
        if progress is not None:
            progress(done[0], total)

    view = frame_view(result)
    target = Path(path)
    with atomic_path(target) as tmp:
        if fmt == "gif":
            _write_gif(view, steps, tmp, fps, tick)
        else:
            _write_mp4(view, steps, tmp, fps, tick)
        size = tmp.stat().st_size  # here: in a set of outputs (atomic.together) the file goes in place at its end
    return Animation(target, fmt, total, s, steps, size)
