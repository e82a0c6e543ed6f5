"""The scene every robot view draws: the path, the lumen's wall, start and end, the target, the robot (points,
links, and a disc of the robot's radius at each module, oriented with it), the colon's sections and the wall
contacts; shared by the path figure, the live view and the animation."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

from bhr._settings.errors import BhrError

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult

__all__ = ["LUMEN_FILL", "LUMEN_WALL", "SHADOW", "marker_stride", "draw_path", "lumen_walls", "draw_lumen_wall",
           "draw_start_end", "colon_sections", "label_sections", "draw_travel_arrow", "draw_target",
           "capsule_outline", "draw_robot", "run_is_planar", "zoom_half_width", "Box", "INSET_ZOOM",
           "FRAME_ZOOM", "FRAME_INCHES", "mark_wall_touches", "draw_contacts", "draw_contact_steps",
           "draw_sections", "draw_section_names"]


def _circle(center: np.ndarray, normal: np.ndarray, radius: float, count: int = 40) -> np.ndarray:
    normal = normal / np.linalg.norm(normal)
    ref = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(normal, ref)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.linspace(0, 2 * np.pi, count)
    return center + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))


def plot_points(ax: Any, pts: np.ndarray, planar: bool, *args: Any, **kw: Any) -> list[Any]:
    """``ax.plot`` of (k, 3) points: x, y on a 2-D axes; x, y, z (clipped to the axes' box) on a 3-D one."""
    pts = np.atleast_2d(pts)
    if planar:
        return ax.plot(pts[:, 0], pts[:, 1], *args, **kw)
    return ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], *args, axlim_clip=True, **kw)


#: Colours of the scene: the lumen (fill and wall lines), start and end marks, shadows on the floor.
LUMEN_FILL, LUMEN_WALL = "#f4e9e4", "#8c6d62"
SHADOW = "0.72"


def marker_stride(path: np.ndarray, marks: int = 120) -> int:
    """Every how many points a path mark is drawn so that a whole path shows about ``marks`` marks."""
    return max(1, int(round(len(path) / marks)))


def draw_path(ax: Any, path: np.ndarray, planar: bool, **kw: Any) -> list[Any]:
    """The trajectory in blue with x marks, as the thesis draws it (``markevery`` thins the marks)."""
    style = {"color": "tab:blue", "marker": "x", "markersize": 3, "linewidth": 0.8, "label": "trajectory"}
    style.update(kw)
    return plot_points(ax, path, planar, **style)


