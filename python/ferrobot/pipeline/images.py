"""Small image tools for reports, with numpy and the standard library only: PNG encoding, projecting 3D
segments through a pinhole camera, drawing lines, and a self-contained HTML flip-book of frames."""

from __future__ import annotations

import base64
import html
import json
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import ShapeError

__all__ = ["encode_png", "write_png", "project", "draw_segments", "write_flipbook"]


def encode_png(rgb: np.ndarray, level: int = 6) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 image (or (H, W) grey)."""
    img = np.asarray(rgb)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
        raise ShapeError(f"image: expected (H, W, 3) or (H, W) uint8, got {img.shape} {img.dtype}")
    h, w = img.shape[:2]
    color = 2 if img.ndim == 3 else 0
    rows = np.ascontiguousarray(img).reshape(h, -1)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], axis=1).tobytes()  # filter 0 per row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, color, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, level)) + chunk(b"IEND", b"")
    )


def write_png(path, rgb: np.ndarray) -> Path:
    path = Path(path)
    path.write_bytes(encode_png(rgb))
    return path


def project(points: np.ndarray, camera_pose: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (..., 2) (u, v) of world points (..., 3) seen by an OpenCV-frame camera at
    ``camera_pose`` (4x4, world) with intrinsic matrix ``k``; and whether each is in front of the camera."""
    p = np.asarray(points, dtype=np.float64)
    r, t = camera_pose[:3, :3], camera_pose[:3, 3]
    c = (p - t) @ r  # = R^T (p - t)
    z = c[..., 2]
    front = z > 1e-6
    zs = np.where(front, z, 1.0)
    u = k[0, 0] * c[..., 0] / zs + k[0, 2]
    v = k[1, 1] * c[..., 1] / zs + k[1, 2]
    return np.stack([u, v], axis=-1), front


def draw_segments(img: np.ndarray, segments: np.ndarray, color, thickness: int = 1) -> None:
    """Draws 2D segments (N, 2, 2) of pixel coordinates (u, v) on ``img`` (H, W, 3) in place."""
    h, w = img.shape[:2]
    col = np.asarray(color, dtype=np.uint8)
    r = thickness // 2
    for (u0, v0), (u1, v1) in np.asarray(segments, dtype=np.float64):
        n = int(max(abs(u1 - u0), abs(v1 - v0))) + 1
        if n > 4 * (w + h):  # far outside the image
            continue
        s = np.linspace(0.0, 1.0, n + 1)
        us = np.rint(u0 + s * (u1 - u0)).astype(int)
        vs = np.rint(v0 + s * (v1 - v0)).astype(int)
        for du in range(-r, r + 1):
            for dv in range(-r, r + 1):
                uu, vv = us + du, vs + dv
                ok = (uu >= 0) & (uu < w) & (vv >= 0) & (vv < h)
                img[vv[ok], uu[ok]] = col


_VIEWER = """<!doctype html>
<html><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: sans-serif; background: #222; color: #eee; margin: 1em; }}
img {{ image-rendering: auto; border: 1px solid #555; display: block; }}
#bar {{ margin-top: .5em; display: flex; gap: .8em; align-items: center; }}
input[type=range] {{ width: {width}px; }}
</style></head><body>
<h3>{title}</h3>
<img id="frame" width="{width}" height="{height}">
<div id="bar"><button id="play">pause</button><input id="slider" type="range" min="0" max="{last}" value="0">
<span id="label"></span></div>
<script>
const frames = {frames};
const labels = {labels};
const img = document.getElementById("frame"), slider = document.getElementById("slider");
const label = document.getElementById("label"), play = document.getElementById("play");
let i = 0, playing = true;
function show(k) {{ i = k; img.src = frames[k]; slider.value = k; label.textContent = labels[k]; }}
slider.oninput = () => show(+slider.value);
play.onclick = () => {{ playing = !playing; play.textContent = playing ? "pause" : "play"; }};
setInterval(() => {{ if (playing) show((i + 1) % frames.length); }}, {interval});
show(0);
</script></body></html>
"""


def write_flipbook(path, frames: list[tuple[float, str, np.ndarray]], title: str, fps: float = 15.0) -> Path:
    """A self-contained HTML page playing ``frames`` ((time, label, rgb) each) with a slider and pause."""
    if not frames:
        raise ShapeError("write_flipbook: no frames")
    uris = ["data:image/png;base64," + base64.b64encode(encode_png(f[2], level=4)).decode() for f in frames]
    labels = [f"t = {t:5.2f} s   {stage}" for t, stage, _ in frames]
    h, w = frames[0][2].shape[:2]
    page = _VIEWER.format(
        title=html.escape(title),
        width=w,
        height=h,
        last=len(frames) - 1,
        frames=json.dumps(uris),
        labels=json.dumps(labels),
        interval=int(1000 / fps),
    )
    path = Path(path)
    path.write_text(page)
    return path
