"""The whole-body controller's arithmetic after the kinematics, compiled with numba: steps 1-5 of
``contactnet.motion.controller`` (centroidal feedback wrench spread over the stance feet, the friction pyramid,
stance and swing legs, joint damping, saturation) in one call of straight loops on 3- to 18-vectors.

In numpy these were about 25 operations on tiny arrays, each costing about a microsecond of interpreter and
dispatch work for a few flops (21 us of the 1 kHz tick); here the whole of it is about 1 us. The same
formulas; the sums run in a fixed order (not BLAS's), so results agree with the numpy form to rounding
(``tests/test_controller.py`` checks them against it). Compiled on first use, cached next to this file.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Layout of the ``gains`` vector (``pack_gains``).
KP_COM, KD_COM, KP_ROT, KD_ROT, KP_SWING, KD_SWING = 0, 3, 6, 9, 12, 15
MU, FZ_MIN, FZ_MAX, KD_JOINT, REGULARIZATION, UNLOAD_ROUNDS, COP_MARGIN, LEG_GRAVITY = 18, 19, 20, 21, 22, 23, 24, 25
N_GAINS = 26


def pack_gains(kp_com: np.ndarray, kd_com: np.ndarray, kp_rot: np.ndarray, kd_rot: np.ndarray, kp_swing: np.ndarray,
               kd_swing: np.ndarray, mu: float, fz_min: float, fz_max: float, kd_joint: float,
               regularization: float, unload_rounds: int = 0, cop_margin_m: float | None = None,
               leg_gravity: float = 0.0) -> np.ndarray:
    """The controller's gains as one float64 vector (N_GAINS,) for ``wbc_torques`` (``cop_margin_m`` None: -1)."""
    cop = -1.0 if cop_margin_m is None else cop_margin_m
    return np.concatenate([kp_com, kd_com, kp_rot, kd_rot, kp_swing, kd_swing,
                           [mu, fz_min, fz_max, kd_joint, regularization, unload_rounds, cop, leg_gravity]]
                          ).astype(np.float64)


