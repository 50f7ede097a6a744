"""The independent generator's effects of the library's families, each in forms of its own
(docs/workbench-suite.md "The independent generator" has the table). Every form is a class
with one size (`size_name`, `size_unit`, `size_max(env)`, `set_size(s)`: s a float or a lane
array), parameters drawn at construction from the seed (`params`), and the hooks of
indep_model.Model it needs: factors (sigma and D multipliers), speed (each screw's effective
speed), screw (each screw's force), drive (the total drive), force (resistances: explicit forces
and implicit damping), mass, and the sensor hooks camera_latency and imu.
"""
import math

import numpy as np

from indep_model import L_X_M, L_Y_M, POS_M, TERRAIN, drive_force_n, yaw_lump

AXES = ("x", "y", "psi")
# Below these speeds dry friction is a stiff damper (taken implicitly): creep under a drive
# below the level is at most this speed (0.2 mm/s; in yaw at the contacts' radius).
EPS = (2e-4, 2e-4, 2e-4 / math.hypot(L_X_M, L_Y_M))
W_STALL_MAX_RPM = 8.0          # dry friction up to the drive of all four screws at 8 rpm
GRID_DT_S = 0.01               # time schedules (episodes, random walks) on a 10 ms grid


def on_grid(X, grid, t):
    """A schedule sampled on GRID_DT_S at time t (float or lanes)."""
    if X.n is None:
        k = int(t / GRID_DT_S)
        return grid[min(max(k, 0), len(grid) - 1)]
    k = np.clip((t / GRID_DT_S).astype(int), 0, len(grid) - 1)
    return grid[k]


class Effect:
    family = None          # the library's family id (None: outside the library)
    mechanism = None       # the outside mechanism's id
    form = ""
    needs = frozenset()    # what the driving must contain: "stopped", "combined", "slow"
    sensor = False         # acts on a sensor, not on the motion
    variables = ()
    form_string = ""
    # an internal state (a lag, a sunk screw) that the visibility's replays restart at rest at
    # each segment's start, as they restart the pose from the truth
    stateful = False
    # how far the log's own error may stand from the visibility those replays record (test_gen_indep)
    replay_tolerance = 0.15

    def __init__(self, rng, env):
        self.env = env
        self.terrain = env.terrain
        self.tp = TERRAIN[env.terrain]
        self.params = {}
        self.draw(rng)

    def draw(self, rng):
        pass

    def describe(self):
        return self.__doc__.strip().split("\n")[0]


def _dof_weights(rng):
    """Which DOFs a per-DOF form acts on: at least one at full level, the others 0..1."""
    w = [float(rng.uniform(0, 1)) if rng.uniform() < 0.6 else 0.0 for _ in range(3)]
    w[int(rng.integers(3))] = 1.0
    return w


# ---- coulomb_friction ----
class CoulombSignDof(Effect):
    """Dry friction per DOF, hard sign with stiction at the sliding level."""
    family, form = "coulomb_friction", "hard_sign_dof"
    size_name, size_unit = "stall_speed", "rpm"
    hard = True          # 1 ms substeps in the log's run

    def draw(self, rng):
        self.params["dof_weights"] = self.wt = _dof_weights(rng)

    def size_max(self):
        return W_STALL_MAX_RPM

    def set_size(self, s):
        self.level = [self.wt[j] * drive_force_n(self.terrain, AXES[j], s) for j in range(3)]

    def force(self, X, st, acc, h, m):
        for j, z in enumerate((st.u, st.v, st.r)):
            if self.wt[j] > 0:
                acc.damp_dof(j, self.level[j] / X.maximum(X.abs(z), EPS[j]))


class CoulombTanhDof(CoulombSignDof):
    """Dry friction per DOF, level x tanh(speed / v_s): no stiction, a smooth reversal."""
    form = "tanh_dof"

    def draw(self, rng):
        super().draw(rng)
        self.params["v_s_mps"] = self.vs = float(rng.uniform(0.002, 0.01))

    def force(self, X, st, acc, h, m):
        for j, z in enumerate((st.u, st.v, st.r)):
            if self.wt[j] > 0:
                vs = self.vs if j < 2 else self.vs / math.hypot(L_X_M, L_Y_M)
                a = X.abs(z) + 1e-12
                acc.damp_dof(j, self.level[j] * X.tanh(a / vs) / a)


