"""The independent generator's sensor effects (the library's pose_time_offset, imu_heading_bias
and imu_heading_drift families): they change what the camera or the IMU reports, not the motion.
Conventions as in indep_effects.py; `camera_latency(t_frames)` gives each frame's latency (s),
`imu(t, psi)` the IMU's heading and yaw-rate errors.
"""
import math

import numpy as np

from indep_effects import GRID_DT_S, Effect, on_grid


# ---- pose_time_offset (the camera) ----
class LatencyConst(Effect):
    """The camera's pose is late by a constant latency."""
    family, form = "pose_time_offset", "constant"
    size_name, size_unit = "mean_latency", "s"
    sensor = True

    def size_max(self):
        return 0.4

    def set_size(self, s):
        self.L = s

    def camera_latency(self, t_frames):
        return np.full(len(t_frames), self.L)


class LatencyJitter(LatencyConst):
    """Latency L + J (u - 0.5) per frame, u uniform (J = 0.5-1.5 L): the frame waits in a
    queue of varying length."""
    form = "jittered"

    def draw(self, rng):
        self.params["jitter_over_latency"] = self.j = float(rng.uniform(0.5, 1.5))
        self.u = rng.uniform(0, 1, size=int(self.env.seconds * 40) + 100)

    def camera_latency(self, t_frames):
        return np.maximum(0.0, self.L * (1 + self.j * (self.u[:len(t_frames)] - 0.5)))


class LatencyDrift(LatencyConst):
    """The camera's clock runs at another rate: latency from a L to (2 - a) L over the log."""
    form = "drifting_clock"

    def draw(self, rng):
        self.params["start_over_mean"] = self.a = float(rng.uniform(0.0, 0.6))

    def camera_latency(self, t_frames):
        return self.L * (self.a + 2 * (1 - self.a) * np.asarray(t_frames) / self.env.seconds)


# ---- imu_heading_bias, imu_heading_drift ----
class _Imu(Effect):
    sensor = True

    def draw(self, rng):
        self.params["sign"] = self.sg = float(rng.choice([-1.0, 1.0]))

    def set_size(self, s):
        self.b = self.sg * s

    def imu(self, t, psi):
        """(heading error in rad, yaw-rate error in rad/s) at times t."""
        return self.b + 0 * t, 0 * t


class BiasConst(_Imu):
    """The IMU heading is off by a constant."""
    family, form = "imu_heading_bias", "constant"
    size_name, size_unit = "bias", "rad"

    def size_max(self):
        return 0.35


class BiasStep(BiasConst):
    """The IMU's heading jumps once (re-initialised, a magnetic disturbance): b0 before
    t_step, b after (b0 = -0.3..0.3 b)."""
    form = "step"

    def draw(self, rng):
        super().draw(rng)
        self.params["t_step_s"] = self.ts = float(rng.uniform(0.3, 0.7)) * self.env.seconds
        self.params["before_over_after"] = self.r0 = float(rng.uniform(-0.3, 0.3))

    def imu(self, t, psi):
        return np.where(t >= self.ts, self.b, self.r0 * self.b), 0 * t


class BiasSettling(BiasConst):
    """The IMU heading's offset settles slowly (a magnetometer warming up):
    b (1 - rho exp(-t / T)), T 20-80 s."""
    form = "settling"

    def draw(self, rng):
        super().draw(rng)
        self.rho, self.T = float(rng.uniform(0.3, 0.8)), float(rng.uniform(20, 80))
        self.params.update(rho=self.rho, settling_s=self.T)

    def imu(self, t, psi):
        return self.b * (1 - self.rho * np.exp(-t / self.T)), 0 * t


class BiasCompass(BiasConst):
    """Compass deviation (hard iron): b (1 + a sin(psi + phi)), a 0.2-0.6: depends on heading."""
    form = "compass_deviation"

    def draw(self, rng):
        super().draw(rng)
        self.a, self.ph = float(rng.uniform(0.2, 0.6)), float(rng.uniform(-math.pi, math.pi))
        self.params.update(amplitude_over_bias=self.a, phase_rad=self.ph)

    def imu(self, t, psi):
        return self.b * (1 + self.a * np.sin(psi + self.ph)), 0 * t


class DriftLinear(_Imu):
    """The gyro has a constant bias: the IMU heading drifts linearly (its yaw rate is off by
    the same bias)."""
    family, form = "imu_heading_drift", "linear"
    size_name, size_unit = "drift_rate", "rad/s"

    def size_max(self):
        return 3e-3

    def imu(self, t, psi):
        return self.b * t, self.b + 0 * t


class DriftRandomWalk(DriftLinear):
    """The gyro bias is a random walk (bias instability), its RMS at the log's end the size;
    the heading error its integral."""
    form = "random_walk"

    def draw(self, rng):
        super().draw(rng)
        n = int(self.env.seconds / GRID_DT_S) + 2
        self.walk = np.cumsum(rng.normal(size=n)) * math.sqrt(GRID_DT_S / self.env.seconds)

    def imu(self, t, psi):
        rate = self.sg * np.abs(self.b) * on_grid(_NP, self.walk, np.asarray(t, dtype=float))
        head = np.cumsum(self.sg * np.abs(self.b) * self.walk) * GRID_DT_S
        return on_grid(_NP, head, np.asarray(t, dtype=float)), rate


class DriftWarmup(DriftLinear):
    """The gyro bias decays while the IMU warms up: d (1 + rho exp(-t / T)), rho 1-3, T 20-90 s."""
    form = "warmup"

    def draw(self, rng):
        super().draw(rng)
        self.rho, self.T = float(rng.uniform(1, 3)), float(rng.uniform(20, 90))
        self.params.update(rho=self.rho, warmup_s=self.T)

    def imu(self, t, psi):
        e = np.exp(-t / self.T)
        return self.b * (t + self.rho * self.T * (1 - e)), self.b * (1 + self.rho * e)


class _NpBackend:
    n = 0


_NP = _NpBackend()