@numba.njit(cache=True, nogil=True)
def cop_scale(com: np.ndarray, foot: np.ndarray, stance: np.ndarray, forces_ref: np.ndarray, wrench: np.ndarray,
              margin_m: float) -> float:
    """The share in [0, 1] of the feedback wrench's horizontal force that keeps the centre of pressure
    ``margin_m`` inside the stance feet's polygon (1: all of it; with fewer than three stance feet, or three on a
    line, 1).

    The ground forces' resultant F with moment M about the CoM has its centre of pressure at
    ``p_xy = c_xy + ((-M_y - h F_x) / F_z, (M_x - h F_y) / F_z)``, ``h`` the CoM's height above the stance feet.
    The planned forces plus the whole feedback wrench give F and M; the horizontal feedback force, scaled by
    alpha, moves p along a line. Alpha is the largest value in [0, 1] that keeps p, edge by edge, inside where
    p(0) is inside and no further out where p(0) is outside (so 0 when the horizontal feedback would move p
    further out across an edge it is already beyond: the rotation's feedback is kept, the push is not
    fought by tipping the body).

    Why: a walk's three stance feet hold a horizontal force only as far as its moment about the CoM can be
    balanced by shifting their vertical loads; a sideways push plus the feedback that fights it asks for more,
    a foot unloads (its force clipped at ``fz_min``), the moment is lost and the body rolls over the other
    two feet. Less horizontal force lets the push move the body instead, which the next steps catch."""
    if wrench[0] == 0.0 and wrench[1] == 0.0:
        return 1.0  # no horizontal feedback to scale
    # One pass over the stance feet: their xy, mean height, and the planned forces' resultant and moment.
    n = 0
    xs, ys = np.empty(4), np.empty(4)
    ground_z = 0.0
    fx0, fy0, fz, mx, my = 0.0, 0.0, wrench[2], wrench[3], wrench[4]
    for leg in range(4):
        if not stance[leg]:
            continue
        xs[n], ys[n] = foot[leg, 0], foot[leg, 1]
        ground_z += foot[leg, 2]
        n += 1
        fx, fy, fzl = forces_ref[leg, 0], forces_ref[leg, 1], forces_ref[leg, 2]
        lx, ly, lz = foot[leg, 0] - com[0], foot[leg, 1] - com[1], foot[leg, 2] - com[2]
        fx0 += fx
        fy0 += fy
        fz += fzl
        mx += ly * fzl - lz * fy
        my += lz * fx - lx * fzl
    if n < 3:
        return 1.0
    h = com[2] - ground_z / n
    if fz <= 1e-6 or h <= 0.0:
        return 1.0
    # p(alpha) = p0 + alpha d
    p0x = com[0] + (-my - h * fx0) / fz
    p0y = com[1] + (mx - h * fy0) / fz
    dx, dy = -h * wrench[0] / fz, -h * wrench[1] / fz
    # the stance feet in counter-clockwise order about their centroid (insertion sort by angle)
    cx, cy = 0.0, 0.0
    for i in range(n):
        cx += xs[i] / n
        cy += ys[i] / n
    angle = np.empty(n)
    for i in range(n):
        angle[i] = np.arctan2(ys[i] - cy, xs[i] - cx)
    for i in range(1, n):
        j = i
        while j > 0 and angle[j - 1] > angle[j]:
            angle[j - 1], angle[j] = angle[j], angle[j - 1]
            xs[j - 1], xs[j] = xs[j], xs[j - 1]
            ys[j - 1], ys[j] = ys[j], ys[j - 1]
            j -= 1
    twice_area = 0.0
    for i in range(n):
        twice_area += xs[i] * ys[(i + 1) % n] - xs[(i + 1) % n] * ys[i]
    if twice_area < 1e-8:
        return 1.0  # the stance feet on a line: no polygon to keep p in
    alpha = 1.0
    for i in range(n):
        ax, ay = xs[i], ys[i]
        bx, by = xs[(i + 1) % n], ys[(i + 1) % n]
        ex, ey = bx - ax, by - ay
        length = np.sqrt(ex * ex + ey * ey)
        if length < 1e-9:
            continue
        nx, ny = -ey / length, ex / length  # inward (left of a counter-clockwise edge)
        slack = nx * (p0x - ax) + ny * (p0y - ay) - margin_m
        rate = nx * dx + ny * dy
        if rate >= 0.0:
            continue  # the feedback moves p inwards of this edge (or along it)
        if slack <= 0.0:
            return 0.0  # outside this edge already: no horizontal feedback that moves p further out
        alpha = min(alpha, slack / -rate)
    return max(0.0, min(alpha, 1.0))


