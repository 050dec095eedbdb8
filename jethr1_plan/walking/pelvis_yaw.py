"""The pelvic rotation (Paper B, V-B and V-C): a look-ahead reference from the predicted CoM and the
planned feet (B-27..B-33), smoothed by the yaw MPC (B-34..B-38, ``planning.yaw_mpc``).

At each MPC update the pelvis is predicted where the CoM is predicted (B-27); with each foot's
planned position at the same future instant, the reference angle is the mean of the two feet's
angles (B-30..B-32):

    θ_LFP = atan(k_pel·Δd_LFP,x / Δd_LFP,y),   θ_RFP = atan(k_pel·Δd_RFP,x / Δd_RFP,y),
    θ_ref = (θ_LFP + θ_RFP)/2

Δd the foot's position minus the pelvis's (B-28, B-29). A foot ahead on the left and one behind on
the right both give a positive angle, and the pelvis turns so that the leading leg's hip moves
forward: Paper B measures the angle about −z (Dyros-Jet's yaw axes point down). Here yaws are about
+z (x forward, y left, z up), so the pelvic rotation applied is −θ_ref: a left hip moves forward
under a negative yaw.
"""

from __future__ import annotations

import numpy as np

__all__ = ["reference_yaw"]


def reference_yaw(pelvis_xy: np.ndarray, left_xy: np.ndarray, right_xy: np.ndarray, k_pel: float) -> np.ndarray:
    """(B-30..B-32): the reference pelvic rotation [rad] at each of N future instants, as a yaw about
    +z (Paper B's angle, measured about −z, negated).

    Args:
        pelvis_xy, left_xy, right_xy: (N, 2) the predicted pelvis and both planned soles [m].
        k_pel: the share of the foot's forward distance the pelvis's rotation is to cover.
    """
    d_left = np.asarray(left_xy, dtype=float) - pelvis_xy
    d_right = np.asarray(right_xy, dtype=float) - pelvis_xy
    theta_left = np.arctan(k_pel * d_left[:, 0] / d_left[:, 1])
    theta_right = np.arctan(k_pel * d_right[:, 0] / d_right[:, 1])
    return -0.5 * (theta_left + theta_right)
