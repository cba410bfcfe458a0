"""Training ContactNet (paper Sec. IV): dataset loading, the train/test split, the training loop and the
`contactnet train` command.

Dataset directory (written by `contactnet datagen`):
    DIR/manifest.json   {"format": "contactnet-dataset-v1", "gait": "walk"|"trot", "robot": "solo12"|...,
                         "n_actions": int,
                         "input_names": [14 names], "shards": ["shard-00000.npz", ...],
                         "episodes": int, "instances": int, "seed": int, "code_version": str,
                         "shard_stats": {name: {"bytes": int, "sha256": str, ...}}, ...}
                        (a shard whose size or sha256 is not the recorded one is refused)
    DIR/shard-XXXXX.npz u (n, 14) float32 inputs, V (n, N_a) float32 costs (+inf = infeasible),
                        episode (n,) int32 episode ids, unique across the whole dataset.

Split: by default whole *episodes* go to train or test (consecutive instances of one episode are
near-duplicates; splitting them across train and test would leak and flatter the test figure).
`split="instance"` is the paper's plain random 70/30 split of instances.

Training: MSE between the network output and the rank targets, Adam, batch 100, lr 1e-3, 1000
epochs (the paper's settings). ``mirror`` (``--mirror``) adds the left-right mirror image of every training
instance (``contactnet.planning.mirror``: the ranking cost is symmetric, so its labels are exact); the test split
stays as generated. The whole dataset lives in memory as tensors; an epoch is one
permutation gather plus slicing, and the parameters/gradients live in one flat buffer so the
Adam step is a handful of vector ops instead of one set per layer (bit-for-bit torch.optim.Adam's
arithmetic, checked in the tests; about 35 % less time per epoch than torch.optim.Adam here).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from contactnet import registry
from contactnet.extras import import_torch
from contactnet.jobs.runner import check_file
from contactnet.planning.mirror import mirrored
from contactnet.planning.network import (
    INPUT_NAMES,
    N_INPUTS,
    ModelFileError,
    Normalizer,
    rank_targets,
    topk_accuracy,
)
from contactnet.planning.network_torch import ContactNet, save_model

torch = import_torch()

DATASET_FORMAT = "contactnet-dataset-v1"
EXIT_INTERRUPTED = 130


class DatasetError(ValueError):
    """A dataset directory that is missing, malformed or inconsistent: one-line message."""


# ---- dataset -----------------------------------------------------------------------------------
def _gait_sizes(gait: Any) -> tuple[int, ...] | None:
    """The numbers of ranked choices a dataset of a registered gait may have, None for anything else: N_a
    (made before the stand choice) or N_a + 1 (the stepping actions, then standing)."""
    if not isinstance(gait, str):
        return None
    try:
        spec = registry.gait_by_name(gait)
    except ValueError:
        return None
    return (spec.n_choices, spec.n_actions)


def _check_arrays(u: np.ndarray, V: np.ndarray, episode: np.ndarray, n_actions: int, where: str) -> None:
    if u.ndim != 2 or u.shape[1] != N_INPUTS:
        raise DatasetError(f"{where}: u has shape {u.shape}, expected (n, {N_INPUTS})")
    n = u.shape[0]
    if V.shape != (n, n_actions):
        raise DatasetError(f"{where}: V has shape {V.shape}, expected ({n}, {n_actions})")
    if episode.shape != (n,):
        raise DatasetError(f"{where}: episode has shape {episode.shape}, expected ({n},)")
    bad = ~np.isfinite(u).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise DatasetError(f"{where}: u has NaN/inf inputs in {int(bad.sum())} row(s), first row {row}")
    if np.isnan(V).any():
        row = int(np.flatnonzero(np.isnan(V).any(axis=1))[0])
        raise DatasetError(f"{where}: V has NaN costs (first row {row}); use +inf for infeasible candidates")
    if np.isneginf(V).any():
        raise DatasetError(f"{where}: V has -inf costs")


@dataclass(frozen=True, eq=False)
class Dataset:
    """All instances of a dataset in memory: inputs u (n, 14), costs V (n, N_a), episode ids (n,), and the
    gait and robot they were made with."""

    u: np.ndarray
    V: np.ndarray
    episode: np.ndarray
    gait: str
    n_actions: int
    input_names: tuple[str, ...] = INPUT_NAMES
    manifest: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None
    robot: str = registry.DEFAULT_ROBOT

    @classmethod
    def from_arrays(cls, u: np.ndarray, V: np.ndarray, episode: np.ndarray | None = None, gait: str = "walk",
                    input_names: tuple[str, ...] | list[str] = INPUT_NAMES,
                    manifest: dict[str, Any] | None = None, path: Path | None = None,
                    robot: str = registry.DEFAULT_ROBOT) -> Dataset:
        """Checked in-memory dataset (episode ids default to one episode per instance)."""
        sizes = _gait_sizes(gait)
        if sizes is None:
            raise DatasetError(f"unknown gait {gait!r}")
        u = np.ascontiguousarray(u, dtype=np.float32)
        V = np.ascontiguousarray(V, dtype=np.float32)
        n_actions = V.shape[1] if V.ndim == 2 and V.shape[1] in sizes else sizes[0]
        episode = np.arange(len(u)) if episode is None else np.asarray(episode)
        if not np.issubdtype(episode.dtype, np.integer):
            raise DatasetError(f"{path or 'dataset'}: episode ids must be integers, got {episode.dtype}")
        episode = episode.astype(np.int64)
        _check_arrays(u, V, episode, n_actions, str(path or "dataset"))
        if len(input_names) != N_INPUTS:
            raise DatasetError(f"{path or 'dataset'}: {len(input_names)} input names, expected {N_INPUTS}")
        return cls(u=u, V=V, episode=episode, gait=gait, n_actions=n_actions,
                   input_names=tuple(str(s) for s in input_names), manifest=dict(manifest or {}), path=path,
                   robot=robot)

    @property
    def n_instances(self) -> int:
        return int(self.u.shape[0])

    @property
    def n_episodes(self) -> int:
        return int(np.unique(self.episode).size)

    def subset(self, rows: np.ndarray) -> Dataset:
        return Dataset(u=self.u[rows], V=self.V[rows], episode=self.episode[rows], gait=self.gait,
                       n_actions=self.n_actions, input_names=self.input_names, manifest=self.manifest,
                       path=self.path, robot=self.robot)


def load_dataset(directory: str | os.PathLike) -> Dataset:
    """Read DIR/manifest.json and its shards; any problem raises DatasetError naming the file."""
    directory = Path(directory)
    manifest_path = directory / "manifest.json"
    if not directory.is_dir():
        raise DatasetError(f"dataset {directory}: no such directory")
    if not manifest_path.is_file():
        raise DatasetError(f"dataset {directory}: no manifest.json (not a dataset, or datagen did not finish)")
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DatasetError(f"{manifest_path}: not valid JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(manifest, dict):
        raise DatasetError(f"{manifest_path}: must be a JSON object")
    if manifest.get("format") != DATASET_FORMAT:
        raise DatasetError(f"{manifest_path}: format is {manifest.get('format')!r}, expected {DATASET_FORMAT!r}")
    for key in ("gait", "n_actions", "input_names", "shards"):
        if key not in manifest:
            raise DatasetError(f"{manifest_path}: missing field {key!r}")
    gait = manifest["gait"]
    sizes = _gait_sizes(gait)
    if sizes is None:
        raise DatasetError(f"{manifest_path}: unknown gait {gait!r} ({' or '.join(registry.gait_names())})")
    robot = manifest.get("robot", registry.DEFAULT_ROBOT)  # datasets made before the field: Solo12
    if not isinstance(robot, str) or not robot:
        raise DatasetError(f"{manifest_path}: robot must be a robot name, got {robot!r}")
    if manifest["n_actions"] not in sizes:
        raise DatasetError(f"{manifest_path}: n_actions is {manifest['n_actions']!r}, gait {gait!r} has "
                           f"{sizes[0]} choices ({sizes[1]} actions and standing)")
    n_actions = int(manifest["n_actions"])
    names = manifest["input_names"]
    if not (isinstance(names, list) and len(names) == N_INPUTS and all(isinstance(s, str) for s in names)):
        raise DatasetError(f"{manifest_path}: input_names must be a list of {N_INPUTS} strings")
    shards = manifest["shards"]
    if not (isinstance(shards, list) and all(isinstance(s, str) for s in shards)):
        raise DatasetError(f"{manifest_path}: shards must be a list of file names")
    if not shards:
        raise DatasetError(f"{manifest_path}: lists no shards (empty dataset)")

    us, Vs, eps = [], [], []
    stats_of = manifest.get("shard_stats") if isinstance(manifest.get("shard_stats"), dict) else {}
    for name in shards:
        shard_path = directory / name
        if not shard_path.is_file():
            raise DatasetError(f"{shard_path}: shard listed in the manifest is missing")
        stats = stats_of.get(name) if isinstance(stats_of.get(name), dict) else {}
        problem = check_file(shard_path, stats.get("bytes"), stats.get("sha256"))  # datasets before: nothing
        if problem is not None:
            raise DatasetError(f"{shard_path}: not the shard datagen wrote: {problem}; run the same datagen "
                               "command again to regenerate it")
        try:
            with np.load(shard_path, allow_pickle=False) as data:
                missing = [k for k in ("u", "V", "episode") if k not in data.files]
                if missing:
                    raise DatasetError(f"{shard_path}: missing array(s) {', '.join(missing)}")
                u, V, episode = data["u"], data["V"], data["episode"]
        except DatasetError:
            raise
        except Exception as exc:  # zipfile/pickle/OS errors for truncated or foreign files
            raise DatasetError(f"{shard_path}: unreadable shard ({type(exc).__name__}: "
                               f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
        if not np.issubdtype(episode.dtype, np.integer):
            raise DatasetError(f"{shard_path}: episode ids must be integers, got {episode.dtype}")
        if not (np.issubdtype(u.dtype, np.floating) and np.issubdtype(V.dtype, np.floating)):
            raise DatasetError(f"{shard_path}: u and V must be floating point, got {u.dtype} and {V.dtype}")
        _check_arrays(u, V, episode, n_actions, str(shard_path))
        us.append(u.astype(np.float32, copy=False))
        Vs.append(V.astype(np.float32, copy=False))
        eps.append(episode.astype(np.int64))
    u, V, episode = np.concatenate(us), np.concatenate(Vs), np.concatenate(eps)
    declared = manifest.get("instances")
    if isinstance(declared, int) and declared != len(u):
        raise DatasetError(f"{manifest_path}: declares {declared} instances but the shards hold {len(u)}")
    if len(u) == 0:
        raise DatasetError(f"dataset {directory}: the shards hold no instances")
    return Dataset.from_arrays(u, V, episode, gait=gait, input_names=names, manifest=manifest, path=directory,
                               robot=robot)


# ---- split -------------------------------------------------------------------------------------
def split_rows(episode: np.ndarray, train_fraction: float, split: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train_rows, test_rows), both sorted. "episode": shuffle whole episodes and fill the train set
    until about `train_fraction` of the instances; "instance": a random permutation of instances."""
    n = len(episode)
    rng = np.random.default_rng(seed)
    if split == "instance":
        if n < 2:
            raise DatasetError("need at least 2 instances to split into train and test")
        perm = rng.permutation(n)
        n_train = min(max(int(round(train_fraction * n)), 1), n - 1)
        return np.sort(perm[:n_train]), np.sort(perm[n_train:])
    if split != "episode":
        raise ValueError(f"split must be 'episode' or 'instance', got {split!r}")
    ids, inverse, counts = np.unique(episode, return_inverse=True, return_counts=True)
    if ids.size < 2:
        raise DatasetError(f"need at least 2 episodes for an episode split (found {ids.size}); use split 'instance'")
    order = rng.permutation(ids.size)
    cumulative = np.cumsum(counts[order])
    # an episode goes to train when the middle of its block lies within the first fraction of instances
    in_train_sorted = (cumulative - counts[order] / 2) <= train_fraction * n
    in_train_sorted[0] = True  # both sides get at least one episode
    if in_train_sorted.all():
        in_train_sorted[-1] = False
    train_episode = np.zeros(ids.size, dtype=bool)
    train_episode[order] = in_train_sorted
    rows_train = train_episode[inverse]
    return np.flatnonzero(rows_train), np.flatnonzero(~rows_train)


