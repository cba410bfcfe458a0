"""The physics engines (PyBullet and MuJoCo, every test on both): Solo12 stands, the sensors read the truth (plus
noise when asked), pushes push, and the referee sees falls and success."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from contactnet.sim.engines import make_simulator
from contactnet.sim.world import (
    ENGINES,
    BodyContact,
    Push,
    SimConfig,
    describe_body_contacts,
    standing_torques,
)
from contactnet.terrain import Terrain, flat, random_field, resolve


@pytest.fixture(params=ENGINES)
def engine(request) -> str:
    return request.param


def Simulator(robot, terrain, config: SimConfig | None = None, *, engine: str):  # noqa: N802, ANN001, ANN201
    """The simulator of ``engine`` (the tests' one constructor for both backends)."""
    return make_simulator(robot, terrain, replace(SimConfig() if config is None else config, engine=engine))


def stand(sim, seconds: float, target: np.ndarray | None = None) -> None:
    """Hold a joint pose (the nominal stance by default) with the joint PD."""
    target = sim.robot.joint_standing if target is None else target
    state = sim.state(with_contacts=False)
    for _ in range(round(seconds / sim.config.dt_s)):
        sim.step(standing_torques(state, target))
        state = sim.state(with_contacts=False)


@pytest.fixture
def flat_sim(robot, engine):
    with Simulator(robot, flat(), engine=engine) as sim:
        yield sim


def test_pinocchio_and_the_engine_agree_on_the_feet(robot, flat_sim):
    rng = np.random.default_rng(3)
    for joints in (robot.joint_standing, robot.joint_standing + rng.uniform(-0.3, 0.3, 12)):
        state = flat_sim.reset(joint_pos=joints, base_height_m=0.5, base_yaw_rad=0.4)
        feet_pin = robot.foot_positions_world(state.q_pinocchio())
        np.testing.assert_allclose(flat_sim.foot_positions_world(), feet_pin, atol=1e-3)
        np.testing.assert_allclose(state.joint_pos, joints, atol=1e-12)


@pytest.mark.parametrize("robot_name", ["solo12", "go2"])
def test_the_engine_simulates_the_models_mass_com_and_inertia(robot_name, engine, tmp_path):
    """What the engine simulates (summed over its own links) is the model pinocchio plans with: the mass, the CoM
    seen from the base link's origin and the composite inertia, in the standing pose. Go2's base link has its CoM
    2 cm ahead of its origin: an engine that took one for the other would put the CoM 2 cm back."""
    from contactnet.robots import load_robot

    model = load_robot(robot_name, cache_dir=tmp_path)
    with Simulator(model, flat(), engine=engine) as sim:
        state = sim.state(with_contacts=False)
        simulated = sim.mass_properties()
    description = model.description
    assert simulated.mass_kg == pytest.approx(description.mass_kg, rel=1e-6)
    np.testing.assert_allclose(state.base_rot_world.T @ (simulated.com_world - state.base_pos_world),
                               description.com_base_standing, atol=2e-4)
    np.testing.assert_allclose(simulated.inertia_com_world, description.inertia_com_standing,
                               atol=2e-3 * np.abs(description.inertia_com_standing).max())


def test_stands_two_seconds_on_flat(flat_sim):
    stand(flat_sim, 2.0)
    state = flat_sim.state()
    assert flat_sim.fall_reason(state) is None
    assert 0.20 < state.base_pos_world[2] < 0.245
    assert state.foot_contact.all()
    weight = flat_sim.robot.mass_kg * flat_sim.config.gravity
    assert state.foot_force_world[:, 2].sum() == pytest.approx(weight, rel=0.05)
    assert np.abs(state.rpy[:2]).max() < 0.05
    np.testing.assert_allclose(state.base_pos_world[:2], flat_sim.terrain.start_xy, atol=0.01)


def test_stands_on_the_start_of_stepping_stones(robot, engine):
    with Simulator(robot, resolve("stepping_stones"), engine=engine) as sim:
        stand(sim, 2.0)
        assert sim.fall_reason() is None
        assert sim.state().foot_contact.all()


def test_a_push_moves_the_base_sideways(robot, engine):
    with Simulator(robot, flat(), engine=engine) as sim:
        sim.add_push(Push(t0_s=0.2, duration_s=0.3, force_world=(0.0, 8.0, 0.0)))
        stand(sim, 0.6)
        pushed = sim.state().base_pos_world
    with Simulator(robot, flat(), engine=engine) as sim:
        stand(sim, 0.6)
        still = sim.state().base_pos_world
    assert pushed[1] - still[1] > 0.005


def test_push_parsing():
    push = Push.parse("1.5,1,5,-5")
    assert push == Push(1.5, 1.0, (5.0, -5.0, 0.0))
    assert push.active(1.5) and push.active(2.49) and not push.active(2.5) and not push.active(1.4)
    for bad in ("1,2,3", "a,1,1,1", "1,0,1,1", "-1,1,1,1", "1,1,nan,1", "0,1,500,0"):
        with pytest.raises(ValueError, match="--push"):
            Push.parse(bad)


def test_joint_velocity_noise_has_the_asked_variance_and_is_seeded(robot, engine):
    def samples(seed):
        with Simulator(robot, flat(), SimConfig(joint_vel_noise_var=0.01, seed=seed), engine=engine) as sim:
            return np.array([sim.state().joint_vel - sim.state().joint_vel_true for _ in range(300)])

    a, b, c = samples(1), samples(1), samples(2)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    assert a.std() == pytest.approx(0.1, rel=0.1)
    assert abs(a.mean()) < 0.02


def test_falling_into_a_hole_is_a_fall(robot, engine):
    terrain = random_field(removed=300, seed=0)  # the whole field is a hole
    with Simulator(robot, terrain, engine=engine) as sim:
        hole_x = terrain.goal_x - 0.75
        sim.reset(base_xy=np.array([hole_x, 0.0]))
        assert sim.fall_reason() is None
        stand(sim, 0.5)
        reason = sim.fall_reason()
        assert reason is not None and "base height" in reason


def test_base_height_is_measured_from_the_ground_under_it(robot, engine):
    """A top 0.3 m high elsewhere does not make a robot standing on the low ground fall, nor hide a low base."""
    terrain = Terrain.from_dict({"name": "low_and_high", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.8, 0.6]},
        {"shape": "rect", "center": [1.0, 0.0], "size": [0.2, 0.2], "z": 0.3}]})
    with Simulator(robot, terrain, engine=engine) as sim:
        assert sim.fall_reason(sim.reset()) is None
        limit = sim.fall_base_height_m
        # (the standing legs reach through the ground that low: MuJoCo sees those contacts at once, PyBullet at
        # its next step; the base's height is judged first)
        reason = sim.fall_reason(sim.reset(base_height_m=limit + 0.005))
        assert reason is None or not reason.startswith("base height")
        reason = sim.fall_reason(sim.reset(base_height_m=limit - 0.005))
        assert reason is not None and reason.startswith("base height")


