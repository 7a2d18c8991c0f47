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
        import uvicorn
    except ImportError:
        print("ferrobot: error: serve-grasp needs the 'serve' extra: pip install 'ferrobot[serve]'", file=sys.stderr)
        return 1
    import os

    from .grasp.server import _ENV_MAX_BODY

    if args.workers < 1:
        print("ferrobot: error: --workers must be >= 1", file=sys.stderr)
        return 2
    if args.max_body_mb <= 0:
        print("ferrobot: error: --max-body-mb must be > 0", file=sys.stderr)
        return 2
    # Worker processes build the app from the environment (uvicorn imports the factory by name).
    os.environ[_ENV_MAX_BODY] = str(int(args.max_body_mb * 1024 * 1024))
    print(
        f"ferrobot grasp service on http://{args.host}:{args.port} ({args.workers} worker(s)); "
        "POST /process (JSON), POST /process_npz (binary), GET /health",
        flush=True,
    )
    uvicorn.run(
        "ferrobot.grasp.server:create_app",
        factory=True,
        host=args.host,
        port=args.port,
        workers=args.workers,
        log_level=args.log_level,
    )
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
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
        )
        print(
            f"{s['successes']}/{s['episodes']} succeeded ({100 * s['success_rate']:.1f}%), "
            f"{s['episodes_per_second']:.2f} episodes/s ({s['episodes_per_hour']:.0f}/h) on this machine"
        )
        if s["failures_by_stage"]:
            print("failures by stage: " + ", ".join(f"{k} {v}" for k, v in s["failures_by_stage"].items()))
        print(f"wrote {out / 'episodes.jsonl'} and {out / 'summary.json'}")
        return 0
    pp = PickPlace(config)
    spec = random_scene(args.seed, args.objects)
    objs = ", ".join(f"{o.name}" for o in spec.objects)
    print(
        f"ferrobot demo: bundled Panda before a table with {len(spec.objects)} objects ({objs}); "
        f"pick '{spec.target}' and place it at ({spec.place_xy[0]:.3f}, {spec.place_xy[1]:.3f})"
    )
    result = pp.run(spec, record_frames=not args.no_animation)
    print(format_report(result))
    paths = write_episode(out, pp, result)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0 if result.success else 1


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
    findings = report["findings"]
    count = {s: sum(f["severity"] == s for f in findings) for s in ("error", "warning", "info")}
    failed = count["error"] > 0 or (args.strict and count["warning"] > 0)
    if args.json:
        print(json.dumps({**report, "counts": count, "ok": not failed}, indent=2))
    else:
        print(report["tree"], end="")
        print()
        shown = [f for f in findings if args.verbose or f["severity"] != "info" or f["code"] == "sphere-coverage"]
        for f in shown:
            where = f"{report['source']}:{f['line']}" if f["line"] else report["source"]
            print(f"{where}: {f['severity']}: [{f['code']}] {f['message']}")
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
    p_demo.add_argument("--objects", type=int, default=None, help="objects on the table (default 3-5 at random)")
    p_demo.add_argument("--no-animation", action="store_true", help="single episode: skip the animation")
    p_demo.add_argument("--quiet", action="store_true", help="batch: no progress bar")
    p_demo.add_argument(
        "--workers", type=int, default=None, help="batch: episodes run in this many processes (default: one per core)"
    )
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
    p_serve.add_argument("--max-body-mb", type=float, default=64.0, help="request size limit in MiB (default 64)")
    p_serve.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p_serve.set_defaults(func=cmd_serve_grasp)
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
