"""The MuJoCo world: the same robot on the same terrain as ``contactnet.sim.pybullet_world``, stepped at 1 kHz under
torque control by MuJoCo (the engine alone, ``mujoco-core``; no viewer).

The robot is the URDF the PyBullet world loads (``Robot.pybullet_urdf``: the same collision recipe, sphere feet),
read by MuJoCo's URDF importer with a free joint added at its root link. Its links do not collide with each other
(PyBullet's default for a URDF). The terrain's tops are exact, with real holes: each polygon of each level is
triangulated (the same earcut triangulation as the PyBullet mesh), the triangles merged into convex pieces, and every
piece extruded into a convex prism down to ``terrain_thickness_m`` below the lowest top, one static mesh geom each
(MuJoCo collides with the convex hull of a mesh, so one concave mesh would fill the holes).

Contact parameters, chosen to match the PyBullet world (``MujocoConfig``, measured in the tests and
``contactnet bench sim``): PyBullet multiplies the two bodies' friction coefficients (feet 0.9 on terrain 0.9: 0.81;
with ``--friction MU`` the terrain's is 1 and the feet's MU), MuJoCo takes the larger, so both the feet and the terrain
get the product; the elliptic friction cone (PyBullet's friction is two orthogonal directions, each limited by
mu N); a contact time constant of ``solref_time_s`` with critical damping.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from contactnet.frames import yaw_to_quat
from contactnet.robots.description import Robot
from contactnet.sim.world import BodyContact, EngineBase, MassProperties, SimConfig, SimState, composite_of
from contactnet.terrain import Terrain

_XYZW = [4, 5, 6, 3]  # the free joint's quaternion (w, x, y, z in qpos[3:7]) as x, y, z, w
_XYZ = np.arange(3)  # a contact's three constraint forces after its efc_address (elliptic cone)


@dataclass(frozen=True)
class MujocoConfig:
    """MuJoCo's own settings (the rest is ``SimConfig``, shared with PyBullet)."""

    solref_time_s: float = 0.005  # contact time constant (MuJoCo's default 0.02 lets a 2.5 kg robot sink 4 mm)
    solref_damping: float = 1.0  # damping ratio (1: critical)
    iterations: int = 50  # constraint solver iterations per step (Newton)
    cone: str = "elliptic"  # friction cone: "elliptic" or "pyramidal"
    integrator: str = "implicitfast"  # stable with the legs' light lower links and no joint damping
    impratio: float = 100.0  # frictional to normal constraint impedance: above 1, feet creep less under a sideways load
    noslip_iterations: int = 0  # MuJoCo's no-slip post-solver (0: off)


def _floating_urdf(urdf_text: str) -> str:
    """The URDF with a free joint between the world and its root link, and MuJoCo's import options."""
    root = re.search(r'<link\s+name="([^"]+)"', urdf_text)
    if root is None:
        raise ValueError("the robot's URDF has no link")
    inject = ('<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="true"/></mujoco>'
              f'<link name="world"/><joint name="mujoco_root" type="floating"><parent link="world"/>'
              f'<child link="{root.group(1)}"/></joint>')
    return re.sub(r"(<robot[^>]*>)", lambda m: m.group(1) + inject, urdf_text, count=1)


def terrain_prisms(terrain: Terrain, thickness_m: float) -> list[np.ndarray]:
    """The terrain's tops as convex prisms: one (2 N, 3) array of vertices (the top's N corners counter-clockwise,
    then the same N at the bottom) per convex piece of each top polygon (tilted with a sloped top), from the top down to ``thickness_m`` below
    the lowest top (or the surface). The pieces are the polygon's triangulation with neighbouring triangles merged
    while the union stays convex (`convex_pieces`): fewer seams inside a top, where a foot resting across two pieces
    could be pushed sideways by the side face of the other."""
    import shapely

    base_z = min(terrain.surface_z, terrain.top_z_range()[0]) - thickness_m
    prisms = []
    for index, (_, geometry) in enumerate(terrain.levels):
        for polygon in shapely.get_parts(geometry):
            if polygon.is_empty or polygon.area <= 0.0:
                continue
            for corners in convex_pieces(polygon):  # a sloped top: the plane's height at each corner
                top = np.column_stack([corners, terrain.level_height(index, corners)])
                bottom = np.column_stack([corners, np.full(len(corners), base_z)])
                prisms.append(np.concatenate([top, bottom]))
    return prisms