def test_body_contact_and_tilt_are_falls(flat_sim):
    # Legs folded under the body and limp (no torque): the base sinks onto the ground. (A joint PD holding the
    # folded legs chatters in MuJoCo: about their hip axes they have too little inertia for its damping at 1 ms.)
    flat_sim.reset(joint_pos=np.tile([0.0, 1.6, -3.0], 4), base_height_m=0.12)
    for _ in range(300):
        flat_sim.step(np.zeros(12))
    assert "base_link" in flat_sim.non_foot_contacts()
    assert flat_sim.fall_reason() is not None
    # Knees on the ground, base high enough: caught by the non-foot contact alone.
    kneeling = np.array([0.0, 0.3, -2.4] * 2 + [0.0, -0.3, 2.4] * 2)
    flat_sim.reset(joint_pos=kneeling, base_height_m=0.4)
    stand(flat_sim, 0.4, target=kneeling)
    assert flat_sim.state().base_pos_world[2] > flat_sim.fall_base_height_m + 0.03
    assert flat_sim.fall_reason().startswith("non-foot contact")
    contacts = flat_sim.body_contacts()
    assert {c.link for c in contacts} == set(flat_sim.non_foot_contacts())
    assert {c.leg for c in contacts} <= {"FL", "FR", "HL", "HR"} and contacts
    assert all(c.link.startswith(c.leg) for c in contacts)  # Solo12 names its links after their leg
    assert not any(c.foot_over_gap or c.on_edge for c in contacts)  # knees on flat ground
    assert "on top of the terrain" in flat_sim.fall_reason() and "gap" not in flat_sim.fall_reason()
    # Rolled over by 1 rad.
    flat_sim.reset(base_height_m=0.4)
    roll = np.array([np.sin(0.5), 0.0, 0.0, np.cos(0.5)])  # 1 rad about x (x, y, z, w)
    if flat_sim.engine == "pybullet":
        flat_sim.client.resetBasePositionAndOrientation(flat_sim.robot_id, [0, 0, 0.4], roll.tolist())
    else:
        flat_sim.data.qpos[3:7] = [roll[3], *roll[:3]]
        flat_sim._mj.mj_forward(flat_sim.model, flat_sim.data)
    assert "tilted" in flat_sim.fall_reason()


