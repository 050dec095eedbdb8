"""robot.wrappers: a PlaCo RobotWrapper handed out again is, to the bit, a new one (state, model, kinematics and
dynamics), one still held is never handed out, and plans made one after another in a process make a bounded
number of them (PlaCo keeps 0.36 MB of every one it frees)."""

from __future__ import annotations

import numpy as np

from jethr1_plan.robot import wrappers
from tests.conftest import ROOT


def _readings(w, robot) -> dict[str, np.ndarray]:
    """Everything the planner reads from a wrapper, at a set posture, velocity and acceleration."""
    rng = np.random.default_rng(7)
    out: dict[str, np.ndarray] = {"q0": np.array(w.state.q), "qd0": np.array(w.state.qd),
                                  "qdd0": np.array(w.state.qdd), "com0": np.array(w.com_world())}
    for name in wrappers.MODEL_VECTORS:
        out[name] = np.array(getattr(w.model, name))
    out["gravity vector"] = np.array(w.model.gravity.vector)
    frames = [robot.legs[s].sole for s in ("left", "right")] + [f.frame for f in robot.fans] + [robot.trunk]
    for f in frames:  # the neutral posture's frames, as a new wrapper has them before any update
        out[f"neutral {f}"] = np.array(w.get_T_world_frame(f))
    T = np.eye(4)
    T[:3, 3] = [0.1, -0.05, 0.42]
    w.set_T_world_fbase(T)
    w.state.q[7:] = np.clip(rng.uniform(-0.4, 0.4, len(robot.joint_names)), robot.lower_rad, robot.upper_rad)
    w.state.qd = rng.uniform(-1, 1, len(w.state.qd))
    w.state.qdd = rng.uniform(-1, 1, len(w.state.qdd))
    w.update_kinematics()
    for f in frames:
        out[f"T {f}"] = np.array(w.get_T_world_frame(f))
        out[f"J {f}"] = np.array(w.frame_jacobian(f, "local_world_aligned"))
    out.update(com=np.array(w.com_world()), M=np.array(w.mass_matrix()), nle=np.array(w.non_linear_effects()),
               centroidal=np.array(w.centroidal_map()), gravity=np.array(w.generalized_gravity()),
               com_jacobian=np.array(w.com_jacobian()))
    return out


def _spoil(w, robot) -> None:
    """A use that changes all a user can change: the posture, rates, a narrowed knee limit, a rate limit, gravity and
    a PlaCo IK solve."""
    import placo

    k = 7 + robot.legs["left"].index[3]
    w.model.lowerPositionLimit[k] += 0.3
    w.model.velocityLimit[6] = 0.5
    w.set_gravity(np.array([0.0, 0.0, -1.0]))
    w.state.q[7:] = 0.2
    w.state.qd[:] = 3.0
    w.state.qdd[:] = -2.0
    w.update_kinematics()
    solver = placo.KinematicsSolver(w)
    solver.mask_fbase(True)
    task = solver.add_frame_task(robot.legs["left"].sole, w.get_T_world_frame(robot.legs["left"].sole))
    task.configure("left", "soft", 1.0, 1.0)
    solver.solve(True)
    w.update_kinematics()


def test_a_wrapper_handed_out_again_after_a_use_is_bitwise_a_new_one(robot) -> None:
    """Handed out, spoilt, dropped and handed out again (the same object: it is reused), every reading of it is
    the bytes of a wrapper PlaCo makes afresh; so is its first use."""
    import placo

    fresh = _readings(placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions), robot)
    w = robot.wrapper()
    first = id(w)
    _spoil(w, robot)
    del w
    again = robot.wrapper()
    assert id(again) == first  # the kept one, not a new one
    got = _readings(again, robot)
    assert got.keys() == fresh.keys()
    for name, value in fresh.items():
        assert np.array_equal(got[name], value), name
    _spoil(again, robot)  # and once more, after readings that updated everything
    del again
    got = _readings(robot.wrapper(), robot)
    for name, value in fresh.items():
        assert np.array_equal(got[name], value), name


