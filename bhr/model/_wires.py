"""The actuator wires' datasheet figures: the ``[thermal]`` table of a robot file (docs/thermal.md).

:class:`ThermalParams` holds the four figures of a nitinol wire and the PWM
period of the board's drive; :mod:`bhr._hardware.thermal` models what the wires
sustain from them, and the firmware header is generated from them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from bhr._settings.errors import BhrError
from bhr._settings.options import check_number, excerpt

__all__ = ["ThermalParams", "DEFAULT_THERMAL", "THERMAL_KEYS", "thermal_from_table", "FLEXINOL_LT_C",
           "transform_thetas", "contraction_reference"]

THERMAL_KEYS: dict[str, tuple[str, float, float]] = {
    # key: (meaning, lowest, highest)
    "contract_ms": ("full-power time that contracts a cold wire", 50, 20000),
    "hold_duty": ("PWM duty that holds a contracted wire", 0.3, 0.95),
    "relax_ms": ("time a contracted wire takes to relax unpowered", 50, 60000),
    "max_full_ms": ("longest full-power time from cold (the board's overheat limit)", 60, 60000),
    "period_ms": ("PWM period of the hold drive", 5, 100),
}


@dataclass(frozen=True)
class ThermalParams:
    """The wire's four datasheet figures and the PWM period (see the module docstring).

    The defaults are the thesis's wires; each figure is checked against the range of :data:`THERMAL_KEYS`
    (a :class:`~bhr.BhrError` otherwise).

    Parameters
    ----------
    contract_ms : float, default 1000.0
        Full-power time that contracts a cold wire, ms (50 ... 20000).
    hold_duty : float, default 0.6
        PWM duty that holds a contracted wire, a fraction (0.3 ... 0.95).
    relax_ms : float, default 1100.0
        Time a contracted wire takes to relax unpowered, ms (50 ... 60000).
    max_full_ms : float, default 3000.0
        Longest full-power time from cold, the board's overheat limit, ms (60 ... 60000; more than 1.5 x
        ``contract_ms``).
    period_ms : int, default 20
        PWM period of the hold drive, whole ms (5 ... 100).

    Examples
    --------
    >>> ThermalParams().duty   # the hold duty the board applies: 12 ms on in a 20 ms period
    0.6
    """

    contract_ms: float = 1000.0
    hold_duty: float = 0.6
    relax_ms: float = 1100.0
    max_full_ms: float = 3000.0
    period_ms: int = 20

    def __post_init__(self) -> None:
        for key, (what, lo, hi) in THERMAL_KEYS.items():
            v = getattr(self, key)
            if isinstance(v, int) and not isinstance(v, bool) and abs(v) > 1e300:  # any length: never converted
                raise BhrError(f"thermal.{key} ({what}) must be between {lo:g} and {hi:g}, got {excerpt(v)}")
            if not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
                raise BhrError(f"thermal.{key} ({what}) must be between {lo:g} and {hi:g}, got {v!r}")
        if self.max_full_ms <= 1.5 * self.contract_ms:
            raise BhrError(f"thermal.max_full_ms ({self.max_full_ms:g}) must exceed 1.5 x contract_ms "
                           f"({self.contract_ms:g}): the drive needs room above the contraction")
        if int(self.period_ms) != self.period_ms:
            raise BhrError(f"thermal.period_ms must be a whole number of milliseconds, got {self.period_ms}")
        if not 1 <= self.hold_ticks < self.period_ms:
            raise BhrError(f"thermal.hold_duty {self.hold_duty:g} leaves no PWM off-time in a "
                           f"{self.period_ms} ms period; use a lower duty")

    # -- the PWM the board really applies ------------------------------------
    @property
    def hold_ticks(self) -> int:
        """Milliseconds on in each PWM period while holding."""
        return int(round(self.hold_duty * self.period_ms))

    @property
    def duty(self) -> float:
        """The hold duty the board applies (hold_ticks / period_ms)."""
        return self.hold_ticks / self.period_ms

    # -- derived dynamics (float) -------------------------------------------
    @property
    def theta_full(self) -> float:
        return 1.0 / self.duty

    @property
    def tau_ms(self) -> float:
        return self.contract_ms / math.log(1.0 / (1.0 - self.duty))

    @property
    def theta_relax(self) -> float:
        return math.exp(-self.relax_ms / self.tau_ms)

    @property
    def theta_limit(self) -> float:
        return self.theta_full * (1.0 - math.exp(-self.max_full_ms / self.tau_ms))

    def describe(self) -> str:
        """The figures in one line of words, as ``bhr plan`` prints them.

        Returns
        -------
        str
            The four figures (ms, duty) and the thermal model's derived time constant and states.

        Examples
        --------
        >>> ThermalParams().describe().split(", relaxation")[0]
        'contraction 1000 ms at full power, hold duty 60% (12/20 ms)'
        """
        return (f"contraction {self.contract_ms:g} ms at full power, hold duty {self.duty:.0%} "
                f"({self.hold_ticks}/{self.period_ms} ms), relaxation {self.relax_ms:g} ms, full-power limit "
                f"{self.max_full_ms:g} ms (tau {self.tau_ms:.0f} ms, theta_relax {self.theta_relax:.3f}, "
                f"theta_limit {self.theta_limit:.3f})")


DEFAULT_THERMAL = ThermalParams()


def thermal_from_table(table: Any, where: str = "thermal") -> ThermalParams:
    """A robot file's ``[thermal]`` table as ThermalParams (keys left out keep their defaults)."""
    if not isinstance(table, Mapping):
        raise BhrError(f"{where} must be a table ([thermal]) with keys {', '.join(THERMAL_KEYS)}")
    unknown = [k for k in table if k not in THERMAL_KEYS]
    if unknown:
        raise BhrError(f"{where}: unknown key {excerpt(unknown[0])}; known keys: {', '.join(THERMAL_KEYS)}")
    vals: dict[str, Any] = {}
    for k, v in table.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise BhrError(f"{where}.{k} must be a number, got {type(v).__name__}")
        v = check_number(v, f"{where}.{k}", limit=1e300)  # the one checker: any length, denormals
        vals[k] = float(v) if k != "period_ms" else (int(v) if float(v).is_integer() else v)
    try:
        return ThermalParams(**vals)
    except BhrError as exc:
        raise BhrError(f"{where}: {exc}") from None


