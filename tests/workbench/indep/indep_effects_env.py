"""The independent generator's effects of the library's families (continued): the ground
(slope, offset resistance, terrain change, blocking), the body (Coriolis, yaw time constant)
and the paper's parameters (the sensors: indep_sensors.py). Conventions as in indep_effects.py.
"""
import math

import numpy as np

from indep_effects import Effect
from indep_model import G_MPS2, I_Z_KGM2, L_X_M, L_Y_M, MASS_KG, POS_M, TERRAIN, drive_force_n


def _path_point(env, rng, lo=0.3, hi=0.7):
    """A point the robot passes (from the run without effects), between lo and hi of the log."""
    t, x, y = env.path
    k = int(rng.uniform(lo, hi) * (len(t) - 1))
    return float(x[k]), float(y[k])


def _max_incline(terrain):
    """Gravity down the slope equals the lateral drive of the four screws at 15 rpm."""
    return math.asin(drive_force_n(terrain, "y", 15.0) / (MASS_KG * G_MPS2))


# ---- terrain_slope ----
class SlopePlane(Effect):
    """An inclined plane: gravity m g sin(beta) downhill (world direction theta), and the
    normal load, so traction and drag, times cos(beta)."""
    family, form = "terrain_slope", "plane"
    size_name, size_unit = "incline", "rad"

    def draw(self, rng):
        self.params["downhill_direction_rad"] = self.th = float(rng.uniform(-math.pi, math.pi))

    def size_max(self):
        return _max_incline(self.terrain)

    def set_size(self, s):
        self.beta = s
        self.f = MASS_KG * G_MPS2 * np.sin(s) if np.ndim(s) else MASS_KG * G_MPS2 * math.sin(s)
        self.cb = np.cos(s) if np.ndim(s) else math.cos(s)

    def factors(self, X, st):
        c = self.cb
        return c, c, c, c, c

    def force(self, X, st, acc, h, m):
        a = self.th - st.psi
        acc.fx = acc.fx + self.f * X.cos(a)
        acc.fy = acc.fy + self.f * X.sin(a)


class SlopeHill(Effect):
    """A broad hill of the field, z = H exp(-d^2 / (2 R^2)): the slope changes gradually as the
    robot drives over it (the size is the steepest incline, at d = R)."""
    family, form = "terrain_slope", "gradual_hill"
    size_name, size_unit = "steepest_incline", "rad"

    def draw(self, rng):
        cx, cy = _path_point(self.env, rng)
        self.R = float(rng.uniform(1.0, 3.0))
        a = float(rng.uniform(-math.pi, math.pi))
        off = float(rng.uniform(0.3, 1.0)) * self.R
        self.cx, self.cy = cx + off * math.cos(a), cy + off * math.sin(a)
        self.params.update(centre_m=[round(self.cx, 3), round(self.cy, 3)], radius_m=self.R)

    def size_max(self):
        return _max_incline(self.terrain)

    def set_size(self, s):
        self.H = np.tan(s) * self.R * math.exp(0.5)

    def force(self, X, st, acc, h, m):
        dx, dy = st.x - self.cx, st.y - self.cy
        z = self.H * X.exp(-(dx * dx + dy * dy) / (2 * self.R ** 2))
        gx, gy = -z * dx / self.R ** 2, -z * dy / self.R ** 2     # grad z
        k = -MASS_KG * G_MPS2 / X.sqrt(1 + gx * gx + gy * gy)     # gravity along -grad z
        fwx, fwy = k * gx, k * gy
        c, s = X.cos(st.psi), X.sin(st.psi)
        acc.fx = acc.fx + c * fwx + s * fwy
        acc.fy = acc.fy - s * fwx + c * fwy


class SlopeLoadTransfer(SlopePlane):
    """An inclined plane with load transfer: the downhill screws carry more of the weight
    (centre of mass h_cg above the ground) and pull harder than the uphill ones."""
    form = "plane_load_transfer"

    def draw(self, rng):
        super().draw(rng)
        self.params["h_cg_m"] = self.hcg = float(rng.uniform(0.1, 0.25))

    def screw(self, X, st, fx, fy, fm, h):
        a = self.th - st.psi
        ex, ey = X.cos(a), X.sin(a)                      # downhill, body frame
        tb = np.tan(self.beta) if np.ndim(self.beta) else math.tan(self.beta)
        den = 4 * (L_X_M ** 2 * ex * ex + L_Y_M ** 2 * ey * ey) + 1e-9
        for i, (xi, yi) in enumerate(POS_M):
            k = 1 + 4 * tb * self.hcg * (xi * ex + yi * ey) / den
            fx[i], fy[i], fm[i] = fx[i] * k, fy[i] * k, fm[i] * k


