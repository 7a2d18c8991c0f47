"""Policy evaluation: roll a policy out for N episodes, write per-episode results, a summary and videos.

A policy is a callable ``obs -> action``, or an object with ``act(obs)`` (or LeRobot's
``select_action(obs)``) and optionally ``reset(...)``, called at every episode start with whichever of the
keyword arguments ``env``, ``obs``, ``info``, ``seed`` its signature names. :func:`load_policy` resolves
``"MODULE:CALLABLE"``, ``"expert"`` (:class:`ferrobot.envs.expert.ExpertPolicy`) and ``"replay:DATASET_DIR"``
(:class:`ferrobot.envs.replay.ReplayPolicy`). A class is instantiated once per environment; an object with
state (``reset``/``act``) is copied per environment when several run at once; a plain function is shared.
A policy with ``reset_options(episode)`` gives the ``options`` of that episode's ``env.reset`` (a replay
restores the recorded scene that way).

Episode ``i`` resets its environment with seed ``seed + i``; with ``num_envs`` K, K environments run
episodes side by side, stepped together by :class:`ferrobot.envs.vector.ThreadedVectorStepper` (each
environment's step in its own thread: the simulation releases the GIL, so the physics of different
environments runs on different cores).
"""

from __future__ import annotations

import collections
import copy
import importlib
import inspect
import json
import math
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import InvalidArgumentError
from ..pipeline.batch import Progress
from .vector import ThreadedVectorStepper

__all__ = ["evaluate", "load_policy", "wilson_interval", "write_video"]


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (default 95%: z = 1.96). ``n`` = 0 gives (0, 1)."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    d = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / d
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, centre - half), min(1.0, centre + half)


def load_policy(spec: str) -> Any:
    """``"expert"``, ``"replay:DATASET_DIR[:EPISODE]"`` or ``"MODULE:CALLABLE"`` -> the policy object (a class is
    returned as is: :func:`evaluate` instantiates it per environment)."""
    if spec == "expert":
        from .expert import ExpertPolicy

        return ExpertPolicy
    if spec.startswith("replay:"):
        from .replay import ReplayPolicy

        return ReplayPolicy.from_spec(spec[len("replay:") :])
    if ":" not in spec:
        raise InvalidArgumentError(f"policy: expected 'expert', 'replay:DIR' or 'MODULE:CALLABLE', got {spec!r}")
    module, name = spec.split(":", 1)
    try:
        obj = importlib.import_module(module)
    except ImportError as e:
        raise InvalidArgumentError(f"policy: cannot import module {module!r}: {e}") from e
    for part in name.split("."):
        if not hasattr(obj, part):
            raise InvalidArgumentError(f"policy: {module!r} has no attribute {name!r}")
        obj = getattr(obj, part)
    if not (callable(obj) or hasattr(obj, "act") or hasattr(obj, "select_action")):
        raise InvalidArgumentError(f"policy: {spec!r} is neither callable nor has act()/select_action()")
    return obj


def _instances(policy: Any, k: int) -> list[Any]:
    if inspect.isclass(policy):
        return [policy() for _ in range(k)]
    stateful = hasattr(policy, "reset") or hasattr(policy, "act") or hasattr(policy, "select_action")
    if stateful and k > 1:
        return [policy] + [copy.deepcopy(policy) for _ in range(k - 1)]
    return [policy] * k


def _reset_policy(policy: Any, env, obs, info, seed: int) -> None:
    fn = getattr(policy, "reset", None)
    if fn is None or not callable(fn):
        return
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        params = {}
    available = {"env": env, "obs": obs, "info": info, "seed": seed}
    var_kw = any(p.kind == inspect.Parameter.VAR_KEYWORD for p in params.values())
    fn(**{k: v for k, v in available.items() if var_kw or k in params})


