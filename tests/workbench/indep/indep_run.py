"""One run of the independent generator (the motors, the body, the camera and the IMU, row by
row), and the replays that measure an effect's visibility: the log's own screw speeds, open
loop, through the base model with and without the effect, 25 s segments each restarted from
the true state.
"""
import math

import numpy as np

from indep_model import SCALAR, Model, Motor, State, lanes

DT_S = 0.01                 # log rows (augerd's 100 Hz)
SEGMENT_S = 25.0            # visibility segments
CPR = 48 * 369              # encoder counts per screw turn (docs/model-notes.md "Hardware facts")


class Sensors:
    """The camera's frames (times, drops, jitter, noise) and the IMU's noise, drawn once per
    log so that every run of the log sees the same."""

    def __init__(self, rng, n_rows):
        T = (n_rows - 1) * DT_S
        self.fps = float(rng.uniform(28, 31))
        t = float(rng.uniform(0, 1 / self.fps)) + np.arange(int(T * self.fps) + 2) / self.fps
        t = t[t <= T]
        self.t_frames = t
        n = len(t)
        # dropped frames: bursts (a two-state chain) and a few long outages
        self.drop_fraction = float(rng.uniform(0.02, 0.12))
        self.burst_frames = float(rng.uniform(2, 8))
        p_bg = 1 / self.burst_frames
        p_gb = self.drop_fraction * p_bg / (1 - self.drop_fraction)
        drop, bad = np.zeros(n, dtype=bool), False
        u = rng.uniform(size=n)
        for k in range(n):
            bad = (u[k] < p_gb) if not bad else (u[k] >= p_bg)
            drop[k] = bad
        self.outages = []
        for _ in range(int(rng.integers(0, 4))):
            a, d = float(rng.uniform(5, T - 5)), float(rng.uniform(0.5, 2.0))
            drop |= (t >= a) & (t < a + d)
            self.outages.append([round(a, 2), round(d, 2)])
        self.drop = drop
        self.row = np.rint(t / DT_S).astype(int)
        self.jitter_s = float(rng.uniform(0.001, 0.004))
        self.jitter = np.clip(rng.normal(size=n), -3, 3) * self.jitter_s
        sxy = float(rng.uniform(0.001, 0.005))
        self.std = np.array([sxy * float(rng.uniform(0.8, 1.2)), sxy * float(rng.uniform(0.8, 1.2)),
                             float(rng.uniform(0.003, 0.008))])
        self.coloured = bool(rng.uniform() < 0.5)
        self.colour_share = float(rng.uniform(0.3, 0.7)) if self.coloured else 0.0
        self.colour_tau_s = float(rng.uniform(0.2, 2.0))
        white = rng.normal(size=(n, 3)) * self.std * math.sqrt(1 - self.colour_share)
        gm = np.zeros((n, 3))
        a = math.exp(-1 / (self.fps * self.colour_tau_s))
        e = rng.normal(size=(n, 3)) * self.std * math.sqrt(self.colour_share)
        gm[0] = e[0]
        for k in range(1, n):
            gm[k] = a * gm[k - 1] + math.sqrt(1 - a * a) * e[k]
        self.noise = white + gm
        self.imu_std = np.array([float(rng.uniform(0.001, 0.004)), float(rng.uniform(0.002, 0.008))])
        self.imu_noise = rng.normal(size=(n_rows, 2)) * self.imu_std
        self.latency = np.zeros(n)

    def truth(self):
        return dict(camera=dict(fps=round(self.fps, 3), std_x_m=self.std[0], std_y_m=self.std[1],
                                std_psi_rad=self.std[2], coloured=self.coloured,
                                coloured_variance_share=self.colour_share,
                                coloured_tau_s=self.colour_tau_s if self.coloured else None,
                                timestamp_jitter_std_s=self.jitter_s,
                                dropped_fraction_target=self.drop_fraction,
                                drop_burst_frames=self.burst_frames, outages_s=self.outages,
                                frames=int((~self.drop).sum()), frames_dropped=int(self.drop.sum())),
                    imu=dict(std_psi_rad=self.imu_std[0], std_r_radps=self.imu_std[1]))


