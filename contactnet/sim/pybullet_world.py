"""The PyBullet world: a robot on a terrain, stepped at 1 kHz under torque control.

One `Simulator` owns one PyBullet client in DIRECT mode (no window), so several can live in one
process (data generation, tests). PyBullet is not thread-safe: only the thread that made a
Simulator may call it.

The terrain is one static body, a concave triangle mesh of the steppable regions extruded downwards
(many separate bodies simulate much slower). Holes have nothing below them.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys

import numpy as np

from contactnet.frames import quat_to_matrix, quat_to_rpy, yaw_to_quat
from contactnet.robots.description import LEG_NAMES, Robot
from contactnet.sim.world import (  # the engine-neutral types, re-exported here where they were first defined
    IMPULSE_DURATION_S,
    BodyContact,
    EngineBase,
    MassProperties,
    Push,
    SimConfig,
    SimState,
    StandingGains,
    composite_of,
    describe_body_contacts,
    standing_torques,
)
from contactnet.terrain import Terrain


@contextlib.contextmanager
def _stdout_silenced(to_stderr: bool = False):
    """Send the process's C-level stdout (fd 1) to /dev/null (``to_stderr``: to stderr) for the duration: what
    PyBullet prints (its banner, a URDF's warnings) never reaches stdout, where ``--json`` writes."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        if to_stderr:
            sys.stderr.flush()
            os.dup2(2, 1)
        else:
            with open(os.devnull, "wb") as devnull:
                os.dup2(devnull.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


class _BoundClient:
    """pybullet's functions bound to one physics client (``physicsClientId`` filled in), like
    ``pybullet_utils.BulletClient`` but without its ``__del__``, which prints a traceback when a Ctrl-C
    lands while one is being made; the `Simulator` disconnects explicitly (``close``)."""

    def __init__(self, pybullet, client_id: int) -> None:  # noqa: ANN001 - the pybullet module
        self._pb = pybullet
        self.client_id = client_id

    def __getattr__(self, name: str):  # noqa: ANN204
        attribute = getattr(self._pb, name)
        return functools.partial(attribute, physicsClientId=self.client_id) if callable(attribute) else attribute


class Simulator(EngineBase):
    """A robot on a terrain in PyBullet (DIRECT mode, torque control, fixed time step).

    `step(tau)` applies joint torques (saturated to the motor limit) for one time step, with any
    active pushes. `state()` reads the sensors. `fallen()` and `reached_goal()` are the referee.
    """

    engine = "pybullet"

    def __init__(self, robot: Robot, terrain: Terrain, config: SimConfig | None = None):
        config = SimConfig() if config is None else config
        with _stdout_silenced():  # PyBullet prints a banner on the C stdout (it would spoil --json)
            import pybullet

            client = _BoundClient(pybullet, pybullet.connect(pybullet.DIRECT))
        self._init_common(robot, terrain, config)
        self._pb = pybullet
        self.client = client
        self._cid = client.client_id  # hot-path calls go to pybullet directly (the bound client wraps each call)
        self.client.setTimeStep(config.dt_s)
        self.client.setGravity(0.0, 0.0, -config.gravity)
        self.client.setPhysicsEngineParameter(numSolverIterations=config.solver_iterations)

        self.terrain_id = self._load_terrain()
        with _stdout_silenced(to_stderr=True):  # a URDF's warnings: on stderr
            self.robot_id = self.client.loadURDF(
                str(robot.pybullet_urdf(config.sphere_feet)),
                basePosition=[0, 0, 1],
                flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
            )
        self._index_robot()
        self.payload_id: int | None = None
        self._payload_frame_base = np.zeros(3)
        self._apply_mismatch()
        self._check_mass(self.mass_properties().mass_kg)
        self.reset()

    # ---- set-up ----------------------------------------------------------------------------
    def _load_terrain(self) -> int:
        """The terrain as one static body: its steppable regions extruded into one concave mesh.

        (PyBullet's compound shapes keep at most 16 children and a multibody at most 127 links, so
        a field of 300 squares does not fit either; one triangle mesh does, simulates as fast, and is
        the very mesh the browser shows.) PyBullet takes at most 131,072 vertices and 524,288 indices
        (174,762 triangles) per mesh shape; a bigger mesh (up to the terrain budget's
        ``MAX_MESH_FACES``) is cut into spatially compact chunks of at most 100,000 triangles, the
        first the body's base and the others fixed links of the same body, so the terrain stays one
        body (``terrain_id``) and each chunk keeps its own bounding-volume tree. Every shipped terrain
        fits in one chunk.
        """
        from contactnet.terrain.mesh import split_mesh

        c = self.client
        mesh = self.terrain.mesh(thickness=self.config.terrain_thickness_m)
        if len(mesh.faces) == 0:
            raise ValueError(f"terrain {self.terrain.name!r} has no steppable surface")
        shapes = []
        for vertices, faces in split_mesh(mesh.vertices, mesh.faces, max_faces=100_000, max_vertices=100_000):
            shape = c.createCollisionShape(
                self._pb.GEOM_MESH,
                vertices=vertices.tolist(),
                indices=faces.ravel().tolist(),
                flags=self._pb.GEOM_FORCE_CONCAVE_TRIMESH,
            )
            if shape < 0:
                raise RuntimeError(f"PyBullet could not build the collision mesh of terrain {self.terrain.name!r}")
            shapes.append(shape)
        links = len(shapes) - 1
        body = c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shapes[0]) if not links else c.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=shapes[0],
            linkMasses=[0.0] * links, linkCollisionShapeIndices=shapes[1:], linkVisualShapeIndices=[-1] * links,
            linkPositions=[[0.0, 0.0, 0.0]] * links, linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * links,
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * links,
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * links, linkParentIndices=[0] * links,
            linkJointTypes=[self._pb.JOINT_FIXED] * links, linkJointAxis=[[0.0, 0.0, 1.0]] * links,
        )
        friction = self.config.foot_friction if self.config.mismatch.friction is None else 1.0
        for link in range(-1, links):
            c.changeDynamics(body, link, lateralFriction=friction, restitution=0.0)
        return body

    def replace_terrain(self, terrain: Terrain) -> None:
        """Swap the terrain body for ``terrain``'s while the robot stays where it is (an edit away from it)."""
        old_id = self.terrain_id
        previous, self.terrain = self.terrain, terrain
        try:
            self.terrain_id = self._load_terrain()
        except BaseException:
            self.terrain = previous
            raise
        self.client.removeBody(old_id)

    def _index_robot(self) -> None:
        c = self.client
        joints, links = {}, {}
        for i in range(c.getNumJoints(self.robot_id)):
            info = c.getJointInfo(self.robot_id, i)
            joints[info[1].decode()] = i
            links[info[12].decode()] = i
        description = self.robot.description
        missing = [n for n in description.joint_names + description.foot_frames if n not in joints and n not in links]
        if missing:
            raise RuntimeError(f"PyBullet model lacks {missing}")
        self.joint_ids = [joints[n] for n in description.joint_names]
        self.foot_links = [links[f] for f in description.foot_frames]
        self._foot_slot = {link: i for i, link in enumerate(self.foot_links)}
        # PyBullet's base pose and velocity are its centre of mass frame's; the base link's frame is that frame
        # moved back by the URDF's <inertial><origin> (None: they coincide, as Solo12's nearly do).
        info = c.getDynamicsInfo(self.robot_id, -1)
        inertial_pos, inertial_quat = tuple(info[3]), tuple(info[4])
        self._com_in_base: tuple[tuple, tuple] | None = None
        if max(map(abs, inertial_pos)) > 1e-9 or max(map(abs, inertial_quat[:3])) > 1e-9:
            self._com_in_base = inertial_pos, inertial_quat
            self._base_in_com = c.invertTransform(inertial_pos, inertial_quat)
        base_name = c.getBodyInfo(self.robot_id)[0].decode()
        self.link_names = {i: name for name, i in links.items()} | {-1: base_name}
        # Each link on the chain from the base to a foot belongs to that foot's leg (the base to none).
        parent = {i: c.getJointInfo(self.robot_id, i)[16] for i in links.values()}
        self._leg_of_link: dict[int, int] = {}
        for slot, foot in enumerate(self.foot_links):
            link = foot
            while link != -1:
                self._leg_of_link.setdefault(link, slot)
                link = parent[link]
        # Disable the default velocity motors: joints move only under our torques.
        c.setJointMotorControlArray(
            self.robot_id, self.joint_ids, self._pb.VELOCITY_CONTROL, forces=[0.0] * len(self.joint_ids)
        )
        for link in [-1, *links.values()]:
            c.changeDynamics(self.robot_id, link, linearDamping=0.0, angularDamping=0.0)
        friction = self.config.foot_friction if self.config.mismatch.friction is None else self.config.mismatch.friction
        for link in self.foot_links:
            c.changeDynamics(self.robot_id, link, lateralFriction=friction, restitution=0.0)

    def _apply_mismatch(self) -> None:
        """Make the simulated robot differ from the model as ``config.mismatch`` says (mass, payload; the friction,
        torque limits, noise and delay are applied where they act)."""
        c, mismatch = self.client, self.config.mismatch
        if mismatch.mass_scale != 1.0:
            for link in [-1, *range(c.getNumJoints(self.robot_id))]:
                info = c.getDynamicsInfo(self.robot_id, link)
                c.changeDynamics(self.robot_id, link, mass=info[0] * mismatch.mass_scale,
                                 localInertiaDiagonal=[v * mismatch.mass_scale for v in info[2]])
        if mismatch.payload_kg > 0:
            # A 3 cm ball that collides with nothing, held at the offset by a stiff fixed constraint. PyBullet places
            # a constraint's frame relative to the link's centre of mass.
            radius = 0.03
            shape = c.createCollisionShape(self._pb.GEOM_SPHERE, radius=radius)
            self.payload_id = c.createMultiBody(baseMass=mismatch.payload_kg, baseCollisionShapeIndex=shape)
            c.setCollisionFilterGroupMask(self.payload_id, -1, 0, 0)
            com_base = np.asarray(c.getDynamicsInfo(self.robot_id, -1)[3])
            self._payload_frame_base = np.array([*mismatch.payload_offset_xy_m, 0.0])
            constraint = c.createConstraint(self.robot_id, -1, self.payload_id, -1, self._pb.JOINT_FIXED, [0, 0, 0],
                                            (self._payload_frame_base - com_base).tolist(), [0, 0, 0])
            c.changeConstraint(constraint, maxForce=1e4)

    def mass_properties(self) -> MassProperties:
        """The simulated robot's mass, CoM and composite inertia now, from PyBullet's own links (payload included)."""
        c = self.client
        masses, coms, rotations, moments = [], [], [], []
        for body in (self.robot_id, self.payload_id):
            if body is None:
                continue
            for link in range(-1, c.getNumJoints(body)):
                info = c.getDynamicsInfo(body, link)
                pos, quat = c.getBasePositionAndOrientation(body) if link < 0 else c.getLinkState(body, link)[:2]
                masses.append(info[0])
                moments.append(info[2])
                coms.append(pos)
                rotations.append(np.array(c.getMatrixFromQuaternion(quat)).reshape(3, 3))
        return composite_of(np.array(masses), np.array(coms), np.array(rotations), np.array(moments))

    def _base_pose(self, com_pose: tuple | None = None) -> tuple:
        """The base link's position and quaternion (x, y, z, w) in the world, from PyBullet's base pose, which is its
        CoM frame's (``com_pose``: that pose, already read)."""
        pb, cid = self._pb, self._cid
        pos, quat = pb.getBasePositionAndOrientation(self.robot_id, physicsClientId=cid) if com_pose is None else com_pose
        if self._com_in_base is None:
            return pos, quat
        return pb.multiplyTransforms(pos, quat, *self._base_in_com, physicsClientId=cid)

    def _base_pose_and_velocity(self) -> tuple:
        """The base link's position, quaternion, linear velocity of its origin and angular velocity (world)."""
        pb, cid = self._pb, self._cid
        com_pose = pb.getBasePositionAndOrientation(self.robot_id, physicsClientId=cid)
        lin, ang = pb.getBaseVelocity(self.robot_id, physicsClientId=cid)
        if self._com_in_base is None:
            return (*com_pose, lin, ang)
        pos, quat = self._base_pose(com_pose)
        lin = np.asarray(lin) - np.cross(ang, np.asarray(com_pose[0]) - np.asarray(pos))  # the origin's, not the CoM's
        return pos, quat, tuple(lin.tolist()), ang

    def _place_payload(self) -> None:
        if self.payload_id is None:
            return
        c = self.client
        pos, quat = self._base_pose()
        rot = np.array(c.getMatrixFromQuaternion(quat)).reshape(3, 3)
        c.resetBasePositionAndOrientation(self.payload_id, (np.asarray(pos) + rot @ self._payload_frame_base).tolist(),
                                          quat)
        c.resetBaseVelocity(self.payload_id, [0, 0, 0], [0, 0, 0])

    def reset(
        self,
        joint_pos: np.ndarray | None = None,
        joint_vel: np.ndarray | None = None,
        base_xy: np.ndarray | None = None,
        base_yaw_rad: float = 0.0,
        base_height_m: float | None = None,
    ) -> SimState:
        """Put the robot at the terrain's start (or base_xy), standing pose unless joints are given.

        The base height defaults to the height at which the lowest foot just touches the surface.
        """
        c = self.client
        q_joint = self.robot.joint_standing if joint_pos is None else np.asarray(joint_pos, float)
        v_joint = np.zeros(12) if joint_vel is None else np.asarray(joint_vel, float)
        xy = self.terrain.start_xy if base_xy is None else np.asarray(base_xy, float)
        if base_height_m is None:
            base_height_m = self._standing_height(q_joint)
        pos = [float(xy[0]), float(xy[1]), float(self.terrain.ground_z(xy)) + base_height_m]
        quat = list(yaw_to_quat(base_yaw_rad))
        if self._com_in_base is not None:  # PyBullet places the CoM frame
            pos, quat = c.multiplyTransforms(pos, quat, *self._com_in_base)
        c.resetBasePositionAndOrientation(self.robot_id, pos, quat)
        c.resetBaseVelocity(self.robot_id, [0, 0, 0], [0, 0, 0])
        for jid, qj, vj in zip(self.joint_ids, q_joint, v_joint, strict=True):
            c.resetJointState(self.robot_id, jid, float(qj), float(vj))
        self._place_payload()
        self._restart_clock()
        return self.state()

    # ---- stepping --------------------------------------------------------------------------
    def step(self, tau: np.ndarray) -> None:
        """Apply joint torques (N m, pinocchio order; clipped to the motor limit) for one time step."""
        pb, cid = self._pb, self._cid
        tau = self._motor_torque(tau)
        pb.setJointMotorControlArray(
            self.robot_id, self.joint_ids, pb.TORQUE_CONTROL, forces=tau.tolist(), physicsClientId=cid
        )
        for push in self.pushes:
            if push.active(self.t_s):
                pos = self._base_pose()[0]  # at the base's origin
                pb.applyExternalForce(self.robot_id, -1, push.force_world, pos, pb.WORLD_FRAME, physicsClientId=cid)
        pb.stepSimulation(physicsClientId=cid)
        self.steps += 1
        self.t_s = self.steps * self.config.dt_s

    # ---- sensing ---------------------------------------------------------------------------
    def state(self, with_contacts: bool = True) -> SimState:
        """Read the sensors. `with_contacts=False` skips the foot-contact query (about 15 us) for
        loops that do not need it; contacts then read as all False."""
        pb, cid, robot = self._pb, self._cid, self.robot_id
        pos, quat, lin, ang = self._base_pose_and_velocity()
        q_tuple, v_tuple, _, _ = zip(*pb.getJointStates(robot, self.joint_ids, physicsClientId=cid), strict=True)
        v_true = np.array(v_tuple)
        v = v_true
        if self.config.joint_vel_noise_var > 0:
            v = v_true + self._rng.normal(0.0, np.sqrt(self.config.joint_vel_noise_var), size=12)
        if with_contacts:
            contact, force = self._foot_contacts()
        else:
            contact, force = np.zeros(4, dtype=bool), np.zeros((4, 3))
        lin, ang, rot = np.array(lin), np.array(ang), np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
        if self._noisy_base:
            quat, rot, lin, ang = self._measured_base(quat, rot, lin, ang)
        return SimState(self.t_s, np.array(pos), np.array(quat), lin, ang, np.array(q_tuple), v, v_true, contact, force,
                        rot)

    def _contact_points(self) -> tuple:
        return self._pb.getContactPoints(bodyA=self.robot_id, bodyB=self.terrain_id, physicsClientId=self._cid)

    def _foot_contacts(self) -> tuple[np.ndarray, np.ndarray]:
        """Feet in contact (4,) and the contact force on each foot (4, 3)."""
        contact = np.zeros(4, dtype=bool)
        force = np.zeros((4, 3))
        for point in self._contact_points():
            slot = self._foot_slot.get(point[3])
            if slot is None:
                continue
            contact[slot] = True
            # Force on the foot: normal (from the terrain to the foot) plus the two friction parts.
            force[slot] += np.multiply(point[9], point[7])
            force[slot] += np.multiply(point[10], point[11]) + np.multiply(point[12], point[13])
        return contact, force

    def foot_contact(self) -> np.ndarray:
        """(4,) bool: which feet touch the terrain now (one contact query, no state read)."""
        contact = np.zeros(4, dtype=bool)
        for point in self._contact_points():
            slot = self._foot_slot.get(point[3])
            if slot is not None:
                contact[slot] = True
        return contact

    def foot_positions_world(self) -> np.ndarray:
        """(4, 3) true foot-ball centres from PyBullet."""
        states = self.client.getLinkStates(self.robot_id, self.foot_links, computeForwardKinematics=1)
        return np.array([s[4] for s in states])

    def non_foot_contacts(self) -> list[str]:
        """Names of robot links other than the feet that touch the terrain now."""
        links = {point[3] for point in self._contact_points()} - self._foot_slot.keys()
        return sorted(self.link_names.get(link, str(link)) for link in links)

    def body_contacts(self) -> list[BodyContact]:
        """The non-foot contacts now, one per link (its point of largest normal force), sorted by link name."""
        strongest: dict[int, tuple] = {}
        for point in self._contact_points():
            link = point[3]
            if link not in self._foot_slot and (link not in strongest or point[9] > strongest[link][9]):
                strongest[link] = point
        if not strongest:
            return []
        feet_xy = self.foot_positions_world()[:, :2]
        over_gap = ~self.terrain.is_safe(feet_xy)
        leg_names = self.robot.description.leg_names
        contacts = []
        for link, point in strongest.items():
            slot = self._leg_of_link.get(link)
            contacts.append(BodyContact(
                link=self.link_names.get(link, str(link)),
                leg=None if slot is None else leg_names[slot],
                point_world=tuple(float(v) for v in point[6]),
                normal_world=tuple(float(v) for v in point[7]),
                normal_force_n=float(point[9]),
                foot_over_gap=bool(slot is not None and over_gap[slot]),
            ))
        return sorted(contacts, key=lambda contact: contact.link)

    # ---- referee (contactnet.sim.world.Referee) --------------------------------------------
    def _true_base(self) -> tuple:
        """The base's position, quaternion (x, y, z, w), linear and angular velocity (world) without sensor noise."""
        return self._base_pose_and_velocity()

    def close(self) -> None:
        if self.client is not None:
            self.client.disconnect()
            self.client = None

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = [
    "IMPULSE_DURATION_S",
    "LEG_NAMES",
    "BodyContact",
    "Push",
    "SimConfig",
    "SimState",
    "Simulator",
    "StandingGains",
    "quat_to_matrix",
    "quat_to_rpy",
    "describe_body_contacts",
    "standing_torques",
    "yaw_to_quat",
]
