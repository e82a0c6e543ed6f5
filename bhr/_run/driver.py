"""Follow-the-leader driver: advance along a trajectory, re-solve, score (thesis ch. 7).

The robot starts straight with its tip on the trajectory's start (the thesis:
tip at the origin, body along -x). At step ``i`` the target is trajectory
point ``i`` and the wanted tip direction the unit vector to point ``i+1`` (the
last step reuses the previous one). After each solve the whole robot advances
by the feed along its base module, and the local axes of modules 2..n are
reset to those of a straight robot (module 1 keeps its own). Point ``j`` (1 =
base, n+1 = tip) is scored against the trajectory point ``(n+1-j) f`` steps
behind the current one (0 before that exists), ``f`` the feed divisor;
module ``j < n`` against the path direction there, and the tip module against
the wanted tip direction.

Solvers whose :meth:`~bhr.solvers._base.Solver.follow_kernel` runs the whole
loop compiled are run that way; any other solver is driven step by step from
Python with the same compiled scoring and advance kernels.
"""
from __future__ import annotations

import json
import math
import sys
import warnings
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from bhr import __version__
from bhr._settings.inputs import MAX_MM, MAX_RUN_BYTES, check_step_points, read_text
from bhr._settings.errors import BhrError
from bhr._settings.options import MIN_MAGNITUDE, OPTIONS, Underflow, excerpt, file_float, has_control_char, robot_limits
from bhr.model._codes import VALID_CODES as STABLE_CODES
from bhr.model._robot import THESIS_ROBOT, Robot, robot_with
from bhr.solvers import Chain, FollowContext, Solver, get_solver
from bhr._run.body import BodyRun, check_body_modules, score_body, simulate_body, whole_robot_codes
from bhr._run.clearance import CecumWatch, ClearanceReport, cecum_step, clearance_report
from bhr._kinematics.leader import angle_deg, score_step
from bhr.model._path import Trajectory, approach_steps, path_directions, spacing, to_steps, unfollowable_bends
from bhr.model._tube import lumen_end_of, make_tube

if TYPE_CHECKING:  # the trail model (7 kernels, and the wall mesh's) loads when a run uses it
    from bhr._run.trail import TrailRun

__all__ = ["follow", "check_locomotion", "FollowResult", "Summary", "BhrWarning", "stats", "load_run", "VERDICTS",
           "verdict_of"]


class BhrWarning(UserWarning):
    """A run that completes but should be read with care (e.g. a curve tighter than the robot can turn)."""


def _floats(a: Any) -> Any:
    """An array as nested lists of Python floats (``float`` of each value, in one call)."""
    return np.asarray(a, dtype=np.float64).tolist()


def _ints(a: Any) -> Any:
    """An array as nested lists of Python ints (``int`` of each value, in one call)."""
    return np.asarray(a).astype(np.int64).tolist()


def _sharpest_turn(dirs: np.ndarray) -> tuple[int, float] | None:
    """(index, angle in degrees) of the largest turn between consecutive step directions; None for one step."""
    if dirs.shape[0] < 2:
        return None
    cos = np.clip(np.einsum("ij,ij->i", dirs[:-1], dirs[1:]), -1.0, 1.0)
    k = int(np.argmin(cos))
    return k, math.degrees(math.acos(float(cos[k])))


def stats(values: np.ndarray, first: int = 0) -> dict[str, float | int]:
    """max, mean, median, root mean square and final of ``values[first:]`` and the worst step (1-based)."""
    v = values[first:] if first < len(values) else values[-1:]
    worst = int(np.argmax(values)) + 1
    return {
        "max": float(np.max(values)),
        "mean": float(np.mean(v)),
        "median": float(np.median(v)),
        "rmse": float(np.sqrt(np.mean(np.square(v)))),
        "final": float(values[-1]),
        "worst_step": worst,
    }


