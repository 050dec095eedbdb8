"""The route's map: the balance space of one support side in the support sole's frame, computed once
and cached on disk.

A map is the balance space (``balance_space.sweep``) of a robot with its support sole at the origin,
for one support side, balance policy and tolerance, sole margin, thrust limit, edge angle ρ and grid
resolution. The physics does not change when both soles move together (gravity and thrust are
vertical, the body yaw of (A-4) depends on the soles' relative position), so the map of a support
sole at S is the map translated by S; the soles keep yaw 0, as in Paper A and as the balance space
assumes.

**Cache.** Maps are kept in ``<cache>/balance_space/<robot>-<side>-<key>.npz``; ``<cache>`` is
``--cache DIR``, else ``$JETHR1_CACHE``, else ``$XDG_CACHE_HOME/jethr1``, else ``~/.cache/jethr1``.
The key is the SHA-256 of the robot's URDF and YAML bytes, every setting of the sweep, the
package's version and the source of the code that computes a map (the balance_space, physics,
kinematics and optimisers packages): a change to any of them computes a new map, so a map is never
one an older sweep computed. Files are written atomically.

**Lookup** (:meth:`BalanceMap.lookup`): a point is in the space when the 8 grid nodes around it all
are (conservative: the space is sampled, and a point between a member and a non-member may be
either); its thrust is the largest of the 8, its margin the least of their distances to the edge
of the space (a distance transform of the member nodes).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import time
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from jethr1_plan import __version__
from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import read_input
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import RobotModel

__all__ = ["FORMAT", "OUTSIDE", "BalanceMap", "MapSettings", "cache_dir", "cached_map", "map_key"]

FORMAT = 2  # the cache file's layout; part of the key
OUTSIDE = -1  # reason code of a point outside the map's grid (beyond the region a step can reach)
#: the grid around the support sole [m], as ``balance-space``'s defaults (x, sideways towards the swing
#: foot, z): everything a step can reach; z from 0.12 m below the support, for steps down
X_RANGE = (-0.8, 0.9)
SIDE_RANGE = (-0.7875, 0.9125)
Z_RANGE = (-0.12, 0.3)


@dataclass(frozen=True)
class MapSettings:
    """Everything a map depends on, beside the robot (SI units)."""

    support_side: str
    resolution_m: float
    thrust_max_n: float
    rho_rad: float
    sole_margin_m: float
    tolerance: Tolerance
    x_range: tuple[float, float] = X_RANGE
    y_range: tuple[float, float] | None = None  # default: SIDE_RANGE towards the swing foot
    z_range: tuple[float, float] = Z_RANGE

    @property
    def y(self) -> tuple[float, float]:
        if self.y_range is not None:
            return self.y_range
        lo, hi = SIDE_RANGE
        return (lo, hi) if self.support_side == "right" else (-hi, -lo)

    def as_dict(self) -> dict:
        return {"support_side": self.support_side, "resolution_m": self.resolution_m,
                "thrust_max_n": self.thrust_max_n, "rho_rad": self.rho_rad, "sole_margin_m": self.sole_margin_m,
                "tolerance": asdict(self.tolerance), "x_range_m": list(self.x_range), "y_range_m": list(self.y),
                "z_range_m": list(self.z_range), "method": "continuation"}


MAX_MAP_BYTES = 200_000_000  # a cached map is a few megabytes (compressed)
MAX_MAP_EXPANDED_BYTES = 2_000_000_000  # its arrays: 17 bytes a cell, at most
SWEEP_CODE = ("balance_space", "physics", "kinematics", "optimisers")  # the packages that compute a map


def sweep_code_digest() -> bytes:
    """SHA-256 of the source files (names and bytes, in name order) of the packages that compute a map."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for package in SWEEP_CODE:
        for path in sorted((root / package).rglob("*.py")):
            rel = path.relative_to(root).as_posix().encode()
            data = path.read_bytes()
            h.update(len(rel).to_bytes(8, "little") + rel + len(data).to_bytes(8, "little") + data)
    return h.digest()


