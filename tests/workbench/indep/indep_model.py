"""The independent generator's robot: the paper's dynamic model, eqs. (5)-(10), with hooks where
effects act, integrated over substeps of 1-5 ms. Written from docs/model-notes.md and the paper
alone (not from the workbench's effect library, nor from the project's simulator), so that the
workbench is judged on physics it was not written with.

One integrator serves two callers: the log's own run (one lane, Python floats: fast for one
trajectory) and the visibility replays (many 25 s segments and effect sizes at once, numpy arrays
over lanes). `SCALAR` and `lanes(n)` are the two backends; effect code is written once against
them (`X.where`, `X.exp`, ...).
"""
import math

import numpy as np

# Geometry and mass (docs/model-notes.md "Geometry and mass").
R_S_M = 0.0775
PHI_RAD = math.pi / 6
L_X_M, L_Y_M = 0.15, 0.30
KAPPA_M = L_X_M + L_Y_M / math.tan(PHI_RAD)
ALPHA_RAD = math.radians(26.5)
C_YAW_M = L_X_M * math.sin(ALPHA_RAD)      # eq. (10): the lumped yaw row, 0.067 m
MASS_KG, I_Z_KGM2 = 29.0, 3.72
G_MPS2 = 9.81
OMEGA_MAX_RPM = 23.0                       # the motor's rating at 12 V

# Screw order 0 front-right, 1 rear-right, 2 rear-left, 3 front-left (REP-103, y left).
POS_M = ((L_X_M, -L_Y_M), (-L_X_M, -L_Y_M), (-L_X_M, L_Y_M), (L_X_M, L_Y_M))
B_X = (-1.0, -1.0, 1.0, 1.0)               # eq. (10), row x
B_Y = (-1.0, 1.0, 1.0, -1.0)               # eq. (10), row y
B_PSI = -C_YAW_M                           # eq. (10), row psi (every screw)

# Table 3 (sigma in N/rpm, D_x, D_y in N/(m/s), D_psi in N m/(rad/s)).
TERRAIN = {
    "sand": dict(sigma_long=0.812, sigma_lat=0.247, d_x=560.33, d_y=320.08, d_psi=11.46),
    "frozen_grass": dict(sigma_long=0.4, sigma_lat=0.16, d_x=509.81, d_y=210.50, d_psi=4.52),
}


def k_inverse():
    """Rows of K_i, eq. (4), built from the screw table of docs/model-notes.md."""
    t = math.tan(PHI_RAD)
    return [(-1 / t, -1.0, -KAPPA_M), (-1 / t, 1.0, -KAPPA_M),
            (1 / t, 1.0, -KAPPA_M), (1 / t, -1.0, -KAPPA_M)]


def yaw_lump(terrain):
    """The real moment of the screw forces about the centre over the paper's lumped yaw row,
    for a pure turn (about 17 on sand). The paper's yaw row and D_psi are both this much smaller
    than the real moments, so a force acting at a point of the body turns the robot, in the
    model's units, by its real moment over this ratio (steady state exact)."""
    p = TERRAIN[terrain]
    real = L_X_M * p["sigma_lat"] + L_Y_M * p["sigma_long"]
    return real / (C_YAW_M * p["sigma_lat"])


def drive_force_n(terrain, axis, omega_rpm):
    """The drive of all four screws at omega_rpm along one DOF (N, or N m for psi), eq. (7)."""
    p = TERRAIN[terrain]
    if axis == "x":
        return 4 * p["sigma_long"] * omega_rpm
    if axis == "y":
        return 4 * p["sigma_lat"] * omega_rpm
    return 4 * C_YAW_M * p["sigma_lat"] * omega_rpm


def steady_velocity(terrain, omega_rpm):
    """Eqs. (6)-(7) at rest of zeta_dot: zeta = D^-1 S B omega."""
    p = TERRAIN[terrain]
    tx = p["sigma_long"] * sum(b * w for b, w in zip(B_X, omega_rpm))
    ty = p["sigma_lat"] * sum(b * w for b, w in zip(B_Y, omega_rpm))
    tp = p["sigma_lat"] * B_PSI * sum(omega_rpm)
    return tx / p["d_x"], ty / p["d_y"], tp / p["d_psi"]


class _Scalar:
    """Backend for one trajectory in Python floats."""
    n = None
    abs = staticmethod(abs)
    tanh = staticmethod(math.tanh)
    exp = staticmethod(math.exp)
    sqrt = staticmethod(math.sqrt)
    cos = staticmethod(math.cos)
    sin = staticmethod(math.sin)
    hypot = staticmethod(math.hypot)
    maximum = staticmethod(max)
    minimum = staticmethod(min)

    @staticmethod
    def where(c, a, b):
        return a if c else b

    @staticmethod
    def sign(a):
        return (a > 0) - (a < 0)

    @staticmethod
    def full(v):
        return float(v)

    @staticmethod
    def land(a, b):
        return a and b