def test_success_is_passing_goal_x(robot, engine):
    terrain = resolve("stepping_stones")
    with Simulator(robot, terrain, engine=engine) as sim:
        assert not sim.reached_goal()
        sim.reset(base_xy=np.array([terrain.goal_x + 0.01, terrain.start_xy[1]]))
        assert sim.reached_goal()


def test_same_seed_same_run(robot, engine):
    def run():
        with Simulator(robot, flat(), SimConfig(joint_vel_noise_var=0.01, seed=5), engine=engine) as sim:
            sim.add_push(Push(0.1, 0.2, (3.0, 0.0, 0.0)))
            stand(sim, 0.4)
            return sim.state().base_pos_world

    np.testing.assert_array_equal(run(), run())


@pytest.mark.slow
@pytest.mark.parametrize("terrain_name", ["flat", "stepping_stones"])
def test_stands_ten_seconds(robot, terrain_name, engine):
    with Simulator(robot, resolve(terrain_name), engine=engine) as sim:
        stand(sim, 10.0)
        assert sim.fall_reason() is None
        assert np.linalg.norm(sim.state().base_pos_world[:2] - sim.terrain.start_xy) < 0.02


def test_the_non_foot_contact_sentence_says_where_and_why():
    shin = BodyContact("FR_LOWER_LEG", "FR", (0.2508, -0.141, 0.0), (0.77, 0.0, 0.64), 75.0, foot_over_gap=True)
    assert describe_body_contacts([shin]) == (
        "non-foot contact: FR_LOWER_LEG on an edge at x 0.25, y -0.14 m (the FR foot stepped into a gap)")
    body = BodyContact("base_link", None, (0.1, 0.0, 0.0), (0.0, 0.0, 1.0), 20.0, foot_over_gap=False)
    other = BodyContact("FL_LOWER_LEG", "FL", (0.3, 0.1, 0.0), (0.0, 0.0, 1.0), 5.0, foot_over_gap=True)
    assert describe_body_contacts([body, other, shin]) == (
        "non-foot contact: base_link on top of the terrain at x 0.10, y 0.00 m; FL_LOWER_LEG on top of the terrain "
        "at x 0.30, y 0.10 m; FR_LOWER_LEG on an edge at x 0.25, y -0.14 m (the FL and FR feet stepped into gaps)")


def test_foot_contact_is_the_state_s(flat_sim):
    """The one-query contact reading the locomotion loop uses at touchdown agrees with the full state's."""
    stand(flat_sim, 0.2)
    np.testing.assert_array_equal(flat_sim.foot_contact(), flat_sim.state().foot_contact)
    assert flat_sim.foot_contact().all()  # standing
    flat_sim.reset(base_height_m=0.5)  # in the air (contacts are those of the last step)
    flat_sim.step(np.zeros(12))
    assert not flat_sim.foot_contact().any()