def convex_pieces(polygon) -> list[np.ndarray]:  # noqa: ANN001 - a shapely Polygon
    """A polygon (with holes) as convex pieces, each (N, 2) counter-clockwise: its earcut triangles (the PyBullet
    mesh's), merged greedily across shared edges while the merged piece stays convex (Hertel-Mehlhorn). A rectangle
    or a disc is one piece, a star its tips and its core. Slivers (triangles of no area) are dropped."""
    from contactnet.terrain.mesh import _triangulate

    xy, triangles = _triangulate(polygon)
    corners = xy[triangles]
    edge1, edge2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(edge1[:, 0] * edge2[:, 1] - edge1[:, 1] * edge2[:, 0])
    pieces: dict[int, list[int]] = {k: list(map(int, t)) for k, t in enumerate(triangles) if area[k] > 1e-8}
    owner: dict[tuple[int, int], int] = {}  # a directed edge -> the piece whose boundary runs along it
    for k, cycle in pieces.items():
        for a, b in zip(cycle, cycle[1:] + cycle[:1], strict=True):
            owner[(a, b)] = k
    changed = True
    while changed:
        changed = False
        for k in list(pieces):
            if k not in pieces:
                continue
            cycle = pieces[k]
            for i, (a, b) in enumerate(zip(cycle, cycle[1:] + cycle[:1], strict=True)):
                other = owner.get((b, a))
                if other is None or other == k or other not in pieces:
                    continue
                merged = _merge(cycle, i, pieces[other], b, a)
                if merged is None or not _convex(xy[merged]):
                    continue
                for c, d in zip(pieces[other], pieces[other][1:] + pieces[other][:1], strict=True):
                    owner[(c, d)] = k
                for c, d in zip(merged, merged[1:] + merged[:1], strict=True):
                    owner[(c, d)] = k
                owner.pop((a, b), None)
                owner.pop((b, a), None)
                pieces[k] = merged
                del pieces[other]
                changed = True
                break
    return [xy[cycle] for cycle in pieces.values()]


def _merge(cycle: list[int], i: int, other: list[int], b: int, a: int) -> list[int] | None:
    """The cycle of two pieces joined along the edge ``cycle[i] -> cycle[i + 1]`` (``a -> b``), which ``other`` runs
    ``b -> a``: ``cycle`` up to ``a``, then ``other`` from after ``a`` round to ``b``, then the rest of ``cycle``."""
    j = other.index(b)
    if other[(j + 1) % len(other)] != a:
        return None
    rest = [other[(j + 2 + m) % len(other)] for m in range(len(other) - 2)]  # other's vertices after a, before b
    return cycle[:i + 1] + rest + cycle[i + 1:]


def _convex(corners: np.ndarray) -> bool:
    """Whether a counter-clockwise cycle of points turns left (or goes straight) at every corner."""
    nxt, after = np.roll(corners, -1, axis=0), np.roll(corners, -2, axis=0)
    turn = (nxt[:, 0] - corners[:, 0]) * (after[:, 1] - nxt[:, 1]) - (nxt[:, 1] - corners[:, 1]) * (after[:, 0] - nxt[:, 0])
    return bool((turn >= -1e-12).all())


