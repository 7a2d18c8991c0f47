"""Analytic RGB-D scenes for the grasp tests and benchmarks: boxes, upright cylinders and cylinders lying on their
side on a table, ray-cast by hand through a pinhole camera (OpenCV convention). Independent of ferrobot."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

W, H = 640, 480
FX = FY = 600.0
CX, CY = 319.5, 239.5


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """4x4 world pose of an OpenCV camera (z forward, y down) at ``eye`` looking at ``target``."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, y, z], axis=1)
    T[:3, 3] = eye
    return T


@dataclass
class Box:
    size: tuple  # (sx, sy, sz), standing on the table (z from 0 to sz)
    center_xy: tuple = (0.0, 0.0)
    yaw: float = 0.0
    label: int = 1


@dataclass
class Cylinder:
    radius: float
    height: float
    center_xy: tuple = (0.0, 0.0)
    label: int = 2


@dataclass
class LyingCylinder:
    """A cylinder lying on the table, its axis horizontal along ``yaw`` (0: world x), centred at ``center_xy``."""

    radius: float
    length: float
    center_xy: tuple = (0.0, 0.0)
    yaw: float = 0.0
    label: int = 3


def bench_bin_walls(label: int = 9) -> list:
    """``benches/clutter.py``'s bin as wall boxes: 30 x 24 cm inside, walls 10 cm tall and 1.2 cm thick outside
    it (:func:`bin_walls` is a smaller square bin of thin walls, for the synthetic clutter scene)."""
    ix, iy, h, t = 0.30, 0.24, 0.10, 0.012
    return [
        Box(size=(ix + 2 * t, t, h), center_xy=(0.0, iy / 2 + t / 2), label=label),
        Box(size=(ix + 2 * t, t, h), center_xy=(0.0, -iy / 2 - t / 2), label=label),
        Box(size=(t, iy, h), center_xy=(ix / 2 + t / 2, 0.0), label=label),
        Box(size=(t, iy, h), center_xy=(-ix / 2 - t / 2, 0.0), label=label),
    ]


@dataclass
class Scene:
    objects: list = field(default_factory=list)
    table_half: float = 0.4  # the table top is the square |x|, |y| <= table_half at z = 0


