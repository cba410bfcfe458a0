"""The 3D scene of a live session in viser: the robot on the terrain, candidate disks, planned steps,
CoM paths and force arrows, the planner's stand horizons and swing retargets (`app/scene/marks.py`), and in
compare mode the other robots as translucent ghosts (`app/scene/robot_display.py`). `LiveScene.update(view)` draws one `LiveView`. A click on a candidate disk
says what the planner knew of it (viser 1.1 reports clicks on scene nodes, not hovers).

Cheap updates matter (the simulation shares the process and the GIL): every node is created once
and later only its changed properties are sent. Per update that is the robot (12 joint rotations
and the base pose, `app/scene/robot_display.py`) and the force lines; the disks, steps and
planned CoM path change at replanning (a few Hz); the actual CoM path is drawn in fixed chunks of
which only the newest one changes; the terrain mesh only when the terrain does.

The scene draws on any viser server: the live one (browsers), or a headless one that a
`SceneRecorder` serializes (app/recordings/recorder.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
import trimesh
import viser

from app.live.view import CandidateView, LiveView
from app.scene.marks import HIDDEN_POS, StepMarks, hidden_mesh_pool
from app.scene.robot_display import CompareGhosts, RobotDisplay
from contactnet.robots import Robot
from contactnet.terrain import Terrain

DISK_RADIUS_M = 0.017
DISK_HEIGHT_M = 0.004
DISK_POOL = 100  # walk: 4 legs x 25 candidates at most (a future ranking of every leg's grid)
STEP_POOL = 6  # 3 planned steps x 2 legs (trot)
#: Foot forces are drawn relative to the robot's weight: a foot carrying all of it draws this long.
WEIGHT_ARROW_M = 0.3
PUSH_SCALE_M_PER_N = 0.02
COM_CHUNK = 200  # points per chunk of the actual CoM path

TERRAIN_DISPLAY_THICKNESS_M = 0.08  # drawn as slabs (the simulation's are 0.4 m deep) over a floor grid
TERRAIN_COLOR = (181, 160, 120)
# Candidate disks (drawn with a toon material, which keeps these colours recognizable). Safe candidates
# go from BEST_COLOR (the best-ranked safe one) to WORST_COLOR, RANK_FADE places down the ranking.
BEST_COLOR = np.array([0, 90, 15], dtype=np.float64)  # the best-ranked safe candidate: vivid green
WORST_COLOR = np.array([120, 120, 120], dtype=np.float64)  # RANK_FADE places down the ranking: grey
RANK_FADE = 8  # safe candidates reach grey this many ranking positions below the best safe one
SAFE_COLOR = np.array([0, 90, 15], dtype=np.uint8)  # safe, when the planner does not rank
UNSAFE_COLOR = np.array([200, 40, 40], dtype=np.uint8)  # a soft red on screen, and small: present, not dominant
CHOSEN_COLOR = np.array([255, 190, 0], dtype=np.uint8)
UNSAFE_SCALE = 0.5
CHOSEN_SCALE = (1.7, 1.7, 3.0)
STEP_COLORS = np.array([[255, 80, 0], [255, 130, 0], [255, 180, 40]], dtype=np.uint8)
UNSAFE_STEP_COLOR = np.array([200, 0, 120], dtype=np.uint8)
PLANNED_COM_COLOR = (0, 160, 255)
ACTUAL_COM_COLOR = (190, 30, 190)
FORCE_COLOR = (40, 90, 235)
PUSH_COLOR = (230, 20, 20)
ESTIMATED_PUSH_COLOR = (255, 140, 0)  # the disturbance observer's estimate, drawn just above the push
ESTIMATE_LIFT_M = 0.04
GOAL_COLOR = (30, 150, 60)
#: How the toon material shows these colours under viser's default lights (lighter: measured on a screenshot,
#: viser 1.1, chromium): the legend draws these, so it looks like the scene.
SHOWN_AS = {
    (0, 90, 15): (0, 172, 70),
    (120, 120, 120): (191, 191, 191),
    (200, 40, 40): (226, 124, 120),
    (255, 190, 0): (228, 214, 82),
}
PICK_LABEL_OFFSET_M = 0.05  # a picked disk's label floats this high above it
#: The default view: from behind and to the right of the robot, looking ahead along +x.
CAMERA_OFFSET_M = np.array([-0.75, -1.0, 0.85])


def rank_fade(position: np.ndarray) -> np.ndarray:
    """0 (best safe) .. 1 (RANK_FADE or more places below it) for positions among the safe candidates."""
    return np.minimum(np.asarray(position, dtype=float), RANK_FADE) / RANK_FADE


def rank_color(position: np.ndarray) -> np.ndarray:
    """(N, 3) uint8: the colour of safe candidates at these positions down the ranking (0 = best safe)."""
    fade = rank_fade(np.atleast_1d(position))[:, None]
    return np.rint((1.0 - fade) * BEST_COLOR + fade * WORST_COLOR).astype(np.uint8)


def shown_color(color) -> np.ndarray:  # noqa: ANN001 - an RGB triple
    """How a disk colour looks on screen (`SHOWN_AS`; other colours as they are)."""
    key = tuple(int(v) for v in np.asarray(color).ravel()[:3])
    return np.asarray(SHOWN_AS.get(key, key), dtype=float)


def shown_rank_color(position: np.ndarray) -> np.ndarray:
    """(N, 3) uint8: how safe candidates at these ranking positions look on screen (for the legend)."""
    fade = rank_fade(np.atleast_1d(position))[:, None]
    best, worst = shown_color(BEST_COLOR), shown_color(WORST_COLOR)
    return np.rint((1.0 - fade) * best + fade * worst).astype(np.uint8)


def safe_positions(safe: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """(N,) each candidate's position among the safe ones by rank (0 = the best-ranked safe one; equal
    ranks, e.g. the two legs of one trot action, share a position); -1 for unsafe ones."""
    safe = np.asarray(safe, dtype=bool)
    rank = np.asarray(rank)
    position = np.full(len(safe), -1, dtype=int)
    if np.any(safe):
        _, dense = np.unique(rank[safe], return_inverse=True)
        position[safe] = dense.ravel()
    return position


def disk_style(
    safe: np.ndarray, rank: np.ndarray | None = None, chosen: tuple[int, ...] = ()
) -> tuple[np.ndarray, np.ndarray]:
    """(colors (N, 3) uint8, scales (N, 3)) of candidate disks.

    With a ranking: safe candidates go from vivid green (the best-ranked safe one) to grey by their
    position among the safe ones (`rank_color`, reaching grey `RANK_FADE` places down), and shrink a
    little as they fade; unsafe ones are soft red, small and flat; the chosen one(s) gold, larger and
    taller. Without a ranking: safe green, unsafe soft red.
    """
    safe = np.asarray(safe, dtype=bool)
    n = len(safe)
    colors = np.empty((n, 3), dtype=np.uint8)
    scales = np.ones((n, 3), dtype=np.float32)
    if rank is None:
        colors[:] = np.where(safe[:, None], SAFE_COLOR, UNSAFE_COLOR)
    else:
        position = np.maximum(safe_positions(safe, rank), 0)
        colors[:] = rank_color(position)
        scales[:, :2] = (1.0 - 0.3 * rank_fade(position))[:, None]
    colors[~safe] = UNSAFE_COLOR
    scales[~safe, :2] = UNSAFE_SCALE
    scales[~safe, 2] = 0.6  # flatter too: under a green disk, never over it
    for k in chosen:
        if 0 <= k < n:
            colors[k] = CHOSEN_COLOR
            scales[k] = CHOSEN_SCALE
    return colors, scales


def _segments(points: np.ndarray) -> np.ndarray:
    """(N, 3) polyline -> (N - 1, 2, 3) segments (at least one, degenerate if needed)."""
    points = np.asarray(points, dtype=np.float32)
    if len(points) < 2:
        p = points[0] if len(points) else HIDDEN_POS
        return np.stack([p, p])[None]
    return np.stack([points[:-1], points[1:]], axis=1)


def _on_ground(points: np.ndarray, terrain: Terrain, lift_m: float) -> np.ndarray:
    """CoM positions projected on the ground, ``lift_m`` above it (inside the body a CoM path is hidden by the
    robot): above the top under each point on a terrain with heights, else above ``surface_z`` (as before
    heights existed)."""
    projected = np.array(points, dtype=np.float32).reshape(-1, 3)
    if _has_heights(terrain) and len(projected):
        projected[:, 2] = terrain.ground_z(projected[:, :2].astype(np.float64)) + lift_m
    else:
        projected[:, 2] = terrain.surface_z + lift_m
    return projected


def _has_heights(terrain: Terrain) -> bool:
    """Does any top differ from ``surface_z`` (where the flat drawing would be hidden or float)?"""
    return len(terrain.levels) > 1 or terrain.levels[0][0] != terrain.surface_z or terrain.sloped


#: side by side (`LiveScene.side_by_side`): free space between the terrain and the copy beside it, m
LANE_GAP_M = 0.3


def lane_offset_m(terrain: Terrain) -> float:
    """How far along +y compare mode's side-by-side lanes lie from each other: the terrain's width and a gap."""
    _, miny, _, maxy = terrain.bounds
    return float(maxy - miny) + LANE_GAP_M


def goal_line_z(terrain: Terrain) -> float:
    """World z of the goal line: the highest top it crosses (``surface_z`` where it crosses none)."""
    minx, miny, maxx, maxy = terrain.bounds
    if terrain.sloped:  # the highest point of the tops along the line
        heights = terrain.height_at(np.column_stack([np.full(200, terrain.goal_x), np.linspace(miny, maxy, 200)]))
        return float(np.nanmax(heights)) if np.isfinite(heights).any() else float(terrain.surface_z)
    line = shapely.LineString([(terrain.goal_x, miny - 0.05), (terrain.goal_x, maxy + 0.05)])
    for top_z, geometry in terrain.levels:  # highest first
        if shapely.intersects(geometry, line):
            return float(top_z)
    return float(terrain.surface_z)


def arrow_segments(tail: np.ndarray, tip: np.ndarray, head_fraction: float = 0.25) -> np.ndarray:
    """(3 N, 2, 3) line segments of N arrows: the shaft, then two head strokes per arrow, in the plane of
    the shaft and the vertical (the horizontal plane for a vertical arrow). Zero-length arrows collapse
    to a point at their tail."""
    tail = np.asarray(tail, dtype=float).reshape(-1, 3)
    tip = np.asarray(tip, dtype=float).reshape(-1, 3)
    shaft = tip - tail
    length = np.linalg.norm(shaft, axis=1, keepdims=True)
    direction = np.divide(shaft, length, out=np.zeros_like(shaft), where=length > 1e-9)
    side = np.cross(direction, [0.0, 0.0, 1.0])
    side_norm = np.linalg.norm(side, axis=1, keepdims=True)
    side = np.where(side_norm > 1e-6, side / np.maximum(side_norm, 1e-12), [1.0, 0.0, 0.0])
    side = np.cross(side, direction)  # in the vertical plane of the shaft (horizontal for a vertical shaft)
    head = head_fraction * length
    back = tip - head * direction
    left, right = back + 0.5 * head * side, back - 0.5 * head * side
    segments = np.empty((len(tail), 3, 2, 3))
    segments[:, 0] = np.stack([tail, tip], axis=1)
    segments[:, 1] = np.stack([tip, left], axis=1)
    segments[:, 2] = np.stack([tip, right], axis=1)
    return segments.reshape(-1, 2, 3).astype(np.float32)


def _ordinal(n: int) -> str:
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


@dataclass(frozen=True)
class PickedCandidate:
    """What is known about one candidate disk (a click on it shows this)."""

    index: int
    leg: str
    xy_world: tuple[float, float]
    safe: bool
    chosen: bool
    rank: int | None  # the planner's ranking position (0 = best), None without a ranking
    safe_position: int | None  # its position among the safe candidates (0 = best safe)
    score: float | None = None  # the network's score or the cost, when the view carries one
    score_name: str = "score"

    def text(self) -> str:
        """One line: leg, rank, safety, score."""
        parts = [self.leg]
        if self.rank is not None:
            rank = f"rank {self.rank}"
            if self.safe and self.safe_position is not None:
                rank += " (best safe)" if self.safe_position == 0 else f" ({_ordinal(self.safe_position + 1)} safe)"
            parts.append(rank)
        parts.append("chosen" if self.chosen else ("safe" if self.safe else "unsafe"))
        if self.score is not None:
            parts.append(f"{self.score_name} {self.score:.3g}")
        return " · ".join(parts)


def describe_candidate(cand: CandidateView, index: int, leg_names: tuple[str, ...]) -> PickedCandidate:
    """The `PickedCandidate` of candidate ``index`` of a view's candidates."""
    leg = int(cand.leg[index])
    rank = None if cand.rank is None else int(cand.rank[index])
    position = None if cand.rank is None else int(safe_positions(cand.safe, cand.rank)[index])
    scores = getattr(cand, "score", None)  # a future CandidateView.score (network score or cost)
    return PickedCandidate(
        index=index,
        leg=leg_names[leg] if 0 <= leg < len(leg_names) else "?",
        xy_world=(float(cand.xy_world[index, 0]), float(cand.xy_world[index, 1])),
        safe=bool(cand.safe[index]),
        chosen=index in cand.chosen,
        rank=rank,
        safe_position=None if position is None or position < 0 else position,
        score=None if scores is None else float(scores[index]),
        score_name=str(getattr(cand, "score_name", "score")),
    )