class CoulombContact(Effect):
    """Dry friction at the four screw contacts, isotropic: each contact's force opposes its
    own sliding velocity (a turn meets the friction at the real lever arms)."""
    family, form = "coulomb_friction", "contact_isotropic"
    size_name, size_unit = "stall_speed_lateral", "rpm"
    hard = True          # 1 ms substeps in the log's run

    def size_max(self):
        return W_STALL_MAX_RPM

    def set_size(self, s):
        self.level = drive_force_n(self.terrain, "y", s) / 4.0

    def level_at(self, X, speed):
        return self.level

    def force(self, X, st, acc, h, m):
        for i, (xi, yi) in enumerate(POS_M):
            sp = X.hypot(st.u - st.r * yi, st.v + st.r * xi)
            acc.damp_contact(i, self.level_at(X, sp) / X.maximum(sp, EPS[0]), m.lam)


# ---- stick_slip_friction ----
class StribeckGaussDof(CoulombSignDof):
    """Dry friction per DOF with a Gaussian Stribeck curve: breakaway level Fs falling to the
    sliding level Fs / ratio as exp(-(v / v_s)^2)."""
    family, form = "stick_slip_friction", "gauss_stribeck_dof"
    size_name = "stall_speed_breakaway"

    def draw(self, rng):
        super().draw(rng)
        self.params["breakaway_ratio"] = self.ratio = float(rng.uniform(1.5, 3.0))
        self.params["v_s_mps"] = self.vs = float(rng.uniform(0.002, 0.015))

    def force(self, X, st, acc, h, m):
        for j, z in enumerate((st.u, st.v, st.r)):
            if self.wt[j] > 0:
                vs = self.vs if j < 2 else self.vs / math.hypot(L_X_M, L_Y_M)
                a = X.abs(z)
                lev = self.level[j] / self.ratio * (1 + (self.ratio - 1) * X.exp(-(a / vs) ** 2))
                acc.damp_dof(j, lev / X.maximum(a, EPS[j]))


class StaticKineticDof(CoulombSignDof):
    """Two-level dry friction per DOF: held at rest up to the static level Fs, sliding at the
    kinetic level Fs / ratio until the DOF comes to rest again."""
    family, form = "stick_slip_friction", "static_kinetic_dof"
    size_name = "stall_speed_static"

    def draw(self, rng):
        super().draw(rng)
        self.params["static_over_kinetic"] = self.ratio = float(rng.uniform(1.3, 2.5))

    def force(self, X, st, acc, h, m):
        for j, z in enumerate((st.u, st.v, st.r)):
            if self.wt[j] > 0:
                a = X.abs(z)
                lev = X.where(a > 3 * EPS[j], self.level[j] / self.ratio, self.level[j])
                acc.damp_dof(j, lev / X.maximum(a, EPS[j]))


class StribeckContact(CoulombContact):
    """Dry friction at the four contacts with a Lorentzian Stribeck curve: breakaway Fs,
    sliding Fs / ratio, Fc (1 + (ratio - 1) / (1 + (v / v_s)^2)) of the contact's speed."""
    family, form = "stick_slip_friction", "contact_lorentz"
    size_name = "stall_speed_lateral_breakaway"

    def draw(self, rng):
        self.params["breakaway_ratio"] = self.ratio = float(rng.uniform(1.5, 3.0))
        self.params["v_s_mps"] = self.vs = float(rng.uniform(0.002, 0.015))

    def level_at(self, X, speed):
        return self.level / self.ratio * (1 + (self.ratio - 1) / (1 + (speed / self.vs) ** 2))


# ---- quadratic_drag ----
V_REF_MPS, R_REF_RADPS = 0.1, 0.15