# ---------------------------------------------------------------------------
# the wire's contraction: strain against the normalised temperature theta, with the transformation's hysteresis

#: Transformation temperatures (deg C) of Dynalloy's 70 deg C "LT" Flexinol wire (the defaults' wire): austenite
#: start and finish on heating (the wire contracts between them), martensite start and finish on cooling (it
#: relaxes between them). Dynalloy, *Technical Characteristics of Flexinol Actuator Wires* (F1140 Rev I.2), the
#: figure "Typical Temperature vs. Strain Characteristics" for the LT alloy at 172 MPa, read to the degree.
FLEXINOL_LT_C: dict[str, float] = {"As": 68.0, "Af": 78.0, "Ms": 52.0, "Mf": 42.0}


def transform_thetas(params: ThermalParams, temps: Mapping[str, float] = FLEXINOL_LT_C) -> tuple[float, ...]:
    """(As, Af, Ms, Mf) as normalised temperatures theta of the thermal model (docs/thermal.md).

    The thermal model puts theta = 1 at the end of the austenite transformation (Af: fully contracted) and a wire
    is relaxed at ``theta_relax`` (Mf: fully stretched back); the temperature is taken linear in theta between
    the two, which places As and Ms. With the defaults: 0.824, 1, 0.541, 0.365.
    """
    tr = params.theta_relax
    af, mf = temps["Af"], temps["Mf"]

    def th(t: float) -> float:
        return tr + (t - mf) / (af - mf) * (1.0 - tr)

    return th(temps["As"]), th(af), th(temps["Ms"]), th(mf)


def contraction_reference(theta_path: Any, thetas: tuple[float, ...], s0: float = 0.0) -> list[float]:
    """The wire's contraction fraction (0 stretched, 1 fully contracted) along a path of temperatures (numpy-free
    reference of :func:`bhr._run.motion.contraction`): a play hysteresis between the heating branch (As..Af) and
    the cooling branch (Mf..Ms), each a half cosine (Liang and Rogers, J. Intell. Mater. Syst. Struct. 1, 1990)."""
    a_s, a_f, m_s, m_f = thetas
    out = []
    s = s0
    for th in theta_path:
        heat = 0.0 if th <= a_s else 1.0 if th >= a_f else 0.5 - 0.5 * math.cos(math.pi * (th - a_s) / (a_f - a_s))
        cool = 1.0 if th >= m_s else 0.0 if th <= m_f else 0.5 - 0.5 * math.cos(math.pi * (th - m_f) / (m_s - m_f))
        s = min(cool, max(heat, s))
        out.append(s)
    return out