def hermite(truth, wvel, t):
    """The true pose (x, y, psi) at times t from the rows (cubic Hermite on pose and world
    velocity; exact to well under a micrometre at 10 ms)."""
    t = np.clip(np.asarray(t, dtype=float), 0, (len(truth) - 1) * DT_S - 1e-9)
    i = np.floor(t / DT_S).astype(int)
    s = t / DT_S - i
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    p0, p1, v0, v1 = truth[i, :3], truth[i + 1, :3], wvel[i], wvel[i + 1]
    return (h00[:, None] * p0 + h10[:, None] * DT_S * v0 + h01[:, None] * p1
            + h11[:, None] * DT_S * v1)


def _hermite1(truth, wvel, t):
    """hermite() at one time (the controller's path: no arrays)."""
    i = min(max(int(t / DT_S), 0), len(truth) - 2)
    s = t / DT_S - i
    s2, s3 = s * s, s * s * s
    a, b, c, d = 2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * DT_S, -2 * s3 + 3 * s2, (s3 - s2) * DT_S
    p0, p1, v0, v1 = truth[i], truth[i + 1], wvel[i], wvel[i + 1]
    return np.array([a * p0[j] + b * v0[j] + c * p1[j] + d * v1[j] for j in range(3)])


def simulate(terrain, effects, p0, n_rows, setpoints, controller, sensors, motor_cfg, n_sub=10):
    """The log's run: setpoints per row (open loop) or the controller on the camera's frames
    (closed loop; a frame reaches it two rows after its own). Returns the rows' truth
    (x, y, psi, u, v, r, s), world velocities, encoder speeds, setpoints."""
    st = State(SCALAR, *p0)
    model = Model(terrain, effects)
    model.reset(SCALAR, st)
    rng_m = np.random.default_rng(motor_cfg["seed"])
    motors = [Motor(motor_cfg["tau_s"][i], motor_cfg["ripple_rpm"], motor_cfg["ripple_tau_s"], CPR,
                    rng_m) for i in range(4)]
    truth, wvel = np.zeros((n_rows, 7)), np.zeros((n_rows, 3))
    turns = np.zeros((n_rows, 4))           # each screw's angle (revolutions) since t = 0
    counts, sp = np.zeros((n_rows, 4)), np.zeros((n_rows, 4))
    truth[0] = [st.x, st.y, st.psi, 0, 0, 0, 0]
    counts[0] = [m.count() for m in motors]
    ripple = rng_m.normal(size=(n_rows, 4)).tolist()
    h = DT_S / n_sub
    fptr, est = 0, None
    for k in range(n_rows - 1):
        if controller is None:
            w_sp = setpoints[k]
        else:
            while fptr < len(sensors.row) and sensors.row[fptr] <= k - 2:
                if not sensors.drop[fptr]:
                    ts = sensors.t_frames[fptr] + sensors.jitter[fptr] - sensors.latency[fptr]
                    est = _hermite1(truth, wvel, min(ts, (k - 1) * DT_S)) + sensors.noise[fptr]
                fptr += 1
            w_sp = controller.command(k, est)
        sp[k] = w_sp
        for i in range(4):
            motors[i].new_row(float(w_sp[i]), DT_S, ripple[k][i])
        for _ in range(n_sub):
            ws, dth = [], []
            for m in motors:
                a, b = m.advance(h)
                ws.append(a)
                dth.append(b)
            model.substep(SCALAR, st, ws, dth, h)
        truth[k + 1] = [st.x, st.y, st.psi, st.u, st.v, st.r, st.s]
        c, s = math.cos(st.psi), math.sin(st.psi)
        wvel[k + 1] = [c * st.u - s * st.v, s * st.u + c * st.v, st.r]
        counts[k + 1] = [m.count() for m in motors]
        turns[k + 1] = st.theta
    if controller is not None:
        sp[-1] = sp[-2]
    omega = np.zeros((n_rows, 4))
    omega[1:] = np.diff(counts, axis=0) / CPR / DT_S * 60.0
    return dict(truth=truth, wvel=wvel, omega=omega, setpoints=sp, turns=turns)


