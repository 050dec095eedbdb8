"""PlaCo ``RobotWrapper``\\ s kept for reuse within a process, each handed out in the state a new one has.

PlaCo (0.10) never frees a wrapper's pinocchio ``Data`` (about 0.36 MB for Jet-HR1): every wrapper made and
dropped keeps that much of the process's memory for good. Planning makes several per plan, so a process that
plans on and on grows without bound. Here a wrapper is made once per URDF (its path, its bytes and PlaCo's
flags) and handed out again once nobody holds it:

* **free** is told by the reference count: a wrapper only this module refers to is free. Whatever is still
  tied to it (a name, an attribute, its ``model`` or ``state`` taken out) keeps it taken. A PlaCo
  ``KinematicsSolver`` holds its wrapper by a C++ reference alone: whoever uses one keeps its wrapper too (as
  PlaCo asks anyway: a wrapper freed under its solver is memory freed under it).
* **a hand-out** returns it to a new wrapper's state: :meth:`placo.RobotWrapper.reset` (q neutral, q̇ and q̈
  zero), the model's joint limits, effort limits, rotor terms and gravity as the URDF gave them (whoever
  narrowed a limit, as the walk's IK does, had it only while holding the wrapper), and the forward
  kinematics of the neutral posture. A wrapper whose model cannot be put back is let go, never handed out.
* **the bound**: the wrappers of the :data:`MAX_MODELS` URDFs handed out last, at most :data:`MAX_PER_MODEL`
  each; beyond that a new wrapper is made and not kept (as PlaCo would do without this module).

A sweep over many URDFs (``jethr1 design``: one per variant) still makes a wrapper or two per URDF; its bound
comes from the processes it runs in (``studies.design``).
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["MAX_MODELS", "MAX_PER_MODEL", "forget_wrappers", "hand_out", "kept", "made"]

MAX_MODELS = 4  # URDFs whose wrappers are kept (the ones handed out last)
MAX_PER_MODEL = 8  # wrappers kept per URDF (as many as were held at once, up to this)
#: the model's vectors a user may change through PlaCo or pinocchio (limits, rotor terms), put back on a hand-out
MODEL_VECTORS = ("lowerPositionLimit", "upperPositionLimit", "velocityLimit", "effortLimit", "rotorInertia",
                 "rotorGearRatio", "armature", "friction", "damping")


def _only_here_count() -> int:
    """``sys.getrefcount`` of an object held by one list only, as :func:`_is_free` reads it."""
    slot: list[Any] = [object()]
    return sys.getrefcount(slot[0])


_FREE_REFS = _only_here_count()


@dataclass
class _Kept:
    """The wrappers of one URDF and its model's vectors as PlaCo first read them."""

    wrappers: list[Any] = field(default_factory=list)
    model: dict[str, np.ndarray] = field(default_factory=dict)


_lock = threading.Lock()
_kept: OrderedDict[tuple[str, int, str], _Kept] = OrderedDict()
_made = 0


def made() -> int:
    """How many wrappers this module has made in this process."""
    return _made


def kept() -> int:
    """How many wrappers are kept now (free or held)."""
    with _lock:
        return sum(len(k.wrappers) for k in _kept.values())


def forget_wrappers() -> None:
    """Let go of every kept wrapper (those still held stay with their holders)."""
    with _lock:
        _kept.clear()


def _is_free(slot: list[Any], i: int) -> bool:
    return sys.getrefcount(slot[i]) == _FREE_REFS


def _model_vectors(wrapper) -> dict[str, np.ndarray]:
    model = wrapper.model
    out = {name: np.array(getattr(model, name), dtype=float) for name in MODEL_VECTORS if hasattr(model, name)}
    out["gravity"] = np.array(model.gravity.vector, dtype=float)
    return out


def _put_back(wrapper, first: dict[str, np.ndarray]) -> bool:
    """Put the model's vectors back as ``first`` holds them; whether they are all equal to it now."""
    model = wrapper.model
    now = _model_vectors(wrapper)
    for name, value in first.items():
        if np.array_equal(now[name], value):
            continue
        if name == "gravity":
            import pinocchio

            model.gravity = pinocchio.Motion(value.copy())
        else:
            setattr(model, name, value.copy())
    again = _model_vectors(wrapper)
    return all(np.array_equal(again[name], value) for name, value in first.items())


def _new(path: str, flags: int):
    global _made
    import placo

    wrapper = placo.RobotWrapper(path, flags)
    _made += 1
    return wrapper


def _digest(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def hand_out(urdf_path: str | os.PathLike, flags: int | None = None):
    """A PlaCo ``RobotWrapper`` of the URDF at ``urdf_path`` with PlaCo ``flags`` (default
    ``ignore_collisions``), in the state a new one has: a kept one nobody holds, else a new one (kept while
    the bounds allow). Raises what ``placo.RobotWrapper`` raises for a URDF it cannot load, and ``OSError``
    for a file that cannot be read."""
    import placo

    flags = int(placo.Flags.ignore_collisions) if flags is None else int(flags)
    path = os.path.realpath(urdf_path)
    key = (path, flags, _digest(path))
    with _lock:
        entry = _kept.get(key)
        if entry is not None:
            _kept.move_to_end(key)
            slot = entry.wrappers
            for i in range(len(slot)):
                if _is_free(slot, i):
                    wrapper = slot[i]
                    wrapper.reset()
                    if _put_back(wrapper, entry.model):
                        wrapper.update_kinematics()
                        return wrapper
                    del slot[i]  # a model that cannot be put back: never handed out again
                    del wrapper
                    break
        wrapper = _new(path, flags)
        if entry is None:
            entry = _kept[key] = _Kept(model=_model_vectors(wrapper))
            while len(_kept) > MAX_MODELS:
                _kept.popitem(last=False)
        if len(entry.wrappers) < MAX_PER_MODEL:
            entry.wrappers.append(wrapper)
        return wrapper
