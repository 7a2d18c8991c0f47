"""The ``ferrobot`` console command."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from . import robots
from ._core import RobotModel
from .errors import FerrobotError


def _load(spec: str, srdf: str | None, ee_link: str | None) -> RobotModel:
    if spec == "panda":
        return robots.panda(ee_link=ee_link)
    return RobotModel.from_urdf(spec, srdf=srdf, ee_link=ee_link)


def _fmt_pose(pose: np.ndarray) -> str:
    from .transforms import matrix_to_pose

    p = matrix_to_pose(pose)
    return (
        f"xyz = [{p[0]:+.4f}, {p[1]:+.4f}, {p[2]:+.4f}] m, wxyz = [{p[3]:+.4f}, {p[4]:+.4f}, {p[5]:+.4f}, {p[6]:+.4f}]"
    )


def cmd_robot(args: argparse.Namespace) -> int:
    model = _load(args.robot, args.srdf, args.ee_link)
    print(f"robot {model.name}: {model.num_dof} DOF, {len(model.link_names)} links")
    print(f"base link {model.base_link}, end effector {model.ee_link}")
    print()
    print(f"{'joint':<24}{'lower':>10}{'upper':>10}{'velocity':>10}{'effort':>9}")
    lo, hi = model.lower_limits, model.upper_limits
    vel, eff = model.velocity_limits, model.effort_limits
    for i, name in enumerate(model.dof_names):
        print(f"{name:<24}{lo[i]:>10.4f}{hi[i]:>10.4f}{vel[i]:>10.4f}{eff[i]:>9.1f}")
    for name, (driver, mult, off) in model.mimic_joints:
        print(f"{name:<24}mimics {driver} (x{mult:g} {off:+g})")
    print()
    states = [n for g, n in model.named_states]
    if args.state in states:
        q = model.named_state(args.state)
        label = f"named state '{args.state}'"
    else:
        q = model.neutral_configuration()
        label = "neutral configuration"
    print(f"FK of {model.ee_link} at {label}:")
    print(f"  q = {np.array2string(q, precision=4)}")
    print(f"  {_fmt_pose(model.fk(q))}")
    print()
    rng = np.random.default_rng(0)
    lo_f = np.where(np.isfinite(lo), lo, -np.pi)
    hi_f = np.where(np.isfinite(hi), hi, np.pi)
    single = 20000
    t0 = time.perf_counter()
    for _ in range(single):
        model.fk(q)
    t_single = (time.perf_counter() - t0) / single
    qs = rng.uniform(lo_f, hi_f, size=(args.batch, model.num_dof))
    model.fk_batch(qs[:1000])
    t0 = time.perf_counter()
    model.fk_batch(qs)
    t_batch = time.perf_counter() - t0
    print(
        f"FK timing: single fk() call {t_single * 1e6:.2f} us; "
        f"fk_batch of {args.batch:,} configurations {t_batch * 1e3:.1f} ms "
        f"({args.batch / t_batch / 1e6:.2f} M/s)"
    )
    return 0


def cmd_serve_grasp(args: argparse.Namespace) -> int:
    try:
        import uvicorn  # noqa: F401
    except ImportError:
        print("ferrobot: error: serve-grasp needs the 'serve' extra: pip install 'ferrobot[serve]'", file=sys.stderr)
        return 1
    from .grasp.server import ServiceLimits, serve

    if args.workers < 1:
        print("ferrobot: error: --workers must be >= 1", file=sys.stderr)
        return 2
    mib = 1024 * 1024
    try:
        limits = ServiceLimits(
            max_body_bytes=int(args.max_body_mb * mib),
            max_json_bytes=int(args.max_json_mb * mib),
            max_image_side=args.max_image_side,
            max_decoded_bytes=int((args.max_decoded_mb or 4 * args.max_body_mb) * mib),
            body_timeout=args.body_timeout,
            header_timeout=args.header_timeout,
            keep_alive=args.keep_alive,
            max_connections=args.max_connections,
            max_inflight=args.max_inflight,
        )
    except ValueError as e:
        flag = str(e).split(".")[1].split(" ")[0].replace("_bytes", "_mb").replace("_", "-")
        print(f"ferrobot: error: --{flag} must be > 0 ({e})", file=sys.stderr)
        return 2
    print(
        f"ferrobot grasp service on http://{args.host}:{args.port} ({args.workers} worker(s)); "
        "POST /process (JSON), POST /process_npz (binary), GET /health",
        flush=True,
    )
    serve(args.host, args.port, args.workers, limits, log_level=args.log_level)
    return 0


def _objects_arg(text: str):
    """``--objects``: a count, or a folder of object files (for ``--clutter``)."""
    return int(text) if text.strip().lstrip("-").isdigit() else text


def _demo_clutter(args: argparse.Namespace) -> int:
    """``ferrobot demo --clutter K [--objects DIR] [--bin] [--clear]``: pick-and-place from clutter."""
    from pathlib import Path

    from .errors import FerrobotError
    from .pipeline import PickPlace, PickPlaceConfig
    from .pipeline.report import format_report, write_episode
    from .pipeline.scene import TABLE_TOP, ObjectSpec, SceneSpec, clutter_scene
    from .transforms import matrix_to_pose

    if not 1 <= args.clutter <= 15:
        print("ferrobot: error: --clutter must be between 1 and 15", file=sys.stderr)
        return 2
    if isinstance(args.objects, int):
        print("ferrobot: error: with --clutter, --objects is a folder of object files", file=sys.stderr)
        return 2
    try:
        spec = clutter_scene(args.seed, args.clutter, args.objects, bin=args.bin, target=args.target)
    except FerrobotError as e:
        print(f"ferrobot: error: {e}", file=sys.stderr)
        return 2
    from .pipeline.scene import place_camera

    out = Path(args.out)
    # In a pile the fingers open only to the grasp's width plus 1 cm before the approach (fully open fingers
    # meet the neighbours and walls the grasp's own fingers clear; ``benches/clutter.py`` does the same).
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01), robot=args.robot, srdf=args.srdf, gripper=args.gripper)
    place_camera(spec, pp.model, pp.gripper)
    where = "in a bin" if args.bin else "in a pile"
    print(f"ferrobot demo: {len(spec.objects)} mesh objects {where} ({', '.join(o.name for o in spec.objects)})")
    if not args.clear:
        print(f"pick '{spec.target}' and place it at ({spec.place_xy[0]:.3f}, {spec.place_xy[1]:.3f})")
        result = pp.run(spec, record_frames=not args.no_animation)
        print(format_report(result))
        paths = write_episode(out, result)
        print("wrote " + ", ".join(str(p) for p in paths.values()))
        return 0 if result.success else 1
    # Clearing: each episode picks an object of what is left and places it aside; the next scene holds the
    # objects left where the simulator left them (the placed object is taken away). Objects are tried from
    # the top of the pile down: one without a grasp, or whose grasps are out of reach, gives way to the next
    # (nothing has moved yet); an attempt that moved the robot counts. Stops when the pile is gone, after
    # two failed attempts in a row, or when no object left has a reachable grasp.
    untouched = {"scene", "perceive", "detect", "select"}
    objects, total, removed, placed, fails, k = list(spec.objects), len(spec.objects), 0, 0, 0, 0
    while objects and fails < 2:
        for o in sorted(objects, key=lambda o: -o.pose[2]):
            target = o.name
            scene = SceneSpec(
                seed=spec.seed,
                objects=objects,
                target=target,
                place_xy=spec.place_xy,
                bin=spec.bin,
                camera_eye=spec.camera_eye,
                camera_target=spec.camera_target,
            )
            result = pp.run(scene, record_frames=not args.no_animation and k == 0)
            if result.success or result.failed_stage not in untouched:
                break
            print(f"  skipped '{target}': {result.failed_stage}: {result.reason}")
        if not result.success and result.failed_stage in untouched:
            print(f"no object left has a reachable grasp ({len(objects)} left)")
            break
        world = result.episode.world
        print(f"episode {k}: {format_report(result)}")
        if k == 0:
            write_episode(out, result)
        k += 1
        # Taken out of the pile: placed, or lying nearer the place location than the pile's centre (carried
        # there but resting outside the place tolerance); such an object leaves the scene like a placed one.
        centre = np.asarray(spec.camera_target[:2], dtype=float)
        place = np.asarray(spec.place_xy, dtype=float)
        left, taken = [], False
        for o in objects:
            pose = world.get_object_pose(o.name)
            p = pose[:3, 3]
            out_of_pile = np.linalg.norm(p[:2] - place) < np.linalg.norm(p[:2] - centre)
            if o.name == target and (result.success or out_of_pile):
                taken = True
                continue
            if p[2] < TABLE_TOP - 0.05:
                continue
            left.append(ObjectSpec(**{**o.__dict__, "pose": [float(x) for x in matrix_to_pose(pose)]}))
        removed += 1 if taken else 0
        placed += 1 if result.success else 0
        fails = 0 if taken else fails + 1
        objects = left
    print(
        f"cleared {removed}/{total} objects ({placed} placed within the tolerance) in {k} episodes; "
        f"wrote the first episode to {out}"
    )
    return 0 if removed == total else 1


def cmd_demo(args: argparse.Namespace) -> int:
    if getattr(args, "clutter", None) is not None:
        return _demo_clutter(args)
    if isinstance(args.objects, str):
        print("ferrobot: error: --objects DIR needs --clutter K", file=sys.stderr)
        return 2
    from pathlib import Path

    from .pipeline import PickPlace, PickPlaceConfig, random_scene
    from .pipeline.batch import run_batch
    from .pipeline.report import format_report, write_episode

    if args.episodes < 1:
        print("ferrobot: error: --episodes must be >= 1", file=sys.stderr)
        return 2
    if args.workers is None:
        import os

        args.workers = os.cpu_count() or 1
    if args.workers < 1:
        print("ferrobot: error: --workers must be >= 1", file=sys.stderr)
        return 2
    if args.objects is not None and not 1 <= args.objects <= 6:
        print("ferrobot: error: --objects must be between 1 and 6", file=sys.stderr)
        return 2
    out = Path(args.out)
    config = PickPlaceConfig()
    if args.episodes > 1:
        print(
            f"ferrobot demo: {args.episodes} pick-and-place episodes, "
            f"seeds {args.seed}..{args.seed + args.episodes - 1}"
        )
        s = run_batch(
            args.episodes,
            workers=args.workers,
            seed=args.seed,
            out=out,
            config=config,
            num_objects=args.objects,
            progress=not args.quiet,
            robot=args.robot,
            srdf=args.srdf,
            gripper=args.gripper,
        )
        print(
            f"{s['successes']}/{s['episodes']} succeeded ({100 * s['success_rate']:.1f}%), "
            f"{s['episodes_per_second']:.2f} episodes/s ({s['episodes_per_hour']:.0f}/h) on this machine"
        )
        if s["failures_by_stage"]:
            print("failures by stage: " + ", ".join(f"{k} {v}" for k, v in s["failures_by_stage"].items()))
        print(f"wrote {out / 'episodes.jsonl'} and {out / 'summary.json'}")
        return 0
    from .pipeline.scene import place_camera

    pp = PickPlace(config, robot=args.robot, srdf=args.srdf, gripper=args.gripper)
    spec = place_camera(random_scene(args.seed, args.objects), pp.model, pp.gripper)
    objs = ", ".join(f"{o.name}" for o in spec.objects)
    who = {"panda": "bundled Panda", "ur5e": "bundled UR5e + 2F-85"}.get(args.robot, args.robot)
    print(
        f"ferrobot demo: {who} ({pp.gripper.name}) before a table with {len(spec.objects)} objects ({objs}); "
        f"pick '{spec.target}' and place it at ({spec.place_xy[0]:.3f}, {spec.place_xy[1]:.3f})"
    )
    result = pp.run(spec, record_frames=not args.no_animation)
    print(format_report(result))
    paths = write_episode(out, result)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0 if result.success else 1


def cmd_view(args: argparse.Namespace) -> int:
    """A 3D view of a demo folder or a URDF robot: live through viser, or written as one HTML file."""
    from pathlib import Path

    from .pipeline.viewer import write_viewer
    from .pipeline.viewer_live import LiveView, episode_scene, robot_scene

    path = Path(args.path)
    if path.is_dir():
        data = episode_scene(path)
    elif path.suffix.lower() == ".urdf":
        data = robot_scene(path, args.trajectory)
    else:
        print(f"ferrobot view: error: {path} is neither a demo folder nor a .urdf file", file=sys.stderr)
        return 2
    if args.html:
        print(f"wrote {write_viewer(args.html, data, f'ferrobot view: {path.name}')}")
        return 0
    view = LiveView(data, host=args.host, port=args.port)
    print(f"ferrobot view: http://{args.host}:{view.port} (Ctrl-C to stop)")
    try:
        view.run()
    except KeyboardInterrupt:
        pass
    finally:
        view.close()
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        print("ferrobot: error: evaluate needs the 'gym' extra: pip install 'ferrobot[gym]'", file=sys.stderr)
        return 1
    import json

    from .envs.evaluate import evaluate, load_policy

    if args.episodes < 1:
        print("ferrobot: error: --episodes must be >= 1", file=sys.stderr)
        return 2
    if args.num_envs < 1:
        print("ferrobot: error: --num-envs must be >= 1", file=sys.stderr)
        return 2
    videos: list[int] = []
    for part in args.video_episodes.split(",") if args.video_episodes else []:
        try:
            if "-" in part:
                a, b = part.split("-", 1)
                videos.extend(range(int(a), int(b) + 1))
            elif part.strip():
                videos.append(int(part))
        except ValueError:
            print(f"ferrobot: error: --video-episodes: bad item {part!r} (e.g. 0,3,5-7)", file=sys.stderr)
            return 2
    env_kwargs = {}
    for item in args.env_kwarg or []:
        if "=" not in item:
            print(f"ferrobot: error: --env-kwarg expects KEY=VALUE (JSON value), got {item!r}", file=sys.stderr)
            return 2
        k, v = item.split("=", 1)
        try:
            env_kwargs[k] = json.loads(v)
        except json.JSONDecodeError:
            env_kwargs[k] = v
    policy = load_policy(args.policy)
    print(
        f"ferrobot evaluate: {args.policy} on {args.env}, {args.episodes} episodes "
        f"(seeds {args.seed}..{args.seed + args.episodes - 1}), {args.num_envs} environment(s)"
    )
    s = evaluate(
        args.env,
        policy,
        args.episodes,
        seed=args.seed,
        num_envs=args.num_envs,
        out=args.out,
        video_episodes=videos,
        env_kwargs=env_kwargs,
        max_episode_steps=args.max_steps,
        progress=not args.quiet,
    )
    lo, hi = s["success_rate_ci95"]
    print(
        f"{s['successes']}/{s['episodes']} succeeded: {100 * s['success_rate']:.1f}% "
        f"(95% CI {100 * lo:.1f}-{100 * hi:.1f}%), {s['episodes_per_second']:.2f} episodes/s"
    )
    if s["failures_by_cause"]:
        print("failures by cause: " + ", ".join(f"{k} {v}" for k, v in s["failures_by_cause"].items()))
    print(f"wrote {args.out}/episodes.jsonl and {args.out}/summary.json")
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    """Recorded pick-and-place episodes as a LeRobot v3.0 or robomimic HDF5 dataset."""
    import json

    from .dataset import GenerateConfig, generate, parse_cameras

    # Bad values raise from GenerateConfig.validate, naming the option.
    config = GenerateConfig(
        episodes=args.episodes,
        seed=args.seed,
        format=args.format,
        robot=args.robot,
        srdf=args.srdf,
        gripper=args.gripper,
        objects=args.objects,
        clutter=args.clutter,
        cameras=parse_cameras(args.cameras),
        control_hz=args.fps,
        randomize=not args.no_randomize,
        segmentation=args.segmentation,
    )
    ray = "off" if args.ray == "off" else args.ray
    summary = generate(args.out, config, workers=args.workers, ray=ray, progress=not args.quiet)
    if summary.get("already_complete"):
        print(f"{args.out}: already complete ({summary['episodes']} episodes); nothing to do")
    keys = ("episodes", "successes", "success_rate", "frames", "episodes_run_now", "episodes_per_hour", "executor")
    print(json.dumps({k: summary.get(k) for k in keys}, indent=2))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    """``ferrobot check``: the tree and the findings; exit 1 on errors (--strict: on warnings too)."""
    import json
    import tempfile
    from pathlib import Path

    from ._core import bundled_robot, urdf_check

    with tempfile.TemporaryDirectory() as tmp:
        path, srdf = args.urdf, args.srdf
        if args.urdf == "panda" and not Path("panda").exists():
            urdf_text, srdf_text, _ = bundled_robot("panda")
            path = str(Path(tmp) / "panda.urdf")
            Path(path).write_text(urdf_text)
            if srdf is None:
                srdf = str(Path(tmp) / "panda.srdf")
                Path(srdf).write_text(srdf_text)
        report = urdf_check(path, srdf=srdf, package_dirs=args.package_dir, skip_coverage=args.no_coverage)
    findings = report.findings
    count = {s: sum(f.severity == s for f in findings) for s in ("error", "warning", "info")}
    failed = count["error"] > 0 or (args.strict and count["warning"] > 0)
    if args.json:
        out = {**report.to_dict(), "findings": [f.to_dict() for f in findings], "counts": count, "ok": not failed}
        print(json.dumps(out, indent=2))
    else:
        print(report.tree, end="")
        print()
        shown = [f for f in findings if args.verbose or f.severity != "info" or f.code == "sphere-coverage"]
        for f in shown:
            where = f"{report.source}:{f.line}" if f.line else report.source
            print(f"{where}: {f.severity}: [{f.code}] {f.message}")
        print(f"{count['error']} error(s), {count['warning']} warning(s), {count['info']} info")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ferrobot", description=__doc__)
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command")
    p_robot = sub.add_parser("robot", help="load a robot and print its joints, limits and FK")
    p_robot.add_argument("robot", help="'panda' (bundled) or a path to a URDF file")
    p_robot.add_argument("--srdf", default=None, help="SRDF file for a URDF path")
    p_robot.add_argument("--ee-link", default=None, help="end-effector link")
    p_robot.add_argument("--state", default="ready", help="named state for the FK example")
    p_robot.add_argument("--batch", type=int, default=1_000_000, help="batch size for FK timing")
    p_robot.set_defaults(func=cmd_robot)
    p_demo = sub.add_parser(
        "demo", help="pick-and-place end to end in simulation: camera, grasp detection, planning, execution"
    )
    p_demo.add_argument("--episodes", type=int, default=1, help="number of episodes (> 1: a batch run)")
    p_demo.add_argument("--seed", type=int, default=0, help="scene seed (batch: seeds seed, seed + 1, ...)")
    p_demo.add_argument("--out", default="ferrobot-demo", help="output folder (default ./ferrobot-demo)")
    p_demo.add_argument(
        "--objects",
        type=_objects_arg,
        default=None,
        help="objects on the table (default 3-5 at random); with --clutter: a folder of URDF / OBJ / STL / DAE objects",
    )
    p_demo.add_argument("--clutter", type=int, default=None, metavar="K", help="a pile of K (1-15) mesh objects")
    p_demo.add_argument("--bin", action="store_true", help="with --clutter: the pile is in a bin")
    p_demo.add_argument("--clear", action="store_true", help="with --clutter: pick and place until the pile is gone")
    p_demo.add_argument("--target", default=None, help="with --clutter: the object to pick (default: the top one)")
    p_demo.add_argument("--no-animation", action="store_true", help="single episode: skip the animation")
    p_demo.add_argument("--quiet", action="store_true", help="batch: no progress bar")
    p_demo.add_argument(
        "--workers", type=int, default=None, help="batch: episodes run in this many processes (default: one per core)"
    )
    p_demo.add_argument("--robot", default="panda", help="'panda', 'ur5e' (bundled) or a URDF path (issue 17)")
    p_demo.add_argument("--srdf", default=None, help="SRDF for a URDF --robot (groups, end effector, states)")
    p_demo.add_argument("--gripper", default=None, help="'panda_hand' or 'robotiq_2f85' (default: the robot's own)")
    p_demo.set_defaults(func=cmd_demo)
    p_check = sub.add_parser("check", help="check a URDF: tree, inertials, limits, meshes, axes, self-collision")
    p_check.add_argument("urdf", help="URDF file ('panda': the bundled Panda)")
    p_check.add_argument("--srdf", default=None, help="SRDF: named states and disabled collision pairs")
    p_check.add_argument("--package-dir", action="append", default=None, help="root for package:// (repeatable)")
    p_check.add_argument("--json", action="store_true", help="print the report as JSON")
    p_check.add_argument("--strict", action="store_true", help="exit 1 on warnings too")
    p_check.add_argument("--no-coverage", action="store_true", help="skip the sphere-model coverage check")
    p_check.add_argument("--verbose", action="store_true", help="print info findings too")
    p_check.set_defaults(func=cmd_check)
    p_serve = sub.add_parser("serve-grasp", help="serve grasp detection over HTTP (FastAPI + uvicorn)")
    p_serve.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p_serve.add_argument("--port", type=int, default=5001, help="port (default 5001)")
    p_serve.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    p_serve.add_argument("--max-body-mb", type=float, default=64.0, help="/process_npz body limit in MiB (default 64)")
    p_serve.add_argument("--max-json-mb", type=float, default=32.0, help="/process JSON body limit in MiB (default 32)")
    p_serve.add_argument(
        "--max-decoded-mb", type=float, default=None, help="decoded .npz arrays limit in MiB (default 4x --max-body-mb)"
    )
    p_serve.add_argument("--max-image-side", type=int, default=4096, help="rows and columns of an image (default 4096)")
    p_serve.add_argument("--body-timeout", type=float, default=30.0, help="seconds to receive a body (default 30)")
    p_serve.add_argument("--header-timeout", type=float, default=10.0, help="seconds to receive headers (default 10)")
    p_serve.add_argument("--keep-alive", type=float, default=5.0, help="idle keep-alive seconds (default 5)")
    p_serve.add_argument("--max-connections", type=int, default=64, help="open connections; more get 503 (default 64)")
    p_serve.add_argument("--max-inflight", type=int, default=2, help="requests detected at once (default 2)")
    p_serve.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p_serve.set_defaults(func=cmd_serve_grasp)
    p_view = sub.add_parser("view", help="3D view of a demo folder or a URDF robot (live via viser, or --html)")
    p_view.add_argument("path", help="a `ferrobot demo` output folder or a .urdf file")
    p_view.add_argument("--trajectory", default=None, help="URDF: an .npz with positions (T, num_dof) to play")
    p_view.add_argument("--html", default=None, help="write a self-contained HTML viewer here instead of serving")
    p_view.add_argument("--host", default="127.0.0.1", help="live view address (default 127.0.0.1)")
    p_view.add_argument("--port", type=int, default=8080, help="live view port (default 8080)")
    p_view.set_defaults(func=cmd_view)
    p_eval = sub.add_parser("evaluate", help="roll a policy out in a ferrobot Gymnasium environment, report success")
    p_eval.add_argument("--env", default="ferrobot/PickPlace-v0", help="environment id (default ferrobot/PickPlace-v0)")
    p_eval.add_argument(
        "--policy", required=True, help="MODULE:CALLABLE, 'expert' (scripted baseline) or 'replay:DATASET_DIR'"
    )
    p_eval.add_argument("--episodes", type=int, default=10, help="number of episodes (default 10)")
    p_eval.add_argument("--seed", type=int, default=0, help="episode i uses seed + i (default 0)")
    p_eval.add_argument("--num-envs", type=int, default=1, help="environments stepped together (default 1)")
    p_eval.add_argument("--out", default="ferrobot-eval", help="output folder (default ./ferrobot-eval)")
    p_eval.add_argument("--video-episodes", default="", help="episodes to film, e.g. 0,3,5-7 (mp4 in OUT/videos)")
    p_eval.add_argument("--max-steps", type=int, default=None, help="episode length in control steps")
    p_eval.add_argument(
        "--env-kwarg", action="append", help='KEY=VALUE passed to gym.make (JSON value), e.g. control_mode="ee_delta"'
    )
    p_eval.add_argument("--quiet", action="store_true", help="no progress bar")
    p_eval.set_defaults(func=cmd_evaluate)
    p_gen = sub.add_parser(
        "generate", help="recorded pick-and-place episodes as a LeRobot v3.0 or robomimic HDF5 dataset"
    )
    p_gen.add_argument("--episodes", type=int, required=True, help="number of episodes (1 to 10,000,000)")
    p_gen.add_argument("--seed", type=int, default=0, help="run seed; episode i's seed derives from (seed, i)")
    p_gen.add_argument("--out", required=True, help="dataset folder (new, empty, or a run of the same command)")
    p_gen.add_argument("--format", default="lerobot", help="lerobot (v3.0) or hdf5 (robomimic layout)")
    p_gen.add_argument("--robot", default="panda", help="'panda', 'ur5e' (bundled) or a URDF path")
    p_gen.add_argument("--srdf", default=None, help="SRDF for a URDF --robot (groups, end effector, states)")
    p_gen.add_argument("--gripper", default=None, help="'panda_hand' or 'robotiq_2f85' (default: the robot's own)")
    p_gen.add_argument(
        "--objects", default=None, help="folder of URDF / OBJ / STL / DAE objects: scenes are piles of them"
    )
    p_gen.add_argument(
        "--clutter",
        type=int,
        default=None,
        help="objects on the table, 1 to 6 (default 3-5); with --objects: mesh objects, 1 to 15 (default 5)",
    )
    p_gen.add_argument("--cameras", default="scene:640x480,wrist:320x240", help="NAME:WxH,... of scene and/or wrist")
    p_gen.add_argument("--fps", type=int, default=10, help="control and recording rate (Hz), divides 240")
    p_gen.add_argument(
        "--segmentation",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="record segmentation label images (lossless uint16 ids; default on, --no-segmentation leaves them out)",
    )
    p_gen.add_argument("--no-randomize", action="store_true", help="no domain randomisation")
    p_gen.add_argument(
        "--ray", default="auto", help="auto (Ray if installed, else local processes), off, or a cluster ADDRESS"
    )
    p_gen.add_argument("--workers", type=int, default=None, help="local worker processes (default one per core)")
    p_gen.add_argument("--quiet", action="store_true", help="no progress bar")
    p_gen.set_defaults(func=cmd_generate)
    args = parser.parse_args(argv)
    if args.version:
        from . import __version__

        print(f"ferrobot {__version__}")
        return 0
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except FerrobotError as e:
        print(f"ferrobot: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
