"""Mechanisms outside the workbench's library, for the independent generator. Each names the
variables its term is built from in the vocabulary of issue 25 (omega_rpm_0..3, u_mps, v_mps,
r_radps, psi_rad, t_s, x_m, y_m) and the form they enter in, so that a discovered term can be
checked against it: `groups` lists the variables a discovered term must use, one of each group.
Conventions as in indep_effects.py.
"""
import math

from indep_effects import Effect
from indep_model import OMEGA_MAX_RPM

OMEGAS = ("omega_rpm_0", "omega_rpm_1", "omega_rpm_2", "omega_rpm_3")


class BackwardWeak(Effect):
    """A screw turning backwards (negative omega, its motor's reverse) pushes weaker, by a
    fraction a: the helix's flanks are not symmetric."""
    mechanism, form = "backward_weak", "backward_fraction"
    size_name, size_unit = "weaker_fraction", "-"
    variables = OMEGAS
    form_string = "backward part of omega_rpm_i: min(omega_rpm_i, 0), i = 0..3"
    groups = (OMEGAS,)

    def size_max(self):
        return 0.7

    def set_size(self, s):
        self.a = s

    def speed(self, X, st, g, h):
        return [X.where(w < 0, (1 - self.a) * w, w) for w in g]


class SpeedSquared(Effect):
    """Traction grows with the screw speed squared (the helix digs in harder the faster it
    turns): thrust of w (1 + a |w| / 23 rpm). Only growing: traction that falls with speed is
    the library's saturation."""
    mechanism, form = "speed_squared_traction", "w_abs_w"
    size_name, size_unit = "change_at_23rpm", "-"
    variables = OMEGAS
    form_string = "omega_rpm_i * abs(omega_rpm_i), i = 0..3"
    groups = (OMEGAS,)

    def size_max(self):
        return 1.0

    def set_size(self, s):
        self.a = s

    def speed(self, X, st, g, h):
        return [w * (1 + self.a * X.abs(w) / OMEGA_MAX_RPM) for w in g]


class Furrows(Effect):
    """Furrows in the field (world direction theta): motion across them meets k D_x more
    resistance, along them none; seen from the body, a resistance that depends on heading."""
    mechanism, form = "heading_dependent_resistance", "furrows"
    size_name, size_unit = "extra_over_D_x", "-"
    variables = ("u_mps", "v_mps", "psi_rad")
    form_string = ("velocity across the furrows, u_mps cos(psi_rad - theta) - v_mps "
                   "sin(psi_rad - theta), projected on the body axes")
    groups = (("psi_rad",), ("u_mps", "v_mps"))

    def draw(self, rng):
        self.params["across_direction_rad"] = self.th = float(rng.uniform(-math.pi, math.pi))

    def size_max(self):
        return 1.5

    def set_size(self, s):
        self.k = s

    def force(self, X, st, acc, h, m):
        a = self.th - st.psi
        nx, ny = X.cos(a), X.sin(a)
        c, k = acc.c, self.k * m.dx
        c[0] = c[0] + k * nx * nx
        c[1] = c[1] + k * nx * ny
        c[3] = c[3] + k * nx * ny
        c[4] = c[4] + k * ny * ny
        acc.full = True


class AngleRipple(Effect):
    """Each screw's thrust ripples with its own angle, twice a turn (two helix starts):
    times 1 + a sin(4 pi turns_i + phi_i)."""
    mechanism, form = "screw_angle_ripple", "two_per_turn"
    size_name, size_unit = "ripple_fraction", "-"
    variables = OMEGAS
    form_string = "sin(4 pi turns_i + phi_i), turns_i = integral of omega_rpm_i / 60 dt"
    groups = (OMEGAS,)

    def draw(self, rng):
        self.params["phases_rad"] = self.ph = [float(rng.uniform(0, 2 * math.pi)) for _ in range(4)]

    def size_max(self):
        return 1.0

    def set_size(self, s):
        self.a = s

    def screw(self, X, st, fx, fy, fm, h):
        for i in range(4):
            k = 1 + self.a * X.sin(4 * math.pi * st.theta[i] + self.ph[i])
            fx[i], fy[i], fm[i] = fx[i] * k, fy[i] * k, fm[i] * k


class Sinking(Effect):
    """The robot sinks as it works the ground: every drag grows with the distance travelled,
    D (1 + q s / s_total), s_total the log's whole path."""
    mechanism, form = "sinking_with_distance", "linear_in_distance"
    size_name, size_unit = "drag_increase_at_end", "-"
    variables = ("u_mps", "v_mps", "t_s")
    form_string = "distance travelled (integral of hypot(u_mps, v_mps) dt) times the velocity"
    groups = (("u_mps", "v_mps"), ("t_s", "x_m", "y_m"))

    def draw(self, rng):
        self.stot = max(1.0, float(self.env.path_length_m))
        self.params["path_length_m"] = round(self.stot, 3)

    def size_max(self):
        return 2.0

    def set_size(self, s):
        self.q = s

    def factors(self, X, st):
        k = 1 + self.q * st.s / self.stot
        return 1.0, 1.0, k, k, k