def lumen_walls(traj: Any, planar: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """The two sides of the lumen's tube in the view's plane: the centerline moved by +-diameter/2 sideways.

    Sideways is the direction in the view's plane (x, y) at right angles to
    the path. None when the trajectory has no lumen.
    """
    lumen = getattr(traj, "lumen", None)
    if lumen is None or len(traj.points) < 2:
        return None
    p = np.asarray(traj.points, dtype=float)
    t = np.gradient(p, axis=0)
    side = np.stack([-t[:, 1], t[:, 0], np.zeros(len(p))], axis=1)  # tangent x z: horizontal, across the path
    norm = np.linalg.norm(side, axis=1)
    bad = norm < 1e-12  # a vertical stretch: any horizontal direction will do
    side[bad] = [1.0, 0.0, 0.0]
    norm[bad] = 1.0
    side /= norm[:, None]
    half = np.asarray(lumen, dtype=float)[:, None] / 2.0
    return p + half * side, p - half * side


def draw_lumen_wall(ax: Any, traj: Any, planar: bool) -> list[Any]:
    """The lumen's wall: from the top, both sides of the tube with the lumen shaded; in 3-D, rings around
    the centerline (one about every half lumen diameter). [] without a lumen."""
    walls = lumen_walls(traj, planar)
    if walls is None:
        return []
    style = {"color": LUMEN_WALL, "linewidth": 0.9, "zorder": 1}
    artists: list[Any] = []
    if planar:
        left, right = walls
        ring = np.vstack([left[:, :2], right[::-1, :2]])
        # the shading is added without updating the data limits (ax.fill would: a Python pass over its hundreds
        # of edges, 0.03 s a panel): the two walls drawn next are its outline and give the same limits
        from matplotlib.patches import Polygon

        shade = Polygon(ring, closed=True, color=LUMEN_FILL, linewidth=0, zorder=0.5, label="lumen")
        ax.add_artist(shade)
        artists.append(shade)
        artists += plot_points(ax, left, planar, label="lumen wall", **style)
        artists += plot_points(ax, right, planar, label="_lumen wall (other side)", **style)
        return artists
    pts = np.asarray(traj.points, dtype=float)
    diameter = np.asarray(traj.lumen, dtype=float)[: len(pts)]
    t = np.gradient(pts, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    seg = float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    every = max(1, int(round(0.5 * float(np.median(diameter)) / max(seg, 1e-9))))
    style.update(linewidth=0.6, alpha=0.55)
    for n, k in enumerate(list(range(0, len(pts), every)) + ([len(pts) - 1] if (len(pts) - 1) % every else [])):
        c = _circle(pts[k], t[k], diameter[k] / 2.0, 32)
        artists += plot_points(ax, c, False, label="lumen wall" if n == 0 else "_lumen ring", **style)
    return artists


def draw_start_end(ax: Any, path: np.ndarray, planar: bool, size: float = 8) -> list[Any]:
    """The start (white circle) and the end (black square) of the path."""
    return (plot_points(ax, path[:1], planar, "o", markersize=size, markerfacecolor="white", markeredgecolor="black",
                  markeredgewidth=1.5, linestyle="none", label="start", zorder=4)
            + plot_points(ax, path[-1:], planar, "s", markersize=size - 1, color="black", linestyle="none",
                    label="end", zorder=4))


def colon_sections(traj: Any) -> list[tuple[str, int]] | None:
    """The anatomical sections of an anatomical colon's path: :func:`bhr.model._anatomy.path_sections`."""
    from bhr.model._anatomy import path_sections

    return path_sections(traj)


def label_sections(ax: Any, traj: Any, planar: bool) -> list[Any]:
    """Each anatomical section's name beside the middle of its stretch of path (anatomical colons only)."""
    sections = colon_sections(traj)
    if not sections:
        return []
    artists = []
    for name, k in sections:
        p = traj.points[k]
        kw = {"fontsize": 7.5, "color": "#5a3d33", "ha": "left", "va": "bottom", "zorder": 8,
              "bbox": {"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.7, "linewidth": 0}}
        artists.append(ax.text(p[0], p[1], name, **kw) if planar else ax.text(p[0], p[1], p[2], name, **kw))
    return artists


def draw_travel_arrow(ax: Any, path: np.ndarray, planar: bool) -> list[Any]:
    """An arrow along the path near its start: the direction the robot travels (anus to cecum on a colon). It is
    named in the legend, not beside the arrow, where a name would cover the path, the robot or a section's name."""
    pts = np.asarray(path, dtype=np.float64)
    if len(pts) < 3:
        return []
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    a = int(np.searchsorted(s, 0.04 * extent))
    b = int(np.searchsorted(s, s[min(a, len(s) - 1)] + 0.08 * extent))
    a, b = min(a, len(pts) - 2), min(max(b, a + 1), len(pts) - 1)
    p, q = pts[a], pts[b]
    style = {"color": "#2b2b2b", "linewidth": 2.0}
    name = ax.plot(*([] for _ in range(2 if planar else 3)), marker=">", markersize=6, label="direction of travel",
                   **style)
    if planar:
        return [ax.annotate("", xy=(q[0], q[1]), xytext=(p[0], p[1]), zorder=8,
                            arrowprops={"arrowstyle": "-|>", **style}), *name]
    d = q - p
    return [ax.quiver(p[0], p[1], p[2], d[0], d[1], d[2], arrow_length_ratio=0.35, **style), *name]


def draw_target(ax: Any, point: np.ndarray, planar: bool, size: float = 9) -> list[Any]:
    """The step's target point (green x)."""
    return plot_points(ax, point, planar, "x", color="tab:green", markersize=size, markeredgewidth=1.5, label="target",
                 zorder=5)


def capsule_outline(a: np.ndarray, b: np.ndarray, radius: float, count: int = 16) -> np.ndarray | None:
    """(K, 2) outline of the module from ``a`` to ``b`` (2-D) widened by ``radius``: the shape the clearance
    scores (the segment's points within the radius), None for a module of no length."""
    d = b - a
    length = float(np.hypot(d[0], d[1]))
    if length == 0.0:
        return None
    u = d / length
    n = np.array([-u[1], u[0]])
    t = np.linspace(-np.pi / 2, np.pi / 2, count)
    front = b + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), n))  # around b, from -n through +u to +n
    back = a + radius * (np.outer(-np.cos(t), u) + np.outer(-np.sin(t), n))  # around a, from +n through -u to -n
    return np.vstack([front, back, front[:1]])


def draw_robot(ax: Any, points: np.ndarray, radius: float, planar: bool, color: str = "tab:red",
               label: str | None = "robot", discs: bool = True) -> list[Any]:
    """Points and links of the robot, and a disc of ``radius`` at the end of each module.

    The disc sits at the module's far end (where its actuators are), normal to
    the module, as in the thesis's figures. Returns the artists drawn.
    """
    artists: list[Any] = []
    artists += plot_points(ax, points, planar, "-o", color=color, markersize=3, linewidth=1.5, label=label, zorder=6)
    if discs and planar and radius > 0:  # seen from the top each module is its capsule: the width clearance counts
        for j in range(points.shape[0] - 1):
            outline = capsule_outline(points[j, :2], points[j + 1, :2], radius)
            if outline is not None:
                artists += ax.fill(outline[:, 0], outline[:, 1], facecolor=color, alpha=0.18, edgecolor=color,
                                   linewidth=0.6, zorder=5, label=f"{label} (radius {radius:g} mm)"
                                   if (j == 0 and label) else None)
    if discs:
        for j in range(points.shape[0] - 1):
            d = points[j + 1] - points[j]
            if np.linalg.norm(d) == 0:
                continue
            c = _circle(points[j + 1], d, radius)
            artists += plot_points(ax, c, planar, color=color, linewidth=0.6, alpha=0.7, zorder=6)
    return artists


def setup_axes(fig: Figure, planar: bool, rect: tuple[float, float, float, float] | None = None) -> Any:
    kw: dict[str, Any] = {} if planar else {"projection": "3d"}
    ax: Any = fig.add_subplot(111, **kw) if rect is None else fig.add_axes(rect, **kw)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    if planar:
        ax.set_aspect("equal", adjustable="box")
    else:
        ax.set_zlabel("z (mm)")
    ax.grid(True, alpha=0.3)
    return ax


def equal_3d(ax: Any, pts: np.ndarray, pad: float = 0.0) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    mid, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1.0) + pad
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1, 1, 1))