# ---- resistance_offset ----
class OffsetFront(Effect):
    """The front (or the rear) ploughs more: the translational resistance acts at (o_x, 0);
    its moment at the real lever arm in the model's lumped yaw units."""
    family, form = "resistance_offset", "front_plough"
    size_name, size_unit = "offset", "m"

    def draw(self, rng):
        self.params["sign"] = self.sg = float(rng.choice([-1.0, 1.0]))

    def size_max(self):
        return 0.3

    def set_size(self, s):
        self.o = self.sg * s

    def force(self, X, st, acc, h, m):
        # drag at (o, 0): F_y = -D_y (v + r o); the change is -D_y r o, moment o F_y / lam
        o, dy = self.o, m.dy
        c = acc.c
        c[5] = c[5] + dy * o
        c[7] = c[7] + o * dy / m.lam
        c[8] = c[8] + o * o * dy / m.lam
        acc.full = True


class OffsetLateral(OffsetFront):
    """One side sinks deeper: the longitudinal resistance acts at (0, o_y)."""
    form = "lateral_offset"

    def size_max(self):
        return 0.35

    def force(self, X, st, acc, h, m):
        # drag at (0, o): F_x = -D_x (u - r o); the change is +D_x r o, moment -o F_x / lam
        o, dx = self.o, m.dx
        c = acc.c
        c[2] = c[2] - dx * o
        c[6] = c[6] - o * dx / m.lam
        c[8] = c[8] + o * o * dx / m.lam
        acc.full = True


class OffsetSpeed(OffsetFront):
    """The leading edge ploughs: the resistance acts at o = o_s (u, v) / 0.1 m/s (at most
    0.3 m), ahead in the direction of travel: a speed-dependent offset."""
    form = "speed_dependent"
    size_name = "offset_at_0.1mps"
    needs = frozenset({"combined"})

    def draw(self, rng):
        pass

    def set_size(self, s):
        self.o = s

    def force(self, X, st, acc, h, m):
        sp = X.hypot(st.u, st.v) + 1e-9
        k = self.o / 0.1 * X.minimum(1.0, 0.3 / (self.o / 0.1 * sp + 1e-12))
        ox, oy = k * st.u, k * st.v
        fx = -m.dx * (st.u - st.r * oy)
        fy = -m.dy * (st.v + st.r * ox)
        acc.fx = acc.fx + fx + m.dx * st.u
        acc.fy = acc.fy + fy + m.dy * st.v
        acc.fp = acc.fp + (ox * fy - oy * fx) / m.lam


# ---- terrain_change ----
class _Terrain(Effect):
    family = "terrain_change"
    size_name, size_unit = "log_factor", "-"

    def draw(self, rng):
        a = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.5, 1.0))
        b = float(rng.uniform(-1.0, 1.0))
        if abs(a - b) < 0.5:
            b = a - math.copysign(0.5, a)
        self.a, self.b = a, b
        self.params.update(sigma_exponent=a, drag_exponent=b)
        self.params["t_change_s"] = self.tc = round(float(rng.uniform(0.3, 0.7)) * self.env.seconds, 2)

    def size_max(self):
        return math.log(3.0)

    def set_size(self, s):
        self.s = s

    def weight(self, X, st):
        return X.where(st.t >= self.tc, 1.0, 0.0)

    def factors(self, X, st):
        w = self.weight(X, st)
        fs, fd = X.exp(w * self.a * self.s), X.exp(w * self.b * self.s)
        return fs, fs, fd, fd, fd


class TerrainAbrupt(_Terrain):
    """The ground changes at once at t_change: sigma times exp(a s), D times exp(b s)."""
    form = "abrupt"


class TerrainTransition(_Terrain):
    """The ground changes over a transition of 5-40 s centred on t_change."""
    form = "transition_in_time"

    def draw(self, rng):
        super().draw(rng)
        self.params["transition_s"] = self.dt = float(rng.uniform(5, 40))

    def weight(self, X, st):
        return X.minimum(1.0, X.maximum(0.0, (st.t - self.tc) / self.dt + 0.5))


class TerrainPatch(Effect):
    """A patch of other ground in the field (a disk of radius 0.5-1.5 m with a soft edge of
    0.1-0.3 m): inside, each of sigma_long, sigma_lat, D_x, D_y, D_psi moves toward the other
    terrain of Table 3 (its ratio to the log's terrain to the power s)."""
    family, form = "terrain_change", "patch_in_space"
    size_name, size_unit = "exponent_toward_other_terrain", "-"

    def draw(self, rng):
        other = "frozen_grass" if self.terrain == "sand" else "sand"
        p, q = TERRAIN[self.terrain], TERRAIN[other]
        self.lr = [math.log(q[k] / p[k]) for k in ("sigma_long", "sigma_lat", "d_x", "d_y", "d_psi")]
        self.cx, self.cy = _path_point(self.env, rng, 0.2, 0.6)
        self.R = float(rng.uniform(0.5, 1.5))
        self.edge = float(rng.uniform(0.1, 0.3))
        self.params.update(other_terrain=other, centre_m=[round(self.cx, 3), round(self.cy, 3)],
                           radius_m=self.R, edge_m=self.edge)

    def size_max(self):
        return 1.5

    def set_size(self, s):
        self.s = s

    def factors(self, X, st):
        d = X.hypot(st.x - self.cx, st.y - self.cy)
        w = X.minimum(1.0, X.maximum(0.0, (self.R - d) / self.edge + 0.5))
        return tuple(X.exp(w * self.s * l) for l in self.lr)


