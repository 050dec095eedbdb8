"""reasons: one vocabulary of why a posture, a sample or a cell fails; the classes every layer tests codes by."""

from __future__ import annotations

import numpy as np

from jethr1_plan.reasons import Reason, balances, has_posture, ik_failed, message


def test_every_code_has_its_message_and_fits_an_int8() -> None:
    assert message(Reason.OK) == ""
    assert all(message(r) for r in Reason if r != Reason.OK)
    assert len({message(r) for r in Reason}) == len(Reason)
    assert all(np.int8(r) == int(r) for r in Reason)
    assert message(np.int8(4)) == Reason.NO_BALANCE.message


def test_the_classes_partition_the_codes() -> None:
    codes = np.array([int(r) for r in Reason], dtype=np.int8)
    ik, posture, ok = ik_failed(codes), has_posture(codes), balances(codes)
    assert [Reason(int(c)) for c in codes[ik]] == [Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NOT_CONVERGED]
    assert not np.any(ik & posture)  # a failed IK has no posture
    assert not posture[codes == Reason.OVERLAP][0] and not ik[codes == Reason.OVERLAP][0]
    assert [Reason(int(c)) for c in codes[ok]] == [Reason.OK, Reason.THRUST_MAX]
    assert np.all(posture[ok])  # a balanced posture is a posture