# ---- configuration and result ------------------------------------------------------------------
@dataclass(frozen=True)
class TrainConfig:
    """Training settings; the defaults are the paper's (Sec. IV) plus our episode split.

    threads: torch intra-op threads while training. 1 is fastest for this small MLP at batch 100 on
    the 2-core machine (about 0.35 s/epoch against 0.5-0.6 s with 2 threads: the per-op thread
    hand-off costs more than it saves on 100 x 128 matrices)."""

    epochs: int = 1000
    batch_size: int = 100
    lr: float = 1e-3
    train_fraction: float = 0.7
    seed: int = 0
    split: str = "episode"  # "episode" (default, no leakage) or "instance" (the paper's plain split)
    threads: int = 1
    max_minutes: float | None = None
    eval_every: int = 10  # epochs between train/test top-k evaluations (history, progress bar)
    mirror: bool = False  # add every training instance's left-right mirror (contactnet.planning.mirror)

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.threads < 1 or self.eval_every < 1:
            raise ValueError("epochs, batch_size, threads and eval_every must be >= 1")
        if not (self.lr > 0 and math.isfinite(self.lr)):
            raise ValueError(f"lr must be positive, got {self.lr}")
        if not 0 < self.train_fraction < 1:
            raise ValueError(f"train_fraction must be in (0, 1), got {self.train_fraction}")
        if self.split not in ("episode", "instance"):
            raise ValueError(f"split must be 'episode' or 'instance', got {self.split!r}")
        if self.max_minutes is not None and not self.max_minutes > 0:
            raise ValueError(f"max_minutes must be positive, got {self.max_minutes}")