def segments(n_rows):
    seg = int(round(SEGMENT_S / DT_S))
    return np.arange(0, n_rows - 1, seg), seg


def replay(terrain, effects, run, reps, n_sub):
    """Open-loop replay of the logged screw speeds from the true state at every segment's
    start; lanes = reps x segments (effects' sizes set per lane by the caller). Returns the
    pose per row (seg + 1, 3, lanes) and the mask of rows inside the log."""
    n_rows = len(run["omega"])
    starts, seg = segments(n_rows)
    nseg = len(starts)
    L = reps * nseg
    X = lanes(L)
    st0 = np.tile(starts, reps)
    tr = run["truth"][st0]
    st = State(X, tr[:, 0], tr[:, 1], tr[:, 2], tr[:, 3], tr[:, 4], tr[:, 5], st0 * DT_S, tr[:, 6])
    st.theta = [run["turns"][st0, i] for i in range(4)]
    model = Model(terrain, effects)
    model.reset(X, st)
    out = np.zeros((seg + 1, 3, L))
    out[0] = tr[:, :3].T
    h = DT_S / n_sub
    for j in range(seg):
        idx = np.minimum(st0 + j + 1, n_rows - 1)
        w = run["omega"][idx]
        ws = [w[:, i] for i in range(4)]
        dth = [w[:, i] * h / 60.0 for i in range(4)]
        for _ in range(n_sub):
            model.substep(X, st, ws, dth, h)
        out[j + 1] = [st.x, st.y, st.psi]
    rows = st0[None, :] + np.arange(seg + 1)[:, None]
    return out, rows <= n_rows - 1


class Visibility:
    """RMS pose difference with and without an effect, per channel, in multiples of the
    channel's camera noise (IMU channels: of the IMU's noise)."""

    def __init__(self, terrain, run, sensors, n_sub):
        self.terrain, self.run, self.sensors, self.n_sub = terrain, run, sensors, n_sub
        self.base, self.mask = replay(terrain, [], run, 1, n_sub)
        self.nseg = self.base.shape[2]

    def of(self, eff, sizes):
        """Visibility per size: array (len(sizes), channels), channels x, y, psi, imu_psi, imu_r."""
        sizes = np.asarray(sizes, dtype=float)
        out = np.zeros((len(sizes), 5))
        if eff.sensor:
            for n, s in enumerate(sizes):
                eff.set_size(float(s))
                out[n] = self._sensor(eff)
            return out
        eff.set_size(np.repeat(sizes, self.nseg))
        pose, _ = replay(self.terrain, [eff], self.run, len(sizes), self.n_sub)
        for n in range(len(sizes)):
            d = pose[:, :, n * self.nseg:(n + 1) * self.nseg] - self.base
            m = self.mask
            for c in range(3):
                out[n, c] = math.sqrt(np.mean(d[:, c][m] ** 2)) / self.sensors.std[c]
        return out

    def _sensor(self, eff):
        tr, wv, se = self.run["truth"], self.run["wvel"], self.sensors
        v = np.zeros(5)
        if hasattr(eff, "camera_latency"):
            tf = se.t_frames
            d = hermite(tr, wv, tf - eff.camera_latency(tf)) - hermite(tr, wv, tf)
            v[:3] = np.sqrt(np.mean(d ** 2, axis=0)) / se.std
        if hasattr(eff, "imu"):
            t = np.arange(len(tr)) * DT_S
            dp, dr = eff.imu(t, tr[:, 2])
            v[3] = math.sqrt(np.mean(np.asarray(dp) ** 2)) / se.imu_std[0]
            v[4] = math.sqrt(np.mean(np.asarray(dr) ** 2)) / se.imu_std[1]
        return v