def _yaw(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def render(scene: Scene, cam_pose: np.ndarray, width: int = W, height: int = H, fx=FX, fy=FY, cx=CX, cy=CY):
    """Depth (H, W) in metres (0 = no hit) and segmentation labels (H, W) int32 (0 = table / nothing)."""
    v, u = np.mgrid[0:height, 0:width].astype(float)
    d_cam = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], -1).reshape(-1, 3)
    R, o = cam_pose[:3, :3], cam_pose[:3, 3]
    d = d_cam @ R.T  # world ray directions; camera z of the hit point equals the ray parameter t
    best = np.full(d.shape[0], np.inf)
    label = np.zeros(d.shape[0], dtype=np.int32)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[2] / d[:, 2]
        hit = (t > 0) & np.all(np.abs(o[:2] + t[:, None] * d[:, :2]) <= scene.table_half, axis=1)
        best = np.where(hit, t, best)
        for obj in scene.objects:
            if isinstance(obj, Box):
                half = np.array(obj.size) / 2.0
                Ry = _yaw(obj.yaw)
                c = np.array([*obj.center_xy, half[2]])
                ol = Ry.T @ (o - c)
                dl = d @ Ry  # (Ry.T @ d.T).T
                t1 = (-half - ol) / dl
                t2 = (half - ol) / dl
                tmin = np.nanmax(np.minimum(t1, t2), axis=1)
                tmax = np.nanmin(np.maximum(t1, t2), axis=1)
                hit = (tmax >= tmin) & (tmin > 0)
                tt = tmin
            elif isinstance(obj, LyingCylinder):
                # In the cylinder's frame (x along the axis, z up through its centre): the side y^2 + z^2 = r^2
                # for |x| <= length / 2, and the two end discs x = +-length / 2.
                Ry = _yaw(obj.yaw)
                c = np.array([*obj.center_xy, obj.radius])
                ol = Ry.T @ (o - c)
                dl = d @ Ry
                a = dl[:, 1] ** 2 + dl[:, 2] ** 2
                b = 2 * (dl[:, 1] * ol[1] + dl[:, 2] * ol[2])
                cc = ol[1] ** 2 + ol[2] ** 2 - obj.radius**2
                disc = b * b - 4 * a * cc
                t_side = (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a)
                x_side = ol[0] + t_side * dl[:, 0]
                side = (disc >= 0) & (t_side > 0) & (np.abs(x_side) <= obj.length / 2)
                tt = np.where(side, t_side, np.inf)
                for end in (-obj.length / 2, obj.length / 2):
                    t_end = (end - ol[0]) / dl[:, 0]
                    q = ol[1:] + t_end[:, None] * dl[:, 1:]
                    disc_hit = (t_end > 0) & (np.sum(q**2, axis=1) <= obj.radius**2)
                    tt = np.where(disc_hit & (t_end < tt), t_end, tt)
                hit = np.isfinite(tt)
            else:
                c = np.array(obj.center_xy)
                oc = o[:2] - c
                a = d[:, 0] ** 2 + d[:, 1] ** 2
                b = 2 * (d[:, 0] * oc[0] + d[:, 1] * oc[1])
                cc = oc @ oc - obj.radius**2
                disc = b * b - 4 * a * cc
                sq = np.sqrt(np.maximum(disc, 0))
                t_side = (-b - sq) / (2 * a)
                z_side = o[2] + t_side * d[:, 2]
                side = (disc >= 0) & (t_side > 0) & (z_side >= 0) & (z_side <= obj.height)
                t_top = (obj.height - o[2]) / d[:, 2]
                p_top = o[:2] + t_top[:, None] * d[:, :2] - c
                top = (t_top > 0) & (np.sum(p_top**2, axis=1) <= obj.radius**2)
                tt = np.where(top, t_top, np.where(side, t_side, np.inf))
                hit = top | side
            closer = hit & (tt < best)
            best = np.where(closer, tt, best)
            label = np.where(closer, obj.label, label)
    depth = np.where(np.isfinite(best), best, 0.0).reshape(height, width)
    return depth, label.reshape(height, width)


def default_scene():
    """A 5 x 7 x 10 cm box (yawed 20°) and a 3 cm radius, 12 cm tall cylinder on a table, camera 0.6 m away."""
    scene = Scene(
        objects=[
            Box(size=(0.05, 0.07, 0.10), center_xy=(0.0, 0.0), yaw=np.deg2rad(20), label=1),
            Cylinder(radius=0.03, height=0.12, center_xy=(0.15, 0.10), label=2),
        ]
    )
    cam = look_at(eye=(-0.35, -0.25, 0.55), target=(0.05, 0.03, 0.04))
    return scene, cam