class QuadIsotropic(Effect):
    """Velocity-squared drag on the speed over ground: -c |V| V on the planar velocity V
    (couples u and v), and -c_psi |r| r in yaw."""
    family, form = "quadratic_drag", "isotropic_speed_squared"
    size_name, size_unit = "ratio_to_linear_at_0.1mps", "-"

    def draw(self, rng):
        self.params["yaw_share"] = self.ay = float(rng.uniform(0, 1))

    def size_max(self):
        return 1.5

    def set_size(self, s):
        self.c = s * self.tp["d_x"] / V_REF_MPS
        self.cp = self.ay * s * self.tp["d_psi"] / R_REF_RADPS

    def force(self, X, st, acc, h, m):
        sp = X.hypot(st.u, st.v)
        acc.damp_dof(0, self.c * sp)
        acc.damp_dof(1, self.c * sp)
        acc.damp_dof(2, self.cp * X.abs(st.r))


class QuadPowerDof(Effect):
    """Bulldozing resistance per DOF as a power law, -c sign(v) |v|^n with n in 1.5..2.5."""
    family, form = "quadratic_drag", "power_law_dof"
    size_name, size_unit = "ratio_to_linear_at_ref", "-"

    def draw(self, rng):
        self.params["exponent"] = self.n = float(rng.uniform(1.5, 2.5))
        self.params["dof_weights"] = self.wt = _dof_weights(rng)

    def size_max(self):
        return 1.5

    def set_size(self, s):
        d = (self.tp["d_x"], self.tp["d_y"], self.tp["d_psi"])
        ref = (V_REF_MPS, V_REF_MPS, R_REF_RADPS)
        self.c = [self.wt[j] * s * d[j] / ref[j] ** (self.n - 1) for j in range(3)]

    def force(self, X, st, acc, h, m):
        for j, z in enumerate((st.u, st.v, st.r)):
            if self.wt[j] > 0:
                acc.damp_dof(j, self.c[j] * X.abs(z) ** (self.n - 1))


class QuadContact(Effect):
    """Velocity-squared drag at the four contacts, -c |v_i| v_i on each contact's velocity."""
    family, form = "quadratic_drag", "contact_speed_squared"
    size_name, size_unit = "ratio_to_linear_at_0.1mps", "-"

    def size_max(self):
        return 1.5

    def set_size(self, s):
        self.c = s * self.tp["d_x"] / V_REF_MPS / 4.0

    def force(self, X, st, acc, h, m):
        for i, (xi, yi) in enumerate(POS_M):
            acc.damp_contact(i, self.c * X.hypot(st.u - st.r * yi, st.v + st.r * xi), m.lam)


# ---- screw_traction_loss ----
class LossConstant(Effect):
    """One screw transmits a constant fraction less of its force."""
    family, form = "screw_traction_loss", "constant"
    size_name, size_unit = "loss", "-"

    def draw(self, rng):
        self.params["screw"] = self.k = int(rng.integers(4))

    def size_max(self):
        return 0.9

    def set_size(self, s):
        self.loss = s

    def factor(self, X, st):
        return 1 - self.loss

    def screw(self, X, st, fx, fy, fm, h):
        f = self.factor(X, st)
        k = self.k
        fx[k], fy[k], fm[k] = fx[k] * f, fy[k] * f, fm[k] * f


class LossSpeed(LossConstant):
    """One screw slips more the faster it turns: loss x |w| / (|w| + w0)."""
    form = "speed_dependent"

    def draw(self, rng):
        super().draw(rng)
        self.params["w0_rpm"] = self.w0 = float(rng.uniform(3, 10))

    def factor(self, X, st):
        a = X.abs(st.w[self.k])
        return 1 - self.loss * a / (a + self.w0)


