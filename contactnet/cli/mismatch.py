"""The model-mismatch options of ``simulate`` and ``experiment`` (``--mass-scale``, ``--payload``, ``--friction``, ...): the
simulated robot differs from the model the planner and the controller use (``contactnet.sim.mismatch``)."""

from __future__ import annotations

import argparse

from contactnet.cli.types import UserError, bounded_float


def mismatch_of(args: argparse.Namespace):  # noqa: ANN202 - a ModelMismatch
    """The model mismatch the options ask for (neutral without them)."""
    from contactnet.sim.mismatch import ModelMismatch, parse_payload

    try:
        payload_kg, offset = parse_payload(args.payload) if args.payload else (0.0, (0.0, 0.0))
        return ModelMismatch(mass_scale=args.mass_scale, payload_kg=payload_kg, payload_offset_xy_m=offset,
                             friction=args.friction, torque_scale=args.torque_scale,
                             orientation_noise_rad=args.orientation_noise, lin_vel_noise_m_s=args.velocity_noise,
                             ang_vel_noise_rad_s=args.gyro_noise, delay_ms=args.delay_ms)
    except ValueError as exc:
        raise UserError(str(exc).replace("model mismatch: ", "")) from None


def add_mismatch_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of a robot that differs from its model (``contactnet.sim.mismatch``), as one group."""
    from contactnet.sim.mismatch import LIMITS

    group = parser.add_argument_group(
        "model mismatch", "the simulated robot differs from the model; the planner and the controller do not know it")
    group.add_argument("--mass-scale", type=bounded_float("--mass-scale", *LIMITS["mass_scale"]), default=1.0,
                       metavar="S", help="every link's mass and inertia times S")
    group.add_argument("--payload", metavar="KG[,DX,DY]",
                       help="a mass fixed to the base, DX, DY metres from the base origin (base frame)")
    group.add_argument("--friction", type=bounded_float("--friction", *LIMITS["friction"]), default=None,
                       metavar="MU", help="the foot-ground friction coefficient (default 0.81: 0.9 x 0.9)")
    group.add_argument("--torque-scale", type=bounded_float("--torque-scale", *LIMITS["torque_scale"]),
                       default=1.0, metavar="S", help="the motors' torque limits times S")
    group.add_argument("--orientation-noise", type=bounded_float("--orientation-noise",
                                                                  *LIMITS["orientation_noise_rad"]),
                       default=0.0, metavar="RAD", help="std of the measured base orientation's error, per axis")
    group.add_argument("--velocity-noise", type=bounded_float("--velocity-noise", *LIMITS["lin_vel_noise_m_s"]),
                       default=0.0, metavar="M_S", help="std of the measured base linear velocity's error")
    group.add_argument("--gyro-noise", type=bounded_float("--gyro-noise", *LIMITS["ang_vel_noise_rad_s"]),
                       default=0.0, metavar="RAD_S", help="std of the measured base angular velocity's error")
    group.add_argument("--delay-ms", type=bounded_float("--delay-ms", *LIMITS["delay_ms"]), default=0.0,
                       metavar="MS", help="the torques act this long after they were computed")


__all__ = ["add_mismatch_arguments", "mismatch_of"]
