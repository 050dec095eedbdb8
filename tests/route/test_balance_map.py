"""The route's map: the conservative lookup, the margin, the cache key (it changes with the robot's files,
the settings and the version), one computation per setting, and the translation the map relies on."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from jethr1_plan.balance_space.sweep import SweepSpec, sweep
from jethr1_plan.errors import InputError
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.load import load_robot
from jethr1_plan.route import balance_map as bm
from jethr1_plan.route.balance_map import OUTSIDE, MapSettings, cache_dir, cached_map, map_key
from jethr1_plan.scenario import ROBUST_DEFAULT
from tests.route.conftest import synthetic_map


def test_a_point_is_in_the_space_only_when_every_node_around_it_is():
    m = synthetic_map("right", reach_m=0.45, free_m=0.3, slope_n_per_m=80.0, res=0.02)
    ok, thrust, margin, reason, need = m.lookup(np.array([[0.3, 0.2, 0.0],     # inside, between nodes
                                                          [0.449, 0.0, 0.0],   # between the last member and beyond
                                                          [0.0, 0.0, 0.05],    # over the support sole
                                                          [2.0, 0.0, 0.0]]))   # beyond the grid
    assert ok.tolist() == [True, False, False, False]
    # thrust: the largest of the 8 nodes around (80 N/m beyond 0.3 m)
    corners = [np.hypot(x, y) for x in (0.3, 0.32) for y in (0.2, 0.22)]
    assert thrust[0] == pytest.approx(80 * (max(corners) - 0.3))
    assert reason[2] == Reason.OVERLAP and reason[3] == OUTSIDE and not np.isfinite(thrust[3])
    assert margin[0] > 0.05 and margin[1] == 0.0
    assert need[0] <= thrust[0]


def test_the_margin_is_the_distance_to_the_edge_of_the_space():
    m = synthetic_map("right", reach_m=0.45, res=0.02)
    x = m.axes[0]
    iy, iz = int(np.argmin(np.abs(m.axes[1]))), int(np.argmin(np.abs(m.axes[2])))
    ix = int(np.flatnonzero(m.member[:, iy, iz])[-1])  # the last member along +x: next to the edge
    assert m.margin[ix, iy, iz] == pytest.approx(0.01)  # half a cell
    ix2 = int(np.argmin(np.abs(x - 0.35)))
    assert m.margin[ix2, iy, iz] == pytest.approx(x[ix] - x[ix2] + 0.01, abs=1e-9)


def _tiny(side: str = "right", **kw) -> MapSettings:
    return MapSettings(side, 0.05, 23.0, math.radians(5), 0.0, kw.pop("tolerance", NOMINAL), x_range=(0.2, 0.3),
                       y_range=(0.15, 0.25), z_range=(0.0, 0.05), **kw)


def test_the_cache_key_changes_with_the_robot_files_the_settings_and_the_version(tmp_path, monkeypatch):
    robot = load_robot("jethr1")
    key = map_key(robot, _tiny())
    assert map_key(robot, _tiny()) == key
    copy = tmp_path / "jethr1"
    shutil.copytree(robot.yaml_path.parent, copy)
    assert map_key(load_robot(copy / "jethr1.yaml"), _tiny()) == key  # the same bytes elsewhere: the same map
    with (copy / "jethr1.yaml").open("a") as f:
        f.write("\n# edited\n")
    assert map_key(load_robot(copy / "jethr1.yaml"), _tiny()) != key
    urdf = load_robot(copy / "jethr1.yaml").urdf_path
    shutil.copytree(robot.yaml_path.parent, tmp_path / "again")
    (tmp_path / "again" / urdf.name).write_text(urdf.read_text() + "\n<!-- edited -->\n")
    assert map_key(load_robot(tmp_path / "again" / "jethr1.yaml"), _tiny()) != key
    for other in (_tiny("left"), _tiny(tolerance=ROBUST_DEFAULT), MapSettings("right", 0.04, 23.0, math.radians(5), 0.0,
                                                                              NOMINAL)):
        assert map_key(robot, other) != key
    monkeypatch.setattr(bm, "__version__", "0.0.0-other")
    assert map_key(robot, _tiny()) != key


def test_the_cache_key_changes_with_the_sweep_code(monkeypatch):
    """A map an older sweep computed is not reused: the key covers the source of the code computing it."""
    robot = load_robot("jethr1")
    key, digest = map_key(robot, _tiny()), bm.sweep_code_digest()
    assert bm.sweep_code_digest() == digest
    monkeypatch.setattr(bm, "SWEEP_CODE", ("balance_space",))  # fewer files read: another digest
    assert bm.sweep_code_digest() != digest
    monkeypatch.setattr(bm, "sweep_code_digest", lambda: b"an edited sweep")
    assert map_key(robot, _tiny()) != key


def test_a_map_is_computed_once_and_then_read_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("JETHR1_CACHE", str(tmp_path / "env"))
    assert cache_dir() == tmp_path / "env"
    assert cache_dir(tmp_path / "given") == tmp_path / "given"
    robot = load_robot("jethr1")
    said: list[str] = []
    first = cached_map(robot, _tiny(), None, say=said.append)
    assert "computing" in said[0] and first.path is not None and first.path.parent == tmp_path / "env" / "balance_space"
    second = cached_map(robot, _tiny(), None, say=said.append)
    assert "reused" in said[-1] and second.reused and not first.reused
    for a, b in ((first.thrust, second.thrust), (first.reason, second.reason)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(first.p_body, second.p_body, atol=1e-6)  # kept in float32
    first.path.write_bytes(b"not a map")  # a damaged file is not trusted, nor replaced: named, in one line
    with pytest.raises(InputError, match=r"not a balance-space map jethr1 wrote .*remove it"):
        cached_map(robot, _tiny(), None, say=said.append)
    assert first.path.read_bytes() == b"not a map"
    first.path.unlink()  # removed: computed again
    said.clear()
    cached_map(robot, _tiny(), None, say=said.append)
    assert "computing" in said[0]


def test_the_balance_space_translates_with_the_support_sole():
    """The map is swept once with the support at the origin and used at every support position: the
    same cells around a support moved by (0.3, -0.2, 0.05) m have the same membership and thrust."""
    base = dict(robot="jethr1", support_side="right", resolution_m=0.05, thrust_max_n=23.0, tolerance=ROBUST_DEFAULT)
    shift = np.array([0.3, -0.2, 0.05])
    ranges = dict(x_range=(0.35, 0.6), y_range=(0.1, 0.25), z_range=(0.0, 0.05))
    a = sweep(SweepSpec(support_xyz=(0.0, 0.0, 0.0), **ranges, **base))
    b = sweep(SweepSpec(support_xyz=tuple(shift), **{k: (lo + s, hi + s) for (k, (lo, hi)), s in
                                                      zip(ranges.items(), shift, strict=True)}, **base))
    np.testing.assert_allclose(b.swing - shift, a.swing, atol=1e-9)
    np.testing.assert_array_equal(a.reason, b.reason)
    assert a.with_thrust.any() and (~a.with_thrust).any() and (a.thrust[a.with_thrust] > 0).any()
    np.testing.assert_allclose(a.thrust[a.with_thrust], b.thrust[b.with_thrust], atol=1e-6)
