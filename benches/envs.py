"""Environment steps per second of ferrobot's Gymnasium environments, vectorised several ways.

    python benches/envs.py [--envs 1,2,8] [--steps 30] [--rounds 3] [--robosuite] [--json FILE]

For N environments of ``ferrobot/PickPlace-v0`` (joint-position control at 10 Hz over the 240 Hz physics:
24 physics steps per environment step), with no camera and with one 224 x 224 RGB camera, it measures
env steps/s (N x vector steps / wall time) of:

- ``threads``: :class:`ferrobot.envs.vector.FerrobotVectorEnv` (one thread per environment; the simulation
  releases the GIL while it steps and renders),
- ``rust``: the same with ``batch="rust"`` (each environment's Python in turn, then the control period of
  every world in one ``ferrobot._core.execute_trajectories`` call: rayon, GIL released),
- ``sync``: Gymnasium's ``SyncVectorEnv`` (one after the other),
- ``async``: Gymnasium's ``AsyncVectorEnv`` (one process per environment, shared-memory observations;
  started with ``spawn``: a forked child inherits rayon's thread pool without its threads and hangs at
  its first parallel render),

and, for the physics alone (24 steps of each world per "step", no Python between), stepping the worlds one
after the other with ``World.step`` against ``ferrobot._core.step_worlds`` (rayon, GIL released).
Methods alternate within each round (this VM's speed drifts); the table gives the median over rounds.
The actions move every arm joint along a slow sine around the start configuration.

``--robosuite`` also times robosuite's ``Lift`` (Panda, MuJoCo, its default OSC pose controller, 10 Hz control,
no camera and one 224 x 224 camera) when robosuite is installed.
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import time

import gymnasium as gym
import numpy as np

import ferrobot
import ferrobot.envs  # noqa: F401
from ferrobot.envs.vector import FerrobotVectorEnv

ENV = "ferrobot/PickPlace-v0"


def kwargs(camera: bool) -> dict:
    if camera:
        return {"obs_mode": "rgb", "cameras": ["scene"], "image_size": (224, 224)}
    return {"obs_mode": "state"}


def actions(single_space, n: int, k: int, q0: np.ndarray) -> np.ndarray:
    a = np.zeros((n, single_space.shape[0]), np.float32)
    a[:, :7] = q0[:7] + 0.15 * np.sin(0.3 * k + np.arange(7))
    return a


def _make(kw: dict):
    import ferrobot.envs  # noqa: F401  (registers the ids in a spawned worker)

    return gym.make(ENV, **kw)


def make_vec(method: str, n: int, camera: bool):
    kw = kwargs(camera)
    if method in ("threads", "rust"):
        return FerrobotVectorEnv(n, env_id=ENV, batch=method, **kw)
    fns = [functools.partial(_make, kw) for _ in range(n)]
    if method == "sync":
        return gym.vector.SyncVectorEnv(fns)
    return gym.vector.AsyncVectorEnv(fns, shared_memory=True, context="spawn")


def time_vec(env, n: int, steps: int) -> float:
    obs, _ = env.reset(seed=0)
    q0 = np.asarray(obs["observation.state"][0], np.float64)
    env.step(actions(env.single_action_space, n, 0, q0))  # warm-up
    t0 = time.perf_counter()
    for k in range(1, steps + 1):
        env.step(actions(env.single_action_space, n, k, q0))
    return n * steps / (time.perf_counter() - t0)


def time_physics(method: str, n: int, steps: int) -> float:
    envs = [gym.make(ENV) for _ in range(n)]
    for i, e in enumerate(envs):
        e.reset(seed=i)
    worlds = [e.unwrapped.world for e in envs]
    t0 = time.perf_counter()
    for _ in range(steps):
        if method == "step_worlds":
            ferrobot._core.step_worlds(worlds, 24)
        else:
            for w in worlds:
                w.step(24)
    return n * steps / (time.perf_counter() - t0)


def time_robosuite(camera: bool, steps: int) -> float | None:
    try:
        import robosuite
    except ImportError:
        return None
    env = robosuite.make(
        "Lift",
        robots="Panda",
        has_renderer=False,
        has_offscreen_renderer=camera,
        use_camera_obs=camera,
        camera_names="frontview",
        camera_heights=224,
        camera_widths=224,
        control_freq=10,
        horizon=10_000,
    )
    env.reset()
    low, high = env.action_spec
    env.step(np.zeros_like(low))
    t0 = time.perf_counter()
    for k in range(steps):
        env.step(np.clip(0.1 * np.sin(0.3 * k + np.arange(len(low))), low, high))
    return steps / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", default="1,2,8")
    ap.add_argument("--steps", type=int, default=30, help="vector steps per measurement")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--robosuite", action="store_true")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    ns = [int(x) for x in args.envs.split(",")]
    results: dict[str, list[float]] = {}
    for r in range(args.rounds):
        for camera in (False, True):
            for n in ns:
                for method in ("threads", "rust", "sync", "async"):
                    env = make_vec(method, n, camera)
                    try:
                        sps = time_vec(env, n, args.steps)
                    finally:
                        env.close()
                    results.setdefault(f"{method} n={n} camera={camera}", []).append(sps)
                    print(f"round {r} camera={camera} n={n} {method}: {sps:.1f} env steps/s", flush=True)
        for n in ns:
            for method in ("sequential", "step_worlds"):
                sps = time_physics(method, n, args.steps)
                results.setdefault(f"physics {method} n={n}", []).append(sps)
                print(f"round {r} physics n={n} {method}: {sps:.1f} world control-steps/s", flush=True)
        if args.robosuite:
            for camera in (False, True):
                sps = time_robosuite(camera, args.steps * 2)
                if sps is not None:
                    results.setdefault(f"robosuite Lift n=1 camera={camera}", []).append(sps)
                    print(f"round {r} robosuite Lift camera={camera}: {sps:.1f} env steps/s", flush=True)
    print()
    print(f"{'configuration':<36}{'median env steps/s':>20}   per round")
    summary = {}
    for k, v in results.items():
        summary[k] = {"median": statistics.median(v), "rounds": v}
        print(f"{k:<36}{statistics.median(v):>20.1f}   {', '.join(f'{x:.1f}' for x in v)}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=2)


if __name__ == "__main__":
    main()
