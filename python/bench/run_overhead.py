#!/usr/bin/env python3
"""The Python call overhead of a short run: Model.run against the C++ API's Model::Simulate on the
same model and options (python/bench/simulate_timing.cc), both after a warm-up, both on the plan
interpreter (jit off). Prints microseconds per run and the difference. Not a test: timings vary
with the machine's load.

    PYTHONPATH=build/ci/python /usr/bin/python3 python/bench/run_overhead.py \
        [--cpp build/ci/python/multibond_py_bench_simulate] [--model examples/mass_spring_damper.yaml]
"""

import argparse
import pathlib
import statistics
import subprocess
import time

import multibond

ROOT = pathlib.Path(__file__).resolve().parents[2]


def python_run_seconds(model, t_end, dt, repeats):
    for _ in range(10):
        model.run(t_end=t_end, dt=dt)
    start = time.perf_counter()
    for _ in range(repeats):
        r = model.run(t_end=t_end, dt=dt)
        r["spring.q"]  # a column view, as a user would read one
    return (time.perf_counter() - start) / repeats


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cpp", default=str(ROOT / "build/ci/python/multibond_py_bench_simulate"))
    p.add_argument("--model", default=str(ROOT / "examples/mass_spring_damper.yaml"))
    p.add_argument("--t-end", type=float, default=0.01)
    p.add_argument("--dt", type=float, default=1e-3)
    p.add_argument("--repeats", type=int, default=2000)
    p.add_argument("--sets", type=int, default=5)
    a = p.parse_args()
    model = multibond.load(a.model, jit="off")
    rows = len(model.run(t_end=a.t_end, dt=a.dt))
    py, cpp = [], []
    for _ in range(a.sets):  # alternated, so that a change of the machine's speed hits both
        py.append(python_run_seconds(model, a.t_end, a.dt, a.repeats))
        out = subprocess.run([a.cpp, a.model, str(a.t_end), str(a.dt), str(a.repeats)], check=True, capture_output=True, text=True)
        cpp.append(float(out.stdout))
    mp, mc = statistics.median(py), statistics.median(cpp)
    print(f"{pathlib.Path(a.model).name}, 0..{a.t_end:g} s, {rows} rows; medians of {a.sets} sets of {a.repeats} runs")
    print(f"  Model.run (Python):          {mp * 1e6:8.1f} us  (sets: {', '.join(f'{x * 1e6:.1f}' for x in py)})")
    print(f"  Model::Simulate (C++ API):   {mc * 1e6:8.1f} us  (sets: {', '.join(f'{x * 1e6:.1f}' for x in cpp)})")
    print(f"  Python's overhead per run:   {(mp - mc) * 1e6:8.1f} us")


if __name__ == "__main__":
    main()
