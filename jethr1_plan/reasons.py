"""Why a posture, a sample or a cell is not feasible: one vocabulary for every layer.

The kinematics report the first three (and OK), the balance model the next three, the balance-space
sweep adds OVERLAP. Codes travel as small integers in numpy arrays (``int8``) and in the compiled
kernel; :func:`message` turns one into the text written to summary.json, the CSV's ``reason``
column and the balance-space files.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

__all__ = ["Reason", "balances", "has_posture", "ik_failed", "message"]


class Reason(IntEnum):
    """Reason codes (the ``int8`` values in arrays), each with its message."""

    OK = 0
    UNREACHABLE = 1  # a leg cannot reach its sole from this P_body
    JOINT_LIMIT = 2  # the posture leaves the URDF's joint limits
    NOT_CONVERGED = 3  # PlaCo's IK did not converge (neither of the above)
    NO_BALANCE = 4  # no thrust within the fan's window holds the ZMP in the sole
    THRUST_MAX = 5  # the thrust needed is above the fan's maximum
    EDGE_ANGLE = 6  # the edge angle of is above ρ
    OVERLAP = 7  # balance space: the swing sole overlaps the support sole

    @property
    def message(self) -> str:
        return _MESSAGES[self]


_MESSAGES = {
    Reason.OK: "",
    Reason.UNREACHABLE: "out of reach",
    Reason.JOINT_LIMIT: "joint limits",
    Reason.NOT_CONVERGED: "IK not converged",
    Reason.NO_BALANCE: "no thrust can balance",
    Reason.THRUST_MAX: "thrust above its maximum",
    Reason.EDGE_ANGLE: "edge angle (A-10)",
    Reason.OVERLAP: "overlaps the support sole",
}


def message(code: int) -> str:
    """The text of reason ``code`` ('' for OK)."""
    return Reason(int(code)).message


def ik_failed(codes: np.ndarray) -> np.ndarray:
    """Where the kinematics gave no valid posture (out of reach, joint limits, not converged)."""
    codes = np.asarray(codes)
    return (codes >= Reason.UNREACHABLE) & (codes <= Reason.NOT_CONVERGED)


def has_posture(codes: np.ndarray) -> np.ndarray:
    """Where a kinematically valid posture exists (whatever its balance)."""
    codes = np.asarray(codes)
    return ~ik_failed(codes) & (codes != Reason.OVERLAP)


def balances(codes: np.ndarray) -> np.ndarray:
    """Where the posture meets every constraint but perhaps the fan's maximum."""
    codes = np.asarray(codes)
    return (codes == Reason.OK) | (codes == Reason.THRUST_MAX)
