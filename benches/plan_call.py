"""Cost of one ``Planner.plan`` call from Python on an easy problem (the direct connection succeeds), with a
full start (``dof_names`` order: its finger value is locked for this query, through a plan request) and
with a start of the planned joints only. Best of 5 batches of 40 calls, CPU time per call.

    python benches/plan_call.py
"""

from __future__ import annotations

import time

import ferrobot


def main() -> None:
    m = ferrobot.robots.panda()
    w = ferrobot.CollisionWorld()
    w.add_box("table", [0.8, 1.2, 0.05], [0.55, 0.0, 0.0, 1, 0, 0, 0])
    w.add_cylinder("post", 0.04, 0.5, [0.5, -0.05, 0.25, 1, 0, 0, 0])
    p = ferrobot.Planner(m, w)
    q0 = m.named_state("ready")
    goal = p.ik([0.45, 0.25, 0.30, 0.0, 1.0, 0.0, 0.0], collision_free=True)
    out = {}
    for label, start in (("full start", q0), ("planned-joints start", q0[:7])):
        best = float("inf")
        for _ in range(5):
            t = time.process_time()
            for s in range(40):
                p.plan(start, goal_q=goal.q, seed=s)
            best = min(best, time.process_time() - t)
        out[label] = f"{best / 40 * 1e6:.0f} us"
    print(ferrobot.__file__, out)


if __name__ == "__main__":
    main()