class MujocoSimulator(EngineBase):
    """A robot on a terrain in MuJoCo: the same interface and referee as the PyBullet ``Simulator``."""

    engine = "mujoco"

    def __init__(self, robot: Robot, terrain: Terrain, config: SimConfig | None = None,
                 mujoco_config: MujocoConfig | None = None):
        import mujoco

        self._mj = mujoco
        config = SimConfig() if config is None else config
        self._init_common(robot, terrain, config)
        self.mujoco_config = MujocoConfig() if mujoco_config is None else mujoco_config
        self._build()
        self.reset()

    # ---- set-up ----------------------------------------------------------------------------
    def _friction(self) -> float:
        """The friction coefficient of a foot on the terrain, as PyBullet combines it (the product)."""
        mismatch = self.config.mismatch
        return self.config.foot_friction ** 2 if mismatch.friction is None else mismatch.friction

    def _build(self) -> None:
        mj, config, mjc = self._mj, self.config, self.mujoco_config
        description = self.robot.description
        urdf = self.robot.pybullet_urdf(config.sphere_feet)
        spec = mj.MjSpec.from_string(_floating_urdf(urdf.read_text()))
        spec.meshdir = str(urdf.parent)
        spec.option.timestep = config.dt_s
        spec.option.gravity = [0.0, 0.0, -config.gravity]
        spec.option.iterations = mjc.iterations
        spec.option.impratio = mjc.impratio
        spec.option.noslip_iterations = mjc.noslip_iterations
        spec.option.cone = getattr(mj.mjtCone, f"mjCONE_{mjc.cone.upper()}")
        spec.option.integrator = getattr(mj.mjtIntegrator, f"mjINT_{mjc.integrator.upper()}")
        friction = self._friction()
        solref = [mjc.solref_time_s, mjc.solref_damping]
        for geom in spec.geoms:  # the robot's: collide with the terrain only, never with each other
            geom.contype, geom.conaffinity = 1, 0
            geom.friction = [friction, 0.005, 0.0001]
            geom.solref = solref
            geom.condim = 3
        scale = config.mismatch.mass_scale
        if scale != 1.0:
            for body in spec.bodies:
                if body.name != "world":
                    body.mass *= scale
                    body.inertia = np.asarray(body.inertia) * scale
        mismatch = config.mismatch
        if mismatch.payload_kg > 0:  # a point mass (a 3 cm ball's inertia) at the offset from the base, no collision
            base = spec.body(description_root(spec))
            radius = 0.03
            base.add_body(name="payload", pos=[*mismatch.payload_offset_xy_m, 0.0], mass=mismatch.payload_kg,
                          inertia=[0.4 * mismatch.payload_kg * radius ** 2] * 3, explicitinertial=True)
        self._add_terrain(spec, friction, solref)
        self.spec = spec
        self.model = model = spec.compile()
        self._check_mass(float(model.body_mass.sum()))
        self.data = mj.MjData(model)
        name = lambda kind, i: mj.mj_id2name(model, kind, i)  # noqa: E731
        joints = {name(mj.mjtObj.mjOBJ_JOINT, j): j for j in range(model.njnt)}
        bodies = {name(mj.mjtObj.mjOBJ_BODY, b): b for b in range(model.nbody)}
        missing = [n for n in (*description.joint_names, *description.foot_frames) if n not in joints and n not in bodies]
        if missing:
            raise RuntimeError(f"the MuJoCo model lacks {missing}")
        self._qadr = np.array([model.jnt_qposadr[joints[n]] for n in description.joint_names])
        self._vadr = np.array([model.jnt_dofadr[joints[n]] for n in description.joint_names])
        self.base_body = model.jnt_bodyid[joints["mujoco_root"]]
        self.foot_bodies = [bodies[f] for f in description.foot_frames]
        self.link_names = {b: n for n, b in bodies.items()}
        self._terrain_geom = np.zeros(model.ngeom, dtype=bool)
        self._terrain_geom[[mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, f"terrain_{k}")
                            for k in range(self._n_terrain_geoms)]] = True
        self._foot_slot_of_geom = np.full(model.ngeom, -1)  # per geom: its foot's slot, -1 if not a foot's
        for g in range(model.ngeom):
            if model.geom_bodyid[g] in self.foot_bodies:
                self._foot_slot_of_geom[g] = self.foot_bodies.index(model.geom_bodyid[g])
        self._no_contacts = (np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros(0))
        self._terrain_list, self._slot_list = self._terrain_geom.tolist(), self._foot_slot_of_geom.tolist()
        self._leg_of_body: dict[int, int] = {}
        for slot, foot in enumerate(self.foot_bodies):
            body = foot
            while body != self.base_body and body != 0:
                self._leg_of_body.setdefault(body, slot)
                body = model.body_parentid[body]
        self._force6 = np.zeros(6)
        self._elliptic = mjc.cone == "elliptic"

    def _add_terrain(self, spec, friction: float, solref: list[float]) -> None:  # noqa: ANN001 - an MjSpec
        prisms = terrain_prisms(self.terrain, self.config.terrain_thickness_m)
        if not prisms:
            raise ValueError(f"terrain {self.terrain.name!r} has no steppable surface")
        for k, prism in enumerate(prisms):
            spec.add_mesh(name=f"terrain_{k}", uservert=prism.ravel().tolist())
            spec.worldbody.add_geom(name=f"terrain_{k}", type=self._mj.mjtGeom.mjGEOM_MESH, meshname=f"terrain_{k}",
                                    contype=0, conaffinity=1, friction=[friction, 0.005, 0.0001], solref=solref,
                                    condim=3)
        self._n_terrain_geoms = len(prisms)

    def mass_properties(self) -> MassProperties:
        """The simulated robot's mass, CoM and composite inertia now, from MuJoCo's bodies (payload included)."""
        m, d = self.model, self.data
        bodies = np.arange(1, m.nbody)  # not the world
        return composite_of(m.body_mass[bodies], d.xipos[bodies], d.ximat[bodies].reshape(-1, 3, 3),
                            m.body_inertia[bodies])

    def replace_terrain(self, terrain: Terrain) -> None:
        """Swap the terrain for ``terrain``'s while the robot stays where it is (its state is carried over)."""
        qpos, qvel = self.data.qpos.copy(), self.data.qvel.copy()
        previous, self.terrain = self.terrain, terrain
        try:
            self._build()
        except BaseException:
            self.terrain = previous
            raise
        self.data.qpos[:], self.data.qvel[:] = qpos, qvel
        self._mj.mj_forward(self.model, self.data)

    def reset(self, joint_pos: np.ndarray | None = None, joint_vel: np.ndarray | None = None,
              base_xy: np.ndarray | None = None, base_yaw_rad: float = 0.0,
              base_height_m: float | None = None) -> SimState:
        """Put the robot at the terrain's start (or base_xy), standing pose unless joints are given; the base height
        defaults to the one at which the lowest foot just touches the surface."""
        q_joint = self.robot.joint_standing if joint_pos is None else np.asarray(joint_pos, float)
        v_joint = np.zeros(12) if joint_vel is None else np.asarray(joint_vel, float)
        xy = self.terrain.start_xy if base_xy is None else np.asarray(base_xy, float)
        if base_height_m is None:
            base_height_m = self._standing_height(q_joint)
        d = self.data
        d.qpos[:], d.qvel[:] = 0.0, 0.0
        x, y, z, w = yaw_to_quat(base_yaw_rad)
        d.qpos[0:7] = [float(xy[0]), float(xy[1]), float(self.terrain.ground_z(xy)) + base_height_m, w, x, y, z]
        d.qpos[self._qadr], d.qvel[self._vadr] = q_joint, v_joint
        d.qfrc_applied[:], d.xfrc_applied[:] = 0.0, 0.0
        d.time = 0.0
        self._mj.mj_forward(self.model, d)
        self._restart_clock()
        return self.state()

    # ---- stepping --------------------------------------------------------------------------
    def step(self, tau: np.ndarray) -> None:
        """Apply joint torques (N m, pinocchio order; clipped to the motor limit) for one time step."""
        d = self.data
        tau = self._motor_torque(tau)
        d.qfrc_applied[self._vadr] = tau
        wrench = d.xfrc_applied[self.base_body]
        wrench[:] = 0.0
        for push in self.pushes:
            if push.active(self.t_s):  # at the base's origin, as PyBullet applies it (MuJoCo's is at the body's CoM)
                force = np.asarray(push.force_world, dtype=float)
                wrench[0:3] += force
                wrench[3:6] += np.cross(d.xpos[self.base_body] - d.xipos[self.base_body], force)
        self._mj.mj_step(self.model, d)
        self.steps += 1
        self.t_s = self.steps * self.config.dt_s

    # ---- sensing ---------------------------------------------------------------------------
    def _true_base(self) -> tuple:
        d = self.data
        qvel = d.qvel
        return d.qpos[0:3].copy(), d.qpos[_XYZW], qvel[0:3].copy(), d.xmat[self.base_body].reshape(3, 3) @ qvel[3:6]

    def state(self, with_contacts: bool = True) -> SimState:
        """Read the sensors (``with_contacts=False``: contacts read as all False)."""
        d = self.data
        pos, quat, lin, ang = self._true_base()
        v_true = d.qvel[self._vadr].copy()
        v = v_true
        if self.config.joint_vel_noise_var > 0:
            v = v_true + self._rng.normal(0.0, np.sqrt(self.config.joint_vel_noise_var), size=12)
        if with_contacts:
            contact, force = self._foot_contacts()
        else:
            contact, force = np.zeros(4, dtype=bool), np.zeros((4, 3))
        rot = d.xmat[self.base_body].reshape(3, 3).copy()
        if self._noisy_base:
            quat, rot, lin, ang = self._measured_base(quat, rot, lin, ang)
        return SimState(self.t_s, pos, quat, lin, ang, d.qpos[self._qadr].copy(), v, v_true, contact, force, rot)

    def _terrain_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The contacts between the robot and the terrain now: their indices, the robot's geom of each and the sign
        that turns MuJoCo's contact force into the force on the robot (see ``_force_on_robot``), as arrays."""
        d = self.data
        n = d.ncon
        if n == 0:
            return self._no_contacts
        geoms = d.contact.geom[:n]  # (n, 2)
        terrain = self._terrain_geom[geoms]  # (n, 2)
        mixed = terrain[:, 0] != terrain[:, 1]
        index = np.flatnonzero(mixed)
        first_is_terrain = terrain[index, 0]
        robot_geom = np.where(first_is_terrain, geoms[index, 1], geoms[index, 0])
        return index, robot_geom, np.where(first_is_terrain, 1.0, -1.0)

    def _force_on_robot(self, i: int, sign: float) -> np.ndarray:
        """The world-frame force (3,) of contact ``i`` on the robot's geom. MuJoCo's contact force, in the contact
        frame whose first axis is the normal from geom1 to geom2, is the force geom1 exerts on geom2."""
        self._mj.mj_contactForce(self.model, self.data, int(i), self._force6)
        frame = self.data.contact.frame[i].reshape(3, 3)
        return sign * (frame.T @ self._force6[0:3])

    def _foot_contacts(self) -> tuple[np.ndarray, np.ndarray]:
        """Feet in contact (4,) and the force of the terrain on each foot (4, 3, world), read every tick. With the
        elliptic cone, a contact's force in its frame is its three constraint forces (what ``mj_contactForce``
        returns), read for all the feet's contacts at once; each foot's contacts are summed in order."""
        contact = np.zeros(4, dtype=bool)
        force = np.zeros((4, 3))
        index, slots, signs = self._foot_terrain_contacts()
        if not index:
            return contact, force
        d, contacts = self.data, self.data.contact
        if self._elliptic:
            local = d.efc_force[contacts.efc_address[index][:, None] + _XYZ]  # (k, 3): normal, two tangents
            frames = contacts.frame[index].reshape(-1, 3, 3)
            world = np.asarray(signs)[:, None] * np.einsum("kij,ki->kj", frames, local)  # frame.T @ local
        else:
            world = np.array([self._force_on_robot(i, sign) for i, sign in zip(index, signs, strict=True)])
        for slot, value in zip(slots, world, strict=True):
            contact[slot] = True
            force[slot] += value
        return contact, force

    def _foot_terrain_contacts(self) -> tuple[list[int], list[int], list[float]]:
        """The contacts between a foot and the terrain now: their indices, the feet's slots and the signs that turn
        MuJoCo's contact force into the force on the foot (read every tick: Python ints over the few contacts)."""
        index, slots, signs = [], [], []
        n = self.data.ncon
        if n:
            terrain, slot_of = self._terrain_list, self._slot_list
            for i, (g1, g2) in enumerate(self.data.contact.geom[:n].tolist()):
                if terrain[g1] != terrain[g2]:
                    slot = slot_of[g2 if terrain[g1] else g1]
                    if slot >= 0:
                        index.append(i)
                        slots.append(slot)
                        signs.append(1.0 if terrain[g1] else -1.0)
        return index, slots, signs

    def foot_contact(self) -> np.ndarray:
        """(4,) bool: which feet touch the terrain now."""
        contact = np.zeros(4, dtype=bool)
        contact[self._foot_terrain_contacts()[1]] = True
        return contact

    def foot_positions_world(self) -> np.ndarray:
        """(4, 3) true foot-ball centres."""
        return self.data.xpos[self.foot_bodies].copy()

    def non_foot_contacts(self) -> list[str]:
        """Names of robot links other than the feet that touch the terrain now."""
        geoms = self._terrain_contacts()[1]
        bodies = set(self.model.geom_bodyid[geoms[self._foot_slot_of_geom[geoms] < 0]].tolist())
        return sorted(self.link_names[b] for b in bodies)

    def body_contacts(self) -> list[BodyContact]:
        """The non-foot contacts now, one per link (its point of largest normal force), sorted by link name."""
        strongest: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}
        for i, geom, sign in zip(*self._terrain_contacts(), strict=True):
            if self._foot_slot_of_geom[geom] >= 0:
                continue
            body = int(self.model.geom_bodyid[geom])
            force = self._force_on_robot(i, sign)
            normal = sign * self.data.contact.frame[i][0:3]  # from the terrain toward the robot
            normal_force = float(force @ normal)
            if body not in strongest or normal_force > strongest[body][0]:
                strongest[body] = (normal_force, self.data.contact.pos[i].copy(), normal.copy())
        if not strongest:
            return []
        over_gap = ~self.terrain.is_safe(self.foot_positions_world()[:, :2])
        leg_names = self.robot.description.leg_names
        contacts = []
        for body, (normal_force, point, normal) in strongest.items():
            slot = self._leg_of_body.get(body)
            contacts.append(BodyContact(
                link=self.link_names[body], leg=None if slot is None else leg_names[slot],
                point_world=tuple(float(v) for v in point), normal_world=tuple(float(v) for v in normal),
                normal_force_n=normal_force, foot_over_gap=bool(slot is not None and over_gap[slot])))
        return sorted(contacts, key=lambda contact: contact.link)

    def close(self) -> None:
        self.data = None

    def __enter__(self) -> MujocoSimulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def description_root(spec) -> str:  # noqa: ANN001 - an MjSpec
    """The name of the robot's root body (the one under the world with the free joint)."""
    for body in spec.bodies:
        if body.name != "world" and body.parent.name == "world":
            return body.name
    raise RuntimeError("the MuJoCo model has no root body")


__all__ = ["MujocoConfig", "MujocoSimulator", "terrain_prisms"]
