"""Grasps from a saved RGB-D frame, as from a real camera: 16-bit depth in millimetres plus intrinsics.

    python examples/grasp_from_rgbd.py [frame.npz] [--out grasps.png]

The default frame (examples/data/table_rgbd.npz) was rendered by ferrobot's simulated camera looking at
a table with objects; it holds ``depth`` (uint16, mm), ``rgb``, ``fx, fy, cx, cy``, ``scale`` and the
camera's world pose (OpenCV convention).
"""

import argparse
from pathlib import Path

import numpy as np

import ferrobot
from ferrobot.pipeline.images import draw_segments, project, write_png

ap = argparse.ArgumentParser()
ap.add_argument("frame", nargs="?", default=Path(__file__).parent / "data" / "table_rgbd.npz")
ap.add_argument("--out", default="grasps.png")
args = ap.parse_args()
f = np.load(args.frame)
fx, fy, cx, cy, scale = (float(f[k]) for k in ("fx", "fy", "cx", "cy", "scale"))

# Crop to the table in front of the camera (camera frame: x right, y down, z forward) and detect.
workspace = [-0.6, 0.6, -0.5, 0.5, 0.2, 1.4]
grasps = ferrobot.grasp.detect_from_rgbd(f["depth"], fx, fy, cx, cy, scale, colors=f["rgb"], workspace=workspace)
grasps = grasps.nms().sort_by_score()
print(f"{len(grasps)} grasps; best 5 (camera frame, graspnetAPI layout):")
for g in grasps[:5]:
    print(f"  score {g.score:.3f} width {g.width * 1e3:.0f} mm at {np.round(g.translation, 3)}")

# In the world (the camera's pose is saved with the frame) and as Panda hand poses.
world_grasps = grasps.transform(f["camera_pose"])
hand = world_grasps[:1].to_hand(ferrobot.Gripper.panda_hand())[0]
print(f"best grasp as a panda_hand pose in the world:\n{np.round(hand, 3)}")

# Draw the best 10 on the colour image.
img = f["rgb"].copy()
k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
lines = grasps[:10].gripper_lines()
for i in range(len(lines)):
    uv, front = project(lines[i], np.eye(4), k)
    draw_segments(img, uv[front.all(axis=1)], (40, 230, 60) if i == 0 else (250, 220, 40), 2 if i == 0 else 1)
print(f"wrote {write_png(args.out, img)}")