# ---- rigid_body_coupling ----
class CoriolisScaled(Effect):
    """The rigid body's Coriolis terms m k (r v, -r u) that eq. (6) leaves out (k = 1 the
    body alone; more with soil carried along)."""
    family, form = "rigid_body_coupling", "coriolis"
    size_name, size_unit = "coupling", "-"
    needs = frozenset({"combined"})

    def size_max(self):
        return 3.0

    def set_size(self, s):
        self.k = s

    def force(self, X, st, acc, h, m):
        acc.fx = acc.fx + self.k * MASS_KG * st.r * st.v
        acc.fy = acc.fy - self.k * MASS_KG * st.r * st.u


class CoriolisAddedMass(CoriolisScaled):
    """Soil dragged along as added mass, more sideways (A_v = k m) than ahead (A_u = rho A_v):
    heavier in the accelerations, and its Coriolis and Munk moment (A_u - A_v) u v."""
    form = "added_mass"

    def draw(self, rng):
        self.params["surge_over_sway"] = self.rho = float(rng.uniform(0.0, 0.4))

    def mass(self, X, m, mu, mv, iz):
        return mu + self.rho * self.k * MASS_KG, mv + self.k * MASS_KG, iz

    def force(self, X, st, acc, h, m):
        au, av = self.rho * self.k * MASS_KG, self.k * MASS_KG
        acc.fx = acc.fx + av * st.r * st.v
        acc.fy = acc.fy - au * st.r * st.u
        acc.fp = acc.fp + (au - av) * st.u * st.v / m.lam


class CoriolisComOffset(CoriolisScaled):
    """The rigid body with its centre of mass off the centre (x_g, y_g up to 0.15 m): the
    Coriolis, centripetal and angular-acceleration terms, times k."""
    form = "com_offset"

    def draw(self, rng):
        self.xg, self.yg = float(rng.uniform(-0.15, 0.15)), float(rng.uniform(-0.1, 0.1))
        self.params.update(x_g_m=self.xg, y_g_m=self.yg)

    def force(self, X, st, acc, h, m):
        r, km = st.r, self.k * MASS_KG
        acc.fx = acc.fx + km * (r * st.v + r * r * self.xg + st.rdot * self.yg)
        acc.fy = acc.fy + km * (-r * st.u + r * r * self.yg - st.rdot * self.xg)


# ---- yaw_time_constant ----
class _Yaw(Effect):
    family = "yaw_time_constant"
    needs = frozenset({"yaw_steps"})
    size_name, size_unit = "abs_log_time_constant_ratio", "-"

    def draw(self, rng):
        self.params["slower"] = self.slower = bool(rng.uniform() < 0.5) or type(self) is not YawInertia

    def size_max(self):
        return math.log(5.0)

    def set_size(self, s):
        self.s = s
        self.tau_nom = I_Z_KGM2 / self.tp["d_psi"]


class YawInertia(_Yaw):
    """The yaw inertia is not Table 3's: the yaw time constant I_z / D_psi times exp(+-s)."""
    form = "inertia"

    def mass(self, X, m, mu, mv, iz):
        return mu, mv, iz * X.exp(self.s if self.slower else -self.s)


class YawTorqueLag(_Yaw):
    """The yaw torque builds up through a first-order lag (the soil's torsional give) of
    tau_nom (exp(s) - 1)."""
    form = "torque_lag"
    stateful = True

    def reset(self, X, st, m):
        self.state = None

    def drive(self, X, st, tx, ty, tp, h):
        if self.state is None:
            self.state = tp
        T = self.tau_nom * (X.exp(self.s) - 1) + 1e-6
        self.state = self.state + (tp - self.state) * (1 - X.exp(-h / T))
        return tx, ty, self.state


