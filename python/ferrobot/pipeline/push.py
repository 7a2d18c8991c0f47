"""Pushing an object the hand cannot grasp where it lies (against a bin wall, in a corner, in a dense pile)
into free space: the push primitive of heightmap-based bin picking (VPG's "push": closed fingers moved
horizontally against the object from its far side), planned and collision-checked on the camera's cloud.

:func:`plan_push` builds a **heightmap** (2.5D: every observed column solid from the support up to its
highest observed point; columns never observed count as solid up to ``unknown_height``) from world-frame
points with instance labels, and searches pushes of one labelled object: for each of ``num_directions``
horizontal directions d, the closed fingers start just outside the object's footprint on its -d side (a
fingertip height of at most ``tip_height`` above the support) and move along d by the longest of
``distances`` whose whole motion is free: the descent (5 cm down the approach to the start) must keep the
hand's solids (closed fingers, palm, housing: the gripper description's ``fingers`` boxes, grown by
``margin``) clear of every column, the target's included; the push itself clear of every column but the
target's; and the object's footprint moved by the push must not run into a column taller than its own top
plus 1 cm (a wall). The hand leans back over the object (approach tilted by ``tilts`` about the horizontal
axis perpendicular to d) so that its housing stays clear of what is behind the fingers; the closing axis is
horizontal, along or across d. Among the feasible pushes the one leaving the object the largest clearance
(up to 10 cm) from everything observed 1 cm or more above the support (walls, neighbours) wins, then the
longest, least tilted and lowest. Nothing is simulated here: the plan is hand poses (world frame) for an executor.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidArgumentError

__all__ = ["FreeSpace", "Heightmap", "PushPlan", "plan_push", "hand_rotation"]


@dataclass
class Heightmap:
    """Highest observed point per ``cell`` x ``cell`` column above the support (m), -1 where no point was
    seen; ``label`` the instance label of that highest point (0 = none); cells of ``origin`` + (i, j) * cell."""

    origin: np.ndarray
    cell: float
    height: np.ndarray
    label: np.ndarray
    support_z: float

    @classmethod
    def from_points(cls, points, labels, support_z: float, bounds, cell: float = 0.005) -> Heightmap:
        """The heightmap of ``points`` (N, 3, world) with ``labels`` (N,) over ``bounds`` = [xmin, xmax,
        ymin, ymax] (m); points below ``support_z`` are ignored."""
        p = np.asarray(points, dtype=np.float64)
        lab = np.asarray(labels, dtype=np.int64)
        if p.ndim != 2 or p.shape[1] != 3 or len(lab) != len(p):
            raise InvalidArgumentError(f"points: expected (N, 3) with N labels, got {p.shape} and {lab.shape}")
        if not (0.001 <= cell <= 0.05):
            raise InvalidArgumentError(f"cell: {cell} m is outside [0.001, 0.05]")
        b = np.asarray(bounds, dtype=np.float64)
        if b.shape != (4,) or not np.all(np.isfinite(b)) or b[1] <= b[0] or b[3] <= b[2]:
            raise InvalidArgumentError(f"bounds: expected finite [xmin, xmax, ymin, ymax] with min < max, got {bounds}")
        if not math.isfinite(support_z):
            raise InvalidArgumentError(f"support_z: expected a finite height (m), got {support_z}")
        if (b[1] - b[0]) * (b[3] - b[2]) / cell**2 > 1e7:
            raise InvalidArgumentError(f"bounds: {bounds} holds more than 10 million cells of {cell} m")
        nx = max(1, int(math.ceil((b[1] - b[0]) / cell)))
        ny = max(1, int(math.ceil((b[3] - b[2]) / cell)))
        height = np.full((nx, ny), -1.0)
        label = np.zeros((nx, ny), dtype=np.int64)
        i = np.floor((p[:, 0] - b[0]) / cell).astype(np.int64)
        j = np.floor((p[:, 1] - b[2]) / cell).astype(np.int64)
        h = p[:, 2] - support_z
        keep = (i >= 0) & (i < nx) & (j >= 0) & (j < ny) & (h >= -0.002) & np.isfinite(h)
        i, j, h, lab = i[keep], j[keep], np.maximum(h[keep], 0.0), lab[keep]
        order = np.argsort(h)  # the highest point of a cell is written last
        height[i[order], j[order]] = h[order]
        label[i[order], j[order]] = lab[order]
        return cls(np.array([b[0], b[2]]), float(cell), height, label, float(support_z))

    def cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(i, j, inside) of world xy points (M, 2)."""
        ij = np.floor((xy - self.origin) / self.cell).astype(np.int64)
        inside = (
            (ij[:, 0] >= 0) & (ij[:, 0] < self.height.shape[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < self.height.shape[1])
        )
        return np.clip(ij[:, 0], 0, self.height.shape[0] - 1), np.clip(ij[:, 1], 0, self.height.shape[1] - 1), inside


@dataclass
class PushPlan:
    """A planned push: the hand-link poses (4x4, world) above the start, at the start and at the end, the
    push direction (unit, world, horizontal), the object's intended displacement ``distance`` and the hand's
    ``travel`` along it (m: the displacement plus the gap the fingers start from), the fingertip (TCP)
    start point (world)."""

    target: int
    pre: np.ndarray
    start: np.ndarray
    end: np.ndarray
    direction: np.ndarray
    distance: float
    travel: float
    tip_start: np.ndarray
    tilt: float
    score: float


def hand_rotation(gripper, approach, closing) -> np.ndarray:
    """The hand link's rotation (world) whose gripper approach and closing axes are ``approach`` and
    ``closing`` (unit, orthogonal, world)."""
    a_g, c_g = np.asarray(gripper.approach, dtype=float), np.asarray(gripper.closing, dtype=float)
    a_w, c_w = np.asarray(approach, dtype=float), np.asarray(closing, dtype=float)
    g = np.column_stack([a_g, c_g, np.cross(a_g, c_g)])
    w = np.column_stack([a_w, c_w, np.cross(a_w, c_w)])
    return w @ g.T


def _hand_samples(gripper, step: float, margin: float) -> np.ndarray:
    """Points (M, 3) on the surfaces of the closed hand's solids in its gripper frame (x approach, y closing,
    z = x × y; origin at the fingertips' centre), grown by ``margin``: the closed fingers (one box) and the
    housing behind their base. Against a heightmap (solid columns) a box collides exactly when a point of its
    surface does, so the surfaces suffice; ``step`` (m) is the largest spacing of the points."""
    f = gripper.fingers
    boxes = [
        ((-f.depth - margin, margin), (-f.thickness - margin, f.thickness + margin), f.height / 2 + margin),
        (
            (-f.depth - f.palm_depth - margin, -f.depth + margin),
            (-f.palm_width / 2 - margin, f.palm_width / 2 + margin),
            f.palm_height / 2 + margin,
        ),
    ]
    out = []
    for (x0, x1), (y0, y1), hz in boxes:
        axes = [
            np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / step)) + 1))
            for lo, hi in ((x0, x1), (y0, y1), (-hz, hz))
        ]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        lo, hi = np.array([x0, y0, -hz]), np.array([x1, y1, hz])
        on_face = np.any(np.isclose(g, lo) | np.isclose(g, hi), axis=1)
        out.append(g[on_face])
    return np.vstack(out)


