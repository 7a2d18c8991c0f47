"""URDF load time against the number of links (issue 15): a long chain and a wide tree.

Loading used to be quadratic in the number of links (3,000 links 2.8 s, 10,000 links 26.5 s):
every element's line number was looked up by scanning the text from its start (roxmltree's
`text_pos_at`), and missing limit attributes were inserted back to front into one string. Prints CPU time
(`time.process_time`) per load, the ratio to the previous size (about 3.3 for a linear
loader, 11 for a quadratic one at 1k -> 3k -> 10k) and checks FK on the chain against its closed
form (every joint turns about z, so the tip is at 1 cm per link straight up and the rotation
about z is the sum of the angles).

    python benches/urdf_load.py [--sizes 1000 3000 10000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ferrobot


def chain(n: int) -> str:
    parts = ['<robot name="chain">', '<link name="l0"/>']
    for i in range(1, n + 1):
        parts.append(
            f'<link name="l{i}"/><joint name="j{i}" type="revolute"><parent link="l{i - 1}"/>'
            f'<child link="l{i}"/><origin xyz="0 0 0.01"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    parts.append("</robot>")
    # One line, as generated documents often are (and as the memory test in
    # tests/test_hardening.py writes it): the old line lookup was slowest there.
    return "".join(parts)


def tree(n: int, fanout: int = 8) -> str:
    """A wide tree: link i hangs from link (i - 1) // fanout; half the joints fixed."""
    parts = ['<robot name="tree">', '<link name="l0"/>']
    for i in range(1, n + 1):
        kind = "fixed" if i % 2 else "continuous"
        parts.append(
            f'<link name="l{i}"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>'
            f'<joint name="j{i}" type="{kind}"><parent link="l{(i - 1) // fanout}"/>'
            f'<child link="l{i}"/><origin xyz="0.01 0 0" rpy="0 0 0.1"/><axis xyz="0 0 1"/></joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000, 10000])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    for name, make in (("chain", chain), ("tree", tree)):
        prev = None
        for n in args.sizes:
            text = make(n)
            best = float("inf")
            for _ in range(args.repeat):
                c0 = time.process_time()
                m = ferrobot.RobotModel.from_urdf_string(text)
                best = min(best, time.process_time() - c0)
            ratio = f"{best / prev:5.1f}x" if prev else "     "
            prev = best
            check = ""
            if name == "chain":
                q = np.random.default_rng(n).uniform(-1, 1, m.num_dof)
                tip = m.fk(q, link=f"l{n}")
                expect = np.eye(4)
                a = q.sum()
                expect[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
                expect[2, 3] = 0.01 * n
                err = np.abs(tip - expect).max()
                check = f"FK error vs closed form {err:.1e}"
            print(f"{name:6s} {n:6d} links: {best:7.3f} s CPU (best of {args.repeat}) {ratio}  {check}", flush=True)


if __name__ == "__main__":
    main()
