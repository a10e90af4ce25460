"""Ctrl-C during `atmosim.render`: a KeyboardInterrupt within about a
second (the render stops after its current wave, which aims at 1 s), and
the GIL free meanwhile."""

import signal
import subprocess
import sys
import textwrap
import time

SCRIPT = textwrap.dedent(
    """
    import sys, threading, time
    import atmosim
    job = {"sensor": {"type": "fisheye", "resolution": 64}, "render": {"samples": 100000}}
    ticks = []
    def tick():  # runs only if render releases the GIL
        while True:
            ticks.append(time.monotonic())
            time.sleep(0.05)
    threading.Thread(target=tick, daemon=True).start()
    print("start", flush=True)
    try:
        atmosim.render(job, threads=1, progress=False)
    except KeyboardInterrupt:
        print("interrupted", len(ticks), flush=True)
        sys.exit(3)
    print("finished", flush=True)
    """
)


def test_ctrl_c_stops_a_render_within_a_second(tmp_path):
    p = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, text=True, cwd=tmp_path)
    assert p.stdout.readline().strip() == "start"
    time.sleep(2.0)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=30)
    elapsed = time.monotonic() - sent
    assert p.returncode == 3, out
    words = out.split()
    assert words[0] == "interrupted"
    # The other thread kept ticking while the render ran (every 50 ms for
    # about 2 s): the GIL was released.
    assert int(words[1]) >= 15
    # Within about a second; slack for a loaded machine and the
    # interpreter's exit.
    assert elapsed < 2.5, f"{elapsed:.2f} s from SIGINT to exit"