def run_is_planar(result: "FollowResult") -> bool:
    """True when a run is drawn from the top (x, y): its path is planar and every pose keeps one height z."""
    return result.trajectory.planar and bool(np.ptp(result.points[:, :, 2]) <= 1e-9)


def check_step(result: "FollowResult", i: int) -> int:
    if not -result.steps <= i < result.steps:
        raise BhrError(f"step {i + 1} is outside the run (steps 1 to {result.steps}); choose a step in that range")
    return i % result.steps


def _body_pose(result: "FollowResult", i: int) -> np.ndarray | None:
    body = getattr(result, "body", None)
    if body is None or not body.modules:
        return None
    return np.vstack([result.points[i, :1], body.points[i]])


def pose_points(result: "FollowResult", i: int) -> np.ndarray:
    body = _body_pose(result, i)
    return result.points[i] if body is None else np.vstack([result.points[i], body])


def zoom_half_width(result: "FollowResult", factor: float) -> float:
    """Half the side of a square view around the head: ``factor`` head lengths, and the lumen with room."""
    head = float(np.sum(np.linalg.norm(np.diff(result.points[0], axis=0), axis=1)))
    head = max(head, result.robot.module_length * result.modules, 4 * result.robot.robot_radius)
    lumen = getattr(result.trajectory, "lumen", None)
    wall = 0.75 * float(np.max(lumen)) if lumen is not None and len(lumen) else 0.0
    return max(factor * head, wall, 3 * result.robot.robot_radius)


def head_centre(result: "FollowResult", i: int) -> np.ndarray:
    pts = result.points[i]
    return (pts.min(axis=0) + pts.max(axis=0)) / 2


