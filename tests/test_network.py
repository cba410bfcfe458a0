"""ContactNet network: the input u_r, rank targets, normalizer, numpy == torch, top-k metric, the model file
(and the robot it records). The torch-free reading of model files: tests/test_model_file.py."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

import contactnet.planning.network as network_module
from contactnet.planning.network import (
    INPUT_NAMES,
    MODEL_FORMAT,
    ContactNet,
    ModelFileError,
    Normalizer,
    NumpyContactNet,
    load_model,
    rank_targets,
    save_model,
    topk_accuracy,
    torch_scores,
)
from contactnet.planning.network_input import (
    N_INPUTS,
    network_input,
    network_input_of_context,
    network_input_of_state,
    network_input_one,
)
from contactnet.registry import model_path


# ---- the network input u_r ---------------------------------------------------------------------
def network_input_reference(feet_xy_world, com_pos_world, com_vel_world, vel_cmd_xy, yaw_rad, ground_z):
    """u_r of one state, slow and obvious: rotate every world vector into the heading frame with a matrix."""
    heading_to_world = np.array([[math.cos(yaw_rad), -math.sin(yaw_rad)], [math.sin(yaw_rad), math.cos(yaw_rad)]])
    world_to_heading = heading_to_world.T
    u = []
    for leg in range(4):
        u += list(world_to_heading @ (np.asarray(feet_xy_world[leg]) - np.asarray(com_pos_world[:2])))
    u.append(com_pos_world[2] - ground_z)
    u += list(world_to_heading @ np.asarray(com_vel_world[:2]))
    u.append(com_vel_world[2])
    u += list(vel_cmd_xy)
    return np.array(u)


def _random_states(rng, lead=()):
    return (rng.normal(size=(*lead, 4, 2)), rng.normal(size=(*lead, 3)), rng.normal(size=(*lead, 3)),
            rng.normal(size=(*lead, 2)), rng.uniform(-4, 4, size=lead), rng.normal(size=lead))


def test_network_input_names():
    assert len(INPUT_NAMES) == N_INPUTS == 14
    assert network_module.INPUT_NAMES is INPUT_NAMES and network_module.network_input is network_input


def test_network_input_vectorised_matches_the_reference():
    rng = np.random.default_rng(5)
    states = _random_states(rng, lead=(6, 7))
    u = network_input(*states)
    assert u.shape == (6, 7, 14) and u.dtype == np.float64
    for i in range(6):
        for j in range(7):
            one = [np.asarray(a)[i, j] for a in states]
            np.testing.assert_allclose(u[i, j], network_input_reference(*one), rtol=0, atol=1e-12)
            np.testing.assert_allclose(network_input_one(*one[:4], float(one[4]), float(one[5])), u[i, j],
                                       rtol=0, atol=1e-12)
    # leading axes broadcast: one command, yaw and ground for a batch of states
    feet, com, vel, cmd, yaw, ground = _random_states(rng, lead=(5,))
    np.testing.assert_allclose(network_input(feet, com, vel, cmd[0], yaw[0], ground[0]),
                               network_input(feet, com, vel, np.tile(cmd[0], (5, 1)), np.full(5, yaw[0]),
                                             np.full(5, ground[0])), rtol=0, atol=0)
    assert network_input(*_random_states(rng)).shape == (14,)
    with pytest.raises(ValueError, match="feet"):
        network_input(feet[:, :3], com, vel, cmd, yaw, ground)


def test_network_input_of_context_and_state_match_the_general_function():
    from types import SimpleNamespace

    from contactnet.terrain import Terrain

    rng = np.random.default_rng(6)
    for _ in range(50):
        feet, com, vel, cmd, yaw, ground = _random_states(rng)
        feet3 = np.column_stack([feet, rng.normal(size=4)])
        terrain = Terrain.from_dict({"name": "level", "start": [0, 0], "goal_x": 1.0, "surface_z": float(ground),
                                     "regions": [{"shape": "rect", "center": [0, 0], "size": [50, 50]}]})
        ctx = SimpleNamespace(foot_pos_world=feet3, com_pos_world=com, com_vel_world=vel, vel_cmd_xy=cmd,
                              yaw_rad=float(yaw), terrain=terrain)
        expected = network_input(feet, com, vel, cmd, yaw, ground)
        np.testing.assert_allclose(network_input_of_context(ctx), expected, rtol=0, atol=1e-12)
        c, s = math.cos(yaw), math.sin(yaw)
        state = SimpleNamespace(foot_pos_world=feet3, com_pos_world=com, com_vel_world=vel, yaw_rad=float(yaw),
                                vel_cmd_world=np.array([c * cmd[0] - s * cmd[1], s * cmd[0] + c * cmd[1]]),
                                ground_z=float(ground))
        np.testing.assert_allclose(network_input_of_state(state), expected, rtol=0, atol=1e-12)


def test_the_torch_names_are_re_exported_from_network_torch():
    import contactnet.planning.network_torch as network_torch

    assert ContactNet is network_torch.ContactNet and save_model is network_torch.save_model
    assert torch_scores is network_torch.torch_scores and network_module.HIDDEN == (128, 128, 128)
    with pytest.raises(AttributeError, match="no attribute 'Nothing'"):
        network_module.Nothing  # noqa: B018


def test_network_input_module_does_not_need_torch():
    import subprocess
    import sys

    code = ("import sys; import contactnet.planning.network_input; "
            "sys.exit(1 if 'torch' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


# ---- rank targets ------------------------------------------------------------------------------
def rank_targets_reference(V) -> np.ndarray:
    """The paper's definition, one row, obviously correct: the decreasing order is the reverse of the
    cheapest-first order with ties broken by index (inf is larger than every finite cost)."""
    n = len(V)
    cheapest_first = sorted(range(n), key=lambda a: (V[a], a))
    decreasing = cheapest_first[::-1]
    return np.array([decreasing.index(a) / (n - 1) for a in range(n)])


def test_rank_targets_paper_example():
    np.testing.assert_allclose(rank_targets([0.8, 0.3, 0.9]), [1 / 2, 2 / 2, 0 / 2])


def test_rank_targets_ties_and_inf():
    # ties: the lower index ranks as cheaper (stable), so argmax Y == argmin V
    np.testing.assert_allclose(rank_targets([1.0, 1.0, 0.0]), [1 / 2, 0, 1])
    # +inf is the most expensive; several infs keep a stable order among themselves
    np.testing.assert_allclose(rank_targets([math.inf, 0.5, math.inf, 0.1]), [1 / 3, 2 / 3, 0, 1])
    Y = rank_targets(np.array([[math.inf, math.inf, math.inf]]))
    np.testing.assert_allclose(Y, [[1, 1 / 2, 0]])


def test_rank_targets_batched_matches_reference():
    rng = np.random.default_rng(3)
    V = rng.integers(0, 6, size=(50, 12)).astype(np.float32)  # many ties
    V[rng.random(V.shape) < 0.15] = np.inf
    Y = rank_targets(V)
    assert Y.shape == V.shape and Y.dtype == np.float32
    for row_v, row_y in zip(V, Y, strict=True):
        np.testing.assert_allclose(row_y, rank_targets_reference(list(row_v)), atol=1e-7)
        np.testing.assert_allclose(np.sort(row_y), np.arange(12) / 11, atol=1e-7)
    np.testing.assert_array_equal(np.argmax(Y, axis=1), np.argmin(V, axis=1))


def test_rank_targets_rejects_bad_shape():
    with pytest.raises(ValueError):
        rank_targets([1.0])
    with pytest.raises(ValueError):
        rank_targets(np.zeros((2, 3, 4)))


# ---- normalizer --------------------------------------------------------------------------------
def test_normalizer_range_round_trip_and_zero_range():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(200, 14)) * rng.uniform(0.01, 5, 14) + rng.normal(size=14)
    u[:, 8] = 0.23  # a constant input (e.g. CoM height in a flat-only dataset)
    norm = Normalizer.fit(u)
    x = norm.normalize(u)
    assert np.all(np.isfinite(x))
    assert np.all(x >= -1 - 1e-12) and np.all(x <= 1 + 1e-12)
    np.testing.assert_allclose(np.delete(x.min(axis=0), 8), -1, atol=1e-12)
    np.testing.assert_allclose(np.delete(x.max(axis=0), 8), 1, atol=1e-12)
    np.testing.assert_allclose(x[:, 8], 0)
    np.testing.assert_allclose(norm.denormalize(x), u, atol=1e-12)
    again = Normalizer.from_dict(json.loads(json.dumps(norm.to_dict())))
    np.testing.assert_array_equal(again.low, norm.low)
    np.testing.assert_array_equal(again.high, norm.high)
    assert again.names == INPUT_NAMES
    with pytest.raises(ValueError):
        Normalizer(low=np.ones(14), high=np.zeros(14))
    with pytest.raises(ValueError):
        Normalizer(low=np.zeros(3), high=np.ones(3))  # 3 inputs, 14 names


# ---- numpy == torch ----------------------------------------------------------------------------
def _random_model(n_actions: int, seed: int = 0) -> tuple[ContactNet, Normalizer, np.ndarray]:
    torch.manual_seed(seed)
    model = ContactNet(n_actions).eval()
    with torch.no_grad():  # larger weights than the default init so the outputs are not tiny
        for p in model.parameters():
            p.mul_(3)
    rng = np.random.default_rng(seed)
    U = rng.normal(size=(64, 14)) * rng.uniform(0.02, 2, 14) + rng.normal(size=14)
    return model, Normalizer.fit(U), U


def test_contactnet_shape():
    model = ContactNet(162)
    sizes = [(lin.in_features, lin.out_features) for lin in model.linears()]
    assert sizes == [(14, 128), (128, 128), (128, 128), (128, 162)]
    relus = [m for m in model.layers if isinstance(m, torch.nn.ReLU)]
    assert len(relus) == 3 and not isinstance(model.layers[-1], torch.nn.ReLU)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("n_actions", [100, 162])
def test_numpy_matches_torch(n_actions, dtype):
    model, norm, U = _random_model(n_actions)
    net = NumpyContactNet.from_torch(model, norm, dtype=dtype)
    reference = torch_scores(model, norm, U)
    assert np.abs(reference).max() > 0.1
    batch = net.scores_batch(U)
    assert batch.shape == (64, n_actions)
    np.testing.assert_allclose(batch, reference, atol=1e-5, rtol=0)
    for i in range(0, 64, 9):
        np.testing.assert_allclose(net.scores(U[i]), reference[i], atol=1e-5, rtol=0)
        np.testing.assert_array_equal(net.ranking(U[i]), np.argsort(-net.scores(U[i]), kind="stable"))
    with pytest.raises(ValueError):
        net.scores(U[:2])


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("hidden", [(32,), (64, 48, 40, 24)])
def test_the_compiled_pass_is_the_numpy_pass(hidden, dtype):
    """The planner's one-input pass (compiled, contactnet.planning.network_kernel) against the numpy layers
    (``_forward``), at any depth, and of the negated network the planner ranks with."""
    rng = np.random.default_rng(len(hidden))
    sizes = (N_INPUTS, *hidden, 30)
    weights = [rng.normal(0.0, 0.5, (n_out, n_in)) for n_in, n_out in zip(sizes[:-1], sizes[1:], strict=True)]
    biases = [rng.normal(0.0, 0.1, n_out) for n_out in sizes[1:]]
    net = NumpyContactNet(weights, biases, dtype=dtype)
    tolerance = 1e-12 if dtype == np.float64 else 1e-5
    for u in rng.uniform(-1.0, 1.0, (20, N_INPUTS)):
        u = u.astype(dtype)
        numpy_scores = net._forward(u)
        assert np.abs(numpy_scores).max() > 0.1
        compiled = net.scores_unchecked(u)
        assert compiled.dtype == dtype and compiled.shape == (30,)
        np.testing.assert_allclose(compiled, numpy_scores, atol=tolerance * np.abs(numpy_scores).max(), rtol=0)
        np.testing.assert_allclose(net.negated().scores_unchecked(u), -numpy_scores,
                                   atol=tolerance * np.abs(numpy_scores).max(), rtol=0)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_compiled_pass_sums_input_by_input(dtype):
    """The compiled pass (eight inputs a pass over the outputs) makes the same floats as the plainest form: each
    output's sum started from its bias and grown one input at a time, in index order, each product and each sum
    rounded to the dtype (layer widths that are and are not multiples of eight)."""
    rng = np.random.default_rng(7)
    sizes = (N_INPUTS, 19, 40, 8, 30)
    weights = [rng.normal(0.0, 0.5, (n_out, n_in)) for n_in, n_out in zip(sizes[:-1], sizes[1:], strict=True)]
    biases = [rng.normal(0.0, 0.1, n_out) for n_out in sizes[1:]]
    net = NumpyContactNet(weights, biases, dtype=dtype)
    layers = [(np.asarray(w, dtype), np.asarray(b, dtype)) for w, b in zip(weights, biases, strict=True)]
    for u in rng.uniform(-1.0, 1.0, (5, N_INPUTS)).astype(dtype):
        h = list(u)
        for depth, (w, b) in enumerate(layers):
            sums = []
            for j in range(len(b)):
                total = b[j]
                for i, x in enumerate(h):
                    total = total + x * w[j, i]  # numpy scalars of the dtype: rounded at each operation
                sums.append(total if depth == len(layers) - 1 or total > 0 else dtype(0.0))
            h = sums
        np.testing.assert_array_equal(net.scores_unchecked(u), np.array(h, dtype=dtype))


# ---- top-k -------------------------------------------------------------------------------------
def test_topk_accuracy_hand_made():
    V = np.array([[0.0, 1, 2, 3, 4, 5, 6, 7]] * 4)
    scores = np.tile(np.arange(8) * 1e-3, (4, 1))  # background prefers the expensive end
    scores[0, 0] = 1  # best: top-1 and top-5
    scores[1, 4] = 1  # 5th cheapest: top-5 only
    scores[2, 5] = 1  # 6th cheapest: neither
    scores[3, 7] = 1  # worst
    assert topk_accuracy(scores, V) == pytest.approx(2 / 4)
    assert topk_accuracy(scores, V, k_true=1) == pytest.approx(1 / 4)
    assert topk_accuracy(scores, V, k_true=6) == pytest.approx(3 / 4)
    # k_pred: any of the two best predictions among the 1 cheapest
    scores[2, 0] = 0.5
    assert topk_accuracy(scores, V, k_pred=2, k_true=1) == pytest.approx(2 / 4)
    # single row, inf, ties
    assert topk_accuracy([0, 0, 1, 0, 0, 0], [np.inf, 0, np.inf, 1, 2, 3], k_true=5) == 0.0  # infeasible pick
    assert topk_accuracy([0, 1, 0], [1.0, 1.0, 0.0], k_true=2) == 1.0  # tied with the 2nd cheapest
    with pytest.raises(ValueError):
        topk_accuracy(np.zeros((2, 3)), np.zeros((2, 4)))


# ---- model file --------------------------------------------------------------------------------
def _save(path: Path, gait: str = "walk", **meta) -> tuple[ContactNet, Normalizer, np.ndarray]:
    model, norm, U = _random_model(100 if gait == "walk" else 162)
    save_model(path, model, norm, {"gait": gait, "test_top5": np.float32(0.9), **meta})
    return model, norm, U


def test_save_load_round_trip(tmp_path):
    path = tmp_path / "sub" / "walk.pt"
    model, norm, U = _save(path, train_top5=0.95, dataset={"instances": 1000, "episodes": 40})
    assert [p.name for p in path.parent.iterdir()] == ["walk.pt"]  # no temp file left
    raw = torch.load(path, weights_only=True)
    assert raw["format"] == MODEL_FORMAT and raw["gait"] == "walk" and raw["n_actions"] == 100
    loaded = load_model(path, expect_gait="walk", expect_n_actions=100)
    assert loaded.gait == "walk" and loaded.n_actions == 100
    assert loaded.metadata["test_top5"] == pytest.approx(0.9)
    assert loaded.metadata["dataset"] == {"instances": 1000, "episodes": 40}
    assert loaded.metadata["normalization"]["low"] == pytest.approx(list(norm.low))
    np.testing.assert_allclose(loaded.net.scores_batch(U), torch_scores(model, norm, U), atol=1e-5)
    np.testing.assert_allclose(torch_scores(loaded.torch_model, loaded.normalizer, U),
                               torch_scores(model, norm, U), atol=1e-6)


def test_save_is_atomic_and_checked(tmp_path):
    path = tmp_path / "walk.pt"
    _save(path)
    before = path.read_bytes()
    model, norm, _ = _random_model(100)
    with pytest.raises(TypeError):
        save_model(path, model, norm, {"gait": "walk", "bad": object()})
    with pytest.raises(ValueError):
        save_model(path, model, norm, {"gait": "trot"})  # 100 outputs is not a trot network
    with pytest.raises(ValueError):
        save_model(path, model, norm, {})
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["walk.pt"]


def test_model_path():
    path = model_path("solo12", "trot")
    assert path.name == "trot.pt" and path.parent.name == "models" and path.parent.parent.name == "contactnet"
    assert model_path("go2", "walk").name == "go2_walk.pt"


def test_model_file_records_its_robot(tmp_path):
    path = tmp_path / "walk.pt"
    _save(path)  # no robot named: Solo12
    assert torch.load(path, weights_only=True)["metadata"]["robot"] == "solo12"
    assert load_model(path, expect_robot="solo12").robot == "solo12"
    go2 = tmp_path / "go2_walk.pt"
    _save(go2, robot="go2")
    loaded = load_model(go2, expect_gait="walk", expect_robot="go2")
    assert loaded.robot == "go2" and loaded.metadata["robot"] == "go2"
    with pytest.raises(ModelFileError) as info:
        load_model(go2, expect_robot="solo12")
    message = str(info.value)
    assert message.endswith("is a 'go2' model, but a 'solo12' model was expected") and "\n" not in message
    assert str(go2) in message
    with pytest.raises(ValueError, match="robot"):
        save_model(tmp_path / "x.pt", *_random_model(100)[:2], {"gait": "walk", "robot": 12})


def test_model_file_without_a_robot_is_solo12(tmp_path):
    path = tmp_path / "walk.pt"
    payload = _payload(path)
    del payload["metadata"]["robot"]  # as the shipped walk.pt / trot.pt, made before the field existed
    torch.save(payload, path)
    assert load_model(path, expect_robot="solo12").robot == "solo12"
    with pytest.raises(ModelFileError, match="is a 'solo12' model, but a 'go2' model was expected"):
        load_model(path, expect_robot="go2")


@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_shipped_models_are_solo12_models(gait):
    path = model_path("solo12", gait)
    if not path.exists():
        pytest.skip(f"{path} not shipped")
    raw = torch.load(path, weights_only=True)
    # A file saved before models named their robot reads as Solo12; a newer one names it.
    assert raw["metadata"].get("robot", "solo12") == "solo12"
    assert load_model(path, expect_gait=gait, expect_robot="solo12").robot == "solo12"
    with pytest.raises(ModelFileError, match="but a 'go2' model was expected"):
        load_model(path, expect_robot="go2")


def _payload(path: Path) -> dict:
    _save(path)
    return torch.load(path, weights_only=True)


class _NotAllowed:
    pass


def _corruptions(tmp_path: Path):
    """(name, writer(path)) for every broken model file case."""
    good = tmp_path / "good.pt"
    payload = _payload(good)
    data = good.read_bytes()

    def edited(**changes):
        def write(path):
            p = dict(payload)
            for key, value in changes.items():
                if value is _DROP:
                    p.pop(key)
                else:
                    p[key] = value
            torch.save(p, path)

        return write

    def state(edit):
        def write(path):
            p = dict(payload)
            p["state_dict"] = edit(dict(p["state_dict"]))
            torch.save(p, path)

        return write

    return [
        ("truncated", lambda path: path.write_bytes(data[: len(data) // 2])),
        ("empty", lambda path: path.write_bytes(b"")),
        ("garbage", lambda path: path.write_bytes(bytes(range(256)) * 10)),
        ("json", lambda path: path.write_text(json.dumps({"gait": "walk"}))),
        ("a list", lambda path: torch.save([1, 2, 3], path)),
        ("unsafe pickle", lambda path: torch.save({"format": MODEL_FORMAT, "x": _NotAllowed()}, path)),
        ("bare state dict", lambda path: torch.save(payload["state_dict"], path)),
        ("wrong format", edited(format="something-else")),
        ("no gait", edited(gait=_DROP)),
        ("no state_dict", edited(state_dict=_DROP)),
        ("no normalizer", edited(normalizer=_DROP)),
        ("no metadata", edited(metadata=_DROP)),
        ("unknown gait", edited(gait="gallop")),
        ("n_actions not the gait's", edited(n_actions=162)),
        ("n_inputs", edited(n_inputs=12)),
        ("hidden", edited(hidden="128")),
        ("normalizer length", edited(normalizer={"low": [0.0] * 3, "high": [1.0] * 3})),
        ("normalizer nan", edited(normalizer={"low": [math.nan] * 14, "high": [1.0] * 14})),
        ("missing weight", state(lambda s: {k: v for k, v in s.items() if k != "layers.6.bias"})),
        ("extra weight", state(lambda s: {**s, "layers.9.weight": torch.zeros(3)})),
        ("wrong shape", state(lambda s: {**s, "layers.0.weight": torch.zeros(128, 12)})),
        ("nan weight", state(lambda s: {**s, "layers.2.bias": torch.full((128,), math.nan)})),
        ("not a tensor", state(lambda s: {**s, "layers.2.bias": [0.0] * 128})),
    ]


_DROP = object()


def test_bad_model_files_raise_one_line_errors(tmp_path):
    cases = _corruptions(tmp_path)
    for name, write in cases:
        path = tmp_path / f"bad-{name.replace(' ', '_')}.pt"
        write(path)
        with pytest.raises(ModelFileError) as info:
            load_model(path)
        message = str(info.value)
        assert str(path) in message, (name, message)
        assert "\n" not in message and len(message) < 300, (name, message)
        assert "Traceback" not in message, (name, message)
    missing = tmp_path / "missing.pt"
    with pytest.raises(ModelFileError, match="missing.pt: no such file"):
        load_model(missing)
    with pytest.raises(ModelFileError, match="is a directory|not a regular file"):
        load_model(tmp_path)


def test_mismatched_model_file(tmp_path):
    path = tmp_path / "walk.pt"
    _save(path)
    with pytest.raises(ModelFileError, match=r"walk\.pt.*'walk' model, but a 'trot' model was expected"):
        load_model(path, expect_gait="trot")
    with pytest.raises(ModelFileError, match="n_actions is 100, expected 162"):
        load_model(path, expect_n_actions=162)
    assert isinstance(ModelFileError("x"), ValueError)


def test_other_hidden_sizes_round_trip_and_the_shape_check_matches_the_network(tmp_path):
    # load_model checks the stored shapes against the architecture before building the network.
    torch.manual_seed(0)
    model = ContactNet(100, hidden=(64, 32, 16, 8))
    norm = Normalizer.fit(np.random.default_rng(0).normal(size=(30, 14)))
    path = save_model(tmp_path / "walk.pt", model, norm, {"gait": "walk"})
    loaded = load_model(path)
    assert loaded.torch_model.hidden == (64, 32, 16, 8)
    assert network_module._layer_shapes(14, [64, 32, 16, 8], 100) == {
        name: tuple(value.shape) for name, value in model.state_dict().items()}
    U = np.random.default_rng(1).normal(size=(5, 14))
    np.testing.assert_allclose(loaded.net.scores_batch(U), torch_scores(model, norm, U), atol=1e-5)