@numba.njit(cache=True, nogil=True)
def _solve_spd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with a x = b for a symmetric positive definite (n, n) ``a`` (Cholesky; ``a`` is overwritten)."""
    n = a.shape[0]
    for j in range(n):
        d = a[j, j]
        for k in range(j):
            d -= a[j, k] * a[j, k]
        d = np.sqrt(d)
        a[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= a[i, k] * a[j, k]
            a[i, j] = s / d
    x = b.copy()
    for i in range(n):  # L y = b
        s = x[i]
        for k in range(i):
            s -= a[i, k] * x[k]
        x[i] = s / a[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        s = x[i]
        for k in range(i + 1, n):
            s -= a[k, i] * x[k]
        x[i] = s / a[i, i]
    return x


@numba.njit(cache=True, nogil=True)
def wbc_torques(com: np.ndarray, vcom: np.ndarray, jacobians: tuple, feet: tuple, rot: np.ndarray, v: np.ndarray,
                rot_err: np.ndarray, com_ref: np.ndarray, com_vel_ref: np.ndarray, ang_vel_ref: np.ndarray,
                forces_ref: np.ndarray, stance: np.ndarray, swing_pos: np.ndarray, swing_vel: np.ndarray,
                external_force: np.ndarray, gains: np.ndarray, torque_limit: np.ndarray, tau: np.ndarray,
                forces: np.ndarray, foot: np.ndarray, normals: np.ndarray, gravity_tau: np.ndarray) -> None:
    """Fills ``tau`` (12,), the joint torques, saturated; ``forces`` (4, 3), the ground forces on the stance feet,
    zero on swing feet; ``foot`` (4, 3), the foot positions. ``jacobians``: the 4 feet's (6, 18) world-aligned frame
    Jacobians (linear rows first); ``feet``: their 4 positions (3,); ``rot``: base orientation; ``v`` (18,) pinocchio
    velocity; ``rot_err`` (3,): log of the reference orientation times ``rot``'s transpose; the rest is the
    ``ControlTarget``, ``external_force`` zero for none, ``gains`` as ``pack_gains``; ``normals`` (4, 3) the unit
    normals of the ground under the feet (world): the friction pyramid of a stance foot is built about it (its
    normal force in [fz_min, fz_max], each of two tangential parts at most mu times it), the same numbers as the
    axis-wise clip where it is +z. ``gravity_tau`` (12,): the torques that hold the legs' own weight (pinocchio's
    generalized gravity without the base rows), added times ``gains[LEG_GRAVITY]`` (0: left out, the legs massless).

    With ``gains[UNLOAD_ROUNDS]`` > 0, a stance foot whose vertical force comes out below ``fz_min`` (the wrench
    asks it to pull on the ground) is held at ``fz_min`` and the rest of the wrench is spread again over the other
    stance feet, up to that many rounds (an active set): the wrench is kept where the plain spread, clipped
    afterwards, would add the pull as a push (a net upward force and a lost moment: the body rises and rolls on).

    The caller makes the output arrays: arrays made here would be boxed on return through a Python callback
    (numba's ``_numba_unpickle``), and a Ctrl-C landing in it came back as a SystemError, not KeyboardInterrupt."""
    # 1. Centroidal feedback wrench, spread over the stance feet: delta = S G^T (G S G^T + eps I)^-1 wrench.
    wrench = np.empty(6)
    for i in range(3):
        wrench[i] = (gains[KP_COM + i] * (com_ref[i] - com[i]) + gains[KD_COM + i] * (com_vel_ref[i] - vcom[i])
                     - external_force[i])
    for i in range(3):
        omega = rot[i, 0] * v[3] + rot[i, 1] * v[4] + rot[i, 2] * v[5]
        wrench[3 + i] = gains[KP_ROT + i] * rot_err[i] + gains[KD_ROT + i] * (ang_vel_ref[i] - omega)
    for leg in range(4):
        for i in range(3):
            foot[leg, i] = feet[leg][i]
    if gains[COP_MARGIN] >= 0.0:  # 1b. no more horizontal feedback than the stance polygon can hold (cop_scale)
        alpha = cop_scale(com, foot, stance, forces_ref, wrench, gains[COP_MARGIN])
        wrench[0] *= alpha
        wrench[1] *= alpha
    grasp = np.zeros((6, 12))  # [I I I I; skew(lever_0) ... skew(lever_3)]
    for leg in range(4):
        if not stance[leg]:
            continue  # the weighted map's columns of a swing foot are zero
        c = 3 * leg
        lx, ly, lz = foot[leg, 0] - com[0], foot[leg, 1] - com[1], foot[leg, 2] - com[2]
        grasp[0, c], grasp[1, c + 1], grasp[2, c + 2] = 1.0, 1.0, 1.0
        grasp[3, c + 1], grasp[3, c + 2] = -lz, ly
        grasp[4, c], grasp[4, c + 2] = lz, -lx
        grasp[5, c], grasp[5, c + 1] = -ly, lx
    mu, fz_min, fz_max = gains[MU], gains[FZ_MIN], gains[FZ_MAX]
    held = np.zeros(4, dtype=np.bool_)  # stance feet held at fz_min by the unloading rounds
    unloaded = np.zeros((4, 3))  # their forces
    rounds = int(gains[UNLOAD_ROUNDS])
    delta = np.zeros((4, 3))
    for round_ in range(rounds + 1):
        normal = np.empty((6, 6))
        for i in range(6):
            for j in range(6):
                s = 0.0
                for k in range(12):
                    if not held[k // 3]:
                        s += grasp[i, k] * grasp[j, k]
                normal[i, j] = s
            normal[i, i] += gains[REGULARIZATION]
        solved = _solve_spd(normal, wrench)  # (b is copied inside)
        newly = False
        for leg in range(4):
            if not stance[leg] or held[leg]:
                continue
            for i in range(3):
                s = 0.0
                for k in range(6):
                    s += grasp[k, 3 * leg + i] * solved[k]
                delta[leg, i] = s
            if round_ < rounds and forces_ref[leg, 2] + delta[leg, 2] < fz_min:
                held[leg] = newly = True
                limit = mu * fz_min
                unloaded[leg, 0] = min(max(forces_ref[leg, 0] + delta[leg, 0], -limit), limit)
                unloaded[leg, 1] = min(max(forces_ref[leg, 1] + delta[leg, 1], -limit), limit)
                unloaded[leg, 2] = fz_min
                for i in range(6):  # that foot's part of the wrench is now fixed: the others spread the rest
                    for j in range(3):
                        wrench[i] -= grasp[i, 3 * leg + j] * (unloaded[leg, j] - forces_ref[leg, j])
        if not newly:
            break
    # 2-3. Stance legs push with the forces (tau = -J^T f), in the friction pyramid; swing legs track.
    forces[:] = 0.0
    push = np.empty((4, 3))
    for leg in range(4):
        jac = jacobians[leg]
        if stance[leg]:
            f = np.empty(3)
            for i in range(3):
                f[i] = unloaded[leg, i] if held[leg] else forces_ref[leg, i] + delta[leg, i]
            nx, ny, nz = normals[leg, 0], normals[leg, 1], normals[leg, 2]
            if nx == 0.0 and ny == 0.0:  # flat ground: the axis-wise pyramid
                fz = min(max(f[2], fz_min), fz_max)
                limit = mu * fz
                forces[leg, 0] = min(max(f[0], -limit), limit)
                forces[leg, 1] = min(max(f[1], -limit), limit)
                forces[leg, 2] = fz
            else:  # a sloped top: tangents t1 (x projected onto the plane) and t2 = n x t1
                ax, ay, az = 1.0 - nx * nx, -nx * ny, -nx * nz
                norm = math.sqrt(ax * ax + ay * ay + az * az)
                ax, ay, az = ax / norm, ay / norm, az / norm
                bx, by, bz = ny * az - nz * ay, nz * ax - nx * az, nx * ay - ny * ax
                fn = min(max(f[0] * nx + f[1] * ny + f[2] * nz, fz_min), fz_max)
                limit = mu * fn
                f1 = min(max(f[0] * ax + f[1] * ay + f[2] * az, -limit), limit)
                f2 = min(max(f[0] * bx + f[1] * by + f[2] * bz, -limit), limit)
                forces[leg, 0] = fn * nx + f1 * ax + f2 * bx
                forces[leg, 1] = fn * ny + f1 * ay + f2 * by
                forces[leg, 2] = fn * nz + f1 * az + f2 * bz
            for i in range(3):
                push[leg, i] = -forces[leg, i]
        else:
            for i in range(3):
                vel = 0.0
                for k in range(18):
                    vel += jac[i, k] * v[k]
                push[leg, i] = (gains[KP_SWING + i] * (swing_pos[leg, i] - foot[leg, i])
                                + gains[KD_SWING + i] * (swing_vel[leg, i] - vel))
    # 4-5. tau = sum over legs of J_leg^T (joint columns) push_leg, joint damping, the legs' weight, saturation.
    for j in range(12):
        s = 0.0
        for leg in range(4):
            jac = jacobians[leg]
            for i in range(3):
                s += jac[i, 6 + j] * push[leg, i]
        s -= gains[KD_JOINT] * v[6 + j]
        if gains[LEG_GRAVITY] != 0.0:
            s += gains[LEG_GRAVITY] * gravity_tau[j]
        tau[j] = min(max(s, -torque_limit[j]), torque_limit[j])


@numba.njit(cache=True, nogil=True)
def _min_eigenvalue_sym3(a: np.ndarray) -> float:
    """The smallest eigenvalue of a symmetric (3, 3) matrix (closed form: the trigonometric solution of its
    characteristic cubic)."""
    off = a[0, 1] * a[0, 1] + a[0, 2] * a[0, 2] + a[1, 2] * a[1, 2]
    if off == 0.0:
        return min(a[0, 0], min(a[1, 1], a[2, 2]))
    mean = (a[0, 0] + a[1, 1] + a[2, 2]) / 3.0
    d0, d1, d2 = a[0, 0] - mean, a[1, 1] - mean, a[2, 2] - mean
    scale = np.sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off) / 6.0)
    # det((a - mean I) / scale) / 2, clipped into [-1, 1] against rounding
    b00, b11, b22 = d0 / scale, d1 / scale, d2 / scale
    b01, b02, b12 = a[0, 1] / scale, a[0, 2] / scale, a[1, 2] / scale
    half_det = 0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02))
    half_det = min(max(half_det, -1.0), 1.0)
    angle = np.arccos(half_det) / 3.0
    return mean + 2.0 * scale * np.cos(angle + 2.0 * np.pi / 3.0)