class FreeSpace:
    """The space a depth camera saw to be empty: a world point is free when it projects into the image in
    front of the observed surface (by ``tolerance``) or onto a pixel without a return; points behind the
    surface (inside what the camera saw, or hidden by it) are not. ``depth`` (H, W, m, 0 = no return),
    ``labels`` (H, W) instance labels, ``fx, fy, cx, cy`` the pinhole intrinsics, ``camera_pose`` the camera's
    pose in the world (4x4, OpenCV axes: z forward, y down)."""

    def __init__(self, depth, labels, fx: float, fy: float, cx: float, cy: float, camera_pose, tolerance=0.003):
        self.depth = np.asarray(depth, dtype=np.float64)
        self.labels = np.asarray(labels)
        if self.depth.ndim != 2 or self.labels.shape != self.depth.shape:
            raise InvalidArgumentError(
                f"depth, labels: expected two (H, W) images, got {self.depth.shape}, {self.labels.shape}"
            )
        self.k = (float(fx), float(fy), float(cx), float(cy))
        self.world_to_cam = np.linalg.inv(np.asarray(camera_pose, dtype=np.float64))
        self.tolerance = float(tolerance)

    def blocked(self, pts: np.ndarray, ignore_label: int | None = None) -> np.ndarray:
        """Per world point (M, 3): True where it is not seen free (pixels of ``ignore_label`` count as free)."""
        c = pts @ self.world_to_cam[:3, :3].T + self.world_to_cam[:3, 3]
        fx, fy, cx, cy = self.k
        z = c[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.round(fx * c[:, 0] / z + cx).astype(np.int64)
            v = np.round(fy * c[:, 1] / z + cy).astype(np.int64)
        h, w = self.depth.shape
        inside = (z > 0) & (u >= 0) & (u < w) & (v >= 0) & (v < h)
        uu, vv = np.clip(u, 0, w - 1), np.clip(v, 0, h - 1)
        d = self.depth[vv, uu]
        free = inside & ((d <= 0) | (z < d - self.tolerance))
        if ignore_label is not None:
            free |= inside & (self.labels[vv, uu] == ignore_label)
        return ~free


def _collides(hm: Heightmap, pts: np.ndarray, ignore_label: int | None, unknown_height: float, view=None) -> bool:
    """Whether world points ``pts`` (M, 3) are inside a solid column (or below the support)."""
    z = pts[:, 2] - hm.support_z
    if np.any(z < 0.002):
        return True
    if view is not None:
        return bool(view.blocked(pts, ignore_label).any())
    i, j, inside = hm.cells(pts[:, :2])
    h = np.where(hm.height[i, j] < 0, unknown_height, hm.height[i, j])
    h = np.where(inside, h, unknown_height)
    if ignore_label is not None:
        h = np.where(hm.label[i, j] == ignore_label, 0.0, h)
    return bool(np.any(z < h))


def _checked_motion(distances, tilts, tip_heights, margin, clearance) -> tuple[list[float], list[float]]:
    """Checks the arguments pushes and slides share: ``distances`` in (0, 0.3] m (returned longest first),
    ``tilts`` in [0, 1.2] rad, ``tip_heights`` in [0.003, 0.1] m (returned lowest first), ``margin`` and
    ``clearance`` in [0, 0.02] m; raises ``InvalidArgumentError`` naming the argument."""
    distances = sorted((float(d) for d in distances), reverse=True)
    if not distances or not all(0 < d <= 0.3 for d in distances):
        raise InvalidArgumentError(f"distances: expected values in (0, 0.3] m, got {distances}")
    if not all(0.0 <= float(t) <= 1.2 for t in tilts):
        raise InvalidArgumentError(f"tilts: expected values in [0, 1.2] rad, got {list(tilts)}")
    tip_heights = sorted(float(h) for h in tip_heights)
    if not tip_heights or not all(0.003 <= h <= 0.1 for h in tip_heights):
        raise InvalidArgumentError(f"tip_heights: expected values in [0.003, 0.1] m, got {tip_heights}")
    for name, v in (("margin", margin), ("clearance", clearance)):
        if not 0.0 <= v <= 0.02:
            raise InvalidArgumentError(f"{name}: {v} m is outside [0, 0.02]")
    return distances, tip_heights


def plan_push(
    points,
    labels,
    target: int,
    gripper,
    support_z: float,
    bounds,
    *,
    cell: float = 0.005,
    num_directions: int = 16,
    distances=(0.10, 0.08, 0.06, 0.04),
    tilts=(0.0, 0.3, 0.6, 0.9),
    tip_heights=(0.012, 0.02, 0.03, 0.04),
    margin: float = 0.004,
    clearance: float = 0.005,
    unknown_height: float = 1.0,
    heightmap: Heightmap | None = None,
    view: FreeSpace | None = None,
) -> PushPlan | None:
    """The best push of the object labelled ``target`` (see the module's docstring), or None. ``points``
    (N, 3) world frame with ``labels`` (N,); ``gripper``: a :class:`ferrobot.Gripper` (its ``fingers`` boxes,
    ``tcp``, ``approach`` and ``closing``); ``support_z``: height of the table or bin floor (m); ``bounds``:
    [xmin, xmax, ymin, ymax] of the heightmap (m). Ranges: ``num_directions`` 1-64, ``distances`` in
    (0, 0.3] m, ``tilts`` in [0, 1.2] rad, ``tip_heights`` in [0.003, 0.1] m, ``margin`` and ``clearance`` in
    [0, 0.02] m."""
    if not 1 <= int(num_directions) <= 64:
        raise InvalidArgumentError(f"num_directions: {num_directions} is outside [1, 64]")
    distances, tip_heights = _checked_motion(distances, tilts, tip_heights, margin, clearance)
    hm = heightmap or Heightmap.from_points(points, labels, support_z, bounds, cell)
    mine = hm.label == target
    if not mine.any():
        return None
    ii, jj = np.nonzero(mine)
    foot = hm.origin + (np.column_stack([ii, jj]) + 0.5) * hm.cell  # target footprint cell centres
    top = float(hm.height[mine].max())
    centre = foot.mean(axis=0)
    # Obstacles to the object's clearance: anything observed 1 cm or more above the support that is not the
    # target (neighbours, walls). A push is scored by the clearance it leaves the object.
    oi, oj = np.nonzero((hm.height >= 0.01) & ~mine)
    obstacles = hm.origin + (np.column_stack([oi, oj]) + 0.5) * hm.cell
    clear_cache: dict = {}

    def clearance_after(k: int, dist: float, d: np.ndarray) -> float:
        key = (k, dist)
        if key not in clear_cache:
            moved = foot + dist * d[:2]
            if len(obstacles) == 0:
                clear_cache[key] = 0.1
            else:
                near = obstacles[np.all(np.abs(obstacles - moved.mean(axis=0)) < 0.2, axis=1)]
                if len(near) == 0:
                    clear_cache[key] = 0.1
                else:
                    d2 = ((moved[::2, None, :] - near[None, :, :]) ** 2).sum(axis=2)
                    clear_cache[key] = min(0.1, float(np.sqrt(d2.min())))
        return clear_cache[key]

    step = 0.008  # surface point spacing and sweep step: below a bin wall's thickness (1.2 cm)
    samples = _hand_samples(gripper, step, margin)
    # Fingertip heights above the support: at most 60 % of the object's height (the push must meet it), and
    # the fingers grown by the margin clear of the support by 3 mm; an object too flat for both is not pushed.
    lowest = 0.003 + margin
    if 0.6 * top < lowest:
        return None
    heights = sorted({max(lowest, min(h, 0.6 * top)) for h in tip_heights})
    # The target's footprint must not run into anything taller than itself (walls) when pushed.
    tall = (hm.height > top + 0.01) | ((hm.height < 0) & (view is None))
    tcp = np.asarray(gripper.tcp, dtype=float)
    best: PushPlan | None = None
    f = gripper.fingers
    for k, tip_z, across in itertools.product(range(int(num_directions)), heights, (True, False)):
        ang = 2 * math.pi * k / num_directions
        d = np.array([math.cos(ang), math.sin(ang), 0.0])
        s = foot @ d[:2]
        # half the closed fingers' extent along d: across d the fingers' height, along d their thickness
        half = f.height / 2 if across else f.thickness
        for tilt in tilts:
            # A hand leaning back over the object meets its top edge first: the fingertips stand off further
            # by the lean over the height between them and the object's top.
            standoff = half + margin + clearance + max(0.0, top - tip_z) * math.tan(tilt)
            tip = np.array([*(centre + (s.min() - centre @ d[:2] - standoff) * d[:2]), hm.support_z + tip_z])
            a = np.array([-math.sin(tilt) * d[0], -math.sin(tilt) * d[1], -math.cos(tilt)])
            if across:
                c = np.cross(np.array([0.0, 0.0, 1.0]), d)
            else:
                c = np.cross(a, np.cross(d, a))  # d made orthogonal to the approach
            c = c / np.linalg.norm(c)
            # gripper frame: x approach, y closing, z = x × y
            rg = np.column_stack([a, c, np.cross(a, c)])
            body = samples @ rg.T  # hand solids about the fingertip, world orientation
            # descent: 5 cm down the approach to the start, target included
            if any(_collides(hm, body + tip - t * a, None, unknown_height, view) for t in np.arange(0.0, 0.0501, step)):
                continue
            # the push: the longest free stretch along d, the target ignored
            # The hand travels the object's displacement plus the gap it starts from (standoff - half).
            gap = standoff - half
            free_to = 0.0
            for t in np.arange(step, distances[0] + gap + 1e-9, step):
                if _collides(hm, body + tip + t * d, target, unknown_height, view):
                    break
                free_to = t
            for dist in distances:
                if dist + gap > free_to + 1e-9:
                    continue
                i2, j2, inside = hm.cells(foot + dist * d[:2])
                if not inside.all() or tall[i2, j2].any():
                    continue
                score = clearance_after(k, dist, d) + 0.1 * dist - 0.01 * tilt - 0.2 * tip_z
                if best is None or score > best.score:
                    rot = hand_rotation(gripper, a, c)
                    start = np.eye(4)
                    start[:3, :3] = rot
                    start[:3, 3] = tip - rot @ tcp
                    pre, end = start.copy(), start.copy()
                    pre[:3, 3] -= 0.05 * a
                    end[:3, 3] += (dist + gap) * d
                    best = PushPlan(target, pre, start, end, d, dist, dist + gap, tip, float(tilt), score)
                break
    return best
