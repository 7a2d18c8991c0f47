"""FK throughput of the Panda from Python: single calls and batches.

    python benches/fk.py [--n 1000000] [--repeats 7] [--json FILE]

Prints medians over the repeats. Targets (2-core machine): batched end-effector
FK >= 5 million configurations/s; one ``fk`` call <= 2 us. Pinocchio's Python
binding is timed on the same configurations as a reference when installed.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

import numpy as np

import ferrobot

SHARED = Path(__file__).resolve().parents[2] / "shared"


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_model(label: str, model, n: int, repeats: int) -> dict:
    rng = np.random.default_rng(0)
    qs = rng.uniform(model.lower_limits, model.upper_limits, size=(n, model.num_dof))
    calls = 20_000
    q0 = qs[0].copy()

    def single():
        for _ in range(calls):
            model.fk(q0)

    def jac():
        for _ in range(calls):
            model.jacobian(q0)

    model.fk_batch(qs[:1000])
    t_single = median_time(single, repeats) / calls
    t_jac = median_time(jac, repeats) / calls
    t_batch = median_time(lambda: model.fk_batch(qs), repeats)
    res = {
        "robot": label,
        "single_fk_us": t_single * 1e6,
        "single_jacobian_us": t_jac * 1e6,
        "batch_n": n,
        "batch_fk_per_s": n / t_batch,
    }
    print(
        f"{label:<22} fk() {res['single_fk_us']:.3f} us | jacobian() {res['single_jacobian_us']:.3f} us"
        f" | fk_batch({n:,}) {t_batch * 1e3:.1f} ms = {res['batch_fk_per_s'] / 1e6:.2f} M configs/s"
    )
    return res


def bench_pinocchio(repeats: int) -> dict | None:
    try:
        import pinocchio as pin
    except ImportError:
        return None
    pm = pin.buildModelFromUrdf(str(SHARED / "robots/panda/panda.urdf"))
    data = pm.createData()
    fid = pm.getFrameId("panda_hand")
    q = np.zeros(pm.nq)
    calls = 20_000

    def single():
        for _ in range(calls):
            pin.framesForwardKinematics(pm, data, q)
            _ = data.oMf[fid].homogeneous

    t = median_time(single, repeats) / calls
    print(f"{'pinocchio (reference)':<22} framesForwardKinematics + oMf[hand] {t * 1e6:.3f} us")
    return {"robot": "pinocchio panda", "single_fk_us": t * 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    print(f"ferrobot {ferrobot.__version__}, {os.cpu_count()} cores")
    results = [
        bench_model("bundled panda (8 dof)", ferrobot.robots.panda(), args.n, args.repeats),
        bench_model(
            "mbm panda (7 dof)",
            ferrobot.RobotModel.from_urdf(SHARED / "robots/panda/panda.urdf", ee_link="panda_hand"),
            args.n,
            args.repeats,
        ),
    ]
    ref = bench_pinocchio(args.repeats)
    if ref:
        results.append(ref)
    if args.json:
        Path(args.json).write_text(json.dumps({"cores": os.cpu_count(), "results": results}, indent=2))


if __name__ == "__main__":
    main()