class _Lanes:
    """Backend for n lanes at once (numpy arrays)."""
    abs = staticmethod(np.abs)
    tanh = staticmethod(np.tanh)
    exp = staticmethod(np.exp)
    sqrt = staticmethod(np.sqrt)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)
    hypot = staticmethod(np.hypot)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    where = staticmethod(np.where)
    sign = staticmethod(np.sign)
    land = staticmethod(np.logical_and)

    def __init__(self, n):
        self.n = n

    def full(self, v):
        return np.full(self.n, v, dtype=float) if np.ndim(v) == 0 else np.array(v, dtype=float)


SCALAR = _Scalar()


def lanes(n):
    return _Lanes(n)


class State:
    """Pose (world), body velocity, time, distance travelled; each a float or a lane array."""
    __slots__ = ("x", "y", "psi", "u", "v", "r", "t", "s", "rdot", "w", "theta")

    def __init__(self, X, x=0.0, y=0.0, psi=0.0, u=0.0, v=0.0, r=0.0, t=0.0, s=0.0):
        self.x, self.y, self.psi = X.full(x), X.full(y), X.full(psi)
        self.u, self.v, self.r = X.full(u), X.full(v), X.full(r)
        self.t, self.s, self.rdot = X.full(t), X.full(s), X.full(0.0)
        self.w = [X.full(0.0)] * 4          # the screws' speeds in this substep, rpm
        self.theta = [X.full(0.0)] * 4      # the screws' angles, revolutions


class Forces:
    """What the resistance hooks add: an explicit body force f and a damping matrix C taken
    implicitly (force -C zeta at the end of the substep), so that dry friction and stiff
    resistances need no tiny steps."""
    __slots__ = ("fx", "fy", "fp", "c", "full")

    def __init__(self):
        self.fx = self.fy = self.fp = 0.0
        self.c = [0.0] * 9
        self.full = False

    def damp_dof(self, j, c):
        self.c[4 * j] = self.c[4 * j] + c

    def damp_contact(self, i, c, lam):
        """Damping c (N/(m/s)) of contact i's velocity (u - r y_i, v + r x_i); the moment of the
        contact force in the model's lumped yaw units (divided by lam, see yaw_lump)."""
        xi, yi = POS_M[i]
        cc = self.c
        cc[0] = cc[0] + c
        cc[2] = cc[2] - c * yi
        cc[4] = cc[4] + c
        cc[5] = cc[5] + c * xi
        cc[6] = cc[6] - c * yi / lam
        cc[7] = cc[7] + c * xi / lam
        cc[8] = cc[8] + c * (xi * xi + yi * yi) / lam
        self.full = True

    def add_contact(self, i, fx, fy, lam):
        """A force (fx, fy) (body axes) at contact i."""
        xi, yi = POS_M[i]
        self.fx = self.fx + fx
        self.fy = self.fy + fy
        self.fp = self.fp + (xi * fy - yi * fx) / lam