@dataclass
class Summary:
    """The summary of a run (thesis ch. 7's figures of merit): errors in mm and degrees, steps from 1.

    ``points``, ``modules`` and ``global_`` hold, per point (base first) and per
    module, the max, mean, median, RMSE and final error and the worst step (see
    :func:`stats`). ``extra`` holds what the body simulation, the lumen
    clearance and the solver add. :meth:`to_dict` is the ``summary`` object of
    ``run.json``.
    """

    steps: int
    solver: str
    trajectory: str
    tip_max_error_mm: float
    tip_final_error_mm: float
    tip_worst_step: int
    points_max_error_mm: float
    points_worst_step: int
    orientation_max_deg: float
    tip_orientation_max_deg: float
    tip_orientation_final_deg: float
    global_max: float
    mean_iterations: float
    points: list[dict[str, float | int]]
    modules: list[dict[str, float | int]]
    global_: list[dict[str, float | int]]
    warnings: list[str]
    #: root mean square of the tip's position and orientation error over its scored steps
    tip_rmse_mm: float = 0.0
    tip_orientation_rmse_deg: float = 0.0
    #: the same per point (base first) and per module
    rmse_point_mm: list[float] = field(default_factory=list)
    rmse_module_deg: list[float] = field(default_factory=list)
    #: steps where some point was more than tol_pos off / the tip more than tol_ori off
    over_tol_pos_steps: int = 0
    over_tol_ori_steps: int = 0
    #: either count is not zero (the run completes; the flag tells)
    tolerance_exceeded: bool = False
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The summary as plain JSON types, in the key order of ``run.json``."""
        out: dict[str, Any] = {}
        for f in fields(self):
            if f.name != "extra":
                out["global" if f.name == "global_" else f.name] = getattr(self, f.name)
        out["warnings"] = list(self.warnings)
        out.update(self.extra)
        return out

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict())

    def __repr__(self) -> str:
        return (f"Summary({self.solver} on {self.trajectory}, {self.steps} steps: tip worst "
                f"{self.tip_max_error_mm:.4g} mm at step {self.tip_worst_step}, ends "
                f"{self.tip_final_error_mm:.4g} mm and {self.tip_orientation_final_deg:.4g} deg off)")



#: A run's verdicts, gravest last: what :attr:`FollowResult.status` says (tables show it beside ``finished``).
VERDICTS = ("followed", "out of tolerance", "touched the wall", "left the lumen")


def verdict_of(s: Summary, robot: Robot) -> tuple[str, str]:
    """The verdict of a run's summary and its reason in words: left the lumen (a point of the robot's axis
    outside the wall), else touched the wall, else out of tolerance, else followed."""
    x = s.extra
    touch = x.get("wall_touch_steps") or []
    if x.get("left_lumen_step") is not None:
        return "left the lumen", f"the robot {x.get('left_lumen_reason') or 'left the lumen'}"
    if touch:
        return ("touched the wall", f"the robot touches the wall at {len(touch)} of {s.steps} steps (first "
                f"step {touch[0]}), up to {x.get('max_penetration_mm', 0.0):.4g} mm deep")
    if s.tolerance_exceeded:
        return ("out of tolerance", f"{s.over_tol_pos_steps} steps with a point more than {robot.tol_pos:g} mm off "
                f"and {s.over_tol_ori_steps} with the tip more than {robot.tol_ori:g} deg off (worst "
                f"{s.points_max_error_mm:.4g} mm at step {s.points_worst_step})")
    return ("followed", f"every scored point within {robot.tol_pos:g} mm and the tip within {robot.tol_ori:g} deg "
            f"over {s.steps} steps")


@dataclass(frozen=True, repr=False, eq=False)
class FollowResult:
    """A whole run: per-step poses, codes and errors, with the summary of the thesis's script.

    What :func:`bhr.follow` returns (and :meth:`from_json` reads back from a ``run.json``); made by bhr, not by
    hand. ``success`` and ``status`` say whether the run kept every scored point within the robot's
    tolerances and, when the path has a lumen, off the wall; ``reason`` says why not, in words.

    The result is frozen: a run's poses, codes, body and model never change once it is made, so its
    :attr:`clearance` and :attr:`summary` are scored once, the first time either is read, and kept
    (:func:`dataclasses.replace` makes another run, scored afresh). The driver does not score inside
    the follower's loop: ``bhr.follow`` returns as soon as the robot has moved, and the clearance to the
    lumen wall (several times the follow's own time on a colon) is computed when the run is first judged.

    Below, N is the number of steps (trajectory points, one feed apart; a whole robot moving along a trail may
    take a few more to bring its tip to the cecum, :attr:`targets`) and n the modules the solver moves (the
    head); points are base first, in mm, in the run's world frame (a straight robot along +X).

    Parameters
    ----------
    trajectory, robot, solver, points, iterations, point_errors_mm, orientation_errors_deg : object
        The fields of the same names (see Attributes).
    codes, warnings, extra, body, trail, motion : object, optional
        The fields of the same names (see Attributes).

    Attributes
    ----------
    trajectory : Trajectory
        The path followed, drawn at the robot's feed: ``trajectory.points``, shape (N, 3), mm; its lumen
        diameters, shape (N,), mm, or None.
    robot : Robot
        The robot that followed it (modules, module length in mm, alpha in deg, tolerances, feed).
    solver : str
        The solver's name, e.g. ``"thesis"``.
    points : numpy.ndarray, shape (N, n+1, 3)
        The head's solved pose at each step: its n+1 points (base first, tip last), mm.
    iterations : numpy.ndarray, shape (N,)
        The solver's iterations at each step (int).
    point_errors_mm : numpy.ndarray, shape (N, n+1)
        Each point's distance from the trajectory point it should lie on, mm, base first; 0 where that point
        is not scored yet (still behind the path's start).
    orientation_errors_deg : numpy.ndarray, shape (N, n)
        The angle between each module's direction and the path's direction there, deg, base module first.
    codes : numpy.ndarray, shape (N, n), or None
        The actuator code of each head module at each step (an int 0-15, no unit), base first; None for a
        continuous solver.
    warnings : list of str
        What the run warns of (a bend tighter than the robot's turn radius, ...), one line each.
    extra : dict of str to object
        Solver- and locomotion-specific results; ``extra["summary"]`` is merged into :attr:`summary`.
    body : BodyRun or None
        The modules behind the head (``body_modules``, ``reach``): ``body.points``, shape (N, B, 3), mm, the
        rear end of each of the B body modules; ``body.codes``, shape (N, B); ``body.point_errors_mm`` and
        ``body.orientation_errors_deg``, shape (N, B), mm and deg. None for the head alone.
    trail : TrailRun or None
        With ``locomotion="trail"``: ``trail.joints``, shape (N, M+1, 3), mm, every joint of the whole robot
        of M modules, tip first; ``trail.joint_codes``, shape (N, M+1). None otherwise.
    motion : MotionRun or None
        With ``locomotion="wires"``: every pose of the whole robot as its wires move it; ``motion.points_mm``,
        shape (P, M+1, 3), mm, tail first, at P poses; ``motion.codes``, shape (P, M). None otherwise.
    steps : int
        N, the number of steps.
    modules : int
        n, the head's modules.
    global_errors : numpy.ndarray, shape (N, n)
        The thesis's global error of each module, w_pos e_pos / tol_pos + w_ori e_ori / tol_ori, no unit.
    board_codes : numpy.ndarray, shape (N, n) or (N, M), or None
        The codes a board is sent at each step (``codes.csv``; int, no unit): the whole robot's, rear first,
        with a body; else the head's, base first. None for a continuous solver.
    clearance : ClearanceReport or None
        With a lumen: the smallest clearance to the wall at each step (``clearance.per_step``, shape (N,),
        mm; below 0 the wall is touched) and its minimum (``clearance.min_mm``); None without a lumen.
    summary : Summary
        The headline figures (``tip_max_error_mm``, ``points_max_error_mm``, ``orientation_max_deg``, mm and
        deg) and per point and module statistics, as ``bhr follow`` prints them; ``summary.to_dict()``.
    status : str
        The verdict: ``"followed"``, ``"out of tolerance"``, ``"touched the wall"`` or ``"left the lumen"``.
    success : bool
        ``status == "followed"``.
    reason : str
        Why :attr:`status` is what it is, in words with the figures.
    finished : str
        ``"ran to the end"`` or ``"stopped at the wall"`` (``stop_at_wall``).
    feeder_stop_step : int or None
        The 1-based step from which the feeder stopped (the tip at a blind cecum), or None.

    Examples
    --------
    >>> import bhr
    >>> run: bhr.FollowResult = bhr.follow(bhr.trajectory("line", length=20))
    >>> run.points.shape, run.status
    ((11, 6, 3), 'followed')
    """

    trajectory: Trajectory
    robot: Robot
    solver: str
    points: np.ndarray  # (N, n+1, 3) solved pose at each step
    iterations: np.ndarray  # (N,)
    point_errors_mm: np.ndarray  # (N, n+1) mm, base first
    orientation_errors_deg: np.ndarray  # (N, n) degrees
    codes: np.ndarray | None = None  # (N, n)
    warnings: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)
    body: BodyRun | None = None  # the modules behind the head (follow(..., body_modules=M))
    trail: TrailRun | None = None  # locomotion "trail": the trail and its clearance tables (bhr._run.trail)
    motion: Any = None  # locomotion "wires": every pose of the whole robot (bhr._run.motion.MotionRun)

    @cached_property
    def clearance(self) -> ClearanceReport | None:
        """The clearance report when the trajectory has a lumen (head and body points), else None; scored once."""
        if self.trajectory.lumen is None:
            return None
        if self.motion is not None:
            from bhr._run.motion import motion_report

            return motion_report(self)
        if self.trail is None:  # a whole robot on a trail read back: its steps, and its poses' minimum per step
            return clearance_report(self, between_steps=self.extra.get("between_steps_clearance_mm"))
        from bhr._run.trail import trail_report

        return trail_report(self)

    @property
    def steps(self) -> int:
        return int(self.points.shape[0])

    @property
    def board_codes(self) -> np.ndarray | None:
        """The codes a board driving this run's robot is sent, one row per step (``codes.csv``): with a body
        (``body_modules``, ``reach``) every module of the whole robot, rear first
        (:func:`bhr._run.body.whole_robot_codes`); else the head's, base first. None for a continuous solver."""
        if self.codes is None:
            return None
        return whole_robot_codes(self.codes, self.body)

    @property
    def targets(self) -> np.ndarray:
        """(N, 3) mm: the trajectory point the tip should be on at each step. A whole robot moving along a trail
        (``locomotion="wires"`` or ``"trail"``) may need more steps than the path has points to bring its tip to
        the cecum (its trail weaves about the centerline); the target of those steps is the path's end."""
        return to_steps(self.trajectory.points, self.steps)

    @property
    def success(self) -> bool:
        """Every scored point within ``tol_pos``, the tip within ``tol_ori`` and (with a lumen) no wall contact."""
        return self.status == "followed"

    @property
    def status(self) -> str:
        """The verdict: ``"followed"``, ``"out of tolerance"``, ``"touched the wall"`` or ``"left the lumen"`` (the
        gravest when several hold: left the lumen, then touched the wall, then out of tolerance)."""
        return self._verdict()[0]

    @property
    def reason(self) -> str:
        """Why :attr:`status` is what it is, in words with the figures."""
        return self._verdict()[1]

    @property
    def feeder_stop_step(self) -> int | None:
        """The 1-based step from which the feeder stopped feeding (the tip at a blind cecum, or the end of the trail
        model's trail), else None: it fed to the path's end."""
        stop = self.extra.get("summary", {}).get("feeder_stop_step")
        return None if stop is None else int(stop)

    @property
    def finished(self) -> str:
        """How the run ended, apart from its verdict: ``"ran to the end"`` or ``"stopped at the wall"``
        (``stop_at_wall`` ended it where the robot left the lumen)."""
        stopped = self.extra.get("summary", {}).get("stopped_at_wall_step")
        return "stopped at the wall" if stopped else "ran to the end"

    def _verdict(self) -> tuple[str, str]:
        s = self.summary
        return s.extra["verdict"], s.extra["verdict_reason"]

    def __repr__(self) -> str:
        s = self.summary
        body = f" (+{self.body.modules} body modules)" if self.body is not None else ""
        return (f"FollowResult({self.solver} on {self.trajectory.name}, {self.modules} modules{body}, {self.steps} "
                f"steps: {self.status}; tip worst {s.tip_max_error_mm:.4g} mm at step {s.tip_worst_step})")

    @property
    def modules(self) -> int:
        return int(self.points.shape[1] - 1)

    @property
    def global_errors(self) -> np.ndarray:
        """(N, n): module j pairs point j+1 with module j, weighted and normalised by the tolerances."""
        r = self.robot
        return (r.weight_pos * self.point_errors_mm[:, 1:] / r.tol_pos
                + r.weight_ori * self.orientation_errors_deg / r.tol_ori)

    @cached_property
    def summary(self) -> Summary:
        """Max, mean, median, RMSE and final per point and module (leading unscored steps left out of mean,
        median and RMSE), and the run's headline figures (see :class:`Summary`); scored once."""
        n = self.modules
        f = self.robot.feed_divisor
        pts = [stats(self.point_errors_mm[:, j], (n - j) * f) for j in range(n + 1)]
        mods = [stats(self.orientation_errors_deg[:, j], (n - j - 1) * f) for j in range(n)]
        glob = [stats(self.global_errors[:, j], (n - j - 1) * f) for j in range(n)]
        worst_flat = int(np.argmax(self.point_errors_mm.max(axis=1))) + 1
        out: dict[str, Any] = {}
        over_pos = int(np.count_nonzero(self.point_errors_mm.max(axis=1) > self.robot.tol_pos))
        over_ori = int(np.count_nonzero(self.orientation_errors_deg[:, -1] > self.robot.tol_ori))
        if self.body is not None:
            b = self.body
            out["body_modules"] = self.modules + b.modules
            out["body_points_max_error_mm"] = float(b.point_errors_mm.max()) if b.modules else 0.0
            out["body_worst_step"] = int(np.argmax(b.point_errors_mm.max(axis=1))) + 1 if b.modules else 0
            out["body_orientation_max_deg"] = float(b.orientation_errors_deg.max()) if b.modules else 0.0
        cl = self.clearance
        if cl is not None:
            out.update(cl.summary())
        out.update(self.extra.get("summary", {}))
        s = Summary(self.steps, self.solver, self.trajectory.name, pts[-1]["max"], pts[-1]["final"],
                       int(pts[-1]["worst_step"]), float(self.point_errors_mm.max()), worst_flat,
                       float(self.orientation_errors_deg.max()), mods[-1]["max"], mods[-1]["final"],
                       float(self.global_errors.max()), float(np.mean(self.iterations)), pts, mods, glob,
                       list(self.warnings), tip_rmse_mm=float(pts[-1]["rmse"]),
                       tip_orientation_rmse_deg=float(mods[-1]["rmse"]),
                       rmse_point_mm=[float(p["rmse"]) for p in pts], rmse_module_deg=[float(m["rmse"]) for m in mods],
                       over_tol_pos_steps=over_pos, over_tol_ori_steps=over_ori,
                       tolerance_exceeded=bool(over_pos or over_ori), extra=out)
        out["verdict"], out["verdict_reason"] = verdict_of(s, self.robot)
        out["finished"] = self.finished
        return s

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string (the text of ``run.json``).

        Returns
        -------
        str
            The run as JSON text, which :meth:`from_json` (after ``json.loads``) reads back.
        """
        return json.dumps(self.to_dict())

    def to_dict(self) -> dict[str, Any]:
        """The ``bhr follow --json`` document (its keys are a documented contract, docs/commands.md).

        Returns
        -------
        dict of str to object
            Plain JSON values: ``trajectory`` (its points, mm, and lumen), ``robot``, ``solver``, ``steps`` (one
            entry per step: its target, points, errors in mm and deg, codes, clearance in mm) and ``summary``.
        """
        n = self.steps
        # whole arrays to Python numbers at once (tolist): the same floats and ints as converting each value
        targets, points = _floats(self.targets), _floats(self.points[:n])
        point_errors, orientation_errors = _floats(self.point_errors_mm[:n]), _floats(self.orientation_errors_deg[:n])
        codes = None if self.codes is None else _ints(self.codes[:n])
        iterations = _ints(self.iterations[:n])
        steps = []
        for i in range(n):
            steps.append({
                "step": i + 1,
                "target": targets[i],
                "points": points[i],
                "point_errors_mm": point_errors[i],
                "module_orientation_errors_deg": orientation_errors[i],
                "codes": None if codes is None else codes[i],
                "iterations": iterations[i],
            })
        cl = self.clearance
        if cl is not None:
            per = _floats(cl.per_step[:n])
            for i, st in enumerate(steps):
                st["clearance_mm"] = None if math.isnan(per[i]) else per[i]
        if self.body is not None and self.body.modules:
            b = self.body
            body_points, body_errors = _floats(b.points[:n]), _floats(b.point_errors_mm[:n])
            body_orientation, body_codes = _floats(b.orientation_errors_deg[:n]), _ints(b.codes[:n])
            for i, st in enumerate(steps):
                st["body_points"] = body_points[i]
                st["body_point_errors_mm"] = body_errors[i]
                st["body_module_orientation_errors_deg"] = body_orientation[i]
                st["body_codes"] = body_codes[i]
        traj_doc = {"name": self.trajectory.name, "params": self.trajectory.params,
                    "points": self.trajectory.points.tolist(),
                    # where the robot starts (straight, its tip at start_point): the tube behind the entrance,
                    # the body's frames and the physics replay's insertion need it when the run is read back
                    "start_direction": [float(v) for v in self.trajectory.start_direction],
                    "start_point": [float(v) for v in self.trajectory.start_point]}
        if self.trajectory.lumen is not None:
            traj_doc["lumen"] = [float(v) for v in self.trajectory.lumen]
            traj_doc["lumen_end"] = self.trajectory.lumen_end
        if getattr(self.trajectory, "lumen_model", "ct") != "ct":
            traj_doc["lumen_model"] = self.trajectory.lumen_model
        if self.trajectory.sections:  # the anatomical sections: [name, first point, one past the last]
            traj_doc["sections"] = [[n, int(a), int(b)] for n, a, b in self.trajectory.sections]
        return {
            "bhr_version": __version__,
            "trajectory": traj_doc,
            "robot": self.robot.to_dict(),
            "solver": self.solver,
            "steps": steps,
            "summary": self.summary.to_dict(),
        }

    @classmethod
    def from_json(cls, doc: Any, where: str = "run") -> "FollowResult":
        """A run back from its :meth:`to_dict` document, without solving (``bhr replay``).

        Parameters
        ----------
        doc : dict of str to object
            The document, e.g. ``json.load`` of a ``run.json`` that ``bhr follow`` wrote.
        where : str, default "run"
            What the document is called in an error message (its file's name).

        Returns
        -------
        FollowResult
            The run, its poses, codes and errors as written (scored again when judged).

        Raises
        ------
        BhrError
            The first thing wrong with the document, named with ``where``.
        """
        return _run_from_json(doc, where)


def _run_from_json(doc: Any, where: str) -> FollowResult:
    def bad(what: str) -> BhrError:
        return BhrError(f"{where}: {what}; give a run.json written by 'bhr follow'")

    def has_bool(value: Any) -> bool:  # a true among numbers: numpy would make it 1.0
        stack = [value]
        while stack:
            v = stack.pop()
            if type(v) is bool:
                return True
            if type(v) is list:
                stack.extend(v)
        return False

    def array(value: Any, shape: tuple[int | None, ...], what: str) -> np.ndarray:
        try:
            raw = np.asarray(value)  # as written: numpy's float() would read the text "１０" as 10
            arr = None if raw.dtype.kind in "USb" else np.asarray(raw, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            raise bad(f"{what} must be numbers of a sensible size") from None
        if arr is None or has_bool(value):
            raise bad(f"{what} must be numbers, not {'text' if raw.dtype.kind in 'US' else 'true/false'}")
        if arr.ndim != len(shape) or any(w is not None and w != h for w, h in zip(shape, arr.shape)):
            want = " x ".join("N" if w is None else str(w) for w in shape) + " numbers" if shape else "one number"
            raise bad(f"{what} must be {want}, got shape {' x '.join(map(str, arr.shape)) or 'scalar'}")
        if not np.all(np.isfinite(arr)):
            raise bad(f"{what} must be finite numbers")
        if np.any((arr != 0.0) & (np.abs(arr) < MIN_MAGNITUDE)):  # 1e-320: the one checker refuses denormals
            raise bad(f"{what} must not be denormals (non-zero numbers under {MIN_MAGNITUDE:g})")
        if arr.size and float(np.abs(arr).max()) > MAX_MM:
            raise bad(f"{what} must lie within +-{MAX_MM:g} mm (or deg)")
        return arr

    if not isinstance(doc, dict) or not all(k in doc for k in ("trajectory", "robot", "solver", "steps")):
        raise bad("not a bhr run (it needs 'trajectory', 'robot', 'solver' and 'steps')")
    tr, rb, steps = doc["trajectory"], doc["robot"], doc["steps"]
    if not isinstance(tr, dict) or not isinstance(rb, dict) or not isinstance(steps, list) or not steps:
        raise bad("'trajectory' and 'robot' must be objects and 'steps' a non-empty list")
    path = array(tr.get("points"), (None, 3), "trajectory points")
    names = set(Robot.__dataclass_fields__)
    try:
        for o in OPTIONS:  # the one number checker first: a 400-digit integer is refused, not overflowed
            if o.group == "robot" and rb.get(o.name) is not None:
                o.check(rb[o.name], "robot")
        robot = Robot(**{k: v for k, v in rb.items() if k in names})
    except (BhrError, TypeError) as exc:
        why = str(exc).splitlines()[0]
        raise bad(why if why.startswith("robot: ") else f"robot: {why}") from None  # "robot: " said once
    n, count = robot.modules, len(steps)
    told_doc = doc.get("summary")
    approach = 0  # a whole robot on a trail may push its tip on to the cecum past the path's end
    if isinstance(told_doc, dict) and told_doc.get("locomotion") in ("trail", "wires"):
        approach = approach_steps(path.shape[0])
    if count > path.shape[0] + approach:
        raise bad(f"{count} steps but only {path.shape[0]} trajectory points"
                  + (f" (and {approach} steps to the cecum)" if approach else ""))
    keys = ("points", "point_errors_mm", "module_orientation_errors_deg", "codes", "iterations")
    for k, st in enumerate(steps):
        if not isinstance(st, dict) or not all(key in st for key in keys):
            raise bad(f"step {k + 1} must be an object with {', '.join(keys)}")
    pts = np.stack([array(st["points"], (n + 1, 3), f"step {k + 1} points") for k, st in enumerate(steps)])
    pe = np.stack([array(st["point_errors_mm"], (n + 1,), f"step {k + 1} point_errors_mm")
                   for k, st in enumerate(steps)])
    oe = np.stack([array(st["module_orientation_errors_deg"], (n,), f"step {k + 1} module_orientation_errors_deg")
                   for k, st in enumerate(steps)])
    written = np.full(count, np.nan)
    for k, st in enumerate(steps):  # written where the path has a lumen; null where nothing is scored yet
        if st.get("clearance_mm") is not None:
            written[k] = array(st["clearance_mm"], (), f"step {k + 1} clearance_mm")
    iters = [st["iterations"] for st in steps]
    max_iter = robot_limits()["max_iter"][0]
    if not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= max_iter
               for v in iters):
        raise bad(f"every step's iterations must be a whole number from 0 to {max_iter:g}")
    codes = None
    if any(st["codes"] is not None for st in steps):
        codes = np.zeros((count, n), dtype=np.int64)
        for k, st in enumerate(steps):
            c = st["codes"]
            if not isinstance(c, list) or len(c) != n or not all(isinstance(v, int) and not isinstance(v, bool)
                                                                  and v in STABLE_CODES for v in c):
                raise bad(f"step {k + 1} codes must be {n} of the stable codes "
                          f"{', '.join(map(str, STABLE_CODES))} (or null in every step)")
            codes[k] = c
    solver = doc["solver"]
    if not isinstance(solver, str) or not solver.strip() or has_control_char(solver) or not solver.isprintable():
        raise bad(f"'solver' must be a solver's name, one line of printable text, got {excerpt(solver)}")
    lumen = None
    if tr.get("lumen") is not None:
        lumen = array(tr["lumen"], (path.shape[0],), "trajectory lumen")
        if not np.all(lumen > 0):  # a diameter: the clearance and the physics replay's wall need a real one
            raise bad(f"trajectory lumen diameters must be greater than 0 mm, got {float(lumen.min()):g}")
    body = None
    if any("body_points" in st for st in steps):
        body = _body_from_json(steps, robot, bad, array)
    summary = doc.get("summary")
    msgs = summary.get("warnings", []) if isinstance(summary, dict) else []
    params: dict[str, Any] = tr["params"] if isinstance(tr.get("params"), dict) else {}
    start_dir, start_pt = _start_from_json(tr, path, pts, robot, bad, array)
    lumen_end = tr.get("lumen_end")
    if lumen_end is None:  # absent in runs written before lumen ends existed: closed
        lumen_end = "closed"
    if lumen_end not in ("open", "closed"):  # "Open" or 5 was read as closed: the clearance of another lumen
        raise bad(f"trajectory lumen_end must be \"open\" or \"closed\", got {excerpt(lumen_end)}")
    name = tr.get("name", "run")
    if not isinstance(name, str) or has_control_char(name) or not name.isprintable():
        # the figures' titles, view.html and the summary print it: one line of printable text, as in a trajectory
        # file (a line break in it forged a line of the page, an escape garbled it)
        raise bad(f"trajectory name must be one line of printable text, got {excerpt(name)}")
    sections = _sections_from_json(tr.get("sections"), path.shape[0], bad)
    model = tr.get("lumen_model", "ct")
    if model not in ("ct", "insufflated"):
        raise bad(f"trajectory lumen_model must be \"ct\" or \"insufflated\", got {excerpt(model)}")
    traj = Trajectory(name, path, dict(params), source=where, lumen=lumen,
                      lumen_end=lumen_end, start_direction=start_dir, start_point=start_pt, sections=sections,
                      lumen_model=model)
    told: dict[str, Any] = summary if isinstance(summary, dict) else {}
    stop = told.get("feeder_stop_step")
    extra: dict[str, Any] = {}
    if stop is not None and told.get("locomotion") not in ("trail", "wires"):
        if isinstance(stop, bool) or not isinstance(stop, int) or not 1 <= stop < pts.shape[0]:
            raise bad(f"summary feeder_stop_step must be a step from 1 to {pts.shape[0] - 1}, got {excerpt(stop)}")
        extra["summary"] = {"feeder_stop_step": stop}  # the robot held its pose from there (contact length)
    if told.get("locomotion") in ("trail", "wires") and lumen is not None:
        # a whole robot on a trail moves between its written steps: each step's clearance_mm is the smallest over
        # all its poses (the wires') or over its slide along the trail (the trail model's)
        extra["between_steps_clearance_mm"] = written
    return FollowResult(traj, robot, solver, pts, np.asarray(iters, dtype=np.int64), pe, oe, codes,
                        [str(m) for m in msgs] if isinstance(msgs, list) else [], extra, body)


def _start_from_json(tr: dict, path: np.ndarray, pts: np.ndarray, robot: Robot, bad: Callable[[str], BhrError],
                     array: Callable[..., np.ndarray]) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The trajectory's start direction and start point from ``run.json`` (``start_direction``, ``start_point``).

    Runs written before bhr kept them: the robot started straight with its base fixed during the first solve,
    so when step 1's base lies one robot length behind the first point, that line is the start direction (and
    the first point the start); otherwise the Trajectory defaults, +x from the origin.
    """
    if tr.get("start_direction") is not None:
        d = array(tr["start_direction"], (3,), "trajectory start_direction")
        if not np.linalg.norm(d) > 0:
            raise bad("trajectory start_direction must not be zero")
        p = array(tr.get("start_point", [0.0, 0.0, 0.0]), (3,), "trajectory start_point")
        return tuple(float(v) for v in d), tuple(float(v) for v in p)
    d = path[0] - pts[0][0]
    length = robot.modules * robot.module_length
    if abs(float(np.linalg.norm(d)) - length) <= 1e-6 * length:
        return tuple(float(v) for v in d / np.linalg.norm(d)), tuple(float(v) for v in path[0])
    return (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)


def _body_from_json(steps: list, robot: Robot, bad: Callable[[str], BhrError],
                    array: Callable[..., np.ndarray]) -> BodyRun:
    """The body behind the head (:class:`bhr._run.body.BodyRun`) from the ``body_*`` keys of every step."""
    keys = ("body_points", "body_point_errors_mm", "body_module_orientation_errors_deg", "body_codes")
    for k, st in enumerate(steps):
        if not all(key in st for key in keys):
            raise bad(f"step {k + 1} must have {', '.join(keys)} (the body is in some steps only)")
    nb = len(steps[0]["body_points"]) if isinstance(steps[0]["body_points"], list) else -1
    if nb < 1:
        raise bad("step 1 body_points must be a list of points")
    pts = np.stack([array(st["body_points"], (nb, 3), f"step {k + 1} body_points") for k, st in enumerate(steps)])
    pe = np.stack([array(st["body_point_errors_mm"], (nb,), f"step {k + 1} body_point_errors_mm")
                   for k, st in enumerate(steps)])
    oe = np.stack([array(st["body_module_orientation_errors_deg"], (nb,),
                         f"step {k + 1} body_module_orientation_errors_deg") for k, st in enumerate(steps)])
    codes = np.stack([array(st["body_codes"], (nb,), f"step {k + 1} body_codes") for k, st in enumerate(steps)])
    # body point k is scored against the trajectory point (n + k) f steps behind (bhr._run.body)
    idx = np.arange(len(steps))[:, None] - (robot.modules + np.arange(1, nb + 1)[None, :]) * robot.feed_divisor
    return BodyRun(nb, pts, codes.astype(np.int64), pe, oe, idx >= 0)


def load_run(path: Any) -> FollowResult:
    """Read a run saved by ``bhr follow`` (``run.json``; ``-`` reads standard input), without solving."""
    name = "standard input" if str(path) == "-" else str(path)
    hint = "give a run.json written by 'bhr follow'"
    if str(path) == "-":
        raw = sys.stdin.buffer.read(MAX_RUN_BYTES + 1)
        if len(raw) > MAX_RUN_BYTES:
            raise BhrError(f"standard input is larger than {MAX_RUN_BYTES // (1024 * 1024)} MiB; {hint}")
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise BhrError(f"standard input is not UTF-8 text; {hint}") from None
    elif Path(path).is_dir():
        raise BhrError(f"{name} is a folder; give the run.json inside it")
    else:
        text = read_text(path, "run file", hint, MAX_RUN_BYTES)
    try:
        doc = json.loads(text, parse_float=file_float)
    except Underflow as exc:
        raise BhrError(f"{name}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise BhrError(f"{name}: not valid JSON (line {exc.lineno}: {exc.msg}); give a run.json written by "
                       "'bhr follow'") from None
    except RecursionError:
        raise BhrError(f"{name}: JSON nested too deeply for a run; {hint}") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise BhrError(f"{name}: unreadable number ({str(exc).splitlines()[0][:80]}); {hint}") from None
    return FollowResult.from_json(doc, name)


#: How far (relative) the spacing of points given as an array may differ from the robot's feed.
FEED_TOLERANCE = 0.1


def _as_trajectory(points: Any, robot: Robot) -> Trajectory:
    """``points`` as a Trajectory spaced by the robot's feed: drawn again (or resampled) at that feed when its
    own feed differs; points given as an array must already be spaced by the feed."""
    if isinstance(points, Trajectory):
        return points.at_feed(robot.feed)
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise BhrError("trajectory points must be an (N, 3) array of x, y, z in mm")
    if not np.all(np.isfinite(arr)):
        raise BhrError("trajectory points must be finite numbers")
    gap = spacing(arr)
    if arr.shape[0] >= 2 and abs(gap - robot.feed) > FEED_TOLERANCE * robot.feed:
        raise BhrError(f"the trajectory's points are {gap:.4g} mm apart but the robot advances {robot.feed:g} mm a "
                       f"step (module_length / feed_divisor); sample the path at the feed, e.g. "
                       f"bhr.trajectory(name, feed={robot.feed:g}), or pass bhr.Trajectory('points', "
                       f"points).at_feed({robot.feed:g})")
    return Trajectory("points", arr, feed=robot.feed)


def check_locomotion(locomotion: str, stop_at_wall: bool | None, all_poses: bool | None = None) -> None:
    """Refuse a locomotion bhr does not have, stop_at_wall with the trail model and all_poses with any but the
    wires (one line each)."""
    if locomotion not in ("thesis", "trail", "wires"):
        raise BhrError(f"locomotion must be thesis, wires or trail, got {locomotion!r}")
    if stop_at_wall is not None and not isinstance(stop_at_wall, bool):
        raise BhrError(f"stop_at_wall must be True or False, got {stop_at_wall!r}")
    if stop_at_wall and locomotion == "trail":
        raise BhrError("stop at wall ends a run where the robot leaves the lumen; the trail model is an idealisation "
                       "that plans its trail inside the lumen: drop --stop-at-wall or give --locomotion wires")
    if all_poses is not None and not isinstance(all_poses, bool):
        raise BhrError(f"all_poses must be True or False, got {all_poses!r}")
    if all_poses and locomotion != "wires":
        raise BhrError(f"all poses keeps every pose of a whole robot moved by its wires (--locomotion wires, the "
                       f"default for --body-modules or --reach with --solver lumen); the {locomotion} model has one "
                       "pose a step, all in run.json: drop --all-poses")


def follow(points: Any, solver: str | Solver = "thesis", robot: Robot | None = THESIS_ROBOT, *,
           solver_options: dict[str, Any] | None = None,
           on_step: Callable[[int, np.ndarray | None], None] | None = None,
           compiled: bool = True, body_modules: int | None = None, reach: str | None = None,
           locomotion: str | None = None, stop_at_wall: bool | None = None, all_poses: bool | None = None,
           **robot_options: Any) -> FollowResult:
    """Run follow-the-leader along ``points`` with ``solver``: one solve per feed step, the tip on the path.

    Parameters
    ----------
    points : Trajectory or array_like, shape (N, 3)
        The path, mm. A :class:`~bhr.model.Trajectory` is drawn again at the robot's feed when its own
        differs (``bhr.trajectory`` samples at the thesis's 2 mm); points given as an array must be spaced
        by the feed (``module_length / feed_divisor``), else a :class:`~bhr.BhrError` says how to resample.
    solver : str or Solver, default "thesis"
        A solver name (:func:`bhr.solvers.available`) or a configured :class:`bhr.solvers.Solver` object,
        which brings its robot when neither ``robot`` nor ``robot_options`` is given.
    robot : Robot or None, default THESIS_ROBOT
        The robot; defaults to the thesis's robot (5 modules of 10 mm, alpha 10 deg, feed 2 mm).
    solver_options : dict of str to object, optional
        The solver's own options (e.g. ``{"lookahead": 12}`` for ``"lumen"``), each checked by the option
        registry, :mod:`bhr._settings.options`.
    on_step : callable ``on_step(i, codes)``, optional
        Called after each step ``i`` (0-based) with that step's codes, an int array of shape (n,), or None
        for a continuous solver; e.g. to stream codes to the board. It forces the step-by-step driver.
    compiled : bool, default True
        Run the whole path in the solver's compiled loop when it has one; False drives it step by step from
        Python (the same numbers, slower).
    body_modules : int, optional
        M >= ``modules``: also simulate the modules behind the head (:mod:`bhr._run.body`); the result's
        ``body`` holds them and they are scored and counted in the clearance too.
    reach : {"cecum"}, optional
        ``"cecum"`` makes the whole robot long enough to reach the path's end from its start (instead of
        ``body_modules``).
    locomotion : {"thesis", "wires", "trail"}, optional
        The thesis's model (``"thesis"``); the robot as it can be built, rigid modules driven by their
        wires along a planned trail (``"wires"``, :mod:`bhr._run.motion`); or the trail model's ideal
        follow-the-leader (``"trail"``, an idealisation, not buildable). Both trail models need
        ``solver="lumen"`` (docs/locomotion.md). By default a whole robot (``body_modules`` or ``reach``)
        with ``solver="lumen"`` on a path with a lumen moves by its wires, anything else by the thesis's
        model.
    stop_at_wall : bool, optional
        End the run at the step where the robot leaves the lumen (:func:`bhr._run.clearance.left_lumen`:
        its axis outside the wall): the result has that many steps, its ``finished`` says so, and no later
        (impossible) pose is scored. Not for the trail model, which plans its trail inside the lumen.
    all_poses : bool, optional
        With ``locomotion="wires"``: keep every pose in ``motion`` however many (by default at most
        :data:`bhr._run.motion.POSE_POINTS_LIMIT` robot points, 6 million; past it the poses are scored but
        not kept, and a physics replay reads the run's steps). A 1.5 m robot's take about 5 GB of memory.
    **robot_options
        Changes to ``robot``'s settings (``modules``, ``module_length`` mm, ``alpha`` deg, ``tol_pos`` mm,
        ... as in the option registry, :mod:`bhr._settings.options`).

    Returns
    -------
    FollowResult
        The run, N steps of a head of n modules: ``points`` (N, n+1, 3) the solved pose at each step, mm,
        base first; ``codes`` (N, n) int, or None for a continuous solver; ``point_errors_mm`` (N, n+1)
        mm; ``orientation_errors_deg`` (N, n) deg; ``iterations`` (N,); ``body`` the modules behind the
        head (None without ``body_modules`` or ``reach``); ``summary`` the thesis's figures;
        ``clearance`` against the lumen (None without one); ``success``, ``status`` and ``reason`` the
        verdict in words; ``warnings`` what was warned about the path.

    Raises
    ------
    BhrError
        Bad input: points not (N, 3), finite and at the feed; an unknown solver or setting; a path too long
        to hold in memory.

    Warns
    -----
    BhrWarning
        The path turns tighter than the robot's minimum turn radius, back on itself, or its lumen is
        narrower than the robot.

    Examples
    --------
    >>> import bhr
    >>> run = bhr.follow(bhr.trajectory("curve", radius=70, angle=90))
    >>> round(run.summary.tip_final_error_mm, 4)
    0.9099
    """
    if isinstance(solver, Solver) and robot is THESIS_ROBOT and not robot_options:
        robot = solver.robot  # a configured solver brings its robot
    robot = robot_with(robot, robot_options)
    traj = _as_trajectory(points, robot)
    path = np.ascontiguousarray(traj.points, dtype=np.float64)
    if path.shape[0] < 2:
        raise BhrError("a trajectory needs at least two points")
    if locomotion is None:
        whole_robot = body_modules is not None or reach is not None
        has_lumen = getattr(traj, "lumen", None) is not None
        named = solver.name if isinstance(solver, Solver) else solver
        locomotion = "wires" if whole_robot and has_lumen and named == "lumen" else "thesis"
    check_locomotion(locomotion, stop_at_wall, all_poses)
    if body_modules is not None:
        body_modules = check_body_modules(body_modules, robot.modules)
    if reach is not None:
        if reach != "cecum":
            raise BhrError(f"reach must be cecum (a robot long enough to reach the path's end), got {reach!r}")
        if body_modules is not None:
            raise BhrError("give either body_modules or reach cecum, not both (reach cecum sets the whole robot's "
                           "modules from the path's length)")
        from bhr._run.trail import cecum_modules

        reach_modules = cecum_modules(path.shape[0], robot.feed_divisor, robot.modules)  # the path's insertion
        if locomotion == "thesis":
            body_modules = check_body_modules(reach_modules, robot.modules, "reach cecum")
    dirs = path_directions(path)
    whole = body_modules or (reach_modules if reach else 0)
    # the path's steps at least; a whole robot on a trail may take more to bring its tip to the cecum (and need
    # more modules to reach it): its plan counts them again before it keeps them (bhr._run.trail, .motion)
    check_step_points(path.shape[0], max(robot.modules, whole) + 1)
    s = get_solver(solver, robot, **(solver_options or {}))
    solver = s.name  # the registered name, also for an alias (seed: thesis)
    s.reset()
    s.prepare(traj)
    msgs: list[str] = []
    turn = _sharpest_turn(dirs)
    if turn is not None and turn[1] > 90.0:
        msg = (f"the trajectory turns back by {turn[1]:.1f} deg at point {turn[0] + 2} (a reversal: no robot can "
               "follow it, its turn radius is near 0); expect large errors")
        msgs.append(msg)
        warnings.warn(msg, BhrWarning, stacklevel=2)
    elif traj.lumen is not None and len(traj.lumen) == path.shape[0]:
        # with a lumen, only the bends the robot cannot take by swinging wide inside it (docs/lumen.md)
        bends = unfollowable_bends(path, np.asarray(traj.lumen), robot.min_turn_radius, robot.robot_radius)
        if bends:
            first, last, r_bend, d_lumen = min(bends, key=lambda x: x[2])
            msg = (f"the trajectory bends tighter than the robot's minimum turn radius {robot.min_turn_radius:.2f} mm "
                   f"with too little lumen to swing wide at {len(bends)} place{'s' if len(bends) > 1 else ''}, "
                   f"tightest at points {first + 1}-{last + 1} (a {r_bend:.1f} mm bend in a lumen {d_lumen:.1f} mm "
                   "across); "
                   "expect the robot to touch the wall there")
            msgs.append(msg)
            warnings.warn(msg, BhrWarning, stacklevel=2)
    elif traj.min_radius < robot.min_turn_radius:
        msg = (f"the trajectory turns with radius {traj.min_radius:.2f} mm, tighter than the robot's minimum "
               f"turn radius {robot.min_turn_radius:.2f} mm; expect large errors")
        msgs.append(msg)
        warnings.warn(msg, BhrWarning, stacklevel=2)
    lumen = getattr(traj, "lumen", None)
    if lumen is not None and len(lumen):
        narrow = np.flatnonzero(np.asarray(lumen, dtype=float) < 2.0 * robot.robot_radius)
        if narrow.size:
            k = int(narrow[np.argmin(np.asarray(lumen)[narrow])])
            msg = (f"the lumen is narrower than the robot ({2.0 * robot.robot_radius:g} mm across) at {narrow.size} of "
                   f"{len(lumen)} points, narrowest {float(lumen[k]):.2f} mm at point {k + 1}; the robot touches the "
                   "wall there whatever the solver does")
            msgs.append(msg)
            warnings.warn(msg, BhrWarning, stacklevel=2)
    n = robot.modules
    N = path.shape[0]
    if locomotion in ("trail", "wires"):
        if s.name != "lumen":
            raise BhrError(f"locomotion {locomotion} plans the trail the whole robot follows with the wall-aware "
                           f"planner; use --solver lumen (not {solver})")
        if locomotion == "wires":
            return _follow_wires(traj, robot, s, solver, path, dirs, body_modules, reach is not None, msgs, on_step,
                                 bool(stop_at_wall), bool(all_poses))
        return _follow_trail(traj, robot, s, solver, path, dirs, body_modules, reach is not None, msgs, on_step)
    chain = Chain.straight(robot, traj.start_direction, traj.start_point, tip_at_origin=True)
    out_points = np.zeros((N, n + 1, 3))
    out_iters = np.zeros(N, dtype=np.int64)
    pe = np.zeros((N, n + 1))
    oe = np.zeros((N, n))
    codes = np.zeros((N, n), dtype=np.int64)
    filled = s.follow_kernel(path, dirs, chain, out_points, out_iters, pe, oe, codes) \
        if compiled and on_step is None else None
    has_codes = True if filled is None else filled
    # the feeder stops when the tip reaches a blind cecum (docs/locomotion.md): from then on the robot holds its pose
    tube = _blind_tube(traj)
    stop: int | None = None
    f = robot.feed_divisor
    if filled is None:
        watch = None if tube is None else CecumWatch(tube)
        for i in range(N):
            if stop is not None:
                _hold(i, stop, out_points, out_iters, codes, path, dirs, f, pe, oe)
                if on_step is not None:
                    on_step(i, codes[i] if has_codes else None)
                continue
            d = dirs[-1] if i == N - 1 else dirs[i]
            res = s.solve(chain, path[i], d if s.accepts_orientation else None,
                          FollowContext(path, dirs, i))
            P = res.chain.points
            tip = res.orientation_error_deg
            if tip is None:
                tip = float(angle_deg(P[n, 0] - P[n - 1, 0], P[n, 1] - P[n - 1, 1], P[n, 2] - P[n - 1, 2], d))
            out_points[i] = P
            out_iters[i] = res.iterations
            score_step(i, P, path, dirs, f, tip, pe[i], oe[i])
            if res.codes is None:
                has_codes = False
            else:
                codes[i] = res.codes
            if on_step is not None:
                on_step(i, None if res.codes is None else codes[i])
            if watch is not None and watch.reached(P[n]):
                stop = i
            chain = res.chain.advance(robot.feed, robot.module_length)
    elif tube is not None:
        stop = cecum_step(tube, out_points[:, n])
        if stop is not None:
            for i in range(stop + 1, N):
                _hold(i, stop, out_points, out_iters, codes, path, dirs, f, pe, oe)
    if stop is not None and stop == N - 1:
        stop = None  # the tip reached the cecum at the last step: the feeder stopped where the path ends anyway
    result = FollowResult(traj, robot, s.name, out_points, out_iters, pe, oe, codes if has_codes else None, msgs,
                          {} if stop is None else {"summary": {"feeder_stop_step": stop + 1}})
    if body_modules is not None:
        result = replace(result, body=_held_body(result, body_modules, stop))
    # the lumen's tube with its blind end, built to watch for the cecum: the run's clearance is scored in it too (not
    # a field: dataclasses.replace makes a run that builds its own)
    object.__setattr__(result, "_tube", tube)
    if stop_at_wall:
        return _stopped_at_wall(result)
    return result


def _stopped_at_wall(result: "FollowResult") -> "FollowResult":
    """``result`` ended at the step where the robot left the lumen (unchanged when it never did, or has no lumen).

    A step depends only on the steps before it (the head's solve, the body following it, the lumen clearance
    tracking each point along the tube), so the first K steps of the whole run are exactly the run stopped there.
    """
    cl = result.clearance
    k = None if cl is None else cl.left_lumen_step
    if k is None or k >= result.steps:
        return result
    codes = None if result.codes is None else result.codes[:k]
    b = result.body
    body = None if b is None else BodyRun(b.modules, b.points[:k], b.codes[:k], b.point_errors_mm[:k],
                                          b.orientation_errors_deg[:k], b.scored[:k])
    summary = {key: v for key, v in result.extra.get("summary", {}).items()
               if not (key == "feeder_stop_step" and v > k)}
    summary["stopped_at_wall_step"] = k
    summary["path_steps"] = result.steps
    return FollowResult(result.trajectory, result.robot, result.solver, result.points[:k], result.iterations[:k],
                        result.point_errors_mm[:k], result.orientation_errors_deg[:k], codes, list(result.warnings),
                        {"summary": summary}, body)


def _blind_tube(traj: Trajectory):
    """The tube of a trajectory whose lumen ends blind (the cecum), else None (no lumen, or an open end)."""
    lumen = getattr(traj, "lumen", None)
    if lumen is None or not len(lumen) or lumen_end_of(traj) != "closed":
        return None
    return make_tube(traj.points, lumen, traj.start_direction, closed_end=True)


def _hold(i: int, stop: int, out_points: np.ndarray, out_iters: np.ndarray, codes: np.ndarray, path: np.ndarray,
          dirs: np.ndarray, f: int, pe: np.ndarray, oe: np.ndarray) -> None:
    """Step ``i`` after the feeder stopped at step ``stop``: the robot holds that step's pose and codes, and is scored
    against step ``i``'s trajectory points as every step is."""
    P = out_points[stop]
    n = P.shape[0] - 1
    d = dirs[-1] if i == path.shape[0] - 1 else dirs[i]
    out_points[i] = P
    out_iters[i] = 0
    codes[i] = codes[stop]
    tip = float(angle_deg(P[n, 0] - P[n - 1, 0], P[n, 1] - P[n - 1, 1], P[n, 2] - P[n - 1, 2], d))
    score_step(i, P, path, dirs, f, tip, pe[i], oe[i])


def _held_body(result: "FollowResult", body_modules: int, stop: int | None) -> BodyRun:
    """The body behind the head (:func:`simulate_body`), holding its pose after the feeder stopped at ``stop``."""
    if stop is None:
        return simulate_body(result, body_modules)
    k = stop + 1
    codes = None if result.codes is None else result.codes[:k]
    part = FollowResult(result.trajectory, result.robot, result.solver, result.points[:k], result.iterations[:k],
                        result.point_errors_mm[:k], result.orientation_errors_deg[:k], codes)
    b = simulate_body(part, body_modules)
    N = result.steps
    rows = np.minimum(np.arange(N), stop)
    pts = np.ascontiguousarray(b.points[rows])
    pe, oe = np.zeros((N, b.modules)), np.zeros((N, b.modules))
    scored = np.zeros((N, b.modules), dtype=bool)
    if b.modules:
        score_body(result, pts, np.ascontiguousarray(result.trajectory.points[:N], dtype=np.float64),
                   path_directions(result.trajectory.points[:N]), pe, oe, scored)
    return BodyRun(b.modules, pts, np.ascontiguousarray(b.codes[rows]), pe, oe, scored)




def _to_cecum(path: np.ndarray, dirs: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The path and its directions for a run of ``steps``: past the path's end (the feeder pushing the tip on to
    the cecum, :func:`bhr._run.trail.plan_to_cecum`) each step's target is the path's end."""
    if steps <= path.shape[0]:
        return path, dirs
    return np.ascontiguousarray(to_steps(path, steps)), np.ascontiguousarray(to_steps(dirs, steps - 1))


def _score_head(head: np.ndarray, codes: np.ndarray, path: np.ndarray, dirs: np.ndarray, f: int,
                on_step: Callable[[int, np.ndarray | None], None] | None) -> tuple[np.ndarray, np.ndarray]:
    """The head's point and module orientation errors (mm, deg) at every step of a whole-robot model, scored as the
    thesis scores its head; ``on_step`` called with each step's codes."""
    N, n = head.shape[0], head.shape[1] - 1
    pe = np.zeros((N, n + 1))
    oe = np.zeros((N, n))
    for i in range(N):
        d = dirs[-1] if i == path.shape[0] - 1 else dirs[i]  # a run stopped at the wall ends before the path
        P = head[i]
        tip = float(angle_deg(P[n, 0] - P[n - 1, 0], P[n, 1] - P[n - 1, 1], P[n, 2] - P[n - 1, 2], d))
        score_step(i, P, path, dirs, f, tip, pe[i], oe[i])
        if on_step is not None:
            on_step(i, codes[i])
    return pe, oe


def _follow_trail(traj: Trajectory, robot: Robot, s: Any, solver: str, path: np.ndarray, dirs: np.ndarray,
                  body_modules: int | None, reach: bool, msgs: list[str],
                  on_step: Callable[[int, np.ndarray | None], None] | None) -> FollowResult:
    """A run in the trail model (bhr._run.trail): plan the trail, move the whole robot along it, score every step."""
    from bhr._run.trail import run_trail, sweep_bound_mm

    n, f = robot.modules, robot.feed_divisor
    # the trail planner's own pull to the centerline (the head's center_weight is the thesis model's)
    tr = run_trail(traj, robot, {**s.settings, "trail_beam": s.trail_beam, "center_weight": s.trail_center_weight},
                   s.window, body_modules, reach)
    N = tr.joints.shape[0]  # the path's steps and those that bring the tip on to the cecum
    approach = max(0, N - path.shape[0])
    path, dirs = _to_cecum(path, dirs, N)
    M = tr.modules
    if reach:
        body_modules = M
    head = np.ascontiguousarray(tr.joints[:, n::-1])
    codes = np.ascontiguousarray(tr.joint_codes[:, n:0:-1])
    pe, oe = _score_head(head, codes, path, dirs, f, on_step)
    iters = (np.arange(N) % f == 0).astype(np.int64)
    result = FollowResult(traj, robot, solver, head, iters, pe, oe, codes, msgs, trail=tr)
    body = None
    if body_modules is not None:
        nb = M - n
        pts = np.ascontiguousarray(tr.joints[:, n + 1:])
        bpe, boe = np.zeros((N, nb)), np.zeros((N, nb))
        scored = np.zeros((N, nb), dtype=bool)
        if nb:
            score_body(result, pts, path, dirs, bpe, boe, scored)
        body = BodyRun(nb, pts, np.ascontiguousarray(tr.joint_codes[:, n + 1:]), bpe, boe, scored)
    model, rigid = sweep_bound_mm(robot.module_length, robot.alpha)
    summary = {
        "locomotion": "trail",
        "trail_vertices": int(tr.codes.shape[0]),
        "feeder_stop_step": int(tr.stop) + 1,
        "cecum_shortfall_mm": float(tr.shortfall_mm),
        "cecum_approach_steps": approach,
        "trail_offset_bound_mm": model,
        "rigid_offset_bound_mm": rigid,
        "procedure_time_s": procedure_time_s(tr),
    }
    return replace(result, body=body, extra={"summary": summary})


def _sections_from_json(doc: Any, count: int, bad: Any) -> tuple[tuple[str, int, int], ...]:
    """A run.json's trajectory sections ([name, first point, one past the last], in order) or ()."""
    if doc is None:
        return ()
    out: list[tuple[str, int, int]] = []
    prev = 0
    if not isinstance(doc, list):
        raise bad("trajectory sections must be a list of [name, first point, one past the last point]")
    for k, item in enumerate(doc, start=1):
        ok = (isinstance(item, list) and len(item) == 3 and isinstance(item[0], str) and item[0].isprintable()
              and 0 < len(item[0]) <= 40 and all(isinstance(v, int) and not isinstance(v, bool) for v in item[1:]))
        if not ok or not prev <= item[1] < item[2] <= count:
            raise bad(f"trajectory section {k} must be [name, first point, one past the last point] in order, "
                      f"within the {count} points, got {excerpt(item)}")
        prev = item[2]
        out.append((item[0], item[1], item[2]))
    return tuple(out)


def _follow_wires(traj: Trajectory, robot: Robot, s: Any, solver: str, path: np.ndarray, dirs: np.ndarray,
                  body_modules: int | None, reach: bool, msgs: list[str],
                  on_step: Callable[[int, np.ndarray | None], None] | None, stop_at_wall: bool = False,
                  all_poses: bool = False) -> FollowResult:
    """A run of the robot as it can be built (bhr._run.motion): plan the trail, drive the rigid robot's joints along
    it by their wires, write and score every pose. ``stop_at_wall``: the run ends with the step where the robot
    leaves the lumen (some joint or module deeper in the wall than the robot's radius)."""
    from bhr._run.motion import wires_motion

    n, f = robot.modules, robot.feed_divisor
    mo, tcodes, M, stop, short, too_short = wires_motion(traj, robot, s, body_modules, reach,
                                              stop_below=-float(robot.robot_radius) if stop_at_wall else None,
                                              all_poses=all_poses)
    N = mo.step_joints.shape[0]  # the path's steps and those to the cecum, or fewer when it stopped at the wall
    traj_steps = path.shape[0]
    approach = max(0, int(mo.planned_steps) - traj_steps)
    path, dirs = _to_cecum(path, dirs, N)
    if reach:
        body_modules = M
    joints, jcodes = mo.step_joints, mo.step_codes
    tipfirst = joints[:, ::-1]
    head = np.ascontiguousarray(tipfirst[:, n::-1])
    codes = np.ascontiguousarray(jcodes[:, ::-1][:, n - 1::-1]) if n else np.zeros((N, 0), np.int64)
    pe, oe = _score_head(head, codes, path, dirs, f, on_step)
    iters = (np.arange(N) % f == 0).astype(np.int64)
    result = FollowResult(traj, robot, solver, head, iters, pe, oe, codes, msgs, motion=mo)
    body = None
    if body_modules is not None:
        nb = M - n
        pts = np.ascontiguousarray(tipfirst[:, n + 1:])
        bpe, boe = np.zeros((N, nb)), np.zeros((N, nb))
        scored = np.zeros((N, nb), dtype=bool)
        if nb:
            score_body(result, pts, path, dirs, bpe, boe, scored)
        bcodes = np.ascontiguousarray(jcodes[:, ::-1][:, n:])  # body module 1 (right behind the head) first
        body = BodyRun(nb, pts, bcodes, bpe, boe, scored)
    names, counts = np.unique(np.array(mo.strategies), return_counts=True)
    # path_steps: the path's own (a study's reach is the share of them the run went)
    stopped = {} if mo.stopped_step is None else {"stopped_at_wall_step": N, "path_steps": int(traj_steps)}
    summary = {
        "locomotion": "wires",
        "trail_vertices": int(tcodes.shape[0]),
        **({"feeder_stop_step": int(stop) + 1} if int(stop) < N else {}),
        "cecum_shortfall_mm": float(short),
        "cecum_approach_steps": approach,
        "too_short_for_cecum": bool(too_short),
        "poses": int(mo.t_s.shape[0]),
        "poses_file": "poses.npz" if mo.kept else None,
        "max_trail_offset_mm": float(np.max(mo.trail_offset_mm)),
        "switching": {str(a): int(b) for a, b in zip(names, counts)},
        "procedure_time_s": float(mo.t_s[-1]),
        **stopped,
    }
    return replace(result, body=body, extra={"summary": summary})


def procedure_time_s(tr: TrailRun) -> float:
    """Seconds the whole procedure takes at the wires' pace (docs/locomotion.md): the thermal model's fastest
    schedule (as :func:`bhr._hardware.thermal.auto_schedule`, the default wire, every module of the robot) of the codes
    every joint is driven to, one row per module length of insertion (between two vertices no wire changes)."""
    from bhr._hardware.thermal import DEFAULT_THERMAL, simulate

    rows = np.ascontiguousarray(tr.joint_codes[:, 1:])
    change = np.ones(rows.shape[0], dtype=bool)
    change[1:] = np.any(rows[1:] != rows[:-1], axis=1)
    rows = np.ascontiguousarray(rows[change])
    # the temperatures are not kept (a trace of every module would be large): one sample per 1000 s
    sim = simulate(DEFAULT_THERMAL, np.zeros(rows.shape[0], np.int64), rows, auto=True, min_gap_ms=1,
                   stride=1_000_000)
    done = sim.done_ms if sim.done_ms >= 0 else sim.end_ms
    return max(float(done), float(sim.times_ms[-1])) / 1000.0
