"""The MuJoCo world against the terrain it is built from and against the PyBullet world: the terrain's prisms are
its steppable area exactly (holes are holes), the robot is the same robot, it stands and walks as in PyBullet, a
push pushes alike, and the model mismatch options change the MuJoCo robot as they change PyBullet's."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from contactnet.locomotion import Locomotion
from contactnet.registry import gait_by_name, make_planner
from contactnet.sim.engines import make_simulator
from contactnet.sim.mismatch import ModelMismatch
from contactnet.sim.mujoco_world import MujocoSimulator, terrain_prisms
from contactnet.sim.world import Push, SimConfig, standing_torques
from contactnet.terrain import flat, random_field, resolve
from contactnet.terrain.mesh import _triangulate


def _stand(sim, seconds: float) -> None:  # noqa: ANN001 - either engine
    state = sim.state(with_contacts=False)
    for _ in range(round(seconds / sim.config.dt_s)):
        sim.step(standing_torques(state, sim.robot.joint_standing))
        state = sim.state(with_contacts=False)


@pytest.mark.parametrize("terrain", [resolve("stepping_stones"), random_field(removed=110, seed=3),
                                     resolve("random_heights", removed=80, seed=2)], ids=lambda t: t.name)
def test_the_prisms_are_the_steppable_area(terrain) -> None:  # noqa: ANN001
    prisms = terrain_prisms(terrain, thickness_m=0.4)
    tops = [p[:len(p) // 2] for p in prisms]  # each piece's corners, counter-clockwise
    pieces = [shapely.Polygon(top[:, :2]) for top in tops]
    steppable = sum(shapely.area(geometry) for _, geometry in terrain.levels)
    assert sum(piece.area for piece in pieces) == pytest.approx(steppable, rel=1e-6)  # no hole covered, no top missing
    assert shapely.union_all(pieces).area == pytest.approx(steppable, rel=1e-6)  # and no two pieces overlap
    for piece, top in zip(pieces, tops, strict=True):
        assert piece.is_valid and piece.area == pytest.approx(piece.convex_hull.area, rel=1e-9)  # convex: MuJoCo's hull
        centroid = np.array(piece.centroid.coords[0])
        assert terrain.is_safe(centroid[None], 0.0)[0]
        assert np.ptp(top[:, 2]) == 0.0 and top[0, 2] == pytest.approx(terrain.ground_z(centroid[None])[0], abs=1e-9)
    bottoms = np.concatenate([p[len(p) // 2:] for p in prisms])
    assert np.ptp(bottoms[:, 2]) == 0.0 and bottoms[0, 2] == pytest.approx(terrain.levels[-1][0] - 0.4)
    triangles = sum(len(_triangulate(polygon)[1]) for _, level in terrain.levels for polygon in shapely.get_parts(level))
    assert len(prisms) < triangles  # merged: fewer seams than the triangulation's


def test_a_hole_in_mujoco_is_a_hole(robot) -> None:
    terrain = random_field(removed=300, seed=0)  # the whole field removed
    with MujocoSimulator(robot, terrain) as sim:
        sim.reset(base_xy=np.array([terrain.goal_x - 0.75, 0.0]))
        _stand(sim, 0.5)
        assert sim.state().base_pos_world[2] < 0.0  # fell through where the field was
        assert sim.fall_reason().startswith("base height")


def test_standing_matches_pybullet(robot) -> None:
    states = {}
    for engine in ("pybullet", "mujoco"):
        with make_simulator(robot, flat(), SimConfig(engine=engine)) as sim:
            _stand(sim, 2.0)
            states[engine] = sim.state()
    pb, mj = states["pybullet"], states["mujoco"]
    assert mj.base_pos_world[2] == pytest.approx(pb.base_pos_world[2], abs=1e-3)  # the feet sink < 1 mm more
    np.testing.assert_allclose(mj.joint_pos, pb.joint_pos, atol=5e-3)  # the feet do not creep apart
    np.testing.assert_allclose(mj.foot_force_world, pb.foot_force_world, atol=0.1)
    assert mj.foot_force_world[:, 2].sum() == pytest.approx(robot.mass_kg * 9.81, rel=1e-3)


def test_a_push_in_the_air_pushes_alike(robot) -> None:
    """Weightless, limp, pushed sideways at the base for 0.1 s: both engines give the base the same motion."""
    after = {}
    for engine in ("pybullet", "mujoco"):
        with make_simulator(robot, flat(), SimConfig(engine=engine, gravity=0.0)) as sim:
            sim.reset(base_height_m=0.5)
            sim.add_push(Push(0.0, 0.1, (0.0, 5.0, 0.0)))
            for _ in range(150):
                sim.step(np.zeros(12))
            after[engine] = sim.state()
    pb, mj = after["pybullet"], after["mujoco"]
    assert pb.base_lin_vel_world[1] > 0.1  # 0.5 N s on 2.5 kg, the base's share of it
    np.testing.assert_allclose(mj.base_lin_vel_world, pb.base_lin_vel_world, atol=0.01 * pb.base_lin_vel_world[1])
    np.testing.assert_allclose(mj.base_ang_vel_world, pb.base_ang_vel_world, atol=0.02)


def test_the_model_mismatch_changes_the_mujoco_robot(robot) -> None:
    def mass(mismatch: ModelMismatch) -> float:
        with MujocoSimulator(robot, flat(), SimConfig(mismatch=mismatch)) as sim:
            return float(sim.model.body_mass.sum())

    assert mass(ModelMismatch()) == pytest.approx(robot.mass_kg, rel=1e-6)
    assert mass(ModelMismatch(mass_scale=1.2)) == pytest.approx(1.2 * robot.mass_kg, rel=1e-6)
    assert mass(ModelMismatch(payload_kg=0.5, payload_offset_xy_m=(0.05, 0.0))) == pytest.approx(robot.mass_kg + 0.5)
    with MujocoSimulator(robot, flat(), SimConfig(mismatch=ModelMismatch(friction=0.5))) as sim:
        assert np.allclose(sim.model.geom_friction[:, 0], 0.5)  # PyBullet: the feet's 0.5 times the terrain's 1
    with MujocoSimulator(robot, flat()) as sim:
        assert np.allclose(sim.model.geom_friction[:, 0], 0.9 * 0.9)  # PyBullet: the feet's 0.9 times the terrain's
    with MujocoSimulator(robot, flat(), SimConfig(mismatch=ModelMismatch(torque_scale=0.8))) as sim:
        sim.step(np.full(12, 100.0))
        np.testing.assert_allclose(sim.data.qfrc_applied[sim._vadr], 0.8 * np.asarray(robot.description.torque_limit_nm))


def test_replacing_the_terrain_keeps_the_robot(robot) -> None:
    with MujocoSimulator(robot, flat()) as sim:
        _stand(sim, 0.3)
        before = sim.state()
        sim.replace_terrain(resolve("stepping_stones"))
        after = sim.state()
        np.testing.assert_array_equal(after.base_pos_world, before.base_pos_world)
        np.testing.assert_array_equal(after.joint_pos, before.joint_pos)
        assert sim.terrain.name == "stepping_stones" and sim._n_terrain_geoms > 2


@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_walks_on_flat_as_in_pybullet(robot, gait: str) -> None:
    reached = {}
    for engine in ("pybullet", "mujoco"):
        spec = gait_by_name(gait)
        with Locomotion(robot, flat(), spec, make_planner("contactnet", spec, robot), SimConfig(engine=engine),
                        vel_cmd_xy=(0.1, 0.0)) as loco:
            summary = loco.run(4.0)
        assert not summary["fell"] and summary["sim"] == engine, summary
        reached[engine] = summary["reached_x"]
    assert reached["pybullet"] > 0.25
    assert reached["mujoco"] == pytest.approx(reached["pybullet"], abs=0.02)
