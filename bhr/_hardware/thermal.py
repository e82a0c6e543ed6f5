"""The thermal model of the nitinol actuator wires, and schedules the board can sustain (docs/thermal.md).

One first-order lumped model per wire, in a normalised temperature
``theta`` (0 = ambient, 1 = fully contracted, i.e. the end of the austenite
transformation):

    tau * d(theta)/dt = u(t) * theta_full - theta

``u`` is the power applied (1 = full power, the PWM duty in between) and
``theta_full`` the temperature full power would reach in the end. Four
figures of the wire (a robot file's ``[thermal]`` table, from the wire's
datasheet) fix everything else:

- ``contract_ms``: full power contracts a cold wire in this time
  (theta reaches 1);
- ``hold_duty``: the PWM duty that holds a contracted wire at theta = 1,
  hence ``theta_full = 1 / hold_duty`` and
  ``tau = contract_ms / ln(1 / (1 - hold_duty))``;
- ``relax_ms``: a contracted wire left unpowered relaxes in this time,
  hence the relaxed temperature ``theta_relax = exp(-relax_ms / tau)``;
- ``max_full_ms``: the longest full-power time allowed from cold, hence the
  temperature limit ``theta_limit = theta_full * (1 - exp(-max_full_ms / tau))``.

The firmware runs exactly the integer version of this model
(:func:`model_constants`; the constants are generated into
``firmware/src/bhr_gen.h`` by :mod:`bhr._hardware.firmware_header`), updated once per
PWM period, and drives each module: full power while one of its energised
wires is below theta = 1, then PWM hold; a released wire is not energised
again before it has relaxed (theta <= theta_relax); a wire that reaches
theta_limit switches its module off (overheat, the last line of defence).
:func:`simulate` replays that logic millisecond by millisecond, so the host
can check a stream before sending it (:func:`check_schedule`) or stretch it
until it fits (:func:`auto_schedule`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from numba import njit
from bhr.model._wires import DEFAULT_THERMAL, THERMAL_KEYS, ThermalParams, thermal_from_table
from bhr._settings.errors import BhrError

__all__ = ["pace", "ThermalParams", "DEFAULT_THERMAL", "THERMAL_KEYS", "ONE", "DUTY_WINDOW_MS", "duty_limit",
           "model_constants", "thermal_from_table",
           "simulate", "simulate_reference", "Schedule", "check_schedule", "auto_schedule", "format_duration"]

#: theta = 1 in the integer model (Q14 fixed point), as on the board.
ONE = 1 << 14
#: Fractional bits of the per-period cooling factor.
A_SHIFT = 16
#: The host keeps this much time (ms) in hand for the serial link's latency when planning.
LINK_MARGIN_MS = 30
#: The window over which a wire's duty limit is stated (docs/thermal.md, "The wire's duty limit").
DUTY_WINDOW_MS = 10_000



def duty_limit(p: ThermalParams, window_ms: int = DUTY_WINDOW_MS) -> float:
    """The most a wire may be on over any ``window_ms`` window (docs/thermal.md, "The wire's duty limit").

    The datasheet's current is a contraction current (the wire contracts in
    ``contract_ms``), not a continuous one: held, the wire takes the hold duty.
    So over a window a wire gets at most one contraction at full power and the
    hold duty for the rest: ``(contract_ms + hold duty x window) / window``
    (0.70 over 10 s for the default wire). The board's drive keeps every wire
    under it whatever the host sends.
    """
    return min(1.0, (p.contract_ms + p.duty * window_ms) / window_ms)


def model_constants(p: ThermalParams) -> dict[str, int]:
    """The integer constants of the model, as the board uses them (Q14 temperatures)."""
    a = 1.0 - math.exp(-p.period_ms / p.tau_ms)
    return {
        "PERIOD_MS": int(p.period_ms),
        "HOLD_TICKS": p.hold_ticks,
        "THETA_ONE": ONE,
        "THETA_FULL": int(round(ONE * p.theta_full)),
        "THETA_RELAX": int(round(ONE * p.theta_relax)),
        "THETA_LIMIT": int(round(ONE * p.theta_limit)),
        "A_Q16": int(round(a * (1 << A_SHIFT))),
    }


def _const_array(p: ThermalParams) -> np.ndarray:
    c = model_constants(p)
    return np.array([c["PERIOD_MS"], c["HOLD_TICKS"], c["THETA_FULL"], c["THETA_RELAX"], c["THETA_LIMIT"],
                     c["A_Q16"]], dtype=np.int64)


# ---------------------------------------------------------------------------
# The board's drive, millisecond by millisecond (firmware/src/board.c).
#
# Both versions below take: row_t (int64[n], the time each row reaches the board; in auto mode
# only row_t[0] is read and the rest is filled in), rows (int64[n, m] codes), end_t (last ms
# simulated), k (model constants, _const_array), theta0 (int64[4m], Q14), stride (trace sampling,
# ms), auto (0/1), min_gap and margin (ms, auto mode). They return (trace, early, overheat_t,
# max_run, max_theta, on_ms, done_t, t_stop): the Q14 temperatures every stride ms, which rows
# asked a module for a wire still relaxing, each module's first overheat time (-1: none), the longest
# continuous on-time and highest temperature per wire, the total on-time per wire, when the
# last row's code was reached (every energised wire contracted; -1: never), and where the run stopped.


@njit(cache=True, inline="always")
def _drive_code(want, dj, cool, warm):
    """(code, blocked): what a module drives for the code ``want`` while it drives ``dj``.

    ``cool``: the module's wires cooling after reaching the limit (4 bits);
    ``warm``: its wires above theta_relax. Nothing for a code that needs a
    cooling wire; nothing, and ``blocked`` = 1, for one that would energise
    anew a wire still relaxing (the board's "early" rule). Used on a row's
    arrival and after every PWM period's temperature update.
    """
    if want & cool:
        want = 0
    if want & ~dj & warm:
        return 0, 1
    return want, 0


@njit(cache=True, inline="always")
def _run_after(on, n, run, longest):
    """A wire on ``on`` of the last ``n`` ticks: its run of on-ticks after them and the longest run so far (a run
    ends when a tick off follows). Scalars in and out: a helper taking the arrays costs the hot loop a reference
    count per array and call, which made bhr plan nine times slower."""
    run += on
    if run > longest:
        longest = run
    if on < n:
        run = 0
    return run, longest


@njit(cache=True, inline="always")
def _wire_on(n, p0, full_power, hold):
    """Ticks a driven wire is on among ``n`` ticks from phase ``p0`` (within one PWM period).

    At full power every tick; held, the ticks whose phase is below ``hold``,
    which come first in a period.
    """
    if full_power == 1:
        return n
    on = min(p0 + n, hold) - p0
    return on if on > 0 else 0


@njit(cache=True, inline="always")
def _wire_masks(j, cooling, theta, relax):
    """Module ``j``'s wires as two 4-bit masks: cooling, and above theta_relax."""
    cool = 0
    warm = 0
    for b in range(4):
        if cooling[4 * j + b] == 1:
            cool |= 1 << b
        if theta[4 * j + b] > relax:
            warm |= 1 << b
    return cool, warm


@njit(cache=True, inline="always")
def _account(j, upto, last, drive, mode_full, hold, period, on_ticks, on_ms, run, max_run):
    """Count module ``j``'s wires' on-ticks from ``last[j]`` up to (not including) tick ``upto``.

    The drive and the power modes stay the same over such a stretch, which
    lies within one PWM period: the kernel counts every module at each
    period's end (inline there, the hot path), and a module before its drive
    changes (here).
    """
    n = upto - last[j]
    if n <= 0:
        return
    p0 = last[j] % period
    d = drive[j]
    for b in range(4):
        i = 4 * j + b
        on = _wire_on(n, p0, mode_full[i], hold) if (d >> b) & 1 else 0
        on_ticks[i] += on
        on_ms[i] += on
        run[i], max_run[i] = _run_after(on, n, run[i], max_run[i])
    last[j] = upto


@njit(cache=True)
def _kernel(row_t, rows, end_t, k, theta0, stride, auto, min_gap, margin, on_trace):
    period, hold, full, relax, limit, a = k[0], k[1], k[2], k[3], k[4], k[5]
    n_rows, m = rows.shape
    na = 4 * m
    theta = theta0.copy()
    on_ticks = np.zeros(na, np.int64)
    drive = np.zeros(m, np.int64)
    requested = np.zeros(m, np.int64)
    mode_full = np.zeros(na, np.int64)  # per wire: 1 full power (contracting), 0 PWM hold
    cooling = np.zeros(na, np.int64)    # per wire: 1 after reaching the limit, until relaxed
    last = np.zeros(m, np.int64)        # per module: the first tick whose on-time is not counted yet
    target = np.zeros(period + 1, np.int64)  # the temperature a period with so many ticks on heads for
    for n_on in range(period + 1):
        target[n_on] = (n_on * full) // period
    for i in range(na):
        if theta[i] > relax:
            cooling[i] = 1
    trace = np.zeros((end_t // stride + 1, na), np.int64)
    for i in range(na):
        trace[0, i] = theta[i]
    on_tr = np.zeros((end_t // stride + 1 if on_trace == 1 else 1, na), np.int64)
    on_ms = np.zeros(na, np.int64)
    run = np.zeros(na, np.int64)
    max_run = np.zeros(na, np.int64)
    max_theta = theta0.copy()
    early = np.zeros((n_rows, m), np.int64)
    overheat_t = np.full(m, -1, np.int64)
    phase = 0
    r = 0
    ready_t = -1  # auto mode: when the next row became sendable
    done_t = -1
    t_stop = end_t
    state_ok = 0  # auto mode: the board's state lets row r go (valid while changed == 0)
    changed = 1   # the drive, the temperatures or r changed since state_ok was found
    if auto == 1:
        for i in range(1, n_rows):
            row_t[i] = end_t + 1
    for t in range(end_t + 1):
        if auto == 1 and r < n_rows and r > 0:
            # is the board ready for row r?  the minimum gap kept, previous row reached (no module held, every
            # wire contracted) and no wire of row r still relaxing
            ok = 1
            if t < row_t[r - 1] + min_gap:
                ok = 0
            else:
                if changed == 1:
                    state_ok = 1
                    for j in range(m):
                        if drive[j] != requested[j]:
                            state_ok = 0
                            break
                        for b in range(4):
                            if mode_full[4 * j + b] == 1:
                                state_ok = 0
                        new_on = rows[r, j] & ~drive[j]
                        for b in range(4):
                            if (new_on >> b) & 1 and theta[4 * j + b] > relax:
                                state_ok = 0
                        if state_ok == 0:
                            break
                    changed = 0
                ok = state_ok
            if ok == 1:
                if ready_t < 0:
                    ready_t = t
                if t >= ready_t + margin:
                    row_t[r] = t
                    ready_t = -1
            else:
                ready_t = -1
            if row_t[r] != t:
                row_t[r] = t + 1 + end_t  # not yet: keep it in the future
        while r < n_rows and row_t[r] <= t:
            changed = 1
            for j in range(m):
                requested[j] = rows[r, j]
            for j in range(m):
                cool, warm = _wire_masks(j, cooling, theta, relax)
                want, blocked = _drive_code(requested[j], drive[j], cool, warm)
                early[r, j] = blocked
                if want != drive[j]:
                    _account(j, t, last, drive, mode_full, hold, period, on_ticks, on_ms, run, max_run)
                    # a wire energised anew starts at full power when below theta = 1; one that stays on
                    # keeps its drive (a holding wire is not pulsed again)
                    new_on = want & ~drive[j]
                    for b in range(4):
                        i = 4 * j + b
                        if (want >> b) & 1 == 0:
                            mode_full[i] = 0
                        elif (new_on >> b) & 1:
                            mode_full[i] = 1 if theta[i] < ONE else 0
                    drive[j] = want
            r += 1
        if r == n_rows and done_t < 0:
            ok = 1
            for j in range(m):
                if drive[j] != requested[j]:
                    ok = 0
            for i in range(na):
                if mode_full[i] == 1:
                    ok = 0
            if ok == 1:
                done_t = t
                if auto == 1:
                    t_stop = t
                    break
        if t == end_t:
            break
        # tick t: the wires' on-time is counted lazily (_account), at the period's end or before a drive changes
        phase += 1
        if phase == period:
            phase = 0
            changed = 1
            p0 = t + 1 - period  # the period's first tick
            for j in range(m):
                # the module's on-ticks since it was last counted (inline: this runs every period for every wire)
                n = t + 1 - last[j]
                d = drive[j]
                cool = 0
                warm = 0
                for b in range(4):
                    i = 4 * j + b
                    on = _wire_on(n, last[j] - p0, mode_full[i], hold) if (d >> b) & 1 else 0
                    on_ticks[i] += on
                    on_ms[i] += on
                    run[i], max_run[i] = _run_after(on, n, run[i], max_run[i])
                    th = theta[i]
                    if th != 0 or on_ticks[i] != 0:  # a cold wire left off stays cold
                        th += ((target[on_ticks[i]] - th) * a) >> 16
                        if th < 0:
                            th = 0
                        theta[i] = th
                        if th > max_theta[i]:
                            max_theta[i] = th
                        on_ticks[i] = 0
                    if th >= limit:
                        cooling[i] = 1
                        if overheat_t[j] < 0:
                            overheat_t[j] = t + 1
                    elif cooling[i] == 1 and th <= relax:
                        cooling[i] = 0
                    if cooling[i] == 1:
                        cool |= 1 << b
                    if th > relax:
                        warm |= 1 << b
                last[j] = t + 1
                want, blocked = _drive_code(requested[j], drive[j], cool, warm)
                drive[j] = want
                for b in range(4):  # each wire on: full power until it has contracted, then hold
                    i = 4 * j + b
                    mode_full[i] = 1 if (want >> b) & 1 and theta[i] < ONE else 0
        if (t + 1) % stride == 0:
            s = (t + 1) // stride
            for i in range(na):
                trace[s, i] = theta[i]
            if on_trace == 1:
                for j in range(m):  # counted already when the sample ends a PWM period
                    if last[j] != t + 1:
                        _account(j, t + 1, last, drive, mode_full, hold, period, on_ticks, on_ms, run, max_run)
                for i in range(na):
                    on_tr[s, i] = on_ms[i]
    for j in range(m):  # every tick before the stop counted
        _account(j, t_stop if t_stop < end_t else end_t, last, drive, mode_full, hold, period, on_ticks, on_ms,
                 run, max_run)
    return trace, early, overheat_t, max_run, max_theta, on_ms, done_t, t_stop, on_tr


def simulate_reference(row_t, rows, end_t, k, theta0, stride, auto, min_gap, margin, on_trace=0):
    """The same drive with numpy arrays over the wires (the readable reference of the kernel)."""
    period, hold, full_t, relax, limit, a = (int(x) for x in k)
    n_rows, m = rows.shape
    bit = np.arange(4)

    def wires(codes):  # (m,) codes -> (m, 4) bools
        return ((np.asarray(codes)[:, None] >> bit[None, :]) & 1).astype(bool)

    th = theta0.reshape(m, 4).astype(np.int64).copy()
    on_ticks = np.zeros((m, 4), np.int64)
    drive = np.zeros(m, np.int64)
    requested = np.zeros(m, np.int64)
    full = np.zeros((m, 4), bool)   # per wire: full power (contracting) or PWM hold
    cooling = th > relax            # per wire: reached the limit (or hot at the start), until relaxed
    trace = np.zeros((end_t // stride + 1, 4 * m), np.int64)
    trace[0] = th.reshape(-1)
    on_tr = np.zeros((end_t // stride + 1 if on_trace else 1, 4 * m), np.int64)
    on_ms = np.zeros((m, 4), np.int64)
    run = np.zeros((m, 4), np.int64)
    max_run = np.zeros((m, 4), np.int64)
    max_theta = th.copy()
    early = np.zeros((n_rows, m), np.int64)
    over = np.full(m, -1, np.int64)
    phase, r, ready_t, done_t, t_stop = 0, 0, -1, -1, end_t
    if auto:
        row_t[1:] = end_t + 1

    def blocked(codes):  # modules where `codes` would energise a wire still relaxing
        return (wires(codes & ~drive) & (th > relax)).any(axis=1)

    def allowed(codes):  # nothing for a module whose code needs a cooling wire
        return np.where((wires(codes) & cooling).any(axis=1), 0, codes)

    def reached():
        return bool(np.all(drive == requested) and not full.any())

    for t in range(end_t + 1):
        if auto and 0 < r < n_rows:
            ok = t >= row_t[r - 1] + min_gap and reached() and not blocked(rows[r]).any()
            if ok:
                ready_t = t if ready_t < 0 else ready_t
                if t >= ready_t + margin:
                    row_t[r], ready_t = t, -1
            else:
                ready_t = -1
            if row_t[r] != t:
                row_t[r] = t + 1 + end_t
        while r < n_rows and row_t[r] <= t:
            requested[:] = rows[r]
            want = allowed(requested)
            early[r] = blocked(want)
            want = np.where(early[r] == 1, 0, want)
            changed = (want != drive)[:, None]
            new_on = wires(want & ~drive)
            full = np.where(changed, np.where(new_on, th < ONE, full & wires(want)), full)
            drive = want
            r += 1
        if r == n_rows and done_t < 0 and reached():
            done_t = t
            if auto:
                t_stop = t
                break
        if t == end_t:
            break
        on = wires(drive) & (full | (phase < hold))
        on_ticks += on
        on_ms += on
        run = np.where(on, run + 1, 0)
        max_run = np.maximum(max_run, run)
        phase += 1
        if phase == period:
            phase = 0
            th = np.maximum(th + (((on_ticks * full_t) // period - th) * a >> 16), 0)
            max_theta = np.maximum(max_theta, th)
            on_ticks[:] = 0
            hot = th >= limit
            over = np.where(hot.any(axis=1) & (over < 0), t + 1, over)
            cooling = hot | (cooling & (th > relax))
            want = allowed(requested)
            drive = np.where(blocked(want), 0, want)
            full = wires(drive) & (th < ONE)
        if (t + 1) % stride == 0:
            trace[(t + 1) // stride] = th.reshape(-1)
            if on_trace:
                on_tr[(t + 1) // stride] = on_ms.reshape(-1)
    return (trace, early, over, max_run.reshape(-1), max_theta.reshape(-1), on_ms.reshape(-1), done_t, t_stop,
            on_tr)


@dataclass
class Simulation:
    """What the board's drive does with rows of codes reaching it at ``times_ms``."""

    params: ThermalParams
    times_ms: np.ndarray      # when each row reaches the board (ms)
    rows: np.ndarray          # (rows, modules) codes
    theta: np.ndarray         # (samples, modules, 4) normalised temperature, every `stride` ms
    stride: int
    early: np.ndarray         # (rows, modules) 1 where the row asked for a wire still relaxing
    overheat_ms: np.ndarray   # (modules,) first overheat time, -1: none
    max_on_ms: np.ndarray     # (modules, 4) longest continuous on-time on the pins
    max_theta: np.ndarray     # (modules, 4)
    on_ms: np.ndarray         # (modules, 4) total on-time
    done_ms: int              # the last row's code reached (-1: not within the run)
    end_ms: int
    on_cum: np.ndarray | None = None  # (samples, modules, 4) on-time so far, every `stride` ms (on_trace=True)

    def max_window_duty(self, window_ms: int = 0) -> np.ndarray:
        """(modules, 4): each wire's highest on-time fraction over any ``window_ms`` window (simulate(on_trace=True)).

        Windows start and end on the samples (every ``stride`` ms); default
        window: DUTY_WINDOW_MS. Compare with :func:`duty_limit`.
        """
        if self.on_cum is None:
            raise BhrError("max_window_duty needs simulate(..., on_trace=True)")
        w = int(window_ms or DUTY_WINDOW_MS)
        k = max(1, w // self.stride)
        c = self.on_cum.reshape(self.on_cum.shape[0], -1)
        if c.shape[0] <= k:
            return (c[-1] / max(w, 1)).reshape(self.on_cum.shape[1:])
        return ((c[k:] - c[:-k]).max(axis=0) / (k * self.stride)).reshape(self.on_cum.shape[1:])

    @property
    def faults(self) -> list[tuple[str, int, int]]:
        """(kind, module 1-based, step 1-based) of each fault the board would raise, in time order."""
        out = []
        for r, j in zip(*np.nonzero(self.early)):
            out.append((int(self.times_ms[r]), "early", int(j) + 1, int(r) + 1))
        for j, t in enumerate(self.overheat_ms):
            if t >= 0:
                step = int(np.searchsorted(self.times_ms, t, side="right"))
                out.append((int(t), "overheat", j + 1, max(step, 1)))
        out.sort()
        return [f[1:] for f in out]


#: At most this many temperature samples (times wires) are kept by default (32 MB): see ``simulate``'s stride.
TRACE_CELLS = 4_000_000

def simulate(params: ThermalParams, times_ms, rows, end_ms: int | None = None, theta0=None,
             stride: int | None = None, reference: bool = False, auto: bool = False, min_gap_ms: int = 0,
             margin_ms: int = LINK_MARGIN_MS, on_trace: bool = False, trace: bool = True) -> Simulation:
    """Replay the board's drive: row ``i`` of ``rows`` (codes per module) reaches it at ``times_ms[i]``.

    ``end_ms`` (default: long enough for every row to be reached) ends the
    run; ``theta0`` (modules x 4, Q14) gives the starting temperatures (default
    cold). The temperatures are sampled every ``stride`` ms (default: the PWM
    period, or a whole number of periods when the run would keep more than
    ``TRACE_CELLS`` samples). ``auto=True`` ignores ``times_ms`` after the first and sends each
    row as soon as the board is ready for it (see :func:`auto_schedule`).
    ``reference=True`` runs the numpy reference instead of the compiled kernel.
    ``on_trace=True`` also keeps each wire's on-time so far at every sample
    (``Simulation.on_cum``, for :meth:`Simulation.max_window_duty`).
    ``trace=False`` keeps no temperature samples but the starting ones (``theta``
    has one sample): the faults, on-times and times are the same, and the
    memory no longer grows with the number of rows (a procedure-time estimate).
    """
    rows = np.ascontiguousarray(np.asarray(rows, dtype=np.int64))
    if rows.ndim != 2 or rows.shape[0] == 0:
        raise BhrError("simulate needs a non-empty table of codes (steps x modules)")
    n, m = rows.shape
    t = np.array(np.asarray(times_ms, dtype=np.int64), copy=True)
    if t.shape != (n,) or (not auto and np.any(np.diff(t) < 0)) or t[0] < 0:
        raise BhrError("row times must be non-negative, one per row, in order")
    per_row = int(params.contract_ms + params.relax_ms * 3 + params.max_full_ms + min_gap_ms + margin_ms
                  + 4 * params.period_ms)
    if end_ms is None:
        end_ms = (int(t[0]) + n * per_row) if auto else int(t[-1] + per_row)
    if not trace:  # no sample but the first
        stride = int(end_ms) + 2
    elif stride is None:  # every PWM period, or coarser when a long run of many modules would fill the memory
        periods = -(-(int(end_ms) + 1) * 4 * m // (TRACE_CELLS * int(params.period_ms)))
        stride = int(params.period_ms) * max(1, periods)
    stride = int(stride)
    th0 = np.zeros(4 * m, np.int64) if theta0 is None else np.asarray(theta0, np.int64).reshape(4 * m).copy()
    k = _const_array(params)
    args = (t, rows, int(end_ms), k, th0, stride, int(auto), int(min_gap_ms), int(margin_ms), int(on_trace))
    if reference:
        out = simulate_reference(*args)
    else:
        out = _kernel(*args)
    samples, early, over, max_run, max_theta, on_ms, done_t, t_stop, on_tr = out
    samples = samples[: t_stop // stride + 1]
    on_cum = on_tr[: t_stop // stride + 1].reshape(-1, m, 4) if on_trace else None
    return Simulation(params, t, rows, samples.reshape(samples.shape[0], m, 4) / ONE, stride, early, over,
                      max_run.reshape(m, 4), max_theta.reshape(m, 4) / ONE, on_ms.reshape(m, 4), int(done_t),
                      int(t_stop), on_cum)


# ---------------------------------------------------------------------------
# Planning a stream


def format_duration(seconds: float) -> str:
    """``6 min 12 s``, ``48.3 s``, ``1 h 02 min``."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    m, s = divmod(int(round(seconds)), 60)
    if m < 60:
        return f"{m} min {s} s"
    h, m = divmod(m, 60)
    return f"{h} h {m:02d} min"


@dataclass
class Schedule:
    """When each row is sent (ms after the first) and what the board's model makes of it."""

    times_ms: np.ndarray
    sim: Simulation
    mode: str   # "rate": fixed rate; "auto": each row sent when the wires allow, never faster than the rate
    rate: float

    @property
    def total_s(self) -> float:
        """Procedure time: from the first row until the last row's code has been reached."""
        done = self.sim.done_ms if self.sim.done_ms >= 0 else self.sim.end_ms
        return max(float(done), float(self.times_ms[-1])) / 1000.0

    @property
    def faults(self) -> list[tuple[str, int, int]]:
        return self.sim.faults


def check_schedule(params: ThermalParams, rows, rate: float, theta0=None, trace: bool = True) -> Schedule:
    """Rows sent at a fixed ``rate`` (rows/s): the model's verdict (``Schedule.faults``; empty = safe).

    The link's latency is allowed for: every row but the first is checked as
    if it reached the board LINK_MARGIN_MS early.
    """
    rows = np.asarray(rows, dtype=np.int64)
    times = np.round(np.arange(rows.shape[0]) * (1000.0 / float(rate))).astype(np.int64)
    early = times.copy()
    early[1:] = np.maximum(times[1:] - LINK_MARGIN_MS, 0)
    early = np.maximum.accumulate(early)
    sim = simulate(params, early, rows, theta0=theta0, trace=trace)
    sim.times_ms = times
    return Schedule(times, sim, "rate", float(rate))


def auto_schedule(params: ThermalParams, rows, rate: float, theta0=None, trace: bool = True) -> Schedule:
    """The fastest schedule, never faster than ``rate``, that the board's model accepts.

    Row ``i+1`` is sent LINK_MARGIN_MS after the board is ready for it: row
    ``i`` has been on for 1/rate, every wire it energises has contracted
    (theta >= 1) and every wire row ``i+1`` energises anew has relaxed
    (theta <= theta_relax).
    """
    rows = np.asarray(rows, dtype=np.int64)
    gap = int(math.ceil(1000.0 / float(rate)))
    sim = simulate(params, np.zeros(rows.shape[0], np.int64), rows, auto=True, min_gap_ms=gap, theta0=theta0,
                   trace=trace)
    return Schedule(sim.times_ms, sim, "auto", float(rate))


def pace(schedule: Schedule, counts: bool = True) -> str:
    """What sets a schedule's procedure time, in words: a fixed rate (``at a fixed 20 Hz``), or the wires and
    the rate cap of an auto schedule, with how many step times each sets (``at the wires' pace, at most 10 Hz:
    the wires set 182 of the 826 step times, the 10 Hz cap the other 644``).

    A step of an auto schedule waits for the rate cap when it is sent as soon as the cap allows (1/rate after
    the one before, and the link's margin); otherwise it waited for a wire to contract or relax. ``counts=False``:
    without the counts (``at the wires' pace, at most 10 Hz``)."""
    if schedule.mode != "auto":
        return f"at a fixed {schedule.rate:g} Hz"
    if not counts:
        return f"at the wires' pace, at most {schedule.rate:g} Hz"
    gaps = np.diff(np.asarray(schedule.times_ms, dtype=np.int64))
    capped = int(np.count_nonzero(gaps <= int(math.ceil(1000.0 / schedule.rate)) + LINK_MARGIN_MS))
    return (f"at the wires' pace, at most {schedule.rate:g} Hz: the wires set {len(gaps) - capped} of the "
            f"{len(gaps)} step times, the {schedule.rate:g} Hz cap the other {capped}")


def summarize(schedule: Schedule, name: str = "") -> str:
    """``colon: 827 steps, 4 min 6 s at the wires' pace, at most 10 Hz: ...`` (:func:`pace`)."""
    n = len(schedule.times_ms)
    return f"{name + ': ' if name else ''}{n} steps, {format_duration(schedule.total_s)} {pace(schedule)}"


def max_safe_rate(params: ThermalParams, rows, rate: float) -> float | None:
    """A fixed rate (<= rate, to 0.1 Hz, at least 0.1 Hz) the model accepts, the highest a bisection finds, or None.

    Whether a rate is accepted is not monotonic in the rate (send times are rounded to whole milliseconds and
    each row may arrive LINK_MARGIN_MS early), so the bisection's answer, rounded down to 0.1 Hz, is checked
    itself and lowered by 0.1 Hz until the model accepts it: the rate printed as the fix is one that passes.
    """
    lo, hi = 0.1, float(rate)
    if check_schedule(params, rows, lo, trace=False).faults:
        return None
    for _ in range(14):
        mid = (lo + hi) / 2
        if check_schedule(params, rows, mid, trace=False).faults:
            hi = mid
        else:
            lo = mid
    tenths = math.floor(lo * 10 + 1e-9)
    for _ in range(20):  # a few tenths down at most (each try simulates the stream), then the rate checked first
        if tenths <= 1:
            break
        if not check_schedule(params, rows, tenths / 10, trace=False).faults:
            return tenths / 10
        tenths -= 1
    return 0.1  # accepted above


def _released_step(rows: np.ndarray, step: int, module: int) -> int | None:
    """The 1-based step at which a wire that ``step`` energises anew on ``module`` was last switched off."""
    j = module - 1
    now, before = int(rows[step - 1, j]), int(rows[step - 2, j]) if step >= 2 else 0
    newly = now & ~before
    for k in range(step - 2, 0, -1):
        if int(rows[k - 1, j]) & newly and not int(rows[k, j]) & newly:
            return k + 1
    return None


SCHEDULES = ("rate", "auto")


def plan(params: ThermalParams, rows, rate: float, schedule: str = "rate", name: str = "",
         sending: bool = False, trace: bool = True) -> Schedule:
    """Check (``schedule="rate"``) or stretch (``"auto"``) a stream of codes before anything is sent.

    A fixed-rate stream that the board's model would fault on raises
    BhrError, one line naming the module, the step and the fix. ``trace=False``:
    no temperature samples kept (see :func:`simulate`), for a schedule without its figure.
    """
    rows = np.asarray(rows, dtype=np.int64)
    if schedule not in SCHEDULES:
        raise BhrError(f"schedule {schedule!r} is not one of {', '.join(SCHEDULES)}")
    if schedule == "auto":
        return auto_schedule(params, rows, rate, trace=trace)
    sched = check_schedule(params, rows, rate, trace=trace)
    if not sched.faults:
        return sched
    kind, module, step = sched.faults[0]
    auto = auto_schedule(params, rows, rate, trace=False)
    safe = max_safe_rate(params, rows, rate)
    fix = (f"use --rate {safe:g}" if safe else "no fixed rate fits") + \
        f" or --schedule auto ({format_duration(auto.total_s)} at the wires' pace, at most {rate:g} Hz)"
    where = f"{name + ': ' if name else ''}module m{module}, step {step}"
    if kind == "early":
        rel = _released_step(rows, step, module)
        what = (f"a wire released at step {rel} has not relaxed yet" if rel else "a wire has not relaxed yet") + \
            f" (relaxation {params.relax_ms:g} ms) when it is energised again at {rate:g} Hz"
    else:
        what = f"a wire would overheat at {rate:g} Hz (over {params.max_full_ms:g} ms of full power)"
    note = " nothing was sent;" if sending else ""
    raise BhrError(f"{where}: {what}, and the board would hold the module off;{note} {fix}")
