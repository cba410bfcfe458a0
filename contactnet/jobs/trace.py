"""A run's trace: the body against its plan and each foot's planned, commanded and measured force, tick by tick.

``contactnet simulate ... --trace FILE.csv --trace-plot FILE.png`` (and ``contactnet replay DIR KEY --trace ...``)
samples the loop every ``TraceConfig.every_ms`` of simulated time from ``TraceConfig.from_s`` on, and writes one
CSV row per sample (world frame, SI units named in the columns) and a plot of them. What a fall looks like from the
inside: did the optimizer ask for it (the planned forces), did the controller deliver it (the commanded ones), did
the ground take it (the measured ones, from the engine's contacts), and did the body follow its plan.

The trace reads and never changes the run: the contact forces come from the engine's contact query (no sensor noise
drawn), the body's state as the controller saw it, the body's own rotation (``body_w*``: the whole robot's angular
momentum about its CoM over its composite inertia, pinocchio's centroidal dynamics) from the same measured state on a
pinocchio Data of its own. ``base_w*`` is the base link's rate, which the optimizer starts from: the two differ when
the legs swing against the base. ``push_*`` is the force applied to the base over the tick (``--push``),
``push_estimate_*`` the disturbance observer's estimate of it (``contactnet.planning.observer``; NaN without the
observer) and ``plan_push_*`` the force the active plan was solved with. ``{leg}_x_m`` .. ``{leg}_z_m`` is each foot's
ball centre as the controller saw it (with the CoM, the support a push must be held over). ``push_hold_margin_m`` is how
far the support polygon of the feet on the ground reaches along the applied push beyond the centre of pressure that
holding it in place asks (``hold_margin``; NaN without a push or with no foot down): below zero, no stance holds it
and only a step does.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import shapely

from contactnet.atomic import atomic_write_bytes, atomic_write_text

if TYPE_CHECKING:
    from contactnet.locomotion import Locomotion

LEGS = ("FL", "FR", "HL", "HR")
#: The plot's file types (matplotlib draws each from the name's suffix).
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


class TraceError(ValueError):
    """A trace that cannot be made or written: ``str()`` is one line naming the file or the value."""


@dataclass(frozen=True)
class TraceConfig:
    """Which instants a trace keeps: every ``every_ms`` of simulated time (whole control ticks of 1 ms) from
    ``from_s`` on."""

    every_ms: int = 10
    from_s: float = 0.0

    def __post_init__(self) -> None:
        if not 1 <= self.every_ms <= 1000:
            raise TraceError(f"trace: every_ms must be 1..1000 ms, got {self.every_ms}")
        if not (np.isfinite(self.from_s) and self.from_s >= 0.0):
            raise TraceError(f"trace: from_s must be a time >= 0 s, got {self.from_s}")


def columns() -> list[str]:
    """The CSV's columns, in order."""
    names = ["t_s"]
    names += [f"com_{a}_m" for a in "xyz"] + [f"com_v{a}_m_s" for a in "xyz"]
    names += ["base_roll_rad", "base_pitch_rad", "base_yaw_rad"]
    names += [f"base_w{a}_rad_s" for a in "xyz"] + [f"body_w{a}_rad_s" for a in "xyz"]
    names += [f"plan_com_{a}_m" for a in "xyz"] + ["plan_roll_rad", "plan_pitch_rad"]
    names += ["push_fx_n", "push_fy_n", "push_estimate_fx_n", "push_estimate_fy_n", "plan_push_fx_n", "plan_push_fy_n"]
    names += ["push_hold_margin_m"]
    for leg in LEGS:
        names += [f"{leg}_stance", f"{leg}_contact"] + [f"{leg}_{a}_m" for a in "xyz"]
        for kind in ("plan", "cmd", "meas"):
            names += [f"{leg}_{kind}_f{a}_n" for a in "xyz"]
    return names


def body_angular_velocity(model, data, q: np.ndarray, v: np.ndarray) -> np.ndarray:  # noqa: ANN001 - pinocchio
    """(3,) the whole robot's angular velocity (world axes, rad/s): its angular momentum about its CoM over its
    composite rotational inertia there (pinocchio's ``ccrba``). The base's rate when the joints do not move."""
    import pinocchio as pin

    pin.ccrba(model, data, q, v)
    return np.linalg.solve(data.Ig.inertia, np.asarray(data.hg.angular))


