"""Unitree A1 from example-robot-data's ``a1_description`` (contactnet does not ship it): its names and four numbers.

Everything else (mass 13.7 kg, inertia, hips, stance, torque limits, reach) is read from its URDF and SRDF. Its base
link has no <inertial> block: contactnet gives it a negligible mass, as pinocchio gives it none
(``contactnet robot check a1`` lists it).
"""

from __future__ import annotations

from contactnet.robots import RobotSpec, register_robot

SPEC = RobotSpec(
    name="a1",
    description="Unitree A1, about 14 kg (a plugin: examples/plugin)",
    description_dir="a1_description",
    urdf="urdf/a1.urdf",
    srdf="srdf/a1.srdf",
    standing_pose="standing",
    leg_prefixes=("FL", "FR", "RL", "RR"),
    joint_suffixes=("hip_joint", "thigh_joint", "calf_joint"),
    foot_suffix="foot",
    foot_radius_m=0.02,
    fz_max_n=120.0,  # about its weight (135 N)
    kin_threshold_m=0.15,
    fall_base_height_m=0.12,
)


def register() -> None:
    register_robot(SPEC)
