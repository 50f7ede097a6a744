"""How the independent generator drives the robot: open loop (the paper's single-DOF runs, or
manual-style mixed driving) or closed loop (its own pose-tracking controller around squares,
diagonals, waypoints). Setpoints are per 10 ms row, in rpm, limited to 23 rpm.
"""
import math

import numpy as np

from indep_model import B_PSI, B_X, B_Y, OMEGA_MAX_RPM, TERRAIN, k_inverse

# Screw-speed patterns of one DOF (docs/model-notes.md "Frames": K_i's columns: +x, +y left,
# +psi ccw).
PATTERN = {"x": (-1.0, -1.0, 1.0, 1.0), "y": (-1.0, 1.0, 1.0, -1.0), "psi": (-1.0, -1.0, -1.0, -1.0)}
OPEN_KINDS = ("paper", "manual")
CLOSED_KINDS = ("square", "diagonal", "waypoints")
# What each kind of driving excites: "stopped" screws standing still while others push,
# "combined" translation and turning at once, "yaw_steps" abrupt changes of the turn rate.
PROVIDES = {"paper": {"slow", "yaw_steps"}, "manual": {"slow", "stopped", "combined", "yaw_steps"},
            "square": {"slow", "combined"}, "diagonal": {"slow", "stopped"},
            "waypoints": {"slow", "stopped", "combined"}}


def paper_plan(rng, n_rows, dt):
    """The paper's validation runs (Section III-C): one DOF at a time, both directions, at 5, 10,
    15, 20 rpm, 4-8 s each, pauses of 1.5-3 s."""
    sp = np.zeros((n_rows, 4))
    t = float(rng.uniform(0.5, 2.0))
    while t < n_rows * dt:
        dof = str(rng.choice(["x", "y", "psi"]))
        w = float(rng.choice([5.0, 10.0, 15.0, 20.0]))
        first = float(rng.choice([-1.0, 1.0]))
        for sg in (first, -first):
            d = float(rng.uniform(4, 8))
            a, b = int(round(t / dt)), int(round((t + d) / dt))
            sp[a:b] = sg * w * np.array(PATTERN[dof])
            t += d + float(rng.uniform(1.5, 3.0))
    return sp


def _manual_target(rng, combined):
    """One joystick-style command as screw speeds (more turning while translating when the
    effect needs it)."""
    kinds = ["dof", "dof", "combo", "diagonal", "side", "creep", "pause"]
    kind = rng.choice(kinds + ["combo", "side", "combo", "side"] if combined else kinds)
    p = {k: np.array(v) for k, v in PATTERN.items()}
    if kind == "pause":
        return np.zeros(4)
    if kind == "dof" or kind == "creep":
        d = p[str(rng.choice(["x", "y", "psi"]))] * float(rng.choice([-1.0, 1.0]))
    elif kind == "combo":
        a = rng.normal(size=3)
        d = a[0] * p["x"] + a[1] * p["y"] + a[2] * p["psi"]
    elif kind == "diagonal":   # along the helix: two screws stand still
        d = float(rng.choice([-1.0, 1.0])) * (p["x"] + float(rng.choice([-1.0, 1.0])) * p["y"])
    else:                      # one side's screws only: forward and turning at once
        d = np.zeros(4)
        side = (0, 1) if rng.uniform() < 0.5 else (2, 3)
        d[list(side)] = p["x"][list(side)] * float(rng.choice([-1.0, 1.0]))
    d = d / np.max(np.abs(d))
    mag = float(rng.uniform(1.5, 5.0)) if kind == "creep" else float(rng.uniform(3, OMEGA_MAX_RPM))
    return d * mag


def manual_plan(rng, n_rows, dt, combined=False):
    """Manual-style driving: commands held 2-7 s, joined by 0.2-1 s ramps; mixed DOFs, the
    helix diagonal, one side alone, slow creeping, pauses."""
    sp = np.zeros((n_rows, 4))
    t, prev = float(rng.uniform(0.5, 2.0)), np.zeros(4)
    while t < n_rows * dt:
        tgt = _manual_target(rng, combined)
        ramp, hold = float(rng.uniform(0.2, 1.0)), float(rng.uniform(2, 7))
        a, b, c = (int(round(x / dt)) for x in (t, t + ramp, t + ramp + hold))
        if a >= n_rows:
            break
        for k in range(a, min(b, n_rows)):
            sp[k] = prev + (tgt - prev) * (k - a + 1) / max(1, b - a)
        sp[b:c] = tgt
        prev, t = tgt, t + ramp + hold
    return sp


def _legs(kind, rng, p0):
    """Waypoints (x, y, psi) and whether a leg turns before it moves."""
    x0, y0, psi0 = p0
    if kind == "square":
        side, turning = float(rng.uniform(0.8, 1.6)), bool(rng.uniform() < 0.5)
        sg = float(rng.choice([-1.0, 1.0]))
        pts, psi = [], psi0
        x, y, hd = x0, y0, psi0 + float(rng.uniform(-math.pi, math.pi))
        for k in range(4):
            x, y = x + side * math.cos(hd), y + side * math.sin(hd)
            if turning:
                psi = hd
            pts.append((x, y, psi))
            hd += sg * math.pi / 2
        return pts, turning
    if kind == "diagonal":
        ang = float(rng.choice([math.pi / 6, math.pi / 3, math.pi / 4, -math.pi / 6, -math.pi / 4]))
        ln = float(rng.uniform(0.8, 1.5))
        a = psi0 + ang
        return [(x0 + ln * math.cos(a), y0 + ln * math.sin(a), psi0), (x0, y0, psi0)], False
    pts = []
    for _ in range(6):
        pts.append((x0 + float(rng.uniform(-1.2, 1.2)), y0 + float(rng.uniform(-1.2, 1.2)),
                    psi0 + float(rng.uniform(-1.5, 1.5))))
    return pts, False