class YawSoilSpring(_Yaw):
    """The yaw torque passes a second-order filter (body on a torsional soil spring, damping
    ratio 0.3-0.7, 1 / omega_n = tau_nom (exp(s) - 1)): the turn overshoots."""
    form = "soil_spring"
    stateful = True

    def draw(self, rng):
        super().draw(rng)
        self.params["damping_ratio"] = self.zeta = float(rng.uniform(0.3, 0.7))

    def reset(self, X, st, m):
        self.y = None

    def drive(self, X, st, tx, ty, tp, h):
        if self.y is None:
            self.y, self.yd = tp, tp * 0.0
        wn = 1.0 / (self.tau_nom * (X.exp(self.s) - 1) + 1e-6)
        # semi-implicit Euler, sub-divided so that h wn stays below 0.2
        n = int(np.max(np.asarray(h * wn)) / 0.2) + 1
        hh = h / n
        for _ in range(n):
            self.yd = (self.yd + hh * wn * wn * (tp - self.y)) / (1 + 2 * self.zeta * wn * hh)
            self.y = self.y + hh * self.yd
        return tx, ty, self.y


# ---- screw_blocking ----
BLOCK_MAX_N = 0.5 * MASS_KG * G_MPS2 / 4      # mu m g / 4, mu = 0.5 (docs/model-notes.md)


class BlockHard(Effect):
    """A screw slower than w_b lies in the soil: dry friction of up to F at its contact,
    opposing the contact's motion (docs/model-notes.md "Blocking")."""
    family, form = "screw_blocking", "hard_threshold"
    size_name, size_unit = "force", "N"
    needs = frozenset({"stopped"})
    hard = True

    def draw(self, rng):
        self.params["w_block_rpm"] = self.wb = float(rng.uniform(0.5, 3.0))

    def size_max(self):
        return BLOCK_MAX_N

    def set_size(self, s):
        self.f = s

    def share(self, X, st, i, h):
        return X.where(X.abs(st.w[i]) < self.wb, 1.0, 0.0)

    def force(self, X, st, acc, h, m):
        for i, (xi, yi) in enumerate(POS_M):
            k = self.share(X, st, i, h)
            sp = X.hypot(st.u - st.r * yi, st.v + st.r * xi)
            acc.damp_contact(i, k * self.f / X.maximum(sp, 2e-4), m.lam)


class BlockSmooth(BlockHard):
    """A slow screw resists at its contact with F exp(-(w / w_b)^2): fades smoothly."""
    form = "smooth_fade"

    def share(self, X, st, i, h):
        return X.exp(-(st.w[i] / self.wb) ** 2)


class BlockSinking(BlockHard):
    """A screw below w_b sinks in over T_sink (its resistance grows as the time spent below
    w_b over T_sink, up to F) and is freed only above 2 w_b (hysteresis)."""
    form = "sinking_hysteresis"
    stateful = True

    def draw(self, rng):
        super().draw(rng)
        self.params["t_sink_s"] = self.ts = float(rng.uniform(0.3, 2.0))

    def reset(self, X, st, m):
        self.tb = [X.full(0.0)] * 4

    def share(self, X, st, i, h):
        a = X.abs(st.w[i])
        t = X.where(a < self.wb, self.tb[i] + h, X.where(a > 2 * self.wb, 0.0, self.tb[i]))
        self.tb[i] = t
        return X.minimum(1.0, t / self.ts)


# ---- paper_params ----
class _Params(Effect):
    family = "paper_params"
    size_name, size_unit = "abs_log_factor", "-"

    def draw(self, rng):
        self.params["sign"] = self.sg = float(rng.choice([-1.0, 1.0]))

    def size_max(self):
        return math.log(2.0)

    def set_size(self, s):
        self.s = s


class ParamsAxisOpposed(_Params):
    """One axis's sigma and D off in opposite directions (sigma x exp(s), D x exp(-s))."""
    form = "axis_opposed"

    def draw(self, rng):
        super().draw(rng)
        self.params["axis"] = self.ax = str(rng.choice(["x", "y"]))

    def factors(self, X, st):
        a, b = X.exp(self.sg * self.s), X.exp(-self.sg * self.s)
        if self.ax == "x":
            return a, 1.0, b, 1.0, 1.0
        return 1.0, a, 1.0, b, 1.0


class ParamsAllScaled(_Params):
    """All sigma times exp(a s), all D times exp(b s) (a, b on the unit circle)."""
    form = "all_scaled"

    def draw(self, rng):
        super().draw(rng)
        ph = float(rng.uniform(0, 2 * math.pi))
        if abs(math.cos(ph) - math.sin(ph)) < 0.4:
            ph += math.pi / 2
        self.a, self.b = math.cos(ph), math.sin(ph)
        self.params.update(sigma_exponent=self.a, drag_exponent=self.b)

    def factors(self, X, st):
        a, b = X.exp(self.a * self.s), X.exp(self.b * self.s)
        return a, a, b, b, b


class ParamsYawDrag(_Params):
    """D_psi alone off, times exp(+-s): the turns' steady rate and time constant change."""
    form = "yaw_drag"

    def factors(self, X, st):
        return 1.0, 1.0, 1.0, 1.0, X.exp(self.sg * self.s)