def hold_margin(force_xy_n: np.ndarray, com_world: np.ndarray, com_vel_world: np.ndarray, feet_xy_world: np.ndarray,
                com_height_m: float, mass_kg: float, gravity: float = 9.81) -> float:
    """(m) How far beyond the centre of pressure that holding a horizontal push ``force_xy_n`` (2,) in place asks the
    support polygon of the feet ``feet_xy_world`` (k, 2; those on the ground) still reaches, along the push.

    The asked point is ``F h / (m g)`` from the CoM toward the push (the push held at the CoM, ``com_height_m`` above
    the ground) plus ``v / omega`` for the CoM's velocity along it (the capture point, ``omega = sqrt(g / h)``): the
    linear inverted pendulum's measure, the body's rotation and the plan's changes of height left out. The margin is
    the distance along the push's line from that point to where the line leaves the feet's convex hull (the centre of
    pressure must lie on that line, the ground's reaction passing through the CoM, and inside the hull): not the
    farthest foot's reach, which overstates it when the push points between two feet. Below zero (the point beyond
    the hull, behind it, or the line missing a hull of one or two feet) no stance on these feet holds the push and
    only a step does. NaN without a push or without a foot."""
    force = float(np.hypot(*force_xy_n))
    if force <= 0.0 or len(feet_xy_world) == 0 or com_height_m <= 0.0:
        return float("nan")
    along = np.asarray(force_xy_n, dtype=float) / force
    feet = np.asarray(feet_xy_world, dtype=float) - np.asarray(com_world, dtype=float)[:2]  # from the CoM
    asked = force * com_height_m / (mass_kg * gravity) + float(com_vel_world[:2] @ along) / math.sqrt(gravity / com_height_m)
    hull = shapely.MultiPoint(feet).convex_hull  # a polygon, or a segment or point for fewer feet in a line
    reach_m = float(np.max(np.abs(feet))) * 2.0 + abs(asked) + 1.0  # the line's half-length: past every foot
    line = shapely.LineString([-reach_m * along, reach_m * along])
    crossing = hull.intersection(line)
    if crossing.is_empty:
        return -float(hull.distance(shapely.Point(asked * along)))
    along_s = np.asarray(shapely.get_coordinates(crossing)) @ along  # where on the line (m from the CoM) it is inside
    return float(min(along_s.max() - asked, asked - along_s.min()))


class LoopTrace:
    """The samples of one run (``run`` drives the loop and samples it; ``write_csv`` and ``plot`` write them)."""

    def __init__(self, config: TraceConfig = TraceConfig()) -> None:
        self.config = config
        self.rows: list[list[float]] = []
        self._data = None

    def run(self, loco: Locomotion, until_s: float) -> dict:
        """``loco.run(until_s)``, tick for tick the same run, sampled on the way; returns its summary."""
        dt = loco.sim.config.dt_s
        end = loco.tick + round(max(until_s - loco.t_s, 0.0) / dt)  # as Locomotion.run_for counts its ticks
        first = round(self.config.from_s / dt)
        every = max(1, round(self.config.every_ms * 1e-3 / dt))
        while loco.tick < end and not loco.done:
            sampling = loco.tick >= first
            ticks = min(every if sampling else first - loco.tick, end - loco.tick)
            loco.run_for(ticks * dt)
            if sampling:
                self.sample(loco)
        return loco.summary()

    def sample(self, loco: Locomotion) -> None:
        """One row: the loop now."""
        controller, state, target = loco.controller, loco.state, loco.target
        if self._data is None:
            self._data = controller.model.createData()
        q, v = state.q_pinocchio(), state.v_pinocchio()
        body_w = body_angular_velocity(controller.model, self._data, q, v)
        contact, measured = loco.sim.foot_forces()
        nan3 = [float("nan")] * 3
        row = [loco.t_s, *controller.last_com, *controller.last_com_vel, *state.rpy, *state.base_ang_vel_world, *body_w]
        if target is None:
            row += nan3 + [float("nan")] * 2
            planned, stance = np.zeros((4, 3)), np.ones(4, dtype=bool)
        else:
            row += [*target.com_pos, *target.rpy[:2]]
            planned, stance = target.forces, target.stance
        pushes = [p.force_world for p in loco.sim.pushes if p.active(loco.t_s - loco.sim.config.dt_s)]
        push_xy = np.sum(pushes, axis=0)[:2] if pushes else np.zeros(2)
        row += list(push_xy)
        observer = loco.observer
        row += [float("nan")] * 2 if observer is None else [observer.estimate_x_n, observer.estimate_y_n]
        held = None if loco.plan is None else loco.plan.solution_force_world
        row += [0.0, 0.0] if held is None else [float(held[0]), float(held[1])]
        commanded, feet, com = controller.last_forces, controller.last_foot_pos, controller.last_com
        height = float(com[2] - loco.terrain.ground_z(com[None, :2])[0])
        row.append(hold_margin(push_xy, com, controller.last_com_vel, feet[contact, :2], height, loco.robot.mass_kg,
                               loco.sim.config.gravity))
        for leg in range(4):
            row += [float(stance[leg]), float(contact[leg]), *feet[leg], *planned[leg], *commanded[leg], *measured[leg]]
        self.rows.append([float(x) for x in row])

    def table(self) -> np.ndarray:
        """(samples, columns) of the rows so far."""
        return np.array(self.rows, dtype=float).reshape(-1, len(columns()))

    def write_csv(self, path: str | os.PathLike) -> Path:
        """The samples as CSV (a header of ``columns()``, 6 significant digits), written whole or not at all."""
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(columns())
        writer.writerows([f"{x:.6g}" for x in row] for row in self.rows)
        return _written(path, lambda p: atomic_write_text(p, out.getvalue()))

    def plot(self, path: str | os.PathLike, title: str = "") -> Path:
        """The samples drawn (``plot_table``), written whole or not at all."""
        figure = plot_table(self.table(), title)
        buffer = io.BytesIO()
        figure.savefig(buffer, format=Path(path).suffix[1:].lower(), dpi=110)
        import matplotlib.pyplot as plt

        plt.close(figure)
        return _written(path, lambda p: atomic_write_bytes(p, buffer.getvalue()))


