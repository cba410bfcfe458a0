"""Height-aware footholds: which candidate footholds a leg can use on a terrain whose tops are at several heights.

On flat ground a foothold is usable when it is safe (``Terrain.is_safe``: on a top, away from its edges).
With heights a foot can also be blocked by the terrain around it, so a candidate is usable only if, besides
being safe:

1. **reach**: the foot-ball centre on that top lies within the leg's 3D reach (``leg_reach_m`` less a
   margin) of the hip predicted at touchdown, and at most ``max_lean_m`` sideways from the leg's plane
   (where its foot stands in the nominal stance): a leg leaning further sweeps its shin over the tops
   beside the foot, which the checks below (made in the leg's plane, leaning with it) do not see well.
   Hips ride at the nominal CoM height over the feet's support, the body pitched with the feet
   (``contactnet.motion.ground``), the landing leg on its candidate;
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
from dataclasses import dataclass, field, fields, replace

import numpy as np

from contactnet.motion.ground import PITCH_SHARE, body_pitch, front_to_hind_m
from contactnet.robots.description import RobotDescription
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class HeightChecks:
    """Limits of the height checks (metres unless named), Solo12's; a planner sizes them to its robot
    (``scaled(size_scale)``, as the gaits are: `contactnet.motion.gait.SIZE_RULE`)."""

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

    def scaled(self, scale: float) -> HeightChecks:
        """The limits for a robot ``scale`` times Solo12's size: every length times ``scale``, counts and angle kept."""
        return replace(self, **{f.name: getattr(self, f.name) * scale for f in fields(self) if f.name.endswith("_m")})


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
    plane_left_m: np.ndarray  # (4,) the leg's plane (where its foot stands upright, nominal stance) left of its hip
    com_height_m: float  # nominal CoM height above the ground
    front_to_hind_m: float  # from the hind to the front feet along x, nominal stance

    @classmethod
    def of(cls, robot: RobotDescription) -> LegGeometry:
        hips = np.asarray(robot.hip_pos_base, dtype=float)
        feet = np.asarray(robot.foot_nominal_base, dtype=float)
        # a widened stance's legs lean: their plane is where the foot stood before (RobotSpec.stance_abduction_rad)
        upright = feet if robot.foot_upright_base is None else np.asarray(robot.foot_upright_base, dtype=float)
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
                   upright[:, 1] - hips[:, 1], float(robot.com_height_nominal_m), front_to_hind_m(feet))

    def hip_heights(self, com_z_world: float | np.ndarray, pitch_rad: float | np.ndarray) -> np.ndarray:
        """(..., 4) world z of the hips with the CoM at ``com_z_world`` and the body pitched by ``pitch_rad``
        (positive nose down), no roll; both (...) or scalars."""
        offset = self.hip_from_com_base
        com_z = np.asarray(com_z_world, dtype=float)[..., None]
        pitch = np.asarray(pitch_rad, dtype=float)[..., None]
        return com_z + offset[:, 2] * np.cos(pitch) - offset[:, 0] * np.sin(pitch)

    def hips_over_tops(self, tops_z: np.ndarray) -> np.ndarray:
        """(..., 4) world z of the hips when the feet stand on ``tops_z`` (..., 4): the CoM at the nominal height
        over their support, the body pitched with them (``contactnet.motion.ground``)."""
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
    """The height checks of candidate footholds (see the module doc) for one robot.

    ``evaluate`` answers each check on its own (diagnostics, tests); ``usable``, the planner's question, their
    conjunction, computed for few numpy calls per batch of candidates (the planner asks one batch per planning
    step; a call costs about the same for one candidate as for dozens): the terrain checks only for the
    candidates with a top and in reach, points kept coordinate first, (2, ...), so numpy's loops run along the
    long axes, the terrain looked up once for the swing paths and leg outlines together, every comparison with
    it in one reduction. The top and the foot ball's room at a small top's centre, the same for every candidate
    moved there, are remembered per top part (``_centres``). ``tests/test_planner_fast.py`` checks that
    ``usable`` is the conjunction of ``evaluate``. The planners' walk computes the same checks compiled, landing by
    landing (``contactnet.planning.heights_walk``), and asks ``usable`` itself about a landing near a limit."""

    def __init__(self, robot: RobotDescription, checks: HeightChecks = HeightChecks()) -> None:
        self.legs = geo = LegGeometry.of(robot)
        self.checks = checks
        k, t = checks.shin_samples, checks.thigh_samples
        shin = np.arange(1, k + 1) / k  # along the shank's horizontal extent
        thigh = np.arange(1, t + 1) / (t + 1)  # from the knee toward the hip
        knee = np.array([0.0, 0.5, 1.0])
        # The lower outline of a leg at S = k + 3 + t samples (shank, knee housing, thigh), for a pose with the
        # knee at height h above the foot-ball centre, the shank's horizontal extent e, the hip at (lever,
        # rise) from the foot: distance from the foot toward the knee side  [e, lever] @ share + reach, the
        # outline's own height above the foot-ball centre  [h, rise] @ share, and the clearance it needs.
        self._share = np.array([np.concatenate([shin, np.ones(3), 1.0 - thigh]),
                                np.concatenate([np.zeros(k + 3), thigh])])
        self._knee_reach = np.concatenate([np.zeros(k), checks.knee_reach_m * knee, np.zeros(t)])
        self._clearance_m = np.concatenate([np.full(k, checks.shin_clearance_m), np.full(3, checks.knee_clearance_m),
                                            np.full(t, checks.thigh_clearance_m)])
        self._lines = np.array([0.0, checks.shin_half_width_m, -checks.shin_half_width_m])  # axis and sides
        self._path_fractions = np.arange(1, checks.path_samples + 1) / (checks.path_samples + 1)
        self._side_offsets = np.linspace(0.0, checks.side_reach_m, 5)[1:]
        ring = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
        ring_radius = geo.foot_radius_m + checks.ball_clearance_m
        self._ring = np.column_stack([np.cos(ring), np.sin(ring)]) * ring_radius
        self._squared_difference = geo.shank_m**2 - geo.thigh_m**2  # per leg, for the knee angle
        self._known_knees = bool(np.all(geo.knee_side != 0))
        self._balls: dict[int, tuple] = {}  # id(TopParts) -> (it, the top and ball check at each centre)
        self._k = _Constants.of(geo, checks)

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
        """Whether the terrain has heights (``Terrain.has_heights``: tops at several heights, or sloped)."""
        return terrain.has_heights

    def usable(
        self,
        terrain: Terrain,
        legs: np.ndarray,
        landing_xy_world: np.ndarray,
        liftoff_xy_world: np.ndarray,
        hip_xy_world: np.ndarray,
        tops_z: np.ndarray,
        yaw_rad: float,
        part: np.ndarray | None = None,
        at_centre: np.ndarray | None = None,
    ) -> np.ndarray:
        """(M,) bool: which landings pass the height checks. ``legs`` (M,) int, ``landing_xy_world`` (M, 2)
        the candidate footholds, ``liftoff_xy_world`` (M, 2) where each of those legs stands now,
        ``hip_xy_world`` (M, 2) each leg's hip (flexion joint) predicted at touchdown, ``tops_z`` (4,) the
        tops under the four feet now (the hips' heights at touchdown follow them, with the landing leg's
        top replaced by its candidate's: ``LegGeometry.hips_over_tops``). Points with no top under them are
        not usable. ``part`` (M,), optional: the top part under each landing (``TopParts.part_at``), and
        ``at_centre`` (M,) bool: the landing is that small part's centre (``centred`` moved it there).

        The conjunction of ``evaluate``'s checks, computed for speed: the terrain checks only for the landings
        with a top and in reach, every comparison of the swing path and the leg outlines against the terrain
        in one reduction."""
        checks, geo, k = self.checks, self.legs, self._k
        legs = np.asarray(legs, dtype=np.intp)
        landing = np.asarray(landing_xy_world, dtype=float).reshape(-1, 2)
        tops_z = np.asarray(tops_z, dtype=float).reshape(4)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        if at_centre is None or part is None:
            top, centred = terrain.height_at(landing), None
        else:  # the tops at the small parts' centres are remembered
            centred = np.asarray(at_centre, dtype=bool)
            top, part = np.empty(len(landing)), np.asarray(part)
            inside, elsewhere = centred.nonzero()[0], (~centred).nonzero()[0]
            if inside.size:
                top[inside] = self._centres(terrain, part[inside])[0]
            if elsewhere.size:
                top[elsewhere] = terrain.height_at(landing[elsewhere])
        foot_z = top + k.foot_radius
        hip_z = self._landing_hip_z(tops_z, legs, top)
        hip_xy = np.asarray(hip_xy_world, dtype=float).reshape(-1, 2)
        to_hip = hip_xy - landing
        ahead_left = to_hip @ np.array([[c, -s], [s, c]])
        toward_plane = ahead_left[:, 1] + geo.plane_left_m[legs]
        rise = hip_z - foot_z
        squared = to_hip * to_hip
        ok = (np.sqrt(squared[:, 0] + squared[:, 1] + rise * rise) <= k.reach) & (top == top)  # 1. reach, a top
        leaning = np.abs(toward_plane) > k.max_lean
        if centred is None:
            parts = terrain.top_parts()
            on = parts.part_at(landing) if part is None else np.asarray(part)
            small = (on >= 0) & (parts.inradius_m[on] <= checks.small_top_inradius_m)
        else:
            small = centred
        ok &= ~(leaning & small)
        wide = (leaning & ok).nonzero()[0]
        if wide.size:  # a leaning leg: the ground beside the foot, toward its plane, no higher than its top
            beside = (landing[wide, None] + np.sign(toward_plane[wide])[:, None, None]
                      * self._side_offsets[None, :, None] * np.array([-s, c]))
            side_z = terrain.height_bound(beside.reshape(-1, 2), outside=-np.inf).reshape(len(wide), -1)
            ok[wide] = side_z.max(axis=1) <= top[wide] + checks.ball_tolerance_m
        # The terrain checks of every landing (as many numpy calls as for the reachable ones alone).
        ok &= self._clear(terrain, legs, landing, np.asarray(liftoff_xy_world, dtype=float).reshape(-1, 2), top,
                          foot_z, hip_z, ahead_left[:, 0], toward_plane, tops_z, c, s, part, centred)
        return ok

    def _clear(self, terrain: Terrain, legs: np.ndarray, landing: np.ndarray, liftoff: np.ndarray, top: np.ndarray,
               foot_z: np.ndarray, hip_z: np.ndarray, ahead: np.ndarray, toward_plane: np.ndarray, tops_z: np.ndarray,
               c: float, s: float, part: np.ndarray | None, at_centre: np.ndarray | None) -> np.ndarray:
        """``usable``'s terrain checks ("step", "ball", "leg" of ``evaluate``) of landings (M,), all at once."""
        geo, k = self.legs, self._k
        m = len(landing)
        n = self._share.shape[1]  # samples along a leg outline
        # The two poses of each leg (see _clearance), stacked: the first m rows, then the late ones.
        toward_knee = geo.knee_side[legs] * ahead if self._known_knees else np.where(
            geo.knee_side[legs] != 0, geo.knee_side[legs] * ahead, np.abs(ahead))
        lever = np.maximum(toward_knee + k.lever_margin, k.min_lever)
        nominal = geo.hip_above_foot_m[legs]
        rise = np.minimum(np.maximum(hip_z - foot_z, k.tiny), nominal)
        late = k.late[legs]
        late_lever, late_rise = lever.copy(), rise.copy()
        np.copyto(late_lever, toward_knee + k.stance_travel, where=late)
        np.copyto(late_rise, nominal, where=late)
        poses = np.concatenate([legs, legs])
        lever, rise = np.concatenate([lever, late_lever]), np.concatenate([rise, late_rise])
        foot = np.concatenate([foot_z, foot_z])
        distance, allowed_z, up = self._leg_outline(poses, foot, lever, rise)  # (2m, n)
        lean = np.minimum(np.maximum(np.concatenate([toward_plane, toward_plane]), k.min_lean), k.max_lean)
        lean = lean[:, None] * up / rise[:, None]
        along = k.knee_direction[poses][:, None] * distance
        # The points to look up, coordinate first: swing paths (m, P), then the outlines' lines (L, 2m, n): the
        # axis and a line to each side, and for an unknown knee the same mirrored through the foot.
        paths, outlines = m * len(self._path_fractions), 2 * m * n
        lines = 3 if self._known_knees else 6
        points = np.empty((2, paths + lines * outlines))
        delta = landing - liftoff
        for axis, (cos_part, sin_part) in enumerate(((c, -s), (s, c))):
            np.add(liftoff[:, axis, None], delta[:, axis, None] * self._path_fractions,
                   out=points[axis, :paths].reshape(m, -1))
            foot = np.concatenate([landing[:, axis], landing[:, axis]])[:, None]  # (2m, 1)
            np.add((foot + along * cos_part).reshape(1, -1), (lean.reshape(1, -1) + self._lines[:, None]) * sin_part,
                   out=points[axis, paths: paths + 3 * outlines].reshape(3, -1))
            if lines == 6:
                np.subtract(np.broadcast_to(2.0 * foot, (2 * m, n)).reshape(1, -1),
                            points[axis, paths: paths + 3 * outlines].reshape(3, -1),
                            out=points[axis, paths + 3 * outlines:].reshape(3, -1))
        heights = _height_bound_of(terrain, points)
        # Every comparison with the terrain as a margin that must not be positive, one row per landing.
        start_top = tops_z[legs]
        outline = heights[paths:].reshape(lines, -1)
        highest = np.maximum(np.maximum(outline[0], outline[1]), outline[2])
        if lines == 6:
            highest = np.maximum(highest, np.maximum(np.maximum(outline[3], outline[4]), outline[5]))
        outline = highest.reshape(2, m, n) - allowed_z.reshape(2, m, n)
        margins = np.concatenate([
            heights[:paths].reshape(m, -1) - np.maximum(start_top, top)[:, None] - k.max_step,  # 2. swing path
            np.maximum(outline[0], outline[1]),  # 4. shin and thigh, both poses
            (np.abs(top - start_top) - k.max_step)[:, None],  # 2. step height
        ], axis=1)
        clear = margins.max(axis=1) <= 0.0
        # 3. the ball's side (exact heights: on a small top the ring lies a few mm inside the top's edges).
        rest = np.arange(m) if at_centre is None else (~at_centre).nonzero()[0]
        if rest.size:
            ring_z = terrain.height_at((landing[rest, None] + self._ring).reshape(-1, 2), outside=-np.inf)
            clear[rest] &= (ring_z.reshape(len(rest), -1) - self._ring_rise(terrain, landing[rest])).max(axis=1) <= (
                top[rest] + self.checks.ball_tolerance_m)
        if rest.size < m:
            inside = at_centre.nonzero()[0]
            clear[inside] &= self._centres(terrain, part[inside])[1]
        return clear

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
        part: np.ndarray | None = None,
        at_centre: np.ndarray | None = None,
    ) -> dict[str, np.ndarray]:
        """Each check of ``usable`` on its own, (M,) bool each: "top" (a top under the point), "reach",
        "step" (the swing), "ball", "leg" (shin and thigh). ``reachable_only``: the terrain checks ("step",
        "ball", "leg") run only for the points with a top and in reach, and are False for the others (what
        ``usable`` needs, for a fraction of the work)."""
        checks, geo = self.checks, self.legs
        legs = np.asarray(legs, dtype=np.intp)
        landing = np.asarray(landing_xy_world, dtype=float).reshape(-1, 2)
        m = len(landing)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        tops_z = np.asarray(tops_z, dtype=float).reshape(4)

        top = terrain.height_at(landing)
        foot_z = top + geo.foot_radius_m
        hip_z = self._landing_hip_z(tops_z, legs, top)
        hip_xy = np.asarray(hip_xy_world, dtype=float).reshape(-1, 2)
        to_hip = hip_xy - landing
        ahead_left = to_hip @ np.array([[c, -s], [s, c]])  # the hip ahead of the foot, left of it
        toward_plane = ahead_left[:, 1] + geo.plane_left_m[legs]  # the foot's offset from its leg's plane
        result = {"top": top == top}  # (no top: NaN)
        # 1. reach from the hip predicted at touchdown, the leg leaning at most max_lean_m.
        rise = hip_z - foot_z
        reach = np.sqrt(np.add.reduce(to_hip * to_hip, axis=1) + rise * rise)
        result["reach"] = reach <= geo.reach_m - checks.reach_margin_m
        leaning = (np.abs(toward_plane) > checks.max_lean_m).nonzero()[0]
        if leaning.size:  # a leaning leg sweeps its shin over the ground beside the foot: that must be no higher,
            # ... and the foot not on a small top (the shin would pass over its edge)
            parts = terrain.top_parts()
            on = terrain.top_parts().part_at(landing[leaning]) if part is None else np.asarray(part)[leaning]
            small = (on >= 0) & (parts.inradius_m[on] <= checks.small_top_inradius_m)
            wide = leaning[~small & result["reach"][leaning]]
            result["reach"][leaning[small]] = False
            if wide.size:
                beside = (landing[wide, None] + np.sign(toward_plane[wide])[:, None, None]
                          * self._side_offsets[None, :, None] * np.array([-s, c]))
                side_z = terrain.height_bound(beside.reshape(-1, 2), outside=-np.inf).reshape(len(wide), -1)
                result["reach"][wide] &= side_z.max(axis=1) <= top[wide] + checks.ball_tolerance_m
        rows = (result["top"] & result["reach"]).nonzero()[0] if reachable_only else np.arange(m)
        for name in ("step", "ball", "leg"):
            result[name] = np.zeros(m, dtype=bool)
        if rows.size:
            step, ball, leg = self._clearance(
                terrain, legs[rows], landing[rows], np.asarray(liftoff_xy_world, dtype=float).reshape(-1, 2)[rows],
                top[rows], foot_z[rows], hip_z[rows], ahead_left[rows, 0], toward_plane[rows], tops_z, c, s,
                None if at_centre is None else np.asarray(part)[rows][np.asarray(at_centre)[rows]],
                None if at_centre is None else np.asarray(at_centre)[rows])
            result["step"][rows], result["ball"][rows], result["leg"][rows] = step, ball, leg
        return result

    def _landing_hip_z(self, tops_z: np.ndarray, legs: np.ndarray, top: np.ndarray) -> np.ndarray:
        """(M,) height of the hip of each landing leg (M,) at touchdown, its foot on ``top`` (M,), the others on
        ``tops_z`` (4,): ``LegGeometry.hips_over_tops`` of the tops with the landing leg's replaced."""
        k = self._k
        fl, fr, hl, hr = tops_z.tolist()
        change = top - tops_z[legs]
        mean_top = (change + (fl + fr + hl + hr)) * k.quarter
        slope = k.slope_weight[legs] * change + (0.5 * (hl + hr) - 0.5 * (fl + fr))  # hind minus front
        pitch = np.arctan2(slope, k.front_to_hind) * k.pitch_share
        return mean_top + k.com_height + k.hip_offset_z[legs] * np.cos(pitch) - k.hip_offset_x[legs] * np.sin(pitch)

    def _clearance(self, terrain: Terrain, legs: np.ndarray, landing: np.ndarray, liftoff: np.ndarray,
                   top: np.ndarray, foot_z: np.ndarray, hip_z: np.ndarray, ahead: np.ndarray,
                   toward_plane: np.ndarray, tops_z: np.ndarray, c: float, s: float,
                   centre_part: np.ndarray | None, at_centre: np.ndarray | None) -> tuple[np.ndarray, ...]:
        """The terrain checks "step", "ball" and "leg" of landings (M,) (see ``evaluate``)."""
        checks, geo = self.checks, self.legs
        m = len(landing)
        # 4. the leg's shallowest poses (see the module doc): at touchdown, and late in the stance for a leg
        # whose knee points forward (toward where the body goes), with its hip at the nominal height then.
        side = geo.knee_side[legs]
        toward_knee = side * ahead if self._known_knees else np.where(side != 0, side * ahead, np.abs(ahead))
        lever = np.maximum(toward_knee + checks.shin_lever_margin_m, checks.min_shin_lever_m)
        nominal = geo.hip_above_foot_m[legs]
        rise = np.minimum(np.maximum(hip_z - foot_z, 1e-6), nominal)
        late = side >= 0
        poses = np.concatenate([legs, legs])
        both_rise = np.concatenate([rise, np.where(late, nominal, rise)])
        distance, allowed_z, up = self._leg_outline(
            poses, np.concatenate([foot_z, foot_z]),
            np.concatenate([lever, np.where(late, toward_knee + checks.stance_travel_m, lever)]), both_rise)
        # The leg leans sideways from the foot toward its plane: its points shift along ``left`` with their height.
        # (By at most max_lean_m: a leg leaning further has had the ground beside its foot checked instead.)
        lean = np.clip(np.concatenate([toward_plane, toward_plane]), -checks.max_lean_m, checks.max_lean_m)
        outline = self._outline_points(np.concatenate([landing, landing]).T, distance, lean[:, None] * up
                                       / both_rise[:, None], poses, c, s)  # (2, 2M, S, lines)
        # The points to look up at once: swing path and leg outline (an upper bound of the tops is enough there).
        start = liftoff.T[:, :, None]
        path = start + (landing.T[:, :, None] - start) * self._path_fractions  # (2, M, P)
        heights = _height_bound_of(terrain, np.concatenate([path.reshape(2, -1), outline.reshape(2, -1)], axis=1))
        path_z = heights[: path[0].size].reshape(m, -1)
        leg_z = heights[path[0].size:].reshape(2 * m, distance.shape[1], -1).max(axis=2)
        # 2. swing: the step and any obstacle on the way.
        start_top = tops_z[legs]  # each leg lifts off from where it stands
        step = ((np.abs(top - start_top) <= checks.max_step_m)
                & (path_z.max(axis=1) - np.maximum(start_top, top) <= checks.max_step_m))
        # 3. the ball's side (exact heights: on a small top the ring lies a few mm inside the top's edges).
        ball = np.empty(m, dtype=bool)
        elsewhere = np.arange(m) if at_centre is None else (~at_centre).nonzero()[0]
        if at_centre is not None and at_centre.any():
            ball[at_centre] = self._centres(terrain, centre_part)[1]
        if elsewhere.size:
            ring_z = terrain.height_at((landing[elsewhere, None] + self._ring).reshape(-1, 2), outside=-np.inf)
            ball[elsewhere] = (ring_z.reshape(len(elsewhere), -1) - self._ring_rise(terrain, landing[elsewhere])).max(
                axis=1) <= top[elsewhere] + checks.ball_tolerance_m
        # 4. the shin and the thigh above the terrain, in both poses.
        leg_clear = np.logical_and.reduce(leg_z <= allowed_z, axis=1)
        return step, ball, leg_clear[:m] & leg_clear[m:]

    def _centres(self, terrain: Terrain, part: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The top (K,) and the "ball" check (K,) of a landing at the centre of each top part ``part`` (K,),
        remembered per terrain (they depend on the part alone)."""
        parts = terrain.top_parts()
        entry = self._balls.get(id(parts))
        if entry is None or entry[0] is not parts:
            if len(self._balls) >= 8:
                self._balls.pop(next(iter(self._balls)))
            n = len(parts.polygons)
            entry = self._balls[id(parts)] = (parts, np.full(n, np.nan), np.zeros(n, dtype=bool))
        _, tops, balls = entry
        top = tops[part]
        missing = (top != top).nonzero()[0]
        if missing.size:
            new = np.unique(part[missing])
            centres = parts.centres_xy[new]
            ring_z = terrain.height_at((centres[:, None] + self._ring).reshape(-1, 2), outside=-np.inf)
            tops[new] = terrain.height_at(centres)
            balls[new] = (ring_z.reshape(len(new), -1) - self._ring_rise(terrain, centres)).max(axis=1) <= (
                tops[new] + self.checks.ball_tolerance_m)
            top = tops[part]
        return top, balls[part]

    def _ring_rise(self, terrain: Terrain, centres_xy: np.ndarray) -> np.ndarray | float:
        """(K, R) how far the plane of the top under each ring's centre (K, 2) rises at the ring's points (0 on flat
        tops): the "ball" check asks for no top higher than that plane around the foot, not than its height."""
        if not terrain.sloped:
            return 0.0
        return terrain.gradient_at(centres_xy) @ self._ring.T

    def stance_clear(self, terrain: Terrain, feet_xy_world: np.ndarray, tops_z: np.ndarray,
                     hip_xy_world: np.ndarray, yaw_rad: float) -> np.ndarray:
        """(4,) bool: whether each leg, standing where it is (``feet_xy_world`` (4, 2) on ``tops_z`` (4,)), keeps
        its shank, knee and thigh clear of the terrain with its hip at ``hip_xy_world`` (4, 2) (e.g. where the
        body will be a while later) and the body at the nominal height over the feet. A leg that fails should
        swing soon: its stance is turning its lower leg onto an edge."""
        geo, k = self.legs, self._k
        legs = k.all_legs
        feet = np.asarray(feet_xy_world, dtype=float).reshape(4, 2)
        tops = np.asarray(tops_z, dtype=float).reshape(4)
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        ahead_left = (np.asarray(hip_xy_world, dtype=float).reshape(4, 2) - feet) @ np.array([[c, -s], [s, c]])
        foot_z = tops + k.foot_radius
        rise = np.minimum(np.maximum(self._landing_hip_z(tops, legs, tops) - foot_z, k.tiny), geo.hip_above_foot_m)
        ahead = ahead_left[:, 0]
        lever = geo.knee_side * ahead if self._known_knees else np.where(geo.knee_side != 0, geo.knee_side * ahead,
                                                                          np.abs(ahead))
        distance, allowed_z, up = self._leg_outline(legs, foot_z, lever, rise)
        toward_plane = ahead_left[:, 1] + geo.plane_left_m
        points = self._outline_points(feet.T, distance, toward_plane[:, None] * up / rise[:, None], legs, c,
                                      s)  # (2, 4, S, lines)
        heights = _height_bound_of(terrain, points.reshape(2, -1)).reshape(4, distance.shape[1], -1)
        margin = np.maximum.reduce(heights, axis=2) - allowed_z
        return (margin.max(axis=1) <= 0.0) | (tops != tops)

    def _outline_points(self, feet: np.ndarray, distance: np.ndarray, lean: np.ndarray, legs: np.ndarray,
                        c: float, s: float) -> np.ndarray:
        """(2, M, S, L) the points under the outlines of legs (M,), coordinate first: ``distance`` (M, S) from the
        feet (2, M) toward the knee side and ``lean`` (M, S) along the left of the heading (cos, sin = c, s), on L
        lines (the axis and ``shin_half_width_m`` to each side; both sides of the foot as well for an unknown
        knee)."""
        along = (self._k.knee_direction[legs][:, None] * distance)[:, :, None]  # (M, S, 1) along the heading
        across = lean[:, :, None] + self._lines  # (M, S, 3) along its left
        points = np.empty((2,) + across.shape[:2] + (3 if self._known_knees else 6,))
        x, y = points[0, :, :, :3], points[1, :, :, :3]
        np.subtract(feet[0][:, None, None] + along * c, across * s, out=x)
        np.add(feet[1][:, None, None] + along * s, across * c, out=y)
        if not self._known_knees:  # unknown knee: the other side too
            np.subtract(2.0 * feet[0][:, None, None], x, out=points[0, :, :, 3:])
            np.subtract(2.0 * feet[1][:, None, None], y, out=points[1, :, :, 3:])
        return points

    def _leg_outline(self, legs: np.ndarray, foot_z: np.ndarray, lever: np.ndarray,
                     rise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The lower outline of legs in one pose each: the hip ``lever`` (M,) past the foot toward the knee and
        ``rise`` (M,) above the foot-ball centre at ``foot_z`` (M,). Returns horizontal distances from the foot
        toward the knee side (M, S), the heights the terrain must stay below there (the shank's axis less
        its clearance, the knee's housing, then the thigh's axis less its clearance) and the leg's own heights
        there above the foot-ball centre (M, S)."""
        geo, k = self.legs, self._k
        dist = np.hypot(lever, rise)
        shank = geo.shank_m[legs]
        cos_alpha = (self._squared_difference[legs] + dist * dist) / (k.two * shank * dist)
        elevation = np.arctan2(rise, lever) - np.arccos(np.minimum(np.maximum(cos_alpha, k.minus_one), k.one))
        if not self._known_knees:
            elevation = np.where(geo.knee_side[legs] != 0, elevation, self.checks.fallback_shin_elevation_rad)
        elevation = np.fmin(np.fmax(elevation, k.zero), k.right_angle)  # fmax: NaN -> 0
        extent = shank * np.cos(elevation)  # horizontal length of the shank
        knee = shank * np.sin(elevation)  # the knee's height above the foot-ball centre
        share, reach = self._share, self._knee_reach
        distance = extent[:, None] * share[0] + lever[:, None] * share[1] + reach
        up = knee[:, None] * share[0] + rise[:, None] * share[1]
        return distance, foot_z[:, None] + up - self._clearance_m, up


@dataclass(frozen=True)
class _Constants:
    """``FootholdChecker.usable``'s numbers as numpy values (a numpy operation with a Python float costs twice as
    much as with a 0-d array) and per-leg tables."""

    foot_radius: np.ndarray
    quarter: np.ndarray
    slope_weight: np.ndarray  # (4,): d(hind - front) / d(top of the leg)
    front_to_hind: np.ndarray
    pitch_share: np.ndarray
    com_height: np.ndarray
    hip_offset_z: np.ndarray  # (4,)
    hip_offset_x: np.ndarray  # (4,)
    reach: np.ndarray
    max_lean: np.ndarray
    min_lean: np.ndarray
    lever_margin: np.ndarray
    min_lever: np.ndarray
    tiny: np.ndarray
    stance_travel: np.ndarray
    max_step: np.ndarray
    all_legs: np.ndarray  # (4,) intp: 0, 1, 2, 3
    late: np.ndarray  # (4,) bool: the leg's knee points forward (its late pose differs)
    knee_direction: np.ndarray  # (4,) +-1: along the heading toward the knee (+1 unknown)
    zero: np.ndarray = field(default_factory=lambda: np.array(0.0))
    one: np.ndarray = field(default_factory=lambda: np.array(1.0))
    minus_one: np.ndarray = field(default_factory=lambda: np.array(-1.0))
    two: np.ndarray = field(default_factory=lambda: np.array(2.0))
    right_angle: np.ndarray = field(default_factory=lambda: np.array(0.5 * math.pi))

    @classmethod
    def of(cls, geo: LegGeometry, checks: HeightChecks) -> _Constants:
        value = np.array
        return cls(value(geo.foot_radius_m), value(0.25), np.array([-0.5, -0.5, 0.5, 0.5]), value(geo.front_to_hind_m),
                   value(PITCH_SHARE), value(geo.com_height_m), geo.hip_from_com_base[:, 2].copy(),
                   geo.hip_from_com_base[:, 0].copy(), value(geo.reach_m - checks.reach_margin_m),
                   value(checks.max_lean_m), value(-checks.max_lean_m), value(checks.shin_lever_margin_m),
                   value(checks.min_shin_lever_m), value(1e-6), value(checks.stance_travel_m), value(checks.max_step_m),
                   np.arange(4), geo.knee_side >= 0, np.where(geo.knee_side != 0, geo.knee_side, 1.0))


def _height_bound_of(terrain: Terrain, points_xy_world: np.ndarray) -> np.ndarray:
    """``terrain.height_bound`` (outside: -inf) of points (2, N) given coordinate first."""
    locator = terrain.height_locator()
    if locator is None:
        return terrain.height_bound(points_xy_world.T, outside=-np.inf)
    return locator.upper_heights_of(points_xy_world)


__all__ = ["FootholdChecker", "HeightChecks", "LegGeometry", "path_top_z", "segment_samples"]
