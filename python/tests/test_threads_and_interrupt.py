"""A run releases the GIL: other threads run Python meanwhile and two runs go on at once, with the
same numbers as one after the other; Ctrl-C stops a run on the main thread cleanly."""

import os
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np

import multibond
from conftest import SOURCE, example

# About a second: two million RK4 steps of the mass-spring-damper.
LONG = dict(t_end=2.5, dt=0.25, solver="rk4", step=1e-6)


def test_a_run_lets_other_threads_run_python():
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")
    done = threading.Event()
    span = {}

    def work():
        span["start"] = time.perf_counter()
        span["results"] = m.run(**LONG)
        span["end"] = time.perf_counter()
        done.set()

    t = threading.Thread(target=work)
    t.start()
    ticks = []
    while not done.is_set():  # the main thread keeps running Python while the run goes on
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    t.join()
    run_time = span["end"] - span["start"]
    inside = [x for x in ticks if span["start"] <= x <= span["end"]]
    gaps = np.diff([span["start"], *inside, span["end"]])
    # Holding the GIL, the run would leave one gap as long as itself.
    assert run_time > 0.2 and gaps.max() < 0.5 * run_time, (run_time, gaps.max())


def test_two_threads_run_at_once_with_the_same_numbers():
    # A short run in one thread begins and ends while a long one goes on in another: holding the
    # GIL, the long run would keep the other thread from starting until it ended.
    m = multibond.load(example("mass_spring_damper.yaml"), jit="off")  # one compiled model, shared: it is immutable
    short = dict(LONG, t_end=0.05, dt=0.01)
    out, span = {}, {}

    def work(key, options):
        span[key + "_start"] = time.perf_counter()
        out[key] = m.run(**options)
        span[key + "_end"] = time.perf_counter()

    long_thread = threading.Thread(target=work, args=("long", LONG))
    long_thread.start()
    while "long_start" not in span:
        time.sleep(0.001)
    time.sleep(0.1)  # the long run is integrating by now
    short_thread = threading.Thread(target=work, args=("short", short))
    short_thread.start()
    short_thread.join()
    long_thread.join()
    assert span["long_start"] < span["short_start"] < span["short_end"] < span["long_end"], span
    np.testing.assert_array_equal(out["long"].array, m.run(**LONG).array)
    np.testing.assert_array_equal(out["short"].array, m.run(**short).array)


INTERRUPTED = textwrap.dedent(
    """
    import os, signal, sys, threading, time
    import multibond
    m = multibond.load(sys.argv[1], jit="off")
    threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    start = time.perf_counter()
    try:
        m.run(t_end=100, dt=0.5, solver="rk4", step=1e-6)  # about 40 s
        print("not interrupted")
        sys.exit(1)
    except KeyboardInterrupt as e:
        elapsed = time.perf_counter() - start
        r = e.results
        print("interrupted", round(elapsed, 3), r.status, len(r), r.t_reached, r.time[-1])
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # Python's handler is back
    after = m.run(t_end=1, dt=0.5)  # and the next run is not stopped
    print("after", after.status, len(after))
    """
)


def test_ctrl_c_stops_a_run_and_raises_keyboard_interrupt(tmp_path):
    script = tmp_path / "interrupt.py"
    script.write_text(INTERRUPTED)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    done = subprocess.run([sys.executable, str(script), str(example("mass_spring_damper.yaml"))], capture_output=True,
                          text=True, timeout=120, env=env, cwd=SOURCE)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines())
    elapsed, status, rows, t_reached, t_last = lines["interrupted"].split()
    assert float(elapsed) < 10.0 and status == "interrupted"
    assert int(rows) >= 1 and 0.0 <= float(t_last) <= float(t_reached) < 100.0
    assert lines["after"] == "ok 3"
