"""Height-aware footholds: which candidate footholds a leg can use on a terrain whose tops are at several heights.

On flat ground a foothold is usable when it is safe (``Terrain.is_safe``: on a top, away from its edges).
With heights a foot can also be blocked by the terrain around it, so a candidate is usable only if, besides
being safe:

1. **reach**: the foot-ball centre on that top lies within the leg's 3D reach (``leg_reach_m`` less a
   margin) of the hip predicted at touchdown, and at most ``max_lean_m`` sideways from the leg's plane
   (where its foot stands in the nominal stance): a leg leaning further sweeps its shin over the tops
   beside the foot, which the checks below (made in the leg's plane, leaning with it) do not see well.
   Hips ride at the nominal CoM height over the feet's support, the body pitched with the feet
   (``contactnet.ground``), the landing leg on its candidate;
2. **swing**: the step from the lift-off top to the landing top, and any terrain along the straight path
   between them above the higher of the two, is at most ``max_step_m`` (what the swing can clear);
3. **foot ball**: no higher top within a ring just outside the ball (its side would hit a riser);
4. **leg**: the terrain on the knee's side of the foot stays below the leg (shank, knee, thigh). The
   further the hip is from the foot toward the knee, and the lower it is, the flatter the shank and the
   lower the knee. Two poses are checked: at touchdown, with the hip where it is predicted (plus
   ``shin_lever_margin_m`` toward the knee, for the swing's last descent and tracking errors) and at most
   its nominal height above the foot; and, for a leg whose knee points forward (the body moves toward
   its knee during the stance: a hind leg of Solo12), late in the stance, the hip ``stance_travel_m``
   further than at touchdown, back at its nominal height above the foot (the other legs have followed). The
   shank's axis must pass ``shin_clearance_m`` above the terrain, the knee ``knee_clearance_m`` (also
   ``knee_reach_m`` beyond it: the joint's housing), the thigh's axis ``thigh_clearance_m``.

Before the checks, a candidate on a small top (a 5 cm square of ``random_heights``: its largest disk at most
``small_top_inradius_m``) moves to that top's centre (``FootholdChecker.centred``), where its ball is farthest
from the risers around it; bigger tops (stair treads, stones) keep the candidate grid as it is.

The checks sample ``Terrain.height_bound`` (a raster lookup, exact away from the tops' outlines and a few mm
conservative next to them) at a fixed number of points per candidate, so they cost the same whatever the
number of holes. A terrain with one level (every top at the same height)
needs none of them: ``FootholdChecker.applies`` is False and planners take their flat-ground path.

Geometry: each leg is a thigh and a shank in its sagittal (x-z) plane, lengths and the side its knee bends
to from the robot's nominal stance (``RobotDescription.knee_pos_base``). Without knee positions the shin
is checked on both sides at ``fallback_shin_elevation_rad``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from contactnet.ground import body_pitch, front_to_hind_m
from contactnet.robots.description import RobotDescription
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class HeightChecks:
    """Limits of the height checks (metres unless named)."""

    max_step_m: float = 0.13  # largest rise or drop between lift-off and landing tops, and obstacle above them
    reach_margin_m: float = 0.015  # the foot stays this much inside the leg's straight length
    ball_clearance_m: float = 0.008  # higher tops stay this far beyond the foot ball's radius
    ball_tolerance_m: float = 0.004  # ... unless they are at most this much higher
    shin_clearance_m: float = 0.018  # the shin's axis passes this high above the terrain (its radius + margin)
    shin_lever_margin_m: float = 0.03  # added to the hip's predicted offset past the foot toward the knee
    stance_travel_m: float = 0.06  # how far the body may move over a stance (legs whose knee points forward)
    min_shin_lever_m: float = 0.0  # the offset used at least
    shin_half_width_m: float = 0.012  # the shin is checked on lines this far to each side of its axis
    shin_samples: int = 8  # points along the shin (each on three lines)
    knee_clearance_m: float = 0.03  # the knee joint passes this high above the terrain (its housing's radius) ...
    knee_reach_m: float = 0.02  # ... also this far beyond it, toward the knee side
    thigh_clearance_m: float = 0.03  # the thigh's axis (from the knee up) passes this high above the terrain
    thigh_samples: int = 2  # points along the thigh, beyond the knee
    path_samples: int = 8  # points along the swing path
    max_lean_m: float = 0.03  # a foot further sideways from its leg's plane (nominal stance) ...
    side_reach_m: float = 0.06  # ... needs the ground this far beside it, toward the plane, no higher than its top
    small_top_inradius_m: float = 0.04  # candidates on a top this small (its largest disk) go to its centre
    fallback_shin_elevation_rad: float = math.radians(35.0)  # shin elevation when the knee is not known


@dataclass(frozen=True)
class LegGeometry:
    """The legs in their sagittal planes (base frame, nominal stance), from a robot description."""

    hip_pos_base: np.ndarray  # (4, 3) hip flexion joints
    thigh_m: np.ndarray  # (4,) hip to knee in the x-z plane
    shank_m: np.ndarray  # (4,) knee to foot-ball centre in the x-z plane
    knee_side: np.ndarray  # (4,) +1: the knee points forward (+x of the base), -1 backward, 0 unknown
    reach_m: float  # straight-leg length, hip to foot-ball centre
    foot_radius_m: float
    hip_from_com_base: np.ndarray  # (4, 3) hips relative to the CoM in the nominal stance
    hip_above_foot_m: np.ndarray  # (4,) hip height above the foot-ball centre in the nominal stance
    plane_left_m: np.ndarray  # (4,) the leg's plane (where its foot stands, nominal stance) left of its hip
    com_height_m: float  # nominal CoM height above the ground
    front_to_hind_m: float  # from the hind to the front feet along x, nominal stance

    @classmethod
    def of(cls, robot: RobotDescription) -> LegGeometry:
        hips = np.asarray(robot.hip_pos_base, dtype=float)
        feet = np.asarray(robot.foot_nominal_base, dtype=float)
        knees = None if robot.knee_pos_base is None else np.asarray(robot.knee_pos_base, dtype=float)
        if knees is None:
            half = np.full(4, 0.5 * robot.leg_reach_m)
            thigh, shank, side = half, half, np.zeros(4)
        else:
            thigh = np.hypot(*(knees - hips)[:, [0, 2]].T)
            shank = np.hypot(*(feet - knees)[:, [0, 2]].T)
            # Which side of the hip-foot line the knee lies on, along x.
            side = np.sign(knees[:, 0] - 0.5 * (hips[:, 0] + feet[:, 0]))
        return cls(hips, thigh, shank, side, float(robot.leg_reach_m), float(robot.foot_radius_m),
                   hips - np.asarray(robot.com_base_standing, dtype=float), hips[:, 2] - feet[:, 2],
                   feet[:, 1] - hips[:, 1], float(robot.com_height_nominal_m), front_to_hind_m(feet))

    def hip_heights(self, com_z_world: float | np.ndarray, pitch_rad: float | np.ndarray) -> np.ndarray:
        """(..., 4) world z of the hips with the CoM at ``com_z_world`` and the body pitched by ``pitch_rad``
        (positive nose down), no roll; both (...) or scalars."""
        offset = self.hip_from_com_base
        com_z = np.asarray(com_z_world, dtype=float)[..., None]
        pitch = np.asarray(pitch_rad, dtype=float)[..., None]
        return com_z + offset[:, 2] * np.cos(pitch) - offset[:, 0] * np.sin(pitch)

    def hips_over_tops(self, tops_z: np.ndarray) -> np.ndarray:
        """(..., 4) world z of the hips when the feet stand on ``tops_z`` (..., 4): the CoM at the nominal height
        over their support, the body pitched with them (``contactnet.ground``)."""
        tops = np.asarray(tops_z, dtype=float)
        return self.hip_heights(tops.mean(axis=-1) + self.com_height_m, body_pitch(tops, self.front_to_hind_m))


def segment_samples(start_xy: np.ndarray, end_xy: np.ndarray, n: int) -> np.ndarray:
    """(M, n, 2) points strictly between each start (M, 2) and end (M, 2), evenly spaced."""
    fractions = (np.arange(1, n + 1) / (n + 1))[None, :, None]
    start = np.asarray(start_xy, dtype=float)[:, None]
    return start + fractions * (np.asarray(end_xy, dtype=float)[:, None] - start)


def path_top_z(terrain: Terrain, start_xy: np.ndarray, end_xy: np.ndarray, n: int = 8) -> np.ndarray:
    """(M,) the highest top under the straight path from each start to each end (ends included); -inf
    where the whole path is over holes."""
    start = np.asarray(start_xy, dtype=float).reshape(-1, 2)
    end = np.asarray(end_xy, dtype=float).reshape(-1, 2)
    points = np.concatenate([start[:, None], segment_samples(start, end, n), end[:, None]], axis=1)
    heights = terrain.height_at(points.reshape(-1, 2), outside=-np.inf).reshape(len(start), -1)
    return heights.max(axis=1)


class FootholdChecker:
    """The height checks of candidate footholds (see the module doc) for one robot."""

    def __init__(self, robot: RobotDescription, checks: HeightChecks = HeightChecks()) -> None:
        self.legs = LegGeometry.of(robot)
        self.checks = checks
        k = checks.shin_samples
        self._shin_fractions = (np.arange(1, k + 1) / k)[None, :]  # along the shank's horizontal extent
        self._thigh_fractions = (np.arange(1, checks.thigh_samples + 1) / (checks.thigh_samples + 1))[None, :]
        self._knee_fractions = np.array([[0.0, 0.5, 1.0]])
        self._side_offsets = np.linspace(0.0, checks.side_reach_m, 5)[1:]
        ring = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
        ring_radius = self.legs.foot_radius_m + checks.ball_clearance_m
        self._ring = np.column_stack([np.cos(ring), np.sin(ring)]) * ring_radius

    def centred(self, terrain: Terrain, points_xy_world: np.ndarray) -> np.ndarray:
        """(N, 2) the candidate footholds (N, 2) with those on a small top (inradius at most
        ``small_top_inradius_m``: a stepping square, not a stair tread) moved to that top's centre, where the
        foot ball is farthest from its risers; the others unchanged."""
        points = np.array(points_xy_world, dtype=float).reshape(-1, 2)
        parts = terrain.top_parts()
        part = parts.part_at(points)
        small = (part >= 0) & (parts.inradius_m[part] <= self.checks.small_top_inradius_m)
        points[small] = parts.centres_xy[part[small]]
        return points

    @staticmethod
    def applies(terrain: Terrain) -> bool:
        """Whether the terrain has tops at more than one height (else every check passes)."""
        return len(terrain.levels) > 1

    def usable(
        self,
        terrain: Terrain,
        legs: np.ndarray,
        landing_xy_world: np.ndarray,
        liftoff_xy_world: np.ndarray,
        hip_xy_world: np.ndarray,
        tops_z: np.ndarray,
        yaw_rad: float,
    ) -> np.ndarray:
        """(M,) bool: which landings pass the height checks. ``legs`` (M,) int, ``landing_xy_world`` (M, 2)
        the candidate footholds, ``liftoff_xy_world`` (M, 2) where each of those legs stands now,
        ``hip_xy_world`` (M, 2) each leg's hip (flexion joint) predicted at touchdown, ``tops_z`` (4,) the
        tops under the four feet now (the hips' heights at touchdown follow them, with the landing leg's
        top replaced by its candidate's: ``LegGeometry.hips_over_tops``). Points with no top under them are
        not usable."""
        checks = self.evaluate(terrain, legs, landing_xy_world, liftoff_xy_world, hip_xy_world, tops_z, yaw_rad,
                               reachable_only=True)
        return checks["top"] & checks["reach"] & checks["step"] & checks["ball"] & checks["leg"]

    def evaluate(
        self,
        terrain: Terrain,
        legs: np.ndarray,
        landing_xy_world: np.ndarray,
        liftoff_xy_world: np.ndarray,
        hip_xy_world: np.ndarray,
        tops_z: np.ndarray,
        yaw_rad: float,
        reachable_only: bool = False,
    ) -> dict[str, np.ndarray]:
        """Each check of ``usable`` on its own, (M,) bool each: "top" (a top under the point), "reach",
        "step" (the swing), "ball", "leg" (shin and thigh). ``reachable_only``: the terrain checks ("step",
        "ball", "leg") run only for the points with a top and in reach, and are False for the others (what
        ``usable`` needs, for a third of the work on the trot's grid)."""
        checks, geo = self.checks, self.legs
        legs = np.asarray(legs, dtype=np.intp)
        landing = np.asarray(landing_xy_world, dtype=float).reshape(-1, 2)
        m = len(landing)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        forward, left = np.array([c, s]), np.array([-s, c])
        tops_z = np.asarray(tops_z, dtype=float).reshape(4)

        top = terrain.height_at(landing)
        foot_z = top + geo.foot_radius_m
        after = np.repeat(tops_z.reshape(1, 4), m, axis=0)
        after[np.arange(m), legs] = top
        hip_z = np.take_along_axis(geo.hips_over_tops(after), legs[:, None], axis=1)[:, 0]
        hip_xy = np.asarray(hip_xy_world, dtype=float).reshape(-1, 2)
        toward_plane = (hip_xy - landing) @ left + geo.plane_left_m[legs]  # the foot's offset from its leg's plane
        result = {"top": np.isfinite(top)}
        # 1. reach from the hip predicted at touchdown, the leg leaning at most max_lean_m.
        reach = np.sqrt(np.sum((hip_xy - landing) ** 2, axis=1) + (hip_z - foot_z) ** 2)
        result["reach"] = reach <= geo.reach_m - checks.reach_margin_m
        leaning = (np.abs(toward_plane) > checks.max_lean_m).nonzero()[0]
        if leaning.size:  # a leaning leg sweeps its shin over the ground beside the foot: that must be no higher,
            beside = (landing[leaning, None] + np.sign(toward_plane[leaning])[:, None, None]
                      * self._side_offsets[None, :, None] * left)
            side_z = terrain.height_bound(beside.reshape(-1, 2), outside=-np.inf).reshape(len(leaning), -1)
            parts = terrain.top_parts()  # ... and the foot not on a small top (the shin would pass over its edge)
            part = parts.part_at(landing[leaning])
            small = (part >= 0) & (parts.inradius_m[part] <= checks.small_top_inradius_m)
            result["reach"][leaning] &= (side_z.max(axis=1) <= top[leaning] + checks.ball_tolerance_m) & ~small
        rows = (result["top"] & result["reach"]).nonzero()[0] if reachable_only else np.arange(m)
        clear = self._clearance(terrain, legs[rows], landing[rows],
                                np.asarray(liftoff_xy_world, dtype=float).reshape(-1, 2)[rows], hip_xy[rows],
                                top[rows], hip_z[rows], toward_plane[rows], tops_z, forward, left)
        for name, value in clear.items():
            result[name] = np.zeros(m, dtype=bool)
            result[name][rows] = value
        return result

    def _clearance(self, terrain: Terrain, legs: np.ndarray, landing: np.ndarray, liftoff: np.ndarray,
                   hip_xy: np.ndarray, top: np.ndarray, hip_z: np.ndarray, toward_plane: np.ndarray,
                   tops_z: np.ndarray, forward: np.ndarray, left: np.ndarray) -> dict[str, np.ndarray]:
        """The terrain checks "step", "ball" and "leg" of landings (M,) (see ``evaluate``)."""
        checks, geo = self.checks, self.legs
        m = len(landing)
        if not m:
            return {name: np.zeros(0, dtype=bool) for name in ("step", "ball", "leg")}
        foot_z = top + geo.foot_radius_m
        # 4. the leg's shallowest poses (see the module doc): at touchdown, and late in the stance for a leg
        # whose knee points forward (toward where the body goes), with its hip at the nominal height then.
        side = geo.knee_side[legs]
        ahead = (hip_xy - landing) @ forward  # (M,) how far the hip is ahead of the foot at touchdown
        toward_knee = np.where(side != 0, side * ahead, np.abs(ahead))
        lever = np.maximum(toward_knee + checks.shin_lever_margin_m, checks.min_shin_lever_m)
        nominal = geo.hip_above_foot_m[legs]
        rise = np.clip(hip_z - foot_z, 1e-6, nominal)
        late = side >= 0
        both_rise = np.concatenate([rise, np.where(late, nominal, rise)])
        d, allowed_z, up = self._leg_outline(
            np.concatenate([legs, legs]), np.concatenate([foot_z, foot_z]),
            np.concatenate([lever, np.where(late, toward_knee + checks.stance_travel_m, lever)]), both_rise)
        # The leg leans sideways from the foot toward its plane: its points shift along ``left`` with their height.
        # (By at most max_lean_m: a leg leaning further has had the ground beside its foot checked instead.)
        lean = np.clip(np.tile(toward_plane, 2), -checks.max_lean_m, checks.max_lean_m)[:, None] * up / both_rise[:, None]
        d, allowed_z, lean = (np.concatenate([a[:m], a[m:]], axis=1) for a in (d, allowed_z, lean))
        shin_both = self._outline_points(landing, d, lean, side, forward, left)
        # The points to look up at once: swing path and leg outline (an upper bound of the tops is enough there),
        # then the ball ring (exact: on a small top it lies a few mm inside the top's edges).
        path = segment_samples(liftoff, landing, checks.path_samples)  # (M, P, 2)
        points = np.concatenate([path.reshape(-1, 2), shin_both.reshape(-1, 2)])
        heights = terrain.height_bound(points, outside=-np.inf)
        path_z = heights[: m * checks.path_samples].reshape(m, -1)
        leg_z = heights[m * checks.path_samples:].reshape(m, d.shape[1], -1)
        ring_z = terrain.height_at((landing[:, None] + self._ring).reshape(-1, 2), outside=-np.inf).reshape(m, -1)
        # 2. swing: the step and any obstacle on the way.
        start_top = tops_z[legs]  # each leg lifts off from where it stands
        higher_end = np.maximum(start_top, top)
        return {
            "step": ((np.abs(top - start_top) <= checks.max_step_m)
                     & (path_z.max(axis=1, initial=-np.inf) - higher_end <= checks.max_step_m)),
            # 3. the ball's side.
            "ball": ring_z.max(axis=1, initial=-np.inf) <= top + checks.ball_tolerance_m,
            # 4. the shin and the thigh above the terrain.
            "leg": np.all(leg_z <= allowed_z[:, :, None], axis=(1, 2)),
        }

    def stance_clear(self, terrain: Terrain, feet_xy_world: np.ndarray, tops_z: np.ndarray,
                     hip_xy_world: np.ndarray, yaw_rad: float) -> np.ndarray:
        """(4,) bool: whether each leg, standing where it is (``feet_xy_world`` (4, 2) on ``tops_z`` (4,)), keeps
        its shank, knee and thigh clear of the terrain with its hip at ``hip_xy_world`` (4, 2) (e.g. where the
        body will be a while later) and the body at the nominal height over the feet. A leg that fails should
        swing soon: its stance is turning its lower leg onto an edge."""
        geo = self.legs
        legs = np.arange(4)
        feet = np.asarray(feet_xy_world, dtype=float).reshape(4, 2)
        tops = np.asarray(tops_z, dtype=float).reshape(4)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        forward, left = np.array([c, s]), np.array([-s, c])
        side = geo.knee_side
        ahead = (np.asarray(hip_xy_world, dtype=float).reshape(4, 2) - feet) @ forward
        foot_z = tops + geo.foot_radius_m
        rise = np.clip(geo.hips_over_tops(tops) - foot_z, 1e-6, geo.hip_above_foot_m)
        lever = np.where(side != 0, side * ahead, np.abs(ahead))
        d, allowed_z, up = self._leg_outline(legs, foot_z, lever, rise)
        toward_plane = (np.asarray(hip_xy_world, dtype=float).reshape(4, 2) - feet) @ left + geo.plane_left_m
        lean = toward_plane[:, None] * up / rise[:, None]
        points = self._outline_points(feet, d, lean, side, forward, left)
        heights = terrain.height_bound(points.reshape(-1, 2), outside=-np.inf).reshape(4, d.shape[1], -1)
        return np.all(heights <= allowed_z[:, :, None], axis=(1, 2)) | ~np.isfinite(tops)

    def _outline_points(self, feet: np.ndarray, d: np.ndarray, lean: np.ndarray, side: np.ndarray,
                        forward: np.ndarray, left: np.ndarray) -> np.ndarray:
        """(M, S, L, 2) the points under a leg outline: ``d`` (M, S) from the feet (M, 2) toward the knee side and
        ``lean`` (M, S) along ``left``, on three lines (the axis and ``shin_half_width_m`` to each side), both
        sides for an unknown knee."""
        directions = np.where(side[:, None] != 0, side[:, None], 1.0)[:, :, None] * forward  # (M, 1, 2)
        offsets = np.array([0.0, self.checks.shin_half_width_m, -self.checks.shin_half_width_m])
        points = (feet[:, None, None] + d[:, :, None, None] * directions[:, :, None]
                  + (lean[:, :, None] + offsets[None, None, :])[..., None] * left)  # (M, S, 3, 2)
        if np.any(side == 0):  # unknown knee: the other side too
            points = np.concatenate([points, 2.0 * feet[:, None, None] - points], axis=2)
        return points

    def _leg_outline(self, legs: np.ndarray, foot_z: np.ndarray, lever: np.ndarray,
                     rise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The lower outline of legs in one pose each: the hip ``lever`` (M,) past the foot toward the knee and
        ``rise`` (M,) above the foot-ball centre at ``foot_z`` (M,). Returns horizontal distances from the foot
        toward the knee side (M, S), the heights the terrain must stay below there (the shank's axis less
        its clearance, the knee's housing, then the thigh's axis less its clearance) and the leg's own heights
        there above the foot-ball centre (M, S)."""
        checks, geo = self.checks, self.legs
        side = geo.knee_side[legs]
        thigh, shank = geo.thigh_m[legs], geo.shank_m[legs]
        dist = np.hypot(lever, rise)
        cos_alpha = np.clip((shank**2 + dist**2 - thigh**2) / (2.0 * shank * dist), -1.0, 1.0)
        elevation = np.where(side != 0, np.arctan2(rise, lever) - np.arccos(cos_alpha),
                             checks.fallback_shin_elevation_rad)
        elevation = np.nan_to_num(np.clip(elevation, 0.0, 0.5 * math.pi), nan=0.0)
        extent = shank * np.cos(elevation)  # horizontal length of the shank
        knee_z = foot_z + shank * np.sin(elevation)
        d_shank = extent[:, None] * self._shin_fractions
        z_shank = foot_z[:, None] + d_shank * np.tan(elevation)[:, None] - checks.shin_clearance_m
        d_knee = extent[:, None] + checks.knee_reach_m * self._knee_fractions
        z_knee = np.repeat(knee_z[:, None] - checks.knee_clearance_m, self._knee_fractions.shape[1], axis=1)
        d_thigh = extent[:, None] + self._thigh_fractions * (lever - extent)[:, None]
        z_thigh = (knee_z[:, None] + self._thigh_fractions * (foot_z + rise - knee_z)[:, None]
                   - checks.thigh_clearance_m)
        distances = np.concatenate([d_shank, d_knee, d_thigh], axis=1)
        clearance = np.concatenate([np.full(d_shank.shape[1], checks.shin_clearance_m),
                                    np.full(d_knee.shape[1], checks.knee_clearance_m),
                                    np.full(d_thigh.shape[1], checks.thigh_clearance_m)])
        allowed = np.concatenate([z_shank, z_knee, z_thigh], axis=1)
        return distances, allowed, allowed + clearance - foot_z[:, None]


__all__ = ["FootholdChecker", "HeightChecks", "LegGeometry", "path_top_z", "segment_samples"]