class LossIntermittent(LossConstant):
    """One screw loses traction in episodes of 2-8 s (a stone, an air pocket), edges 0.3 s."""
    form = "intermittent"

    def draw(self, rng):
        super().draw(rng)
        n = int(self.env.seconds / GRID_DT_S) + 2
        grid = np.zeros(n)
        t, eps = float(rng.uniform(3, 20)), []
        while t < self.env.seconds:
            d = float(rng.uniform(2, 8))
            eps.append((round(t, 2), round(t + d, 2)))
            t += d + float(rng.exponential(15)) + 1
        tt = np.arange(n) * GRID_DT_S
        for a, b in eps:
            grid = np.maximum(grid, np.clip(np.minimum(tt - a, b - tt) / 0.3 + 0.5, 0, 1))
        self.grid = grid
        self.params["episodes_s"] = eps

    def factor(self, X, st):
        return 1 - self.loss * on_grid(X, self.grid, st.t)


# ---- traction_saturation ----
class SatScrewExp(Effect):
    """Each screw's force vector saturates as the soil's shear strength: |f| -> F_max (1 -
    exp(-|f| / F_max)) (Janosi-like), F_max = one screw's longitudinal force at 23 / s rpm."""
    family, form = "traction_saturation", "screw_exponential"
    size_name, size_unit = "force_at_23rpm_over_limit", "-"

    def size_max(self):
        return 5.0

    def set_size(self, s):
        self.fmax = self.tp["sigma_long"] * 23.0 / s

    def screw(self, X, st, fx, fy, fm, h):
        for i in range(4):
            a = X.hypot(fx[i], fy[i]) + 1e-12
            k = self.fmax * (1 - X.exp(-a / self.fmax)) / a
            fx[i], fy[i], fm[i] = fx[i] * k, fy[i] * k, fm[i] * k


class SatAxisTanh(Effect):
    """The total drive saturates per axis, F_max tanh(tau / F_max), each axis at its own
    limit (the whole drive at 23 / s rpm, times 0.5-2 per axis)."""
    family, form = "traction_saturation", "axis_tanh"
    size_name, size_unit = "force_at_23rpm_over_limit", "-"

    def draw(self, rng):
        self.params["axis_limit_factors"] = self.kf = [1.0] + [float(rng.uniform(0.5, 2)) for _ in range(2)]

    def size_max(self):
        return 5.0

    def set_size(self, s):
        self.lim = [self.kf[j] * drive_force_n(self.terrain, AXES[j], 23.0 / s) for j in range(3)]

    def drive(self, X, st, tx, ty, tp, h):
        l0, l1, l2 = self.lim
        return l0 * X.tanh(tx / l0), l1 * X.tanh(ty / l1), l2 * X.tanh(tp / l2)


class SatTotalClip(Effect):
    """The footprint's total shear force is clipped: the norm of (tau_x, tau_y, the yaw
    moment over the contacts' radius) at most F_max; all three scaled together."""
    family, form = "traction_saturation", "total_clip"
    size_name, size_unit = "force_at_23rpm_over_limit", "-"
    hard = True

    def size_max(self):
        return 4.0

    def set_size(self, s):
        self.fmax = drive_force_n(self.terrain, "x", 23.0 / s)

    def drive(self, X, st, tx, ty, tp, h):
        lam = yaw_lump(self.terrain)
        n = X.sqrt(tx * tx + ty * ty + (lam * tp / math.hypot(L_X_M, L_Y_M)) ** 2) + 1e-12
        k = X.minimum(1.0, self.fmax / n)
        return tx * k, ty * k, tp * k


# ---- force_lag ----
class _Lag(Effect):
    family = "force_lag"
    stateful = True
    size_name, size_unit = "tau", "s"

    def size_max(self):
        return 1.0

    def set_size(self, s):
        self.tau = s

    def reset(self, X, st, m):
        self.state = None


class LagSpeed(_Lag):
    """The soil's shear builds up behind the screw: each screw's thrust follows its speed
    through a first-order lag."""
    form = "speed_lag"

    def speed(self, X, st, g, h):
        if self.state is None:
            self.state = list(g)
        a = 1 - X.exp(-h / self.tau)
        self.state = [s + (x - s) * a for s, x in zip(self.state, g)]
        return list(self.state)


