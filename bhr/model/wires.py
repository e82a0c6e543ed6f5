"""The actuator wires' datasheet figures: the ``[thermal]`` table of a robot file (docs/thermal.md).

:class:`ThermalParams` holds the four figures of a nitinol wire and the PWM
period of the board's drive; :mod:`bhr.hardware.thermal` models what the wires
sustain from them, and the firmware header is generated from them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from bhr.settings.errors import BhrError
from bhr.settings.options import check_number, excerpt

__all__ = ["ThermalParams", "DEFAULT_THERMAL", "THERMAL_KEYS", "thermal_from_table"]

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
    """The wire's four datasheet figures and the PWM period (see the module docstring)."""

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