def inside(scene: Scene, p: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Whether world points (N, 3) are inside an object shrunk by ``margin`` or below the table top."""
    solid = p[:, 2] < -margin
    for obj in scene.objects:
        if isinstance(obj, Box):
            half = np.array(obj.size) / 2.0 - margin
            c = np.array([*obj.center_xy, obj.size[2] / 2.0])
            q = (p - c) @ _yaw(obj.yaw)
            solid |= np.all(np.abs(q) < half, axis=1)
        elif isinstance(obj, LyingCylinder):
            q = (p - np.array([*obj.center_xy, obj.radius])) @ _yaw(obj.yaw)
            r = np.hypot(q[:, 1], q[:, 2])
            solid |= (r < obj.radius - margin) & (np.abs(q[:, 0]) < obj.length / 2 - margin)
        else:
            r = np.linalg.norm(p[:, :2] - np.array(obj.center_xy), axis=1)
            solid |= (r < obj.radius - margin) & (p[:, 2] > margin) & (p[:, 2] < obj.height - margin)
    return solid


def object_volume(obj, step: float = 0.002) -> np.ndarray:
    """Points filling an object (world frame) on a grid of ``step``."""
    if isinstance(obj, Box):
        half = np.array(obj.size) / 2.0
        axes = [np.arange(-h + step / 2, h, step) for h in half]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        return g @ _yaw(obj.yaw).T + np.array([*obj.center_xy, half[2]])
    if isinstance(obj, LyingCylinder):
        r, half = obj.radius, obj.length / 2
        xs = np.arange(-half + step / 2, half, step)
        ys = np.arange(-r + step / 2, r, step)
        g = np.stack(np.meshgrid(xs, ys, ys, indexing="ij"), -1).reshape(-1, 3)
        g = g[np.hypot(g[:, 1], g[:, 2]) < r]
        return g @ _yaw(obj.yaw).T + np.array([*obj.center_xy, r])
    r = obj.radius
    xs = np.arange(-r + step / 2, r, step)
    zs = np.arange(step / 2, obj.height, step)
    g = np.stack(np.meshgrid(xs, xs, zs, indexing="ij"), -1).reshape(-1, 3)
    g = g[np.hypot(g[:, 0], g[:, 1]) < r]
    return g + np.array([*obj.center_xy, 0.0])


def hand_boxes(width, depth, height=0.02, finger_depth=0.05, finger_width=0.01, approach_distance=0.03):
    """The hand's solid boxes (min, max) in the gripper frame, as documented in ferrobot.grasp."""
    half, outer, hz = width / 2, width / 2 + finger_width, height / 2
    base = depth - finger_depth
    back = base - finger_width - approach_distance
    return [
        (np.array([base, -outer, -hz]), np.array([depth, -half, hz])),
        (np.array([base, half, -hz]), np.array([depth, outer, hz])),
        (np.array([back, -outer, -hz]), np.array([base, outer, hz])),
    ]


def sample_box(lo, hi, n=6) -> np.ndarray:
    axes = [np.linspace(a, b, n) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def bin_walls(half=0.16, height=0.12, t=0.01, label=9):
    """Four thin walls of a square bin around the origin (boxes standing on the table)."""
    return [
        Box(size=(2 * half, t, height), center_xy=(0.0, half), label=label),
        Box(size=(2 * half, t, height), center_xy=(0.0, -half), label=label),
        Box(size=(t, 2 * half, height), center_xy=(half, 0.0), label=label),
        Box(size=(t, 2 * half, height), center_xy=(-half, 0.0), label=label),
    ]


def clutter_scene(with_bin: bool = False):
    """Seven boxes and cylinders 1-3 cm apart (labels 1-7; the target 1 in the middle), optionally in a bin
    (label 9), and a camera 0.7 m away looking down at them."""
    objects = [
        Box(size=(0.04, 0.05, 0.06), center_xy=(0.0, 0.0), yaw=0.3, label=1),
        Cylinder(radius=0.025, height=0.15, center_xy=(0.0, 0.065), label=2),
        Box(size=(0.03, 0.09, 0.11), center_xy=(0.06, -0.01), yaw=0.1, label=3),
        Box(size=(0.05, 0.05, 0.04), center_xy=(-0.065, -0.01), yaw=-0.2, label=4),
        Cylinder(radius=0.02, height=0.08, center_xy=(-0.01, -0.07), label=5),
        Box(size=(0.06, 0.03, 0.05), center_xy=(0.08, 0.09), yaw=0.5, label=6),
        Box(size=(0.03, 0.03, 0.09), center_xy=(-0.08, 0.08), label=7),
    ]
    if with_bin:
        objects += bin_walls()
    cam = look_at(eye=(-0.3, -0.2, 0.55), target=(0.0, 0.0, 0.04))
    return Scene(objects=objects, table_half=0.4), cam