def draw_context(ax: Any, result: "FollowResult", planar: bool, markevery: int = 1,
                  path_style: dict[str, Any] | None = None, contacts_step: int | None = None) -> list[Any]:
    """What does not move between steps: the lumen wall, the path, its start and end, the wall contacts (of every
    step, or of the 0-based ``contacts_step`` only)."""
    traj = result.trajectory
    artists = draw_lumen_wall(ax, traj, planar)
    artists += draw_path(ax, traj.points, planar, markevery=markevery, **(path_style or {}))
    artists += draw_start_end(ax, traj.points, planar)
    _draw_touch_points(ax, result, planar, contacts_step)
    return artists


def draw_pose(ax: Any, result: "FollowResult", i: int, planar: bool, target_size: float = 9) -> list[Any]:
    """What changes with the step: the target, the robot (head) and the body behind it."""
    new = draw_target(ax, result.targets[i], planar, target_size)
    new += draw_robot(ax, result.points[i], result.robot.robot_radius, planar)
    body = _body_pose(result, i)
    if body is not None:
        new += draw_robot(ax, body, result.robot.robot_radius, planar, color="tab:orange", label="body")
    return new


def depth_cue(ax: Any, result: "FollowResult", i: int | None, floor: float) -> list[Any]:
    """3-D depth cue: the path's (and at step ``i`` the robot's) shadow on the floor, and drop lines to it
    from the start, the end and the robot's tip."""
    path = result.trajectory.points

    def flat(p: np.ndarray) -> np.ndarray:
        q = np.array(p, dtype=float, copy=True)
        q[:, 2] = floor
        return q

    art = plot_points(ax, flat(path), False, color=SHADOW, linewidth=0.9, label="shadow on the floor", zorder=0.5)
    drops = [path[0], path[-1]]
    if i is not None:
        art += plot_points(ax, flat(pose_points(result, i)), False, color="0.45", linewidth=2.0, zorder=0.6)
        drops.append(result.points[i, -1])
    for p in drops:
        art += plot_points(ax, np.array([p, [p[0], p[1], floor]]), False, linestyle=":", color="0.45", linewidth=0.9)
    return art


Box = tuple[float, float, float, float]


def inset_rect(ax_limits: Box, pts: np.ndarray, window: Box, side: float) -> Box:
    """Where an inset of ``side`` (data units) covers the fewest ``pts`` and not the zoomed ``window``."""
    x0, x1, y0, y1 = ax_limits
    w, h = x1 - x0, y1 - y0
    fw, fh = side / w, side / h
    m = 0.015
    cands = [(m, m), (1 - fw - m, m), (m, 1 - fh - m), (1 - fw - m, 1 - fh - m), ((1 - fw) / 2, (1 - fh) / 2),
             ((1 - fw) / 2, m), ((1 - fw) / 2, 1 - fh - m), (m, (1 - fh) / 2), (1 - fw - m, (1 - fh) / 2)]
    fx, fy = (pts[:, 0] - x0) / w, (pts[:, 1] - y0) / h
    wx0, wx1 = (window[0] - x0) / w, (window[1] - x0) / w
    wy0, wy1 = (window[2] - y0) / h, (window[3] - y0) / h
    best, best_score = cands[0], None
    for cx, cy in cands:
        inside = int(np.count_nonzero((fx >= cx) & (fx <= cx + fw) & (fy >= cy) & (fy <= cy + fh)))
        overlap = not (cx + fw < wx0 or cx > wx1 or cy + fh < wy0 or cy > wy1)
        score = inside + (10 * len(pts) if overlap else 0)
        if best_score is None or score < best_score:
            best, best_score = (cx, cy), score
    return best[0], best[1], fw, fh


def zoom_window(result: "FollowResult", i: int, factor: float) -> tuple[np.ndarray, float]:
    return head_centre(result, i), zoom_half_width(result, factor)


def set_window(ax: Any, centre: np.ndarray, half: float, planar: bool) -> None:
    if planar:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
    else:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)


#: Zoom of the path figure's inset and of the animation: half the view's side, in head lengths.
INSET_ZOOM = 0.8
FRAME_ZOOM = 1.2
#: The frame of the animation and the live view: inches (1000 x 700 pixels at 100 dpi).
FRAME_INCHES = (10.0, 7.0)


