"""Model mismatch: how the simulated robot differs from the model its planner and controller believe in.

Every field is neutral by default (the simulated robot is exactly the model). None of them is known to the
planner or the controller: they are the simulator's secret, to measure how robust the robot is.

- ``mass_scale``: every link's mass and inertia times this (the whole robot heavier or lighter).
- ``payload_kg`` at ``payload_offset_xy_m`` (base frame, from the base origin): a rigid point-like mass (a 3 cm
  ball without collision) fixed to the base.
- ``friction``: the foot-ground friction coefficient. PyBullet multiplies the two bodies' coefficients: the feet
  get ``friction`` and the ground 1. None keeps the world's own (``SimConfig.foot_friction`` on both bodies).
- ``torque_scale``: the motors' torque limits times this (the controller still plans with the nominal ones).
- Sensor noise beyond the joint velocities, Gaussian, drawn every read: ``orientation_noise_rad`` (a random
  rotation vector of this standard deviation per axis applied to the measured base orientation),
  ``lin_vel_noise_m_s`` and ``ang_vel_noise_rad_s`` (on the measured base velocities). The referee (falls, goal)
  sees the truth.
- ``delay_ms``: the torques take effect this long after they were computed (the control loop's latency,
  rounded to whole time steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

LIMITS = {  # field: (low, high), inclusive
    "mass_scale": (0.2, 5.0),
    "payload_kg": (0.0, 50.0),
    "friction": (0.01, 5.0),
    "torque_scale": (0.05, 5.0),
    "orientation_noise_rad": (0.0, 0.5),
    "lin_vel_noise_m_s": (0.0, 2.0),
    "ang_vel_noise_rad_s": (0.0, 5.0),
    "delay_ms": (0.0, 100.0),
}
PAYLOAD_OFFSET_LIMIT_M = 1.0


@dataclass(frozen=True)
class ModelMismatch:
    """The simulated robot's differences from the model (see the module docstring); neutral by default."""

    mass_scale: float = 1.0
    payload_kg: float = 0.0
    payload_offset_xy_m: tuple[float, float] = (0.0, 0.0)
    friction: float | None = None
    torque_scale: float = 1.0
    orientation_noise_rad: float = 0.0
    lin_vel_noise_m_s: float = 0.0
    ang_vel_noise_rad_s: float = 0.0
    delay_ms: float = 0.0

    def __post_init__(self) -> None:
        for name, (low, high) in LIMITS.items():
            value = getattr(self, name)
            if value is None and name == "friction":
                continue
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and low <= value <= high):
                raise ValueError(f"model mismatch: {name} must be a number in [{low:g}, {high:g}], got {value!r}")
        offset = self.payload_offset_xy_m
        if (not isinstance(offset, tuple | list) or len(offset) != 2
                or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                           and abs(v) <= PAYLOAD_OFFSET_LIMIT_M for v in offset)):
            raise ValueError(f"model mismatch: payload_offset_xy_m must be two numbers within "
                             f"+-{PAYLOAD_OFFSET_LIMIT_M:g} m, got {offset!r}")
        object.__setattr__(self, "payload_offset_xy_m", (float(offset[0]), float(offset[1])))

    @property
    def neutral(self) -> bool:
        """The simulated robot is exactly the model."""
        return self == ModelMismatch()

    @property
    def sensor_noise(self) -> bool:
        """Any noise on the base's measured orientation or velocities."""
        return bool(self.orientation_noise_rad or self.lin_vel_noise_m_s or self.ang_vel_noise_rad_s)

    @staticmethod
    def from_dict(values: dict | None) -> ModelMismatch:
        """The mismatch of a record's trial (``dataclasses.asdict`` of one, lists for tuples); None: neutral."""
        if not values:
            return ModelMismatch()
        return ModelMismatch(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})

    def label(self) -> str:
        """What differs from the model, short (e.g. ``mass1.2,mu0.5``); '' when neutral."""
        parts = []
        for f in fields(self):
            value, default = getattr(self, f.name), f.default
            if value == default:
                continue
            if f.name == "payload_offset_xy_m":
                if self.payload_kg:
                    parts.append(f"at{value[0]:g},{value[1]:g}")
                continue
            parts.append(f"{_SHORT[f.name]}{value:g}")
        return ",".join(parts)


_SHORT = {"mass_scale": "mass", "payload_kg": "payload", "friction": "mu", "torque_scale": "torque",
          "orientation_noise_rad": "rpynoise", "lin_vel_noise_m_s": "vnoise", "ang_vel_noise_rad_s": "wnoise",
          "delay_ms": "delay"}


def parse_payload(text: str) -> tuple[float, tuple[float, float]]:
    """Parse 'KG[,DX,DY]' (kilograms, metres in the base frame) into (kg, (dx, dy))."""
    parts = text.split(",")
    if len(parts) not in (1, 3):
        raise ValueError(f"--payload expects KG or KG,DX,DY, got {text!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"--payload expects numbers KG[,DX,DY], got {text!r}") from None
    kg, dx, dy = (values + [0.0, 0.0])[:3]
    return kg, (dx, dy)