class Model:
    """The base model for one terrain, with its effects (objects of indep_effects)."""

    def __init__(self, terrain, effects=()):
        p = TERRAIN[terrain]
        self.terrain = terrain
        self.sl, self.sa = p["sigma_long"], p["sigma_lat"]
        self.dx, self.dy, self.dp = p["d_x"], p["d_y"], p["d_psi"]
        self.lam = yaw_lump(terrain)
        self.effects = list(effects)
        self.h_factors = [e for e in self.effects if hasattr(e, "factors")]
        self.h_speed = [e for e in self.effects if hasattr(e, "speed")]
        self.h_screw = [e for e in self.effects if hasattr(e, "screw")]
        self.h_drive = [e for e in self.effects if hasattr(e, "drive")]
        self.h_force = [e for e in self.effects if hasattr(e, "force")]
        self.h_mass = [e for e in self.effects if hasattr(e, "mass")]

    def reset(self, X, st):
        for e in self.effects:
            if hasattr(e, "reset"):
                e.reset(X, st, self)
        mu, mv, iz = X.full(MASS_KG), X.full(MASS_KG), X.full(I_Z_KGM2)
        for e in self.h_mass:
            mu, mv, iz = e.mass(X, self, mu, mv, iz)
        self.mu, self.mv, self.iz = mu, mv, iz

    def substep(self, X, st, w, dtheta, h):
        """Advance st by h seconds; w: the four screws' mean speeds over the substep (rpm),
        dtheta their turns (revolutions)."""
        st.w = w
        th = st.theta
        st.theta = [th[0] + dtheta[0], th[1] + dtheta[1], th[2] + dtheta[2], th[3] + dtheta[3]]
        t0 = st.t
        st.t = t0 + 0.5 * h                 # hooks see the substep's midpoint
        sl, sa, dx, dy, dp = self.sl, self.sa, self.dx, self.dy, self.dp
        for e in self.h_factors:
            a, b, c, d, f = e.factors(X, st)
            sl, sa, dx, dy, dp = sl * a, sa * b, dx * c, dy * d, dp * f
        g = w
        for e in self.h_speed:
            g = e.speed(X, st, g, h)
        # eq. (7): tau = S B omega, per screw where effects act on single screws
        if self.h_screw:
            fx = [sl * B_X[i] * g[i] for i in range(4)]
            fy = [sa * B_Y[i] * g[i] for i in range(4)]
            fm = [sa * B_PSI * g[i] for i in range(4)]
            for e in self.h_screw:
                e.screw(X, st, fx, fy, fm, h)
            tx = fx[0] + fx[1] + fx[2] + fx[3]
            ty = fy[0] + fy[1] + fy[2] + fy[3]
            tp = fm[0] + fm[1] + fm[2] + fm[3]
        else:
            tx = sl * (g[2] + g[3] - g[0] - g[1])
            ty = sa * (g[1] + g[2] - g[0] - g[3])
            tp = sa * B_PSI * (g[0] + g[1] + g[2] + g[3])
        for e in self.h_drive:
            tx, ty, tp = e.drive(X, st, tx, ty, tp, h)
        acc = Forces()
        acc.fx, acc.fy, acc.fp = tx, ty, tp
        for e in self.h_force:
            e.force(X, st, acc, h, self)
        u0, v0, r0 = st.u, st.v, st.r
        mu, mv, iz = self.mu, self.mv, self.iz
        # eq. (6), trapezoidal in -D zeta (error ~(h D / M)^2 / 12), implicit in C:
        # (M/h + D/2 + C) zeta1 = (M/h - D/2) zeta0 + f
        b0 = (mu / h - 0.5 * dx) * u0 + acc.fx
        b1 = (mv / h - 0.5 * dy) * v0 + acc.fy
        b2 = (iz / h - 0.5 * dp) * r0 + acc.fp
        c = acc.c
        a00, a11, a22 = mu / h + 0.5 * dx + c[0], mv / h + 0.5 * dy + c[4], iz / h + 0.5 * dp + c[8]
        if acc.full:
            a01, a02, a10, a12, a20, a21 = c[1], c[2], c[3], c[5], c[6], c[7]
            det = (a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20)
                   + a02 * (a10 * a21 - a11 * a20))
            u1 = (b0 * (a11 * a22 - a12 * a21) - a01 * (b1 * a22 - a12 * b2)
                  + a02 * (b1 * a21 - a11 * b2)) / det
            v1 = (a00 * (b1 * a22 - a12 * b2) - b0 * (a10 * a22 - a12 * a20)
                  + a02 * (a10 * b2 - b1 * a20)) / det
            r1 = (a00 * (a11 * b2 - b1 * a21) - a01 * (a10 * b2 - b1 * a20)
                  + b0 * (a10 * a21 - a11 * a20)) / det
        else:
            u1, v1, r1 = b0 / a00, b1 / a11, b2 / a22
        # eq. (5), eq. (9): the pose with the substep's mean velocity and mid heading
        psi1 = st.psi + 0.5 * h * (r0 + r1)
        pm = 0.5 * (st.psi + psi1)
        um, vm = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
        cp, sp = X.cos(pm), X.sin(pm)
        st.x = st.x + h * (cp * um - sp * vm)
        st.y = st.y + h * (sp * um + cp * vm)
        st.psi = psi1
        st.s = st.s + h * X.hypot(um, vm)
        st.rdot = (r1 - r0) / h
        st.u, st.v, st.r = u1, v1, r1
        st.t = t0 + h


class Motor:
    """One screw module: the speed follows the setpoint as a first-order lag (tau_s), limited to
    OMEGA_MAX_RPM; a slow random ripple of the loaded speed (the module's own PID is not
    perfect); an encoder of cpr counts per output turn. Exact over any step."""

    def __init__(self, tau_s, ripple_rpm, ripple_tau_s, cpr, rng):
        self.tau_s, self.cpr = tau_s, cpr
        self.ripple_rpm, self.ripple_tau_s = ripple_rpm, ripple_tau_s
        self.w = 0.0
        self.turns = rng.uniform(0, 1)          # the encoder's phase
        self.ripple = 0.0
        self._h = self._e = self._a = None

    def new_row(self, setpoint_rpm, dt_s, normal):
        """The setpoint of the next row; normal: a standard normal draw for the ripple."""
        if self._a is None:
            self._a = math.exp(-dt_s / self.ripple_tau_s)
            self._b = math.sqrt(1 - self._a ** 2) * self.ripple_rpm
        self.ripple = self._a * self.ripple + self._b * normal
        target = setpoint_rpm + (self.ripple if abs(setpoint_rpm) > 0.05 else 0.0)
        self.target = max(-OMEGA_MAX_RPM, min(OMEGA_MAX_RPM, target))

    def advance(self, h):
        """Return (mean speed over h in rpm, turns over h)."""
        tgt, w0 = self.target, self.w
        if h != self._h:
            self._h, self._e = h, math.exp(-h / self.tau_s)
        e = self._e
        dturns = (tgt * h + (w0 - tgt) * self.tau_s * (1 - e)) / 60.0
        self.w = tgt + (w0 - tgt) * e
        self.turns += dturns
        return dturns * 60.0 / h, dturns

    def count(self):
        return math.floor(self.turns * self.cpr)
