"""Ctrl-C (SIGINT) stops long native calls: they look for Python signals every 50 ms while the GIL is
released and raise the signal's KeyboardInterrupt (issue 19: `localize` with
`max_iterations=2**31-1` ran on for 36 s after SIGINT).

Each case runs in its own process: the parent waits until the child is inside the native call,
sends SIGINT, and expects the child to end with KeyboardInterrupt well within the timeout (a
guard against hanging the suite, not a measurement)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

_SCRIPT = textwrap.dedent(
    """
    import signal
    import sys
    import numpy as np
    import planicp
    from planicp import IcpConfig, RelocalizationConfig, se2

    xs = np.arange(0.0, 4.0, 0.05)
    ys = np.arange(0.0, 3.0, 0.05)
    box = np.vstack([np.c_[xs, 0 * xs], np.c_[xs, 0 * xs + 3.0], np.c_[0 * ys, ys], np.c_[0 * ys + 4.0, ys],
                     np.c_[xs[:30], 0 * xs[:30] + 1.0]])  # a shelf, so that the box is not symmetric
    plan = planicp.PlanMap.from_points(box)
    truth = (1.7, 1.6, 0.3)
    scan = se2.transform_points(se2.inverse(truth), box[::2] + 0.01)
    # Zero tolerances: every one of the 2**31 - 1 iterations runs (hours).
    endless = IcpConfig(max_iterations=2**31 - 1, translation_tolerance=0.0, rotation_tolerance=0.0)
    case = sys.argv[1]
    # A suite started in the background (`pytest ... &`) hands its children SIGINT ignored, and
    # Python then installs no KeyboardInterrupt handler: give the child Python's own.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    print("calling", flush=True)
    if case == "localize":
        planicp.localize(scan, plan, truth, endless)
    elif case == "localize_kd_tree":
        planicp.localize(scan, plan, truth, IcpConfig(max_iterations=2**31 - 1, translation_tolerance=0.0,
                                                      rotation_tolerance=0.0, correspondence_search="kd_tree"))
    elif case == "relocalize":
        planicp.relocalize(scan, plan, config=RelocalizationConfig(icp=endless))
    print("returned", flush=True)
    """
)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to a child process is a POSIX affair")
@pytest.mark.parametrize("case", ["localize", "localize_kd_tree", "relocalize"])
def test_ctrl_c_stops_a_long_native_call_with_keyboard_interrupt(case: str) -> None:
    child = subprocess.Popen(
        [sys.executable, "-c", _SCRIPT, case],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "calling", child.stderr.read() if child.stderr else ""
        time.sleep(1.0)  # well inside the native call (its set-up takes milliseconds)
        assert child.poll() is None, "the endless call returned"
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=10.0)
    except subprocess.TimeoutExpired:
        child.kill()
        child.communicate()
        pytest.fail(f"{case}: still running 10 s after SIGINT: the native call ignores Ctrl-C")
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
    assert "returned" not in out
    assert child.returncode != 0
    last = err.strip().splitlines()[-1] if err.strip() else ""
    assert last == "KeyboardInterrupt", err[-2000:]