def map_key(robot: RobotModel, settings: MapSettings) -> str:
    """The cache key: SHA-256 of the robot's URDF and YAML bytes, the settings, the package version and
    the source of the sweep's code (:func:`sweep_code_digest`)."""
    h = hashlib.sha256()
    for part in (f"jethr1-plan {__version__} map format {FORMAT}".encode(), sweep_code_digest(),
                 Path(robot.urdf_path).read_bytes(), Path(robot.yaml_path).read_bytes(),
                 json.dumps(settings.as_dict(), sort_keys=True).encode()):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def cache_dir(given: Path | str | None = None) -> Path:
    """Where maps are kept: ``given``, else $JETHR1_CACHE, else $XDG_CACHE_HOME/jethr1, else ~/.cache/jethr1."""
    if given:
        return Path(given)
    if os.environ.get("JETHR1_CACHE"):
        return Path(os.environ["JETHR1_CACHE"])
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "jethr1"


@dataclass
class BalanceMap:
    """The balance space of one support side, its support sole at the origin (arrays over the grid)."""

    settings: MapSettings
    axes: tuple[np.ndarray, np.ndarray, np.ndarray]  # grid coordinates relative to the support sole [m]
    thrust: np.ndarray  # (nx, ny, nz) least thrust F* [N] (inf where nothing balances; > F_max: THRUST_MAX)
    reason: np.ndarray  # (nx, ny, nz) int8 reason codes (Reason.OK: a member)
    p_body: np.ndarray  # (nx, ny, nz, 3) the best posture's trunk position relative to the support sole [m] (NaN: none)
    key: str = ""
    path: Path | None = None
    reused: bool = False
    wall_s: float = 0.0

    def __post_init__(self) -> None:
        from scipy.ndimage import distance_transform_edt

        self.member = self.reason == Reason.OK
        res = self.settings.resolution_m
        # distance of each member node to the nearest node that is not one, less half a cell: to the edge [m]
        padded = np.pad(self.member, 1, constant_values=False)
        self.margin = (distance_transform_edt(padded)[1:-1, 1:-1, 1:-1] * res - res / 2).clip(min=0.0)
        self.margin[~self.member] = 0.0
        self.origin = np.array([a[0] for a in self.axes])
        self.shape = np.array(self.member.shape)
        # :meth:`lookup`'s gathers on the raveled grids: a node's index is its (ix, iy, iz) @ strides
        self._strides = np.array([self.shape[1] * self.shape[2], self.shape[2], 1], dtype=np.int64)
        self._corners = np.array([[dx, dy, dz] for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)]) @ self._strides
        self._member_flat, self._thrust_flat = self.member.ravel(), np.ravel(self.thrust)
        self._margin_flat, self._reason_flat = self.margin.ravel(), np.ravel(self.reason)
        xy = np.stack(np.meshgrid(self.axes[0], self.axes[1], indexing="ij"), axis=-1)[self.member.any(axis=2)]
        #: the farthest a member node lies from the support sole's centre, horizontally [m]
        self.reach_m = float(np.linalg.norm(xy, axis=1).max() + res) if len(xy) else 0.0

    def lookup(self, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At points ``rel`` (..., 3) relative to the support sole [m]: (in the space, thrust [N],
        margin [m], the nearest node's reason code (:data:`OUTSIDE` beyond the grid) and thrust [N])."""
        rel = np.asarray(rel, dtype=float)
        res = self.settings.resolution_m
        g = (rel - self.origin) / res
        i0 = np.floor(g + 1e-9).astype(np.int64)
        inside = np.all((i0 >= 0) & (i0 + 1 < self.shape), axis=-1)
        # the cell's eight corner nodes, as indices into the raveled grids
        corners = (np.clip(i0, 0, self.shape - 2) @ self._strides)[..., None] + self._corners
        ok = inside & self._member_flat.take(corners).all(axis=-1)
        thrust = self._thrust_flat.take(corners).max(axis=-1)
        margin = self._margin_flat.take(corners).min(axis=-1)
        near = np.clip(np.rint(g).astype(np.int64), 0, self.shape - 1) @ self._strides
        reason = np.where(inside, self._reason_flat.take(near), OUTSIDE)
        need = np.where(inside, self._thrust_flat.take(near), np.inf)
        return ok, np.where(inside, thrust, np.inf), np.where(ok, margin, 0.0), reason, need

    def reach_along(self, direction_xy: np.ndarray, within_rad: float = math.radians(10.0)) -> float:
        """The farthest a member node lies from the support sole's centre [m], horizontally, within
        ``within_rad`` of the direction ``direction_xy`` (0 where none)."""
        X, Y = np.meshgrid(self.axes[0], self.axes[1], indexing="ij")
        xy = np.stack([X, Y], axis=-1)[self.member.any(axis=2)]
        d = np.linalg.norm(xy, axis=1)
        u = np.asarray(direction_xy, dtype=float) / max(float(np.linalg.norm(direction_xy)), 1e-12)
        cos = (xy @ u) / np.maximum(d, 1e-12)
        near = cos >= math.cos(within_rad)
        return float(d[near].max()) if near.any() else 0.0

    def posture(self, rel: np.ndarray) -> np.ndarray:
        """The trunk position [m] relative to the support sole of the grid node nearest to ``rel`` (..., 3),
        shifted by the point's offset from that node (NaN where the node has no posture or lies beyond the grid)."""
        rel = np.asarray(rel, dtype=float)
        g = np.rint((rel - self.origin) / self.settings.resolution_m).astype(np.int64)
        inside = np.all((g >= 0) & (g < self.shape), axis=-1)
        g = np.clip(g, 0, self.shape - 1)
        node = self.origin + g * self.settings.resolution_m
        p = self.p_body[g[..., 0], g[..., 1], g[..., 2]] + (rel - node) / 2
        return np.where(inside[..., None], p, np.nan)

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        np.savez_compressed(buf, x=self.axes[0], y=self.axes[1], z=self.axes[2], thrust=self.thrust.astype(np.float32),
                            reason=self.reason.astype(np.int8), p_body=self.p_body.astype(np.float32),
                            meta=np.frombuffer(json.dumps({"key": self.key, "settings": self.settings.as_dict(),
                                                           "version": __version__}).encode(), dtype=np.uint8))
        return buf.getvalue()

    @classmethod
    def from_file(cls, path: Path, settings: MapSettings, key: str) -> BalanceMap:
        """The map cached at ``path`` (a regular file, bounded; its archive's members bounded before they are
        decompressed).

        Raises:
            InputError: not a regular file, too large, or not a map of this key (corrupt, edited): the file is
                left as it is and named.
        """
        data = read_input(path, MAX_MAP_BYTES, "a balance-space map")
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as z:
                expanded = sum(i.file_size for i in z.infolist())
            if expanded > MAX_MAP_EXPANDED_BYTES:
                raise ValueError(f"its arrays expand to {expanded:,} bytes")
            with np.load(io.BytesIO(data), allow_pickle=False) as f:
                meta = json.loads(bytes(f["meta"]).decode())
                if not isinstance(meta, dict) or meta.get("key") != key:
                    raise ValueError("another map's key")
                axes = (f["x"].astype(float), f["y"].astype(float), f["z"].astype(float))
                thrust, reason = f["thrust"].astype(float), f["reason"].astype(np.int8)
                p_body = f["p_body"].astype(float)
            if thrust.shape != reason.shape or thrust.shape != tuple(len(a) for a in axes) or \
                    p_body.shape != (*thrust.shape, 3):
                raise ValueError("arrays of different shapes")
        except Exception as exc:  # zip, numpy and json raise many kinds on a corrupt file
            raise InputError(str(path), "", f"not a balance-space map jethr1 wrote ({type(exc).__name__}: "
                             f"{str(exc)[:60]}): remove it (it is recomputed), or give --cache another folder") \
                from None
        return cls(settings, axes, thrust, reason, p_body, key=key, path=path, reused=True)


def compute_map(robot: RobotModel, settings: MapSettings, jobs: int = 1, progress=None) -> BalanceMap:
    """Sweep the balance space around a support sole at the origin (``balance_space.sweep``)."""
    from jethr1_plan.balance_space.sweep import SweepSpec, sweep
    from jethr1_plan.io.pool import pool_config

    spec = SweepSpec(robot=robot, support_side=settings.support_side, support_xyz=(0.0, 0.0, 0.0),
                     x_range=settings.x_range, y_range=settings.y, z_range=settings.z_range,
                     resolution_m=settings.resolution_m, thrust_max_n=settings.thrust_max_n, rho_rad=settings.rho_rad,
                     sole_margin_m=settings.sole_margin_m, tolerance=settings.tolerance)
    t0 = time.perf_counter()
    with pool_config():  # its workers die with the command
        r = sweep(spec, jobs=jobs, progress=progress)
    axes = spec.axes()
    shape = tuple(len(a) for a in axes)
    swing = r.swing.reshape(*shape, 3)
    for k in range(3):  # the sweep's cells come x-major, then y, then z: the grid itself
        expect = np.moveaxis(np.broadcast_to(axes[k], shape[:k] + shape[k + 1:] + (shape[k],)), -1, k)
        if not np.allclose(swing[..., k], expect, atol=1e-9):
            raise AssertionError("the balance-space sweep returned its cells in an unexpected order")
    return BalanceMap(settings, axes, r.thrust.reshape(shape), r.reason.reshape(shape).astype(np.int8),
                      r.p_body.reshape(*shape, 3), wall_s=time.perf_counter() - t0)


def cached_map(robot: RobotModel, settings: MapSettings, cache: Path | str | None = None, jobs: int = 1,
               say: Callable[[str], None] | None = None, progress=None, compute: bool = True) -> BalanceMap | None:
    """The map of ``settings``: read from the cache, else computed and cached (``say`` gets one line each way).

    Raises:
        InputError: the cache folder cannot be written (the map is computed but cannot be kept).
    """
    from jethr1_plan.io.atomic import write_bytes_atomic
    from jethr1_plan.io.record import check_writable

    key = map_key(robot, settings)
    folder = cache_dir(cache) / "balance_space"
    check_writable(folder)  # before minutes of work: a file in the way, a folder that cannot be written
    path = folder / f"{robot.name}-{settings.support_side}-{key[:20]}.npz"
    what = (f"{settings.support_side} support, {_policy(settings.tolerance)}, "
            f"{1000 * settings.resolution_m:g} mm grid, F_max {settings.thrust_max_n:g} N")
    found = BalanceMap.from_file(path, settings, key) if os.path.lexists(path) else None
    if not compute:
        return found
    if found is not None:
        if say:
            say(f"balance-space map ({what}): reused {path}")
        return found
    if say:
        nx, ny, nz = (math.floor((hi - lo) / settings.resolution_m + 1e-9) + 1
                      for lo, hi in (settings.x_range, settings.y, settings.z_range))
        say(f"balance-space map ({what}): computing {nx * ny * nz:,} cells once (cached in {folder}/)")
    m = compute_map(robot, settings, jobs=jobs, progress=progress)
    m.key, m.path = key, path
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(str(folder), "", f"cannot create the map cache: {exc.strerror or exc} (--cache DIR or "
                         "$JETHR1_CACHE choose another place)") from None
    write_bytes_atomic(path, m.to_bytes())
    if say:
        say(f"balance-space map ({what}): computed in {m.wall_s:.1f} s, {int(m.member.sum()):,} cells in the space; "
            f"wrote {path}")
    return m


def _policy(tol: Tolerance) -> str:
    if tol == Tolerance():
        return "minimal"
    return f"robust ±{100 * tol.thrust:g} % thrust, ±{100 * tol.mass:g} % mass, {1000 * tol.com_m:g} mm CoM"