class LiveScene:
    """Scene nodes of one session on one viser server; `update(view)` sends what changed.

    A click on a candidate disk shows what the planner knew about it (`PickedCandidate`) in a label
    next to the disk, for the browser that clicked, and tells the `pick_listeners` (the legend panel).
    """

    def __init__(self, server: viser.ViserServer, robot: Robot):
        self.server = server
        self.foot_radius_m = robot.description.foot_radius_m
        self.force_scale_m_per_n = WEIGHT_ARROW_M / robot.description.weight_n
        scene = server.scene
        scene.set_up_direction("+z")
        self.robot = RobotDisplay(server, robot)
        self.leg_names = tuple(robot.description.leg_names)
        self.ghosts = CompareGhosts(server, robot, self.robot.display)
        self.marks = StepMarks(server, self.foot_radius_m)
        disk = trimesh.creation.cylinder(radius=DISK_RADIUS_M, height=DISK_HEIGHT_M, sections=20)
        self.disks = hidden_mesh_pool(scene, "/plan/candidates", disk, DISK_POOL, SAFE_COLOR)
        ball = trimesh.creation.icosphere(subdivisions=2, radius=0.018)
        self.steps = scene.add_batched_meshes_simple(
            "/plan/steps",
            ball.vertices,
            ball.faces,
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (STEP_POOL, 1)),
            batched_positions=np.tile(HIDDEN_POS, (STEP_POOL, 1)),
            batched_colors=np.tile(STEP_COLORS[0], (STEP_POOL, 1)),
            lod="off",
            cast_shadow=False,
        )
        self.planned_com = scene.add_line_segments(
            "/plan/com", _segments(np.zeros((0, 3))), PLANNED_COM_COLOR, thickness=0.006
        )
        self.forces = scene.add_line_segments(
            "/forces/feet", np.tile(HIDDEN_POS, (4 * 3, 2, 1)), FORCE_COLOR, thickness=0.007
        )
        self.push = scene.add_line_segments(
            "/forces/push", np.tile(HIDDEN_POS, (3, 2, 1)), PUSH_COLOR, thickness=0.014
        )
        self.estimated_push = scene.add_line_segments(
            "/forces/estimated_push", np.tile(HIDDEN_POS, (3, 2, 1)), ESTIMATED_PUSH_COLOR, thickness=0.01
        )
        self._com_chunks: list[viser.LineSegmentsHandle] = []
        self._com_drawn = 0
        self._com_first: np.ndarray | None = None
        self._terrain_version: int | None = None
        self._terrain_nodes: list = []
        #: compare mode side by side: each other robot walks a copy of the terrain beside the main one (its lane),
        #: instead of a ghost over the same terrain; a display choice of this 3D view (the simulation is the same)
        self.side_by_side = False
        self._lane_nodes: list = []
        self._lane_key: tuple | None = None
        self._plan_key: tuple | None = None
        self._candidates_key: int | None = None
        self._com_plan_last: np.ndarray | None = None
        self._drawn: tuple[CandidateView | None, np.ndarray] = (None, np.zeros((0, 3)))  # candidates, disk positions
        self._pick_labels: dict[int, viser.LabelHandle] = {}
        #: Called with (client, PickedCandidate) after a click on a disk, (None, None) when the disks change.
        self.pick_listeners: list[Callable[[viser.ClientHandle | None, PickedCandidate | None], None]] = []
        self.disks.on_click(self._on_disk_click)

    def update(self, view: LiveView) -> None:
        with self.server.atomic():
            if view.terrain_version != self._terrain_version:
                self._draw_terrain(view)
            snap = view.snapshot
            self.robot.set(snap.q)
            self._draw_forces(view)
            if id(view.candidates) != self._candidates_key:
                self._candidates_key = id(view.candidates)
                self._draw_candidates(view)
            plan_key = tuple(id(s) for s in snap.planned_steps)
            if plan_key != self._plan_key:
                self._plan_key = plan_key
                self._draw_steps(view)
            com_plan = snap.com_plan
            if self._com_plan_last is None or not np.array_equal(com_plan, self._com_plan_last):
                self._com_plan_last = com_plan
                self.planned_com.points = _segments(_on_ground(com_plan, view.terrain, 0.004))
            self._draw_com_path(view.com_path, view.terrain)
            self.marks.update(view)
            self._draw_lanes(view)
            self.ghosts.update(view)

    # ---- pieces ------------------------------------------------------------------------------------
    def _draw_lanes(self, view: LiveView) -> None:
        """Side by side: a copy of the terrain (and its goal line) per other robot of compare mode, `lane_offset_m`
        apart along +y, and the ghosts moved onto them; nothing (and the ghosts over the main terrain) otherwise."""
        compare = getattr(view, "compare", None)
        lanes = len(compare) if (self.side_by_side and compare) else 0
        dy = lane_offset_m(view.terrain) if lanes else 0.0
        self.ghosts.lane_dy_m = dy
        key = (view.terrain_version, lanes) if lanes else None
        if key == self._lane_key:
            return
        for node in self._lane_nodes:
            node.remove()
        self._lane_nodes, self._lane_key = [], key
        if not lanes:
            return
        terrain = view.terrain
        mesh = terrain.mesh(thickness=TERRAIN_DISPLAY_THICKNESS_M)
        _, miny, _, maxy = terrain.bounds
        goal_z = goal_line_z(terrain) + 0.002
        scene = self.server.scene
        for i in range(lanes):
            y = (i + 1) * dy
            self._lane_nodes += [
                scene.add_mesh_simple(f"/compare/lane_{i}/mesh", mesh.vertices, mesh.faces, color=TERRAIN_COLOR,
                                      flat_shading=True, cast_shadow=False, position=(0.0, y, 0.0)),
                scene.add_line_segments(
                    f"/compare/lane_{i}/goal",
                    np.array([[[terrain.goal_x, miny + y - 0.05, goal_z], [terrain.goal_x, maxy + y + 0.05, goal_z]]]),
                    GOAL_COLOR, thickness=0.008,
                ),
            ]

    def _draw_terrain(self, view: LiveView) -> None:
        for node in self._terrain_nodes:
            node.remove()
        terrain = view.terrain
        mesh = terrain.mesh(thickness=TERRAIN_DISPLAY_THICKNESS_M)
        scene = self.server.scene
        z = terrain.surface_z
        goal_z = goal_line_z(terrain) + 0.002
        minx, miny, maxx, maxy = terrain.bounds
        nodes = [
            scene.add_mesh_simple(
                "/terrain/mesh",
                mesh.vertices,
                mesh.faces,
                color=TERRAIN_COLOR,
                flat_shading=True,
                cast_shadow=False,
            ),
            scene.add_line_segments(
                "/terrain/goal",
                np.array(
                    [[[terrain.goal_x, miny - 0.05, goal_z], [terrain.goal_x, maxy + 0.05, goal_z]]]
                ),
                GOAL_COLOR,
                thickness=0.008,
            ),
            scene.add_grid(
                "/terrain/floor",
                width=max(maxx - minx, 1.0) + 1.0,
                height=max(maxy - miny, 1.0) + 1.0,
                position=((minx + maxx) / 2, (miny + maxy) / 2, z - 0.45),
                cell_size=0.1,
                section_size=0.5,
                shadow_opacity=0.0,
            ),
        ]
        self._terrain_nodes = nodes
        self._terrain_version = view.terrain_version
        self._candidates_key = None
        self._plan_key = None

    def _draw_candidates(self, view: LiveView) -> None:
        positions = np.tile(HIDDEN_POS, (DISK_POOL, 1))
        colors = np.tile(SAFE_COLOR, (DISK_POOL, 1))
        scales = np.ones((DISK_POOL, 3), dtype=np.float32)
        cand = view.candidates
        if cand is not None:
            n = min(len(cand.xy_world), DISK_POOL)
            positions[:n, :2] = cand.xy_world[:n]
            positions[:n, 2] = view.terrain.ground_z(cand.xy_world[:n]) + 0.5 * DISK_HEIGHT_M + 0.001
            rank = None if cand.rank is None else cand.rank[:n]
            colors[:n], scales[:n] = disk_style(cand.safe[:n], rank, cand.chosen)
            # taller disks stand on the ground
            positions[:n, 2] += 0.5 * DISK_HEIGHT_M * (scales[:n, 2] - 1.0)
        self.disks.batched_positions = positions
        self.disks.batched_colors = colors
        self.disks.batched_scales = scales
        self._drawn = (cand, positions)
        self._clear_picks()

    # ---- clicks on disks ------------------------------------------------------------------------------
    def _on_disk_click(self, event: viser.SceneNodePointerEvent) -> None:
        cand, positions = self._drawn
        index = event.instance_index
        if cand is None or index is None or not 0 <= index < min(len(cand.xy_world), DISK_POOL):
            return
        picked = describe_candidate(cand, int(index), self.leg_names)
        client = event.client
        label_at = positions[index] + np.array([0.0, 0.0, PICK_LABEL_OFFSET_M])
        if client is not None:
            self._pick_labels[client.client_id] = client.scene.add_label(
                "/plan/picked", picked.text(), position=label_at, anchor="bottom-center", font_screen_scale=0.9
            )
        for listener in self.pick_listeners:
            listener(client, picked)

    def _clear_picks(self) -> None:
        """The disks changed: a label would now describe another candidate."""
        labels, self._pick_labels = self._pick_labels, {}
        for label in labels.values():
            try:
                label.remove()
            except Exception:  # noqa: BLE001 - the browser may be gone
                pass
        if labels:
            for listener in self.pick_listeners:
                listener(None, None)

    def _draw_steps(self, view: LiveView) -> None:
        positions = np.tile(HIDDEN_POS, (STEP_POOL, 1))
        colors = np.tile(STEP_COLORS[0], (STEP_POOL, 1))
        k = 0
        for j, step in enumerate(view.snapshot.planned_steps[:3]):
            footholds = np.asarray(step.footholds_xy_world)
            safe = view.terrain.is_safe(footholds) & bool(step.safe)
            ball_z = view.terrain.ground_z(footholds) + self.foot_radius_m
            for xy, z, ok in zip(footholds, ball_z, safe, strict=True):
                if k < STEP_POOL:
                    positions[k] = (xy[0], xy[1], z)
                    colors[k] = STEP_COLORS[min(j, 2)] if ok else UNSAFE_STEP_COLOR
                    k += 1
        self.steps.batched_positions = positions
        self.steps.batched_colors = colors

    def _draw_forces(self, view: LiveView) -> None:
        feet = view.foot_pos_world.copy()
        feet[:, 2] -= self.foot_radius_m
        forces = np.asarray(view.snapshot.forces, dtype=float)
        self.forces.points = arrow_segments(feet, feet + self.force_scale_m_per_n * forces)
        push = view.push_force_world
        if np.any(push):
            base = np.asarray(view.snapshot.q[:3], dtype=float)
            start = base - PUSH_SCALE_M_PER_N * push
            self.push.points = arrow_segments(start[None], base[None])
        else:
            self.push.points = np.tile(HIDDEN_POS, (3, 2, 1))
        estimate = view.estimated_push_world
        if estimate is not None:
            tip = np.asarray(view.snapshot.q[:3], dtype=float) + np.array([0.0, 0.0, ESTIMATE_LIFT_M])
            self.estimated_push.points = arrow_segments((tip - PUSH_SCALE_M_PER_N * estimate)[None], tip[None])
        else:
            self.estimated_push.points = np.tile(HIDDEN_POS, (3, 2, 1))

    def _draw_com_path(self, path: np.ndarray, terrain: Terrain) -> None:
        n = len(path)
        first = path[0] if n else None
        restart = n < self._com_drawn or (
            first is not None and self._com_first is not None and not np.array_equal(first, self._com_first)
        )
        if restart or (n == 0 and self._com_chunks):
            for chunk in self._com_chunks:
                chunk.remove()
            self._com_chunks, self._com_drawn = [], 0
        self._com_first = None if first is None else first.copy()
        if n == self._com_drawn or n < 2:
            return
        # Chunk c covers points [c * COM_CHUNK, (c + 1) * COM_CHUNK] (sharing the end point).
        last_chunk = (n - 2) // COM_CHUNK
        first_dirty = max(0, (self._com_drawn - 2) // COM_CHUNK) if self._com_drawn >= 2 else 0
        for c in range(first_dirty, last_chunk + 1):
            segment = _segments(_on_ground(path[c * COM_CHUNK : min(n, (c + 1) * COM_CHUNK + 1)], terrain, 0.003))
            if c < len(self._com_chunks):
                self._com_chunks[c].points = segment
            else:
                self._com_chunks.append(
                    self.server.scene.add_line_segments(
                        f"/com_path/{c}", segment, ACTUAL_COM_COLOR, thickness=0.004
                    )
                )
        self._com_drawn = n


def follow_anchor(view: LiveView) -> np.ndarray:
    """The point a following camera looks at: a little ahead of the robot's base, near the ground."""
    base = np.asarray(view.snapshot.q[:3], dtype=float)
    return np.array([base[0] + 0.25, base[1], float(view.terrain.ground_z(base[:2])) + 0.05])


def default_camera(view: LiveView) -> tuple[np.ndarray, np.ndarray]:
    """(position, look_at) behind and to the right of the robot, looking ahead along +x."""
    look_at = follow_anchor(view)
    return look_at + CAMERA_OFFSET_M, look_at
