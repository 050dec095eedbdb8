"""Paper B's pelvic-yaw MPC (B-34..B-38), smoothing the body yaw that (A-4) gives.

The yaw is a double integrator, θ_{i+1} = A θ_i + B θ̈_i with θ = (θ, θ̇) (B-34). At each control
step an N-step horizon (B-35, B-36) is optimised with ``placo.Problem``:

    min  α/2 ‖Θ_ref − Θ‖² + β/2 ‖Θ̈‖²   s.t.  θ_min ≤ θ ≤ θ_max                     (B-37)

and only the first acceleration is applied (B-38). Θ_ref is the (A-4) yaw along the whole
sequence (transfers blend it with minimum jerk), so the MPC sees the turn coming and starts it
earlier. The bounds are the trunk yaws the hip-yaw joints allow with the feet facing +x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.control.time_laws import min_jerk, swing_row_positions

__all__ = ["YawSchedule", "build_schedule", "inverse_min_jerk", "mpc_smooth", "yaw_mpc_step", "yaw_step_state"]


def yaw_mpc_step(state: np.ndarray, ref: np.ndarray, dt: float, alpha: float = 1.0, beta: float = 1e-10,
                 lo: float = -np.inf, hi: float = np.inf) -> tuple[float, np.ndarray, np.ndarray]:
    """One update of (B-37): from the yaw state (θ [rad], θ̇ [rad/s]) over the horizon of the reference
    ``ref`` (N,) [rad] at steps of ``dt`` [s], minimise α/2‖Θ_ref − Θ‖² + β/2‖Θ̈‖² within [lo, hi].
    Returns the first acceleration [rad/s²] (B-38), the state after it (B-34) and the predicted yaws (N,) [rad]."""
    import placo

    n = len(ref)
    problem = placo.Problem()
    u = problem.add_variable(n)
    integ = placo.Integrator(u, np.asarray(state, dtype=float).copy(), 2, dt)
    for k in range(1, n + 1):
        problem.add_constraint(integ.expr(k, 0) == ref[k - 1]).configure("soft", alpha)
        if np.isfinite(lo):
            problem.add_constraint(integ.expr(k, 0) >= lo)
        if np.isfinite(hi):
            problem.add_constraint(integ.expr(k, 0) <= hi)
    problem.add_constraint(u.expr() == np.zeros(n)).configure("soft", beta)
    problem.solve()
    acc = np.asarray(u.value, dtype=float)
    predicted = np.empty(n)
    x = np.asarray(state, dtype=float).copy()
    for k in range(n):
        x = integ.A @ x + integ.B.ravel() * acc[k]
        predicted[k] = x[0]
        if k == 0:
            first = x.copy()
    return float(acc[0]), first, predicted


def yaw_step_state(state: np.ndarray, acc: float, dt: float) -> np.ndarray:
    """(B-34): the yaw state (θ, θ̇) after ``dt`` [s] at the angular acceleration ``acc`` [rad/s²]."""
    theta, rate = state
    return np.array([theta + dt * rate + 0.5 * dt * dt * acc, rate + dt * acc])


def mpc_smooth(ref: np.ndarray, dt: float, horizon_s: float = 1.6, alpha: float = 1.0, beta: float = 1e-10,
               lo: float = -np.inf, hi: float = np.inf) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Receding-horizon yaw (θ [rad], θ̇ [rad/s], θ̈ [rad/s²]) at every step of the reference ``ref``."""
    ref = np.asarray(ref, dtype=float)
    m = len(ref)
    n = max(2, round(horizon_s / dt))
    padded = np.concatenate([ref, np.full(n + 1, ref[-1])])
    state = np.array([float(np.clip(ref[0], lo, hi)), 0.0])
    theta, rate, acc = np.zeros(m), np.zeros(m), np.zeros(m)
    for i in range(m):
        theta[i], rate[i] = state
        acc[i], state, _ = yaw_mpc_step(state, padded[i + 1:i + n + 1], dt, alpha, beta, lo, hi)
    return theta, rate, acc


def inverse_min_jerk(s: np.ndarray) -> np.ndarray:
    """t ∈ [0, 1] with min_jerk(t) = s (monotone, so by interpolation on a fine grid)."""
    grid = np.linspace(0.0, 1.0, 20001)
    return np.interp(s, min_jerk(grid), grid)


@dataclass
class YawSchedule:
    """The smoothed yaw at every output row, and at every swing sample of every step."""

    row_yaw: np.ndarray  # (rows,) [rad]
    row_ref: np.ndarray  # (rows,) the reference [rad]
    sample_yaw: list[np.ndarray]  # per step, (samples,) [rad]

    def at_row(self, i: int) -> float:
        return float(self.row_yaw[i])


def build_schedule(scenario, robot, eq4_of_step, sample_paths, horizon_s: float, alpha: float, beta: float
                   ) -> YawSchedule:
    """Lay out the rows exactly as the sequence builder will, fill the (A-4) reference and smooth it.

    Args:
        eq4_of_step: per step, the (A-4) yaw as a function of the swing sole position.
        sample_paths: per step, the swing path samples (N, 3).
    """
    tm = scenario.timing
    dt = 1.0 / tm.rate_hz
    n_tr, n_sw = max(1, round(tm.transfer_s * tm.rate_hz)), max(1, round(tm.swing_s * tm.rate_hz))
    ref: list[float] = []
    swing_starts = []
    yaw_prev = 0.0
    for yaw_of, path in zip(eq4_of_step, sample_paths, strict=True):
        yaw_first = yaw_of(path[0])
        d = (yaw_first - yaw_prev + np.pi) % (2 * np.pi) - np.pi
        ref += [yaw_prev + float(min_jerk(k / n_tr)) * d for k in range(n_tr)]
        swing_starts.append(len(ref))
        idx = np.arange(len(path))
        for u in swing_row_positions(len(path), tm.swing_s, tm.rate_hz):
            ref.append(yaw_of(np.array([np.interp(u, idx, path[:, j]) for j in range(3)])))
        yaw_prev = yaw_of(path[-1])
    ref += [yaw_prev] * (n_tr + 1)
    reference = np.unwrap(np.asarray(ref))
    i_yaw = robot.legs["left"].index[0]  # the hip yaw
    lo, hi = -robot.upper_rad[i_yaw], -robot.lower_rad[i_yaw]  # trunk yaw = foot yaw (0) − hip yaw
    yaw, _, _ = mpc_smooth(reference, dt, horizon_s, alpha, beta, lo, hi)
    samples = []
    for start, path in zip(swing_starts, sample_paths, strict=True):
        frac = inverse_min_jerk(np.arange(len(path)) / (len(path) - 1)) * n_sw  # fractional row index
        samples.append(np.interp(start + frac, np.arange(len(yaw)), yaw))
    return YawSchedule(row_yaw=yaw, row_ref=reference, sample_yaw=samples)