def test_a_wrapper_still_held_is_never_handed_out(robot) -> None:
    """Two held at once are two objects; the posture solver's wrapper (which it keeps beside PlaCo's solver, as
    PlaCo asks) and a wrapper whose model is still held are left alone while others are handed out."""
    from jethr1_plan.kinematics.placo import PlacoPostureSolver

    a, b = robot.wrapper(), robot.wrapper()
    assert a is not b
    solver = PlacoPostureSolver(robot)
    solver.robot.state.q[7:] = 0.1
    model = a.model
    a.state.q[7:] = 0.2
    del a
    others = [robot.wrapper() for _ in range(3)]
    assert all(o is not b and o is not solver.robot for o in others)
    assert np.all(solver.robot.state.q[7:] == 0.1)
    assert all(not np.any(o.state.q[7:]) for o in others)  # handed out neutral: none is the one still held
    assert model.nq == len(b.state.q)


def test_a_changed_urdf_at_the_same_path_gets_its_own_wrapper(tmp_path) -> None:
    """The key is the URDF's bytes as well as its path: a URDF rewritten in place is read afresh."""
    import shutil

    from jethr1_plan.robot.load import forget_robots

    folder = tmp_path / "jethr1"
    shutil.copytree(ROOT / "robots" / "jethr1", folder)
    urdf = next(folder.glob("*.urdf"))
    w = wrappers.hand_out(urdf)
    mass = float(w.total_mass())
    del w
    urdf.write_text(urdf.read_text().replace('<mass value="', '<mass value="1', 1))
    forget_robots()
    assert float(wrappers.hand_out(urdf).total_mass()) > mass + 0.9


def test_the_kept_wrappers_are_bounded(tmp_path) -> None:
    """Wrappers of more URDFs than MAX_MODELS, several held at once: at most MAX_MODELS × MAX_PER_MODEL kept."""
    import shutil

    wrappers.forget_wrappers()
    held = []
    for i in range(wrappers.MAX_MODELS + 2):
        folder = tmp_path / f"r{i}"
        shutil.copytree(ROOT / "robots" / "jethr1", folder)
        urdf = next(folder.glob("*.urdf"))
        urdf.write_text(urdf.read_text() + f"<!-- {i} -->\n")
        held += [wrappers.hand_out(urdf) for _ in range(wrappers.MAX_PER_MODEL + 1)]
    assert wrappers.kept() == wrappers.MAX_MODELS * wrappers.MAX_PER_MODEL
    del held


def test_plans_one_after_another_make_few_wrappers_and_the_same_rows(monkeypatch) -> None:
    """Three plans in one process (Paper A's forward step, the side step, the forward step again): PlaCo makes at
    most two wrappers in all (one per wrapper held at once; without reuse, about four a plan), and the third plan's
    rows and figures are the first's bytes: nothing of a use leaks into the next."""
    import placo

    from jethr1_plan.planning.plan import plan
    from jethr1_plan.scenario import load_scenario

    wrappers.forget_wrappers()
    made: list[str] = []
    real = placo.RobotWrapper

    def counting(*args):
        made.append(str(args[0]))
        return real(*args)

    monkeypatch.setattr(placo, "RobotWrapper", counting)
    forward = ROOT / "configs" / "forward_ditch_450_fast.yaml"
    first = plan(load_scenario(forward)).rows
    plan(load_scenario(ROOT / "configs" / "side_step.yaml"))
    third = plan(load_scenario(forward)).rows
    assert 1 <= len(made) <= 2
    assert first is not None and third is not None
    assert first.columns.keys() == third.columns.keys()
    for col, values in first.columns.items():
        a, b = np.asarray(values), np.asarray(third.columns[col])
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), col
    assert repr(first.analysis) == repr(third.analysis)