def reference(kind, rng, n_rows, dt, p0, terrain):
    """The reference pose per row (x, y, psi unwrapped) and its rate, looping the legs; each
    leg on a smooth (1 - cos) profile, pauses of 1-2 s at the waypoints."""
    pts, turning = _legs(kind, rng, p0)
    v_ref = float(rng.uniform(0.03, 0.06)) * (1.0 if terrain == "sand" else 0.8)
    r_ref = float(rng.uniform(0.06, 0.15))
    ref = np.zeros((n_rows, 3))
    ref[:] = p0
    t, cur, i = float(rng.uniform(1.0, 2.0)), np.array(p0, dtype=float), 0
    k0 = int(t / dt)
    ref[:k0] = cur
    while k0 < n_rows:
        tgt = np.array(pts[i % len(pts)], dtype=float)
        i += 1
        steps = []
        if turning and abs(tgt[2] - cur[2]) > 1e-6:
            mid = np.array([cur[0], cur[1], tgt[2]])
            steps = [(cur, mid, abs(tgt[2] - cur[2]) / r_ref), (mid, tgt, np.hypot(*(tgt - cur)[:2]) / v_ref)]
        else:
            d = max(np.hypot(*(tgt - cur)[:2]) / v_ref, abs(tgt[2] - cur[2]) / r_ref)
            steps = [(cur, tgt, d)]
        for a, b, d in steps:
            n = max(1, int(1.5 * d / dt))      # the (1 - cos) profile peaks at pi/2 the mean
            for j in range(n):
                if k0 + j >= n_rows:
                    break
                s = 0.5 * (1 - math.cos(math.pi * (j + 1) / n))
                ref[k0 + j] = a + (b - a) * s
            k0 += n
            if k0 < n_rows:
                ref[k0:] = b
            k0 += int(rng.uniform(1.0, 2.0) / dt)
        cur = tgt
    rate = np.gradient(ref, dt, axis=0)
    return ref, rate


class Controller:
    """A pose-tracking controller of its own: the pose error rotated into the body frame
    (J(psi)^T, as docs/model-notes.md "Tracking" decides), a PD with feed-forward of the
    reference's rate, through the nominal model's inverse D^-1 S B, eq. (22) with the
    pseudo-inverse; optionally a share of the null space [-1, 1, -1, 1] keeps the screws
    turning; screws limited to 23 rpm (all scaled down together)."""

    def __init__(self, kind, rng, n_rows, dt, p0, terrain, null_space):
        self.ref, self.rate = reference(kind, rng, n_rows, dt, p0, terrain)
        p = TERRAIN[terrain]
        sb = np.array([[p["sigma_long"] * b for b in B_X], [p["sigma_lat"] * b for b in B_Y],
                       [p["sigma_lat"] * B_PSI] * 4])
        self.alloc = np.linalg.pinv(sb) @ np.diag([p["d_x"], p["d_y"], p["d_psi"]])
        self.kp = np.array([float(rng.uniform(0.6, 1.2)), float(rng.uniform(0.6, 1.2)),
                            float(rng.uniform(0.8, 1.5))])
        self.kd = float(rng.uniform(0.05, 0.2))
        self.null = float(rng.uniform(2.0, 4.0)) * float(rng.choice([-1, 1])) if null_space else 0.0
        self.alloc_rows = [tuple(float(a) for a in row) for row in self.alloc]
        self.ref_np = self.ref
        self.ref, self.rate = self.ref.tolist(), self.rate.tolist()
        self.kp = self.kp.tolist()
        self.dt = dt
        self.reset()
        self.gains = dict(kp_per_s=self.kp, kd_s=self.kd, null_rpm=self.null)

    def command(self, k, est):
        """Setpoints for row k from the latest camera pose est (x, y, psi) or None."""
        if est is None:
            return (0.0, 0.0, 0.0, 0.0)
        xd, yd, pd = self.ref[k]
        c, s = math.cos(est[2]), math.sin(est[2])
        ex, ey = xd - est[0], yd - est[1]
        e = (c * ex + s * ey, -s * ex + c * ey, math.remainder(pd - est[2], 2 * math.pi))
        if self.e_prev is not None:
            a = self.dt / 0.3
            self.de = [d + a * ((x - y) / self.dt - d) for d, x, y in zip(self.de, e, self.e_prev)]
        self.e_prev = e
        vx, vy, vp = self.rate[k]
        ff = (c * vx + s * vy, -s * vx + c * vy, vp)
        z = [ff[j] + self.kp[j] * e[j] + self.kd * self.de[j] for j in range(3)]
        w = [a[0] * z[0] + a[1] * z[1] + a[2] * z[2] for a in self.alloc_rows]
        if self.null and max(abs(z[0]), abs(z[1])) > 0.005:
            w = [wi + self.null * n for wi, n in zip(w, (-1.0, 1.0, -1.0, 1.0))]
        m = max(abs(wi) for wi in w)
        return [wi * OMEGA_MAX_RPM / m for wi in w] if m > OMEGA_MAX_RPM else w

    def reset(self):
        self.e_prev, self.de = None, [0.0, 0.0, 0.0]


def check_kinematics():
    """PATTERN agrees with the K_i of docs/model-notes.md (signs of its columns)."""
    ki = k_inverse()
    for j, dof in enumerate(("x", "y", "psi")):
        col = [row[j] for row in ki]
        assert all(math.copysign(1, a) == b for a, b in zip(col, PATTERN[dof])), dof
