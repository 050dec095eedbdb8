"""pipeline.walk: a walk generated, analysed, judged, its servo commands and (when asked) its rehearsal; the arms'
effect measured against the same walk with the arms held."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from jethr1_plan.pipeline import walk as pipeline
from jethr1_plan.walking.spec import load_walk_text
from tests.conftest import ROOT


def _two_steps(**success: object):
    doc = yaml.safe_load((ROOT / "configs" / "walks" / "dyros_walk.yaml").read_text())
    doc["footsteps"]["count"] = 2
    doc["success"].update(success)
    return load_walk_text(yaml.safe_dump(doc), "two_steps.yaml")


@pytest.fixture(scope="module")
def walked():
    return pipeline.run_walk(_two_steps(), rehearse=False)


def test_the_commands_are_the_rows_plus_the_filtered_sag(walked) -> None:
    """commands = q + low-pass(τ)/k: a first-order low-pass never exceeds its input's largest magnitude."""
    q, tau = walked.walk.q, walked.analysis.tau
    k = walked.spec.robot.servo_stiffness_nm_per_rad
    assert walked.commands_rad.shape == q.shape
    sag = walked.commands_rad - q
    assert np.all(np.abs(sag) <= np.max(np.abs(tau), axis=0) / k + 1e-12)
    assert np.max(np.abs(sag)) > 0  # the legs carry the robot: there is a sag to compensate


def test_swinging_arms_lower_the_peak_yaw_momentum(walked) -> None:
    """Paper B (B-43): the arms cancel the lower body's yaw momentum; held, the same walk's peak is larger."""
    w = walked.walk
    with_arms = float(np.max(np.abs(w.h_low + w.h_up)))
    assert walked.armless_peak_momentum_nms is not None
    assert walked.armless_peak_momentum_nms > with_arms


def test_no_rehearsal_unless_asked(walked, monkeypatch) -> None:
    assert walked.rehearsal is None
    asked = []
    monkeypatch.setattr(pipeline, "rehearse_walk", lambda walk, commands: asked.append(commands) or "run")
    assert pipeline.run_walk(_two_steps(rehearse=False)).rehearsal is None and not asked  # the spec says no
    result = pipeline.run_walk(_two_steps(rehearse=False), rehearse=True)  # the caller overrides it
    assert result.rehearsal == "run" and np.array_equal(asked[0], result.commands_rad)