class BentScrew(Effect):
    """A bent screw module steers: a sideways force k D_y u proportional to the forward
    speed."""
    mechanism, form = "sideways_from_forward", "bent_screw"
    size_name, size_unit = "v_over_u", "-"
    variables = ("u_mps",)
    form_string = "u_mps in the y channel"
    groups = (("u_mps",),)

    def draw(self, rng):
        self.params["sign"] = self.sg = float(rng.choice([-1.0, 1.0]))

    def size_max(self):
        return 0.5

    def set_size(self, s):
        self.k = self.sg * s

    def force(self, X, st, acc, h, m):
        acc.c[3] = acc.c[3] - self.k * m.dy
        acc.full = True


class BatterySag(Effect):
    """The batteries sag: every screw pushes less as the log goes on, sigma (1 - a t / T)."""
    mechanism, form = "battery_sag", "linear_in_time"
    size_name, size_unit = "loss_at_end", "-"
    variables = ("t_s",) + OMEGAS
    form_string = "t_s * omega_rpm_i (the drive times time)"
    groups = (("t_s",), OMEGAS)

    def size_max(self):
        return 0.6

    def set_size(self, s):
        self.a = s

    def factors(self, X, st):
        k = 1 - self.a * st.t / self.env.seconds
        return k, k, 1.0, 1.0, 1.0


class Backlash(Effect):
    """Play in each screw's gearbox (a worn coupling): after a reversal the motor turns through
    the play, b turns, before the screw turns with it. A lost angle, not a lost time: at 5 rpm a
    play of 0.25 turn holds the screw 3 s, at 20 rpm 0.75 s (the library's lag and dead band
    are a time and a speed)."""
    mechanism, form = "gear_backlash", "play_in_turns"
    size_name, size_unit = "play", "turn"
    stateful = True
    # a replay restarted mid-play at a segment's start is up to half a play off the log's
    # screws for the whole segment (measured: 14.8 against 9.4 times the noise in psi)
    replay_tolerance = 0.7
    variables = OMEGAS
    form_string = ("each screw's speed through a play of b turns: the screw stands until its "
                   "motor has turned through the play")
    groups = (OMEGAS,)

    def size_max(self):
        return 0.5

    def set_size(self, s):
        self.b = s

    def reset(self, X, st, m):
        self.d = None

    def speed(self, X, st, g, h):
        # d_i: where the motor stands in the play (turns, -b/2..b/2; the screw follows only
        # the motor's motion beyond it)
        if self.d is None:
            self.d = [0.0 * w for w in g]
        half, out = 0.5 * self.b, []
        for i, w in enumerate(g):
            dn = self.d[i] + w * h / 60.0
            self.d[i] = X.minimum(half, X.maximum(-half, dn))
            out.append((dn - self.d[i]) * 60.0 / h)
        return out


class TurnTraction(Effect):
    """Turning churns the soil under the screws: traction falls with the yaw rate,
    sigma (1 - a min(1, |r| / 0.15 rad/s))."""
    mechanism, form = "traction_falls_with_yaw_rate", "abs_r"
    size_name, size_unit = "loss_at_0.15radps", "-"
    variables = ("r_radps",) + OMEGAS
    form_string = "abs(r_radps) * omega_rpm_i"
    groups = (("r_radps",), OMEGAS)

    def size_max(self):
        return 0.7

    def set_size(self, s):
        self.a = s

    def factors(self, X, st):
        k = 1 - self.a * X.minimum(1.0, X.abs(st.r) / 0.15)
        return k, k, 1.0, 1.0, 1.0


class FieldRows(Effect):
    """Rows in the field (spacing 0.4-1.5 m, world direction theta): the drag is periodic in
    position, D (1 + a sin(2 pi d / lambda + phi)), d the position across the rows."""
    mechanism, form = "periodic_in_position", "field_rows"
    size_name, size_unit = "drag_amplitude", "-"
    variables = ("x_m", "y_m", "u_mps", "v_mps")
    form_string = "sin(2 pi (x_m cos theta + y_m sin theta) / lambda + phi) times the velocity"
    groups = (("x_m", "y_m"),)

    def draw(self, rng):
        self.th = float(rng.uniform(-math.pi, math.pi))
        self.lam = float(rng.uniform(0.4, 1.5))
        self.ph = float(rng.uniform(0, 2 * math.pi))
        self.params.update(direction_rad=self.th, spacing_m=self.lam, phase_rad=self.ph)

    def size_max(self):
        return 0.6

    def set_size(self, s):
        self.a = s

    def factors(self, X, st):
        d = st.x * math.cos(self.th) + st.y * math.sin(self.th)
        k = 1 + self.a * X.sin(2 * math.pi * d / self.lam + self.ph)
        return 1.0, 1.0, k, k, k