class LagTwoStage(_Lag):
    """The drive builds up in two equal first-order stages (total time constant tau)."""
    form = "two_stage_force"

    def reset(self, X, st, m):
        self.s1 = self.s2 = None

    def drive(self, X, st, tx, ty, tp, h):
        x = [tx, ty, tp]
        if self.s1 is None:
            self.s1, self.s2 = list(x), list(x)
        a = 1 - X.exp(-2 * h / self.tau)
        self.s1 = [s + (v - s) * a for s, v in zip(self.s1, x)]
        self.s2 = [s + (v - s) * a for s, v in zip(self.s2, self.s1)]
        return tuple(self.s2)


class LagDeadTime(Effect):
    """The drive arrives after a dead time (a transport delay: the soil yields late)."""
    family, form = "force_lag", "dead_time"
    stateful = True
    size_name, size_unit = "delay", "s"

    def size_max(self):
        return 0.3

    def set_size(self, s):
        self.delay = s

    def reset(self, X, st, m):
        self.buf = None

    def drive(self, X, st, tx, ty, tp, h):
        if self.buf is None:
            nb = int(math.ceil(0.3 / h)) + 4
            self.nb, self.pos = nb, 0
            shape = (nb,) if X.n is None else (nb, X.n)
            self.buf = [np.full(shape, 0.0) + v for v in (tx, ty, tp)]
        self.pos = (self.pos + 1) % self.nb
        k = self.delay / h
        j = np.floor(k).astype(int) if X.n is not None else int(k)
        fr = k - j
        out = []
        for b, v in zip(self.buf, (tx, ty, tp)):
            b[self.pos] = v
            i0, i1 = (self.pos - j) % self.nb, (self.pos - j - 1) % self.nb
            if X.n is None:
                out.append(b[i0] * (1 - fr) + b[i1] * fr)
            else:
                ln = np.arange(X.n)
                out.append(b[i0, ln] * (1 - fr) + b[i1, ln] * fr)
        return tuple(out)


class LagAsymmetric(_Lag):
    """The drive builds up with tau and falls back faster (tau x 0.2-0.5): soil compresses
    slowly and lets go at once."""
    form = "asymmetric_force_lag"

    def draw(self, rng):
        self.params["release_over_build"] = self.rel = float(rng.uniform(0.2, 0.5))

    def drive(self, X, st, tx, ty, tp, h):
        x = [tx, ty, tp]
        if self.state is None:
            self.state = list(x)
        out = []
        for s, v in zip(self.state, x):
            tau = X.where(X.abs(v) > X.abs(s), self.tau, self.tau * self.rel)
            out.append(s + (v - s) * (1 - X.exp(-h / tau)))
        self.state = out
        return tuple(out)


# ---- screw_dead_band ----
class DeadRampJoin(Effect):
    """No thrust below w_d; above it the thrust ramps at twice the slope and joins the
    nominal line at 2 w_d."""
    family, form = "screw_dead_band", "ramp_join"
    size_name, size_unit = "w_dead", "rpm"
    needs = frozenset({"slow"})
    hard = True          # 1 ms substeps in the log's run

    def size_max(self):
        return 6.0

    def set_size(self, s):
        self.wd = s

    def shape(self, X, w):
        a = X.abs(w)
        m = X.minimum(a, X.maximum(0.0, 2 * (a - self.wd)))
        return X.sign(w) * m

    def speed(self, X, st, g, h):
        return [self.shape(X, w) for w in g]


class DeadSmooth(DeadRampJoin):
    """Smooth gate: thrust of w (1 - exp(-(w / w_d)^2))."""
    form = "smooth_gate"

    def shape(self, X, w):
        return w * (1 - X.exp(-(w / self.wd) ** 2))


class DeadAsymmetric(DeadRampJoin):
    """Shifted dead zone, asymmetric: w_d turning forward, rho w_d backward (rho 0.2-0.7)."""
    form = "asymmetric_shift"

    def draw(self, rng):
        self.params["backward_over_forward"] = self.rho = float(rng.uniform(0.2, 0.7))

    def shape(self, X, w):
        d = X.where(w > 0, self.wd, self.wd * self.rho)
        return X.sign(w) * X.maximum(0.0, X.abs(w) - d)
