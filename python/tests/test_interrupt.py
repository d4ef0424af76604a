"""Long runs release the GIL and end at Ctrl-C (KeyboardInterrupt) between steps."""

import signal
import subprocess
import sys
import threading
import time

import helixbif

CHILD = r"""
import signal, sys, time
import helixbif
signal.signal(signal.SIGINT, signal.default_int_handler)
study = helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 40})
print("started", flush=True)
started = time.time()
try:
    study.simulate(0.3, t_end=1e7, ramp_time=5, shape_every=0)
except KeyboardInterrupt:
    print(f"interrupted {time.time() - started:.3f}", flush=True)
    sys.exit(3)
print("finished", flush=True)
"""


def test_ctrl_c_ends_a_simulation():
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline().strip() == "started"
        time.sleep(1.0)
        sent = time.time()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
        waited = time.time() - sent
    finally:
        child.kill()
    assert child.returncode == 3, (out, err)
    assert out.startswith("interrupted")
    # One time step at N = 40 takes milliseconds: the run ends at the next step.
    assert waited < 10.0


def test_runs_release_the_gil():
    counted = [0]
    done = threading.Event()

    def count():
        while not done.is_set():
            counted[0] += 1

    worker = threading.Thread(target=count)
    worker.start()
    try:
        helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 40}).simulate(
            0.3, t_end=200, ramp_time=5, shape_every=0
        )
        before = counted[0]
        time.sleep(0.05)
    finally:
        done.set()
        worker.join()
    # The counting thread ran during the run (with the GIL held throughout, it could count
    # only in the interpreter's switch intervals, a few times).
    assert before > 1000
