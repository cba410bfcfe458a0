"""Model mismatch: the simulated robot differs from the model as asked, and only the simulator knows it.

Each perturbation is checked against a physical consequence measured in the simulator (the weight on the
feet, a slide's friction, the torque limit, the noise's spread, the delay's lag), not against its own code; in both
physics engines (where the payload sits is read from PyBullet's bodies only).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from contactnet.sim.engines import make_simulator
from contactnet.sim.mismatch import ModelMismatch, parse_payload
from contactnet.sim.world import ENGINES, Push, SimConfig, standing_torques
from contactnet.terrain import flat


@pytest.fixture(params=ENGINES)
def engine(request) -> str:
    return request.param


def Simulator(robot, terrain, config: SimConfig | None = None, *, engine: str = "pybullet"):  # noqa: N802, ANN001, ANN201
    """The simulator of ``engine`` (PyBullet unless named)."""
    return make_simulator(robot, terrain, replace(SimConfig() if config is None else config, engine=engine))


def _stand(sim, seconds: float) -> None:  # noqa: ANN001 - either engine's simulator
    state = sim.state(with_contacts=False)
    for _ in range(round(seconds / sim.config.dt_s)):
        sim.step(standing_torques(state, sim.robot.joint_standing))
        state = sim.state(with_contacts=False)


def _weight_on_feet_n(sim) -> float:  # noqa: ANN001
    """The vertical ground force on the feet, averaged over 0.2 s of standing (after 1 s to settle)."""
    _stand(sim, 1.0)
    forces = []
    for _ in range(200):
        _stand(sim, 0.001)
        forces.append(sim.state().foot_force_world[:, 2].sum())
    return float(np.mean(forces))


def test_the_weight_on_the_feet_follows_mass_scale_and_payload(robot, engine):
    g = 9.81
    with Simulator(robot, flat(), engine=engine) as sim:
        nominal = _weight_on_feet_n(sim)
    assert nominal == pytest.approx(robot.mass_kg * g, rel=0.03)
    with Simulator(robot, flat(), SimConfig(mismatch=ModelMismatch(mass_scale=1.2)), engine=engine) as sim:
        assert _weight_on_feet_n(sim) == pytest.approx(1.2 * robot.mass_kg * g, rel=0.03)
    mismatch = ModelMismatch(payload_kg=0.5, payload_offset_xy_m=(0.05, 0.0))
    with Simulator(robot, flat(), SimConfig(mismatch=mismatch), engine=engine) as sim:
        heavier = _weight_on_feet_n(sim)
        # The payload sits ahead of the base: the front feet carry more of the weight than without it.
        front_share = sim.state().foot_force_world[:2, 2].sum() / sim.state().foot_force_world[:, 2].sum()
        if engine == "pybullet":
            payload_xy = np.asarray(sim.client.getBasePositionAndOrientation(sim.payload_id)[0][:2])
            base_xy = np.asarray(sim.client.getBasePositionAndOrientation(sim.robot_id)[0][:2])
            assert payload_xy - base_xy == pytest.approx([0.05, 0.0], abs=0.005)
    assert heavier == pytest.approx((robot.mass_kg + 0.5) * g, rel=0.03)
    with Simulator(robot, flat(), engine=engine) as sim:
        _stand(sim, 1.0)
        nominal_front = sim.state().foot_force_world[:2, 2].sum() / sim.state().foot_force_world[:, 2].sum()
    assert front_share > nominal_front + 0.02


def test_the_payload_follows_the_robot_when_it_is_reset(robot):
    mismatch = ModelMismatch(payload_kg=1.0, payload_offset_xy_m=(0.0, -0.04))
    with Simulator(robot, flat(), SimConfig(mismatch=mismatch)) as sim:
        _stand(sim, 0.5)
        sim.reset(base_xy=np.array([0.3, 0.2]))
        payload = np.asarray(sim.client.getBasePositionAndOrientation(sim.payload_id)[0])
        assert payload[:2] == pytest.approx([0.3, 0.16], abs=1e-6)
        _stand(sim, 1.0)
        assert not sim.fallen()


def test_friction_lets_a_pushed_robot_slide_sooner(robot, engine):
    """A sideways push that the nominal ground holds makes the robot slide on ground of friction 0.2."""
    def slide_m(mismatch: ModelMismatch) -> float:
        with Simulator(robot, flat(), SimConfig(mismatch=mismatch), engine=engine) as sim:
            _stand(sim, 0.5)
            feet0 = sim.foot_positions_world()[:, :2].copy()
            sim.add_push(Push(sim.t_s, 0.5, (0.0, 0.25 * robot.mass_kg * 9.81, 0.0)))
            _stand(sim, 0.6)
            return float(np.abs(sim.foot_positions_world()[:, 1] - feet0[:, 1]).max())

    assert slide_m(ModelMismatch()) < 0.01
    assert slide_m(ModelMismatch(friction=0.2)) > 0.05


def test_torque_limits_scale(robot, engine):
    with Simulator(robot, flat(), SimConfig(mismatch=ModelMismatch(torque_scale=0.8)), engine=engine) as sim:
        assert sim.torque_limit_nm == pytest.approx(0.8 * np.asarray(robot.description.torque_limit_nm))


def test_base_sensor_noise_has_its_spread_and_the_referee_sees_the_truth(robot, engine):
    mismatch = ModelMismatch(orientation_noise_rad=0.02, lin_vel_noise_m_s=0.05, ang_vel_noise_rad_s=0.1)
    with Simulator(robot, flat(), SimConfig(mismatch=mismatch, seed=3), engine=engine) as sim:
        rpy = np.array([sim.state(with_contacts=False).rpy for _ in range(400)])
        lin = np.array([sim.state(with_contacts=False).base_lin_vel_world for _ in range(400)])
        ang = np.array([sim.state(with_contacts=False).base_ang_vel_world for _ in range(400)])
        assert rpy[:, :2].std(axis=0) == pytest.approx([0.02, 0.02], rel=0.2)
        assert lin.std(axis=0) == pytest.approx([0.05] * 3, rel=0.2)
        assert ang.std(axis=0) == pytest.approx([0.1] * 3, rel=0.2)
        state = sim.state()
        state.base_quat_world = np.array([np.sin(0.5), 0.0, 0.0, np.cos(0.5)])  # a lie of 1 rad roll
        state.base_rot_world = None
        assert sim.fall_reason(state) is None  # the referee reads the true pose


def test_delay_shifts_the_torques_by_whole_steps(robot, engine):
    """The joint's response to a torque step starts delay_ms later."""
    def response(delay_ms: float) -> np.ndarray:
        with Simulator(robot, flat(), SimConfig(mismatch=ModelMismatch(delay_ms=delay_ms)), engine=engine) as sim:
            sim.reset(base_height_m=1.0)  # in the air, at rest: only the torques move the joints
            velocities = []
            for k in range(12):
                tau = np.zeros(12)
                tau[0] = 0.5 if k >= 2 else 0.0
                sim.step(tau)
                velocities.append(sim.state(with_contacts=False).joint_vel_true[0])
            return np.array(velocities)

    now, later = response(0.0), response(5.0)
    first_move = int(np.argmax(np.abs(now) > 1e-3))
    assert int(np.argmax(np.abs(later) > 1e-3)) == first_move + 5


def test_bad_mismatch_names_the_field():
    with pytest.raises(ValueError, match="mass_scale"):
        ModelMismatch(mass_scale=0.0)
    with pytest.raises(ValueError, match="friction"):
        ModelMismatch(friction=float("nan"))
    with pytest.raises(ValueError, match="payload_offset_xy_m"):
        ModelMismatch(payload_offset_xy_m=(0.1, 3.0))
    with pytest.raises(ValueError, match="KG"):
        parse_payload("0.5,0.1")
    assert parse_payload("0.5") == (0.5, (0.0, 0.0))
    assert parse_payload("0.5,0.05,-0.02") == (0.5, (0.05, -0.02))
    assert ModelMismatch().neutral and ModelMismatch().label() == ""
    assert ModelMismatch(mass_scale=1.2, payload_kg=0.5, payload_offset_xy_m=(0.05, 0)).label() == \
        "mass1.2,payload0.5,at0.05,0"
