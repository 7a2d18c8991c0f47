"""What an episode leaves behind: a printed report, and a folder with ``report.json``, the executed
trajectory (``trajectory.npz``), the camera view with the grasps drawn (``grasp.png``) and an animation
(``animation.html``, a self-contained flip-book) and an interactive 3D view (``viewer.html``)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from .images import draw_segments, project, write_flipbook, write_png
from .pick_place import Episode, EpisodeResult, PickPlace
from .viewer import gripper_lines, viewer_data, write_viewer

__all__ = ["format_report", "write_episode", "grasp_image"]


def format_report(result: EpisodeResult) -> str:
    """A short human-readable table: each stage's time and outcome."""
    lines = [f"episode seed {result.seed}: target '{result.target}'"]
    for s in result.stages:
        mark = "ok  " if s.ok else "FAIL"
        extra = s.reason if not s.ok else ", ".join(f"{k}={_fmt(v)}" for k, v in list(s.detail.items())[:4])
        lines.append(f"  {mark} {s.name:<10} {1e3 * s.time_s:8.1f} ms  {extra}")
    if result.success:
        lines.append(
            f"SUCCESS: placed {1e3 * result.place_error_m:.1f} mm from the place location; "
            f"{result.sim_time_s:.2f} s simulated in {result.wall_time_s:.2f} s wall"
        )
    else:
        lines.append(f"FAILED at {result.failed_stage}: {result.reason}")
    return "\n".join(lines)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.3g}"
    return str(v)


def grasp_image(episode: Episode | PickPlace, top: int = 8) -> np.ndarray | None:
    """The perception camera's RGB frame of ``episode`` (an :class:`Episode` record, ``result.episode``) with
    the best ``top`` detected grasps (yellow) and the chosen one (green, thick) drawn on it; None before
    detection."""
    ep = _record(episode, "grasp_image(pp)", "grasp_image(result.episode)")
    if ep.grasps_world is None or ep.frame is None:
        return None
    img = ep.frame.rgb.copy()
    cam, k = ep.camera.world_transform, ep.camera.intrinsic_matrix
    gw = ep.grasps_world
    lines = gripper_lines(gw, getattr(ep, "gripper", None))
    chosen = ep.choice
    for i in range(min(top, len(gw))):
        if i == chosen:
            continue
        uv, front = project(lines[i], cam, k)
        draw_segments(img, uv[front.all(axis=1)], (250, 220, 40), 1)
    if chosen is not None:
        uv, front = project(lines[chosen], cam, k)
        draw_segments(img, uv[front.all(axis=1)], (40, 230, 60), 3)
    return img


def _record(obj, old: str, new: str) -> Episode:
    """The episode record of ``obj``: a record, or (deprecated) a :class:`PickPlace` after ``run``."""
    if isinstance(obj, PickPlace):
        warnings.warn(f"{old} is deprecated: pass the episode record, {new}", DeprecationWarning, stacklevel=3)
        return obj.episode
    return obj


def write_episode(out: Path, result: EpisodeResult, *deprecated) -> dict[str, Path]:
    """Writes the folder of the episode ``result`` (from :meth:`PickPlace.run`, which carries its record in
    ``result.episode``); returns the paths written. The old call ``write_episode(out, pp, result)`` works for
    one release with a DeprecationWarning."""
    if isinstance(result, PickPlace):
        if len(deprecated) != 1:
            raise TypeError("write_episode(out, result): one episode result expected")
        warnings.warn(
            "write_episode(out, pp, result) is deprecated: call write_episode(out, result)",
            DeprecationWarning,
            stacklevel=2,
        )
        result = deprecated[0]
    elif deprecated:
        raise TypeError("write_episode(out, result): one episode result expected")
    ep = result.episode
    if ep is None:
        raise TypeError("write_episode: the result carries no episode record (made by PickPlace.run?)")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    report = {"result": result.to_dict(), "scene": ep.spec.to_dict()}
    if ep.gripper is not None:  # what `ferrobot view` needs to draw this robot's grasp
        report["gripper"] = {"name": ep.gripper.name, **ep.gripper.detection_options().to_dict()}
    if ep.choice is not None:
        g = ep.grasps_world[ep.choice]
        report["grasp"] = {
            "score": g.score,
            "width": g.width,
            "height": g.height,
            "depth": g.depth,
            "translation_world": g.translation.tolist(),
            "rotation_world": g.rotation_matrix.tolist(),
            "hand_pose_base": ep.hand_grasp.tolist(),
        }
    paths["report"] = out / "report.json"
    paths["report"].write_text(json.dumps(report, indent=2))
    rec = ep.recorder
    if rec is not None and rec.q:
        arrays = rec.arrays()
        paths["trajectory"] = out / "trajectory.npz"
        np.savez_compressed(paths["trajectory"], joint_names=np.array(ep.robot.dof_names), **arrays)
    img = grasp_image(ep)
    if img is not None:
        paths["grasp_png"] = write_png(out / "grasp.png", img)
    if rec is not None and rec.frames:
        title = f"ferrobot pick-and-place, seed {result.seed}: " + (
            "success" if result.success else f"failed at {result.failed_stage}"
        )
        paths["animation"] = write_flipbook(out / "animation.html", rec.frames, title)
        paths["viewer"] = write_viewer(out / "viewer.html", viewer_data(ep), title)
    return paths
