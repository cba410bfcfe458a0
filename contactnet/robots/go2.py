"""Unitree Go2 (about 16 kg, 12 joints), from example-robot-data's `go2_description`.

Its legs are named FL, FR, RL, RR (hip, thigh, calf joints); the hind legs map onto our HL, HR. Torque
limits come from the URDF (23.7 N m at hip and thigh, 45.43 N m at the knee). The foot is a ball of
about 2.2 cm radius at the `*_foot` frame (the collision mesh spans 4.5 x 4 x 3.9 cm).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from contactnet.robots.description import RobotSpec

FOOT_RADIUS_M = 0.022


#: The calf (its frame at the knee, the foot 0.213 m below along -z) as two cylinders along the visual mesh's
#: centre line, which bends 2 cm forward (+x) in the middle: (bottom xz, top xz, radius), metres. The lower one
#: stops 6 mm above the foot ball, as Solo12's shin does.
CALF_CYLINDERS_M = (((0.020, -0.130), (-0.003, 0.0), 0.014), ((0.012, -0.185), (0.020, -0.130), 0.013))


def _cylinder_between(bottom_xz: tuple[float, float], top_xz: tuple[float, float],
                      radius_m: float) -> tuple[ET.Element, str, str]:
    """A cylinder from ``bottom_xz`` to ``top_xz`` (link frame, y = 0): its element, origin xyz and rpy."""
    dx, dz = top_xz[0] - bottom_xz[0], top_xz[1] - bottom_xz[1]
    length = math.hypot(dx, dz)
    centre_x, centre_z = 0.5 * (top_xz[0] + bottom_xz[0]), 0.5 * (top_xz[1] + bottom_xz[1])
    pitch = math.atan2(dx, dz)  # turns the cylinder's z axis onto the segment
    shape = ET.Element("cylinder", radius=f"{radius_m}", length=f"{length:.5f}")
    return shape, f"{centre_x:.5f} 0 {centre_z:.5f}", f"0 {pitch:.5f} 0"


def collision_recipe(link_name: str) -> tuple[ET.Element, str] | list[tuple[ET.Element, str, str]] | None:
    """PyBullet collisions: each foot a ball of the foot's radius; each calf two cylinders along its bend that stop
    above the foot ball (the URDF's two convex hulls fill the bend and wrap the foot: they reach 3-5 mm beyond the
    ball beside it, so a foot brushing a riser counted as the calf touching it); the other links keep their convex
    meshes."""
    if link_name.endswith("_foot"):
        return ET.Element("sphere", radius=f"{FOOT_RADIUS_M}"), "0 0 0"
    if link_name.endswith("_calf"):
        return [_cylinder_between(*cylinder) for cylinder in CALF_CYLINDERS_M]
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
    # On terrain of one level the joints hold the legs' own weight: a stance leg planned with almost no load keeps its
    # pose (limp, its foot slid off its top under a side push); measured to lose runs on heights, so not there
    # (docs/results.md, "Go2's legs hold their own weight"). And the feedback wrench a foot would pull for is spread
    # again over the other feet (two rounds): clipped instead, it lifted the body while a side push had the windward
    # feet unloaded, and the roll grew between re-solves (docs/results.md, "Go2's feedback spread again").
    one_level_controller_gains=(("leg_gravity", 1.0), ("unload_rounds", 2)),
    # On terrain of one level the trot's feet stand 2.9 cm wider each side (0.171 m from the centre line, not 0.142 m):
    # its side pushes no longer tip it over on its two stance feet; the walk keeps the SRDF's stance, with which it
    # lost fewer feet into gaps (docs/results.md, "Go2's trot stands wider on terrain of one level").
    one_level_stance_abduction_rad=0.1,
    one_level_stance_gaits=("trot",),
    # On terrain of one level a foot that bracing puts down on the push's side lands 5 cm farther along the push: met
    # as a front foot lifted, a 32.2 N side push asked a centre of pressure beyond the other three feet; with the CoM
    # reference held while braced (it had taken the body on over a stretched hind leg) none of 800 32.2 N pushes fell
    # (docs/results.md, "Held still while braced (the default), and Go2's foot braced outward").
    brace_outward_m=0.05,
    collision_recipe=collision_recipe,
    recipe_version="sphere-feet-calf-cylinders-v2",
)
