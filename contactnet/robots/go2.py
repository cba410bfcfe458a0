"""Unitree Go2 (about 16 kg, 12 joints), from example-robot-data's `go2_description`.

Its legs are named FL, FR, RL, RR (hip, thigh, calf joints); the hind legs map onto our HL, HR. Torque
limits come from the URDF (23.7 N m at hip and thigh, 45.43 N m at the knee). The foot is a ball of
about 2.2 cm radius at the `*_foot` frame (the collision mesh spans 4.5 x 4 x 3.9 cm).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from contactnet.robots.description import RobotSpec

FOOT_RADIUS_M = 0.022


def collision_recipe(link_name: str) -> tuple[ET.Element, str] | None:
    """PyBullet collisions: each foot a ball of the foot's radius; the other links keep their convex meshes."""
    if link_name.endswith("_foot"):
        return ET.Element("sphere", radius=f"{FOOT_RADIUS_M}"), "0 0 0"
    return None


SPEC = RobotSpec(
    name="go2",
    description="Unitree Go2, about 16 kg",
    description_dir="go2_description",
    urdf="urdf/go2.urdf",
    srdf="srdf/go2.srdf",
    standing_pose="standing",
    leg_prefixes=("FL", "FR", "RL", "RR"),
    joint_suffixes=("hip_joint", "thigh_joint", "calf_joint"),
    foot_suffix="foot",
    foot_radius_m=FOOT_RADIUS_M,
    # The SRDF's "standing" (thigh 0.785, calf -1.44 rad) puts the feet 2 cm behind the hips; thigh 0.8 and
    # calf -1.6 rad puts them under the hips (thigh and calf are equally long), as Solo12's stance does.
    standing_leg_joints_rad=(0.0, 0.8, -1.6),
    fz_max_n=160.0,  # about its weight (158 N), like Solo12's 25 N
    kin_threshold_m=0.16,  # Solo12's 0.12 m scaled by the leg length (0.426 vs 0.32 m)
    fall_base_height_m=0.14,
    # Legs of about 2 kg (Solo12's: 0.34 kg): stiffer swing tracking and more joint damping.
    controller_gains=(
        ("kp_swing", (900.0, 900.0, 900.0)),
        ("kd_swing", (30.0, 30.0, 30.0)),
        ("kd_joint", 0.2),
    ),
    collision_recipe=collision_recipe,
    recipe_version="sphere-feet-v1",
)