@dataclass
class TrainResult:
    model: ContactNet
    normalizer: Normalizer
    metrics: dict[str, float]  # train_top1, train_top5, test_top1, test_top5 (fractions), final_loss
    history: list[dict[str, float]]
    config: TrainConfig
    epochs_done: int
    seconds: float
    stopped: str  # "done", "time limit", "interrupted"
    counts: dict[str, int]  # instances/episodes used, train/test sizes, rows dropped

    @property
    def interrupted(self) -> bool:
        return self.stopped == "interrupted"

    @property
    def seconds_per_epoch(self) -> float:
        return self.seconds / max(self.epochs_done, 1)


# ---- training ----------------------------------------------------------------------------------
class _FlatAdam:
    """Adam over one flat buffer that holds every parameter (the layers' parameters become views).

    Gradients accumulate in place into a flat gradient buffer, so a step is one zero_() and a few
    vector ops on ~48k numbers instead of per-layer bookkeeping. The arithmetic is torch.optim.Adam's
    (single-tensor path, default betas/eps, no weight decay), written out so a step has no optimizer
    framework overhead and training does not import torch._dynamo (1.5 s); see the test against
    torch.optim.Adam."""

    def __init__(self, model: torch.nn.Module, lr: float, betas: tuple[float, float] = (0.9, 0.999),
                 eps: float = 1e-8) -> None:
        params = list(model.parameters())
        total = sum(p.numel() for p in params)
        self.flat = torch.zeros(total)
        self.grad = torch.zeros(total)
        offset = 0
        for p in params:
            k = p.numel()
            self.flat[offset : offset + k].copy_(p.detach().reshape(-1))
            p.data = self.flat[offset : offset + k].view_as(p)
            p.grad = self.grad[offset : offset + k].view_as(p)
            offset += k
        self._params = params
        self.lr, self.beta1, self.beta2, self.eps = lr, betas[0], betas[1], eps
        self.exp_avg = torch.zeros(total)
        self.exp_avg_sq = torch.zeros(total)
        self._denom = torch.empty(total)
        self.steps = 0

    def zero_grad(self) -> None:
        self.grad.zero_()

    @torch.no_grad()
    def step(self) -> None:
        self.steps += 1
        grad = self.grad
        self.exp_avg.lerp_(grad, 1 - self.beta1)
        self.exp_avg_sq.mul_(self.beta2).addcmul_(grad, grad, value=1 - self.beta2)
        bias_correction1 = 1 - self.beta1**self.steps
        bias_correction2_sqrt = (1 - self.beta2**self.steps) ** 0.5
        torch.sqrt(self.exp_avg_sq, out=self._denom)
        self._denom.div_(bias_correction2_sqrt).add_(self.eps)
        self.flat.addcdiv_(self.exp_avg, self._denom, value=-self.lr / bias_correction1)

    def check_views(self) -> bool:
        """True while every parameter and gradient still points into the flat buffers."""
        lo, hi = self.flat.data_ptr(), self.flat.data_ptr() + self.flat.numel() * 4
        glo, ghi = self.grad.data_ptr(), self.grad.data_ptr() + self.grad.numel() * 4
        return all(lo <= p.data_ptr() < hi and p.grad is not None and glo <= p.grad.data_ptr() < ghi
                   for p in self._params)