@numba.njit(cache=True, nogil=True)
def leg_ground_forces(jacobians: tuple, tau: np.ndarray, gravity_tau: np.ndarray, damping_m2: float,
                      forces: np.ndarray, sigma_min: np.ndarray) -> None:
    """Fills ``forces`` (4, 3) with the ground force on each foot (on the robot, world frame) that the joint torques
    ``tau`` (12,) deliver if the foot is on the ground and the leg is still: each leg's static balance
    ``tau_leg = g_leg - J_leg^T f``, ``g_leg`` the torques that hold the leg's own weight (``gravity_tau`` (12,),
    pinocchio's generalized gravity without the base rows) and ``J_leg`` the foot's (3, 3) Jacobian in the leg's
    joints, solved as damped least squares ``f = (J J^T + damping I)^-1 J (g_leg - tau_leg)`` so that a stretched
    (near singular) leg does not amplify torque errors without bound. Fills ``sigma_min`` (4,) with each leg's
    smallest singular value of ``J_leg`` (m): near zero, the leg is stretched straight and its torques do not tell
    the force along it. ``jacobians`` as for ``wbc_torques``."""
    for leg in range(4):
        jac = jacobians[leg]
        c = 6 + 3 * leg
        rhs = np.empty(3)
        normal = np.empty((3, 3))
        for i in range(3):
            s = 0.0
            for k in range(3):
                s += jac[i, c + k] * (gravity_tau[3 * leg + k] - tau[3 * leg + k])
            rhs[i] = s
            for j in range(3):
                s = 0.0
                for k in range(3):
                    s += jac[i, c + k] * jac[j, c + k]
                normal[i, j] = s
        sigma_min[leg] = np.sqrt(max(_min_eigenvalue_sym3(normal), 0.0))
        for i in range(3):
            normal[i, i] += damping_m2
        f = _solve_spd(normal, rhs)
        for i in range(3):
            forces[leg, i] = f[i]