def legend_below(fig: Figure, ax: Any, ncol: int | None = None, x: float = 0.5) -> Any:
    """One legend below the axes (fixed, so it never hides the path nor moves between frames)."""
    handles, labels = ax.get_legend_handles_labels()
    seen: dict[str, Any] = {}
    for hd, lb in zip(handles, labels):
        seen.setdefault(lb, hd)
    return fig.legend(list(seen.values()), list(seen), loc="lower center", bbox_to_anchor=(x, 0.0),
                      ncol=ncol or min(len(seen), 5), fontsize=8, frameon=False)


# --- lumen clearance and the whole body (bhr._run.clearance, bhr._run.body) ---


def mark_wall_touches(ax: Any, result: "FollowResult") -> None:
    """Shade the steps where some point of the robot touches the lumen wall (clearance <= 0)."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return
    steps = cl.touch_steps
    start = prev = steps[0]
    first = True
    for s in steps[1:] + [None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        ax.axvspan(start - 0.5, prev + 0.5, color="tab:red", alpha=0.18, linewidth=0,
                   label="wall touched" if first else None)
        first = False
        if s is not None:
            start = prev = s


def _draw_touch_points(ax: Any, result: "FollowResult", planar: bool, step: int | None = None) -> None:
    """Mark where the robot touched the wall on the path view (every step, or ``step``'s): see
    :func:`draw_contacts`."""
    draw_contacts(ax, result, planar, step)


def draw_contacts(ax: Any, result: "FollowResult", planar: bool, step: int | None = None) -> list[Any]:
    """Red dots where the robot touched the lumen wall: each touching module's deepest spot, at every step, or at
    the 0-based ``step`` only (a figure of one step shows that step's contacts, labelled with it)."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return []
    w = cl.contacts(step)
    if not len(w):
        return []
    label = "wall contact (every step)" if step is None else f"wall contact at step {step + 1}"
    style = {"color": "tab:red", "marker": "o", "markersize": 3.5 if step is None else 6, "linestyle": "none",
             "alpha": 0.55 if step is None else 0.9, "label": label, "zorder": 4 if step is None else 7}
    if planar:
        return ax.plot(w[:, 0], w[:, 1], **style)
    return ax.plot(w[:, 0], w[:, 1], w[:, 2], axlim_clip=True, **style)  # none outside a zoomed 3-D view


def draw_contact_steps(ax: Any, result: "FollowResult") -> list[Any]:
    """On a per-step clearance plot: a red dot at each step where the robot touches the wall."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return []
    steps = np.asarray(cl.touch_steps)
    per = cl.per_step[steps - 1]
    pen = cl.max_penetration_mm
    return ax.plot(steps, per, "o", color="tab:red", markersize=2.5, linestyle="none",
                   label=f"wall contact ({len(steps)} steps, deepest {pen:.2f} mm)")


def draw_sections(ax: Any, result: "FollowResult") -> None:
    """On a per-step figure: the trajectory's anatomical sections (a real or generated colon's) as alternate grey
    bands named at the top (step k targets point k - 1, so a section of points [a, b) covers steps a + 1 ... b)."""
    from bhr.model._anatomy import path_section_ranges

    sections = path_section_ranges(result.trajectory)
    if not sections:
        return
    import matplotlib.transforms as mtransforms

    trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    for k, (name, a, b) in enumerate(sections):
        lo, hi = a + 0.5, min(b, result.steps) + 0.5
        if lo >= hi:
            continue
        if k % 2 == 0:
            ax.axvspan(lo, hi, color="#e6e9f0", zorder=0, linewidth=0)
        label = name.replace(" and ", "\nand ") if " and " in name else name.replace(" ", "\n")  # narrow bands
        ax.text((lo + hi) / 2, 0.985, label, transform=trans, ha="center", va="top",
                fontsize=7, color="#333", zorder=5, clip_on=True)


def draw_section_names(ax: Any, traj: Any, planar: bool) -> None:
    """On a path view: each anatomical section's name beside its middle point."""
    for name, a, b in getattr(traj, "sections", ()):
        p = traj.points[(a + b - 1) // 2]
        kw = {"fontsize": 7, "color": "#222", "ha": "left", "va": "bottom", "zorder": 10,
              "bbox": {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7}}
        if planar:
            ax.text(p[0], p[1], " " + name, **kw)
        else:
            ax.text(p[0], p[1], p[2], " " + name, **kw)