def _act(policy: Any, obs) -> Any:
    if hasattr(policy, "act"):
        return policy.act(obs)
    if hasattr(policy, "select_action"):
        return policy.select_action(obs)
    return policy(obs)


def write_video(path: Path, frames: list[np.ndarray], fps: float) -> Path:
    """Writes RGB frames (H, W, 3) uint8 as an H.264 mp4 with PyAV (MPEG-4 part 2 when libx264 is missing),
    or, without PyAV, as a self-contained HTML flipbook (``ferrobot.pipeline.images.write_flipbook``)."""
    path = Path(path)
    try:
        import av
    except ImportError:
        from ..pipeline.images import write_flipbook

        html = path.with_suffix(".html")
        write_flipbook(html, [(i / fps, "", f) for i, f in enumerate(frames)], path.stem, fps=fps)
        return html
    h, w = frames[0].shape[:2]
    with av.open(str(path), mode="w") as out:
        try:
            stream = out.add_stream("libx264", rate=int(round(fps)))
        except Exception:  # codec not in this PyAV build
            stream = out.add_stream("mpeg4", rate=int(round(fps)))
        stream.width, stream.height = w - w % 2, h - h % 2
        stream.pix_fmt = "yuv420p"
        for f in frames:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(f[: stream.height, : stream.width]), format="rgb24")
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path