MARGIN_FLOOR_CM = 15.0  # the plot's hold margin panel shows no lower (cm): the CSV has every value


def plot_table(table: np.ndarray, title: str = ""):  # noqa: ANN201 - a matplotlib Figure
    """A figure of a trace's table: the CoM height, roll and pitch against the plan, the roll rate of the base and of
    the whole body, the push (applied, estimated by the observer, held by the plan), the feet's hold margin against
    it, and each foot's normal force as planned, commanded and measured (grey where the foot does not touch the
    ground)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    col = {name: i for i, name in enumerate(columns())}
    t = table[:, col["t_s"]]
    fig, axes = plt.subplots(9, 1, figsize=(9, 14.5), sharex=True, constrained_layout=True)
    ax = axes[0]
    ax.plot(t, table[:, col["com_z_m"]], label="CoM")
    ax.plot(t, table[:, col["plan_com_z_m"]], "--", label="plan")
    ax.set_ylabel("height (m)")
    ax = axes[1]
    for name, colour in (("roll", "C0"), ("pitch", "C1")):
        ax.plot(t, table[:, col[f"base_{name}_rad"]], colour, label=name)
        ax.plot(t, table[:, col[f"plan_{name}_rad"]], colour, ls="--", label=f"{name} plan")
    ax.set_ylabel("angle (rad)")
    ax = axes[2]
    ax.plot(t, table[:, col["base_wx_rad_s"]], label="base")
    ax.plot(t, table[:, col["body_wx_rad_s"]], label="whole body")
    ax.set_ylabel("roll rate (rad/s)")
    ax = axes[3]
    for axis, colour in (("x", "C0"), ("y", "C1")):
        ax.plot(t, table[:, col[f"push_f{axis}_n"]], colour, label=f"push {axis}")
        ax.plot(t, table[:, col[f"push_estimate_f{axis}_n"]], colour, ls=":", label=f"estimate {axis}")
        ax.plot(t, table[:, col[f"plan_push_f{axis}_n"]], colour, ls="--", label=f"planned with {axis}")
    ax.set_ylabel("push (N)")
    ax = axes[4]
    margin_cm = 100.0 * table[:, col["push_hold_margin_m"]]
    ax.plot(t, margin_cm, "C2", label="support's reach along the push beyond the hold's need")
    ax.axhline(0.0, color="0.5", lw=0.8)
    if np.isfinite(margin_cm).any() and np.nanmin(margin_cm) < -MARGIN_FLOOR_CM:  # one foot down: tens of cm below,
        ax.set_ylim(bottom=-MARGIN_FLOOR_CM)  # which would flatten the rest
    ax.set_ylabel("hold margin (cm)")
    for leg_index, leg in enumerate(LEGS):
        ax = axes[5 + leg_index]
        off = table[:, col[f"{leg}_contact"]] < 0.5
        ax.fill_between(t, 0, 1, where=off, transform=ax.get_xaxis_transform(), color="0.9", step="mid",
                        label="no contact")
        ax.plot(t, table[:, col[f"{leg}_plan_fz_n"]], "--", label="planned")
        ax.plot(t, table[:, col[f"{leg}_cmd_fz_n"]], label="commanded")
        ax.plot(t, table[:, col[f"{leg}_meas_fz_n"]], ":", label="measured")
        ax.set_ylabel(f"{leg} f_z (N)")
    axes[-1].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=7, ncol=4)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def check_output(path: str | os.PathLike, suffixes: tuple[str, ...]) -> Path:
    """``path`` if a file of one of ``suffixes`` can be written there (its folder exists); else a ``TraceError``."""
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise TraceError(f"trace file {path}: the name must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise TraceError(f"trace file {path}: is a folder")
    if not path.parent.is_dir():
        raise TraceError(f"trace file {path}: folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        raise TraceError(f"trace file {path}: cannot write in {path.parent}")
    return path


def _written(path: str | os.PathLike, write) -> Path:  # noqa: ANN001 - a callable of the path
    try:
        return write(path)
    except OSError as exc:  # a StorageError too: one line naming the file
        raise TraceError(f"trace file {path}: {exc}") from None


__all__ = ["LEGS", "LoopTrace", "TraceConfig", "TraceError", "body_angular_velocity", "check_output", "columns",
           "hold_margin", "plot_table"]