def predict_scores(model: ContactNet, x: torch.Tensor, chunk: int = 16384) -> np.ndarray:
    """Scores for normalized inputs x (n, 14) in chunks, as float64 numpy."""
    out = []
    with torch.no_grad():
        for start in range(0, x.shape[0], chunk):
            out.append(model(x[start : start + chunk]).double().numpy())
    return np.concatenate(out) if out else np.zeros((0, model.n_actions))


def evaluate(model: ContactNet, x: torch.Tensor, V: np.ndarray) -> dict[str, float]:
    """top-1 (argmax == argmin V) and the paper's top-5 on normalized inputs x and costs V."""
    if len(V) == 0:
        return {"top1": float("nan"), "top5": float("nan")}
    scores = predict_scores(model, x)
    return {"top1": topk_accuracy(scores, V, k_true=1), "top5": topk_accuracy(scores, V, k_true=5)}


def train(dataset: Dataset, config: TrainConfig = TrainConfig(), progress: bool = True,
          stop_on_interrupt: bool = False, on_epoch: Callable[[int, float], None] | None = None) -> TrainResult:
    """Train a ContactNet on `dataset`. With `stop_on_interrupt`, Ctrl-C ends training after the
    current batch and returns the partial result (stopped == "interrupted"); otherwise it propagates.
    torch's thread count and global RNG are restored afterwards."""
    from tqdm import tqdm

    feasible = np.isfinite(dataset.V).any(axis=1)
    rows = np.flatnonzero(feasible)
    if rows.size < 2:
        raise DatasetError(f"{dataset.path or 'dataset'}: fewer than 2 instances with a feasible candidate")
    data = dataset.subset(rows) if rows.size < dataset.n_instances else dataset
    train_rows, test_rows = split_rows(data.episode, config.train_fraction, config.split, config.seed)
    u_train, v_train, v_test = data.u[train_rows], data.V[train_rows], data.V[test_rows]
    if config.mirror:  # the training split and its mirror image; the test split as generated
        u_mirror, v_mirror = mirrored(u_train, v_train, registry.gait_by_name(data.gait))
        u_train, v_train = np.concatenate([u_train, u_mirror]), np.concatenate([v_train, v_mirror])
    normalizer = Normalizer.fit(u_train, names=data.input_names)
    x_train = torch.from_numpy(normalizer.normalize(u_train).astype(np.float32)).contiguous()
    x_test = torch.from_numpy(normalizer.normalize(data.u[test_rows]).astype(np.float32)).contiguous()
    y_train = torch.from_numpy(rank_targets(v_train))
    n_train = len(u_train)
    counts = {
        "instances": dataset.n_instances, "episodes": dataset.n_episodes,
        "dropped_infeasible": int(dataset.n_instances - rows.size),
        "train_instances": int(n_train), "test_instances": int(len(test_rows)),
        "mirrored_instances": int(n_train - len(train_rows)),
        "train_episodes": int(np.unique(data.episode[train_rows]).size),
        "test_episodes": int(np.unique(data.episode[test_rows]).size),
    }

    old_threads = torch.get_num_threads()
    torch.set_num_threads(config.threads)
    history: list[dict[str, float]] = []
    stopped = "done"
    epoch = 0
    start = time.perf_counter()
    deadline = None if config.max_minutes is None else start + 60 * config.max_minutes
    try:
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(config.seed)
            model = ContactNet(dataset.n_actions)
            optimizer = _FlatAdam(model, config.lr)
            generator = torch.Generator().manual_seed(config.seed)
            loss_fn = torch.nn.functional.mse_loss
            bs = config.batch_size
            bar = tqdm(range(config.epochs), desc=f"train {dataset.gait}", unit="epoch", file=sys.stderr,
                       disable=not progress, dynamic_ncols=True, leave=True)
            last_test_top5 = float("nan")
            try:
                for epoch_index in bar:
                    model.train()
                    perm = torch.randperm(n_train, generator=generator)
                    xs, ys = x_train[perm], y_train[perm]
                    total = torch.zeros(())
                    for s in range(0, n_train, bs):
                        optimizer.zero_grad()
                        xb, yb = xs[s : s + bs], ys[s : s + bs]
                        loss = loss_fn(model(xb), yb)
                        loss.backward()
                        optimizer.step()
                        total += loss.detach() * xb.shape[0]
                    epoch = epoch_index + 1
                    epoch_loss = float(total) / n_train
                    if epoch % config.eval_every == 0 or epoch == config.epochs:
                        model.eval()
                        tr, te = evaluate(model, x_train, v_train), evaluate(model, x_test, v_test)
                        last_test_top5 = te["top5"]
                        history.append({"epoch": epoch, "loss": epoch_loss, "train_top1": tr["top1"],
                                        "train_top5": tr["top5"], "test_top1": te["top1"], "test_top5": te["top5"],
                                        "seconds": time.perf_counter() - start})
                    shown = "-" if math.isnan(last_test_top5) else f"{100 * last_test_top5:.1f}%"
                    bar.set_postfix(loss=f"{epoch_loss:.5f}", test_top5=shown, refresh=False)
                    if on_epoch is not None:
                        on_epoch(epoch, epoch_loss)
                    if deadline is not None and time.perf_counter() > deadline and epoch < config.epochs:
                        stopped = "time limit"
                        break
            except KeyboardInterrupt:
                if not stop_on_interrupt:
                    raise
                stopped = "interrupted"
            finally:
                bar.close()
    finally:
        torch.set_num_threads(old_threads)
    seconds = time.perf_counter() - start

    model.eval()
    tr, te = evaluate(model, x_train, v_train), evaluate(model, x_test, v_test)
    with torch.no_grad():
        final_loss = float(loss_fn(model(x_train), y_train)) if n_train else float("nan")
    metrics = {"train_top1": tr["top1"], "train_top5": tr["top5"], "test_top1": te["top1"],
               "test_top5": te["top5"], "final_loss": final_loss}
    if epoch > 0 and (not history or history[-1]["epoch"] != epoch):
        history.append({"epoch": epoch, "loss": final_loss, "train_top1": tr["top1"], "train_top5": tr["top5"],
                        "test_top1": te["top1"], "test_top5": te["top5"], "seconds": seconds})
    return TrainResult(model=model, normalizer=normalizer, metrics=metrics, history=history, config=config,
                       epochs_done=epoch, seconds=seconds, stopped=stopped, counts=counts)