def evaluate(
    env_id: str,
    policy: Any,
    episodes: int,
    *,
    seed: int = 0,
    num_envs: int = 1,
    out: str | Path | None = None,
    video_episodes: list[int] | tuple[int, ...] = (),
    env_kwargs: dict | None = None,
    max_episode_steps: int | None = None,
    progress: bool = True,
) -> dict:
    """Rolls ``policy`` out for ``episodes`` episodes of ``env_id``; returns the summary (also written to
    ``out/summary.json``, with ``out/episodes.jsonl`` and ``out/videos/episode_XXXXX.mp4``)."""
    if episodes < 1:
        raise InvalidArgumentError(f"episodes: expected >= 1, got {episodes}")
    if num_envs < 1:
        raise InvalidArgumentError(f"num_envs: expected >= 1, got {num_envs}")
    num_envs = min(num_envs, episodes)
    videos = {int(v) for v in video_episodes}
    bad = sorted(v for v in videos if not 0 <= v < episodes)
    if bad:
        raise InvalidArgumentError(f"video_episodes: {bad} not in 0..{episodes - 1}")
    if videos and out is None:
        raise InvalidArgumentError("video_episodes: needs an output folder (out)")
    kwargs = dict(env_kwargs or {})
    if videos:
        kwargs["render_mode"] = "rgb_array"
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = int(max_episode_steps)
    import ferrobot.envs  # noqa: F401  (registers the ids)

    policies = _instances(policy, num_envs)
    # A policy may say which environment it needs (a replay: the dataset's robot and gripper); given
    # env_kwargs win.
    hook = getattr(policies[0], "env_kwargs", None)
    if callable(hook):
        kwargs = {**hook(), **kwargs}
    envs = [gym.make(env_id, **kwargs) for _ in range(num_envs)]
    stepper = ThreadedVectorStepper(envs)
    out_dir = Path(out) if out is not None else None
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "episodes.jsonl").write_text("")
    fps = float(envs[0].unwrapped.control_hz)
    bar = Progress(episodes) if progress else None
    records: list[dict] = []
    t_start = time.perf_counter()

    # Per-slot episode state.
    next_episode = 0
    slot = [dict() for _ in range(num_envs)]

    def start(i: int) -> None:
        nonlocal next_episode
        ep = next_episode
        next_episode += 1
        s = slot[i]
        s.clear()
        s.update(episode=ep, seed=seed + ep, steps=0, ret=0.0, t0=time.perf_counter(), frames=[], cause="")
        hook = getattr(policies[i], "reset_options", None)  # e.g. a replay restores the recorded scene
        options = hook(ep) if callable(hook) else None
        obs, info = envs[i].reset(seed=seed + ep, options=options)
        s["obs"], s["info"] = obs, info
        try:
            _reset_policy(policies[i], envs[i], obs, info, seed + ep)
        except Exception as e:
            s["cause"] = f"policy_error: {type(e).__name__}: {e}"
        if ep in videos:
            s["frames"].append(envs[i].render())

    def finish(i: int, success: bool, cause: str) -> None:
        s = slot[i]
        rec = {
            "episode": s["episode"],
            "seed": s["seed"],
            "success": bool(success),
            "steps": s["steps"],
            "time_s": time.perf_counter() - s["t0"],
            "sim_time_s": s["steps"] / fps,
            "return": s["ret"],
            "failure_cause": "" if success else cause,
        }
        pol_fail = getattr(policies[i], "failure", "")
        if pol_fail:
            rec["policy_failure"] = str(pol_fail)
        if s["episode"] in videos and out_dir is not None:
            vdir = out_dir / "videos"
            vdir.mkdir(exist_ok=True)
            rec["video"] = str(write_video(vdir / f"episode_{s['episode']:05d}.mp4", s["frames"], fps))
        records.append(rec)
        if out_dir is not None:
            with open(out_dir / "episodes.jsonl", "a") as f:
                f.write(json.dumps(rec) + "\n")
        if bar is not None:
            bar.update(len(records), sum(r["success"] for r in records))

    active = []
    for i in range(num_envs):
        start(i)
        active.append(i)
    while active:
        actions, stepping = {}, []
        for i in list(active):
            s = slot[i]
            if s["cause"]:  # the policy failed at reset
                finish(i, False, s["cause"])
                active.remove(i)
                continue
            try:
                actions[i] = _act(policies[i], s["obs"])
                stepping.append(i)
            except Exception as e:
                finish(i, False, f"policy_error: {type(e).__name__}: {e}")
                active.remove(i)
        results = stepper.step({i: actions[i] for i in stepping})
        for i in stepping:
            s = slot[i]
            res = results[i]
            if isinstance(res, BaseException):
                finish(i, False, f"env_error: {type(res).__name__}: {res}")
                done = True
            else:
                obs, reward, terminated, truncated, info = res
                s["obs"], s["info"] = obs, info
                s["steps"] += 1
                s["ret"] += float(reward)
                if s["episode"] in videos:
                    s["frames"].append(envs[i].render())
                done = terminated or truncated
                if done:
                    success = bool(info.get("is_success", False))
                    cause = info.get("failure_cause", "") or ("timeout" if truncated else "terminated")
                    finish(i, success, cause)
            if done:
                active.remove(i)
                if next_episode < episodes:
                    start(i)
                    active.append(i)
    for p in policies:
        if hasattr(p, "close"):
            p.close()
    for e in envs:
        e.close()
    stepper.close()

    records.sort(key=lambda r: r["episode"])
    n = len(records)
    ok = sum(r["success"] for r in records)
    lo, hi = wilson_interval(ok, n)
    causes = collections.Counter(r["failure_cause"] for r in records if not r["success"])
    wall = time.perf_counter() - t_start
    summary = {
        "env": env_id,
        "env_kwargs": {k: v for k, v in kwargs.items() if isinstance(v, (int, float, str, bool, type(None)))},
        "episodes": n,
        "successes": ok,
        "success_rate": ok / n,
        "success_rate_ci95": [lo, hi],
        "ci_method": "Wilson score interval, 95%",
        "failures_by_cause": dict(causes.most_common()),
        "mean_steps": float(np.mean([r["steps"] for r in records])),
        "mean_return": float(np.mean([r["return"] for r in records])),
        "seeds": [seed, seed + episodes - 1],
        "num_envs": num_envs,
        "wall_time_s": wall,
        "episodes_per_second": n / wall if wall > 0 else 0.0,
    }
    if out_dir is not None:
        (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
