"""Solo12 (ODRI, 2.5 kg, 12 torque-controlled joints): the paper's robot, from example-robot-data.

Measured facts this spec relies on (pinocchio and PyBullet agree): total mass 2.500 kg; HAA at
(+-0.1946, +-0.0875, 0), HFE 0.014 m further out; thigh and shank 0.16 m; the foot is a ball of radius
about 0.016 m (the foot mesh spans +-0.016 m); `straight_standing` puts the feet 0.2229 m below the base.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from contactnet.robots.description import RobotSpec

#: Radius of the foot ball (the foot mesh spans +-0.016 m), in m.
FOOT_RADIUS_M = 0.016
#: Peak torque of a Solo12 actuator (0.025 N m/A x gear 9 x 12 A), in N m.
TORQUE_LIMIT_NM = 2.7


def collision_recipe(link_name: str) -> tuple[ET.Element, str] | None:
    """PyBullet collisions: each foot a ball of the foot's radius (the mesh foot simulates about half as
    fast), each lower leg a thin cylinder that stops above the foot ball, so a contact of the lower leg
    means the shin touched something."""
    if link_name.endswith("_FOOT"):
        return ET.Element("sphere", radius=f"{FOOT_RADIUS_M}"), "0 0 0"
    if link_name.endswith("_LOWER_LEG"):
        side_y = 0.008 if link_name[1] == "L" else -0.008
        return ET.Element("cylinder", radius="0.011", length="0.125"), f"0 {side_y} -0.0725"
    return None


SPEC = RobotSpec(
    name="solo12",
    description="Solo12 (ODRI), 2.5 kg, the ContactNet paper's robot",
    description_dir="solo_description",
    urdf="robots/solo12.urdf",
    srdf="srdf/solo.srdf",
    standing_pose="straight_standing",
    leg_prefixes=("FL", "FR", "HL", "HR"),
    joint_suffixes=("HAA", "HFE", "KFE"),
    foot_suffix="FOOT",
    foot_radius_m=FOOT_RADIUS_M,
    torque_limit_nm=TORQUE_LIMIT_NM,
    # One foot may carry the whole robot (25 N, its weight); Solo12's knees saturate about there.
    fz_max_n=25.0,
    # The hip (HFE) stands 0.24 m above the ground: 0.12 m horizontally keeps the leg well inside reach.
    kin_threshold_m=0.12,
    fall_base_height_m=0.10,
    # walk_crouch_m stays 0: 2 cm lower held 10 N pushes far better but lost feet into gaps with friction 0.5
    # (docs/results.md, "The walk 2 cm lower (measured, not the default)").
    # On terrain of one level the feet stand 2.2 cm wider each side (0.169 m from the centre line, not 0.147 m): pushes
    # from the side no longer tip it over; on terrain with heights the legs would meet the tops, so there the stance
    # stays the SRDF's (docs/results.md, "A wider stance on terrain of one level").
    one_level_stance_abduction_rad=0.1,
    # On terrain with heights each stance foot keeps at least 4 % of the weight (0.98 N, not 0.5 N): a foot on a
    # stone's edge planned unloaded while another leg swings slid off it (MuJoCo's raised stones); on one level the
    # same press cost the narrow stones and pushes (docs/results.md, "Stance feet pressed on terrain with heights").
    heights_controller_gains=(("fz_min_n", 0.98),),
    collision_recipe=collision_recipe,
    recipe_version="sphere-feet-v1",
)
