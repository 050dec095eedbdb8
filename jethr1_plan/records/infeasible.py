"""The first infeasible sample or row of a plan: where (step, phase, sample, time), why (the reason),
and, where the optimiser refused a sample under the robust policy, the share of the tolerance the most
robust posture held there. summary.json's ``first_infeasible`` is :meth:`Infeasible.to_dict`; the
planner raises :class:`InfeasibleAt` with it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.records.plan_columns import TOLERANCE_SHARE

__all__ = ["Infeasible", "InfeasibleAt", "ShareAt"]


@dataclass(frozen=True)
class ShareAt:
    """The share of the tolerance a refused sample holds, the tolerance it means, and the least share
    the scenario accepts (``balance.robust.min_share``)."""

    share: float
    thrust_error: float
    mass_error: float
    com_error_m: float
    min_share: float

    def to_dict(self) -> dict:
        return {"share": self.share, "thrust_error": self.thrust_error, "mass_error": self.mass_error,
                "com_error_m": self.com_error_m, "min_share": self.min_share}

    @classmethod
    def from_dict(cls, d: dict) -> ShareAt:
        return cls(d["share"], d["thrust_error"], d["mass_error"], d["com_error_m"], d["min_share"])


@dataclass(frozen=True)
class Infeasible:
    """The first infeasible swing sample (``time_s`` None: the optimiser's, with the sample's ``thrust_n``
    and ``share``) or output row (``time_s``: the row's time [s]).

    ``p_body_m``, ``swing_m``: P_body and the swing sole there [m], where known."""

    step: int
    phase: str
    sample: int
    reason: str
    time_s: float | None = None
    p_body_m: tuple[float, ...] | None = None
    swing_m: tuple[float, ...] | None = None
    thrust_n: float | None = None
    share: ShareAt | None = None
    row: int | None = None  # a row named by its index alone (a sequence rebuilt from executed steps)

    @classmethod
    def at_row(cls, row: int, reason: str) -> Infeasible:
        """The row of index ``row``, refused for ``reason``."""
        return cls(-1, "", -1, reason, row=row)

    @property
    def optimised(self) -> bool:
        """A sample the optimiser refused (not a row of the sequence)."""
        return self.time_s is None and self.row is None

    def to_dict(self) -> dict:
        """summary.json's ``first_infeasible``."""
        if self.row is not None:
            return {"row": self.row, "reason": self.reason}
        if self.optimised:
            out = {"step": self.step, "phase": self.phase, "sample": self.sample, "swing_m": _list(self.swing_m),
                   "p_body_m": _list(self.p_body_m), "thrust_n": self.thrust_n, "reason": self.reason}
            if self.share is not None:
                out[TOLERANCE_SHARE] = self.share.to_dict()
            return out
        out = {"time_s": self.time_s, "step": self.step, "phase": self.phase, "sample": self.sample,
               "reason": self.reason}
        if self.p_body_m is not None:
            out["p_body_m"] = _list(self.p_body_m)
        if self.swing_m is not None:
            out["swing_m"] = _list(self.swing_m)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> Infeasible:
        """The record of a summary.json's ``first_infeasible``."""
        if "row" in d:
            return cls.at_row(int(d["row"]), str(d["reason"]))
        share = d.get(TOLERANCE_SHARE)
        return cls(int(d["step"]), str(d["phase"]), int(d["sample"]), str(d["reason"]), d.get("time_s"),
                   _tuple(d.get("p_body_m")), _tuple(d.get("swing_m")), d.get("thrust_n"),
                   ShareAt.from_dict(share) if share is not None else None)

    def describe(self) -> str:
        """One line: where, the swing sole, the reason, the thrust and the tolerance share held."""
        if self.row is not None:
            return f"infeasible at row {self.row}: {self.reason}"
        where = f"step {self.step} {self.phase} sample {self.sample}"
        pos = f" (swing sole at {np.round(self.swing_m, 4).tolist()} m)" if self.swing_m is not None else ""
        thrust = f", minimal thrust {self.thrust_n:.2f} N" if self.thrust_n is not None else ""
        s = self.share
        if s is not None:
            thrust += (f"; the most robust posture found there holds {100 * s.share:.1f} % of the tolerance "
                       f"(±{100 * s.thrust_error:.1f} % thrust, ±{100 * s.mass_error:.1f} % mass, "
                       f"{1000 * s.com_error_m:.1f} mm of CoM error)" if s.share > 0 else
                       "; no posture balances this sample even without tolerance")
        return f"infeasible at {where}{pos}: {self.reason}{thrust}"


def _list(v: tuple[float, ...] | None) -> list[float] | None:
    return None if v is None else list(v)


def _tuple(v) -> tuple[float, ...] | None:
    return None if v is None else tuple(v)


class InfeasibleAt(InfeasiblePlan):
    """The plan is infeasible (exit 3) at ``first``; ``summary``: the summary.json of what was planned."""

    def __init__(self, first: Infeasible, summary: dict | None = None) -> None:
        super().__init__(first.describe(), summary)
        self.first = first