# ---- the command -------------------------------------------------------------------------------
def model_metadata(dataset: Dataset, result: TrainResult) -> dict[str, Any]:
    """Everything the model file records about how it was made."""
    from contactnet import __version__

    config = result.config
    paper_top5 = registry.gait_by_name(dataset.gait).paper_top5
    return {
        "gait": dataset.gait,
        "robot": dataset.robot,
        "n_actions": dataset.n_actions,
        "input_names": list(dataset.input_names),
        "normalization": result.normalizer.to_dict(),
        **{k: float(v) for k, v in result.metrics.items()},
        "paper_top5": None if paper_top5 is None else list(paper_top5),
        "dataset": {
            "path": str(dataset.path) if dataset.path else None,
            **result.counts,
            "manifest_episodes": dataset.manifest.get("episodes"),
            "seed": dataset.manifest.get("seed"),
            "code_version": dataset.manifest.get("code_version"),
        },
        "training": {
            **asdict(config),
            "optimizer": "Adam",
            "loss": "MSE on rank targets",
            "epochs_done": result.epochs_done,
            "stopped": result.stopped,
            "seconds": round(result.seconds, 3),
        },
        "history": result.history,
        "code_version": __version__,
        "torch_version": torch.__version__,
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def _pct(x: float) -> str:
    return "   n/a" if x is None or not math.isfinite(x) else f"{100 * x:6.2f}"


def summary_text(dataset: Dataset, result: TrainResult, out_path: Path | None) -> str:
    c, m, cfg = result.counts, result.metrics, result.config
    paper = registry.gait_by_name(dataset.gait).paper_top5  # None: the paper has no figure for this gait
    split = "by episode" if cfg.split == "episode" else "by instance (paper)"
    mirror = " (half of them the mirror images of the other half)" if c.get("mirrored_instances") else ""
    lines = [
        f"contactnet train: {dataset.gait} model of {dataset.robot}"
        + (f" -> {out_path}" if out_path else " (not saved)"),
        f"  data    {dataset.path}: {c['instances']:,} instances, {c['episodes']:,} episodes"
        + (f" ({c['dropped_infeasible']} all-infeasible rows dropped)" if c["dropped_infeasible"] else ""),
        f"  split   {split}, {cfg.train_fraction:.0%} train: {c['train_instances']:,} train / "
        f"{c['test_instances']:,} test instances ({c['train_episodes']:,} / {c['test_episodes']:,} episodes){mirror}",
        f"  epochs  {result.epochs_done}/{cfg.epochs} ({result.stopped}) in {result.seconds / 60:.1f} min, "
        f"{result.seconds_per_epoch:.2f} s/epoch; batch {cfg.batch_size}, lr {cfg.lr:g}, seed {cfg.seed}",
        "            train %   test %   paper train / test %",
        f"  top-1    {_pct(m['train_top1'])}   {_pct(m['test_top1'])}   -",
        f"  top-5    {_pct(m['train_top5'])}   {_pct(m['test_top5'])}   "
        + ("-" if paper is None else f"{paper[0]:.2f} / {paper[1]:.2f}"),
    ]
    return "\n".join(lines)


def train_command(gait: str, data_dir: str | os.PathLike, out_path: str | os.PathLike, epochs: int = 1000,
                  batch_size: int = 100, lr: float = 1e-3, seed: int = 0, split: str = "episode",
                  train_fraction: float = 0.7, threads: int = 1, max_minutes: float | None = None,
                  save_partial: bool = False, progress: bool = True, robot: str | None = None,
                  mirror: bool = False) -> int:
    """`contactnet train`: load DIR, check the gait (and the robot, unless `robot` is None), train, save the
    model file (which records the dataset's robot), print a summary.

    Returns the exit code: 0, or 130 after Ctrl-C (nothing saved unless `save_partial`). Dataset
    problems raise DatasetError, an unwritable output ModelFileError (both one-line ValueErrors)."""
    dataset = load_dataset(data_dir)
    if dataset.gait != gait:
        raise DatasetError(f"dataset {data_dir} is a {dataset.gait!r} dataset, but --gait {gait} was asked")
    if robot is not None and dataset.robot != robot:
        raise DatasetError(f"dataset {data_dir} was made with {dataset.robot!r}, but --robot {robot} was asked")
    out = Path(out_path)
    _check_writable(out)
    if dataset.manifest.get("complete") is False:
        print(f"warning: dataset {data_dir} is incomplete ({dataset.manifest.get('episodes')} of "
              f"{dataset.manifest.get('episodes_planned')} episodes); training on what is there", file=sys.stderr)
    config = TrainConfig(epochs=epochs, batch_size=batch_size, lr=lr, seed=seed, split=split,
                         train_fraction=train_fraction, threads=threads, max_minutes=max_minutes, mirror=mirror)
    print(f"training {gait}: {dataset.n_instances:,} instances from {data_dir}, {epochs} epochs "
          f"(Ctrl-C stops; nothing is saved{'' if not save_partial else ' but the partial model'})", file=sys.stderr)
    result = train(dataset, config, progress=progress, stop_on_interrupt=True)
    if result.interrupted and not save_partial:
        print(f"interrupted after {result.epochs_done} of {epochs} epochs: nothing saved "
              f"({out} untouched; pass --save-partial to keep a partial model)", file=sys.stderr)
        return EXIT_INTERRUPTED
    save_model(out, result.model, result.normalizer, model_metadata(dataset, result))
    print(summary_text(dataset, result, out))
    return EXIT_INTERRUPTED if result.interrupted else 0


def _check_writable(out: Path) -> None:
    """Fail before a long training run, not after it."""
    if out.exists() and out.is_dir():
        raise ModelFileError(f"model file {out}: is a directory; give a file name such as {out / 'walk.pt'}")
    parent = out.parent if str(out.parent) else Path(".")
    existing = parent
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise ModelFileError(f"model file {out}: cannot write in {existing}")


__all__ = [
    "DATASET_FORMAT", "Dataset", "DatasetError", "TrainConfig", "TrainResult", "evaluate", "load_dataset",
    "model_metadata", "predict_scores", "split_rows", "summary_text", "train", "train_command",
]
