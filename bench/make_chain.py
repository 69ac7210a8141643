#!/usr/bin/env python3
"""Writes the scaling benchmark's test model to standard output: a chain of N rigid bodies (rods)
hanging from the ground, each on a revolute joint (axis y) to the previous one, under gravity, with
a torque step on the last body.

  compliant (default): translation K 1e6, R 20; rotation K 1e4, R 10 on every joint
  --rigid:             every joint an ideal constraint (`rigid: all`)

Usage: bench/make_chain.py N [--rigid] [--t-end T] > chain.yaml
"""
import argparse


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", type=int, help="number of bodies (>= 1)")
    ap.add_argument("--rigid", action="store_true", help="ideal (rigid) joints instead of compliant ones")
    ap.add_argument("--t-end", type=float, default=0.01, help="end time [s] (0.01)")
    a = ap.parse_args()
    if a.n < 1:
        ap.error("N must be at least 1")
    L = 0.1  # each rod's length [m]; joints at its ends, CoM in its middle
    out = []
    out.append(f"# A chain of {a.n} rods hanging from the ground (bench/make_chain.py).")
    out.append(f"model: chain_{a.n}{'_rigid' if a.rigid else ''}")
    out.append("gravity: [0, 0, -9.81]")
    if a.rigid:
        out.append("rigid: all")
    out.append("bodies:")
    for i in range(a.n):
        z = -(i + 0.5) * L
        out.append(f"  b{i}: {{mass: 1.0, inertia: [8.4e-4, 8.4e-4, 1.0e-5], position: [0, 0, {z:.6g}]}}")
    out.append("joints:")
    coupling = "" if a.rigid else ", translation: {K: 1.0e6, R: 20}, rotation: {K: 1.0e4, R: 10}"
    for i in range(a.n):
        if i == 0:
            out.append(f"  j{i}: {{type: revolute, child: b0, at: [0, 0, 0], child_at: [0, 0, {L / 2:.6g}], axis: y{coupling}}}")
        else:
            out.append(f"  j{i}: {{type: revolute, parent: b{i - 1}, child: b{i}, at: [0, 0, {-L / 2:.6g}], "
                       f"child_at: [0, 0, {L / 2:.6g}], axis: y{coupling}}}")
    out.append("drives:")
    out.append(f"  push: {{type: torque, body: b{a.n - 1}, axis: y, value: {{step: {{at: 0.0, value: 1.0}}}}}}")
    out.append(f"simulation: {{t_end: {a.t_end:g}, dt: {a.t_end / 10:g}}}")
    print("\n".join(out))


if __name__ == "__main__":
    main()
