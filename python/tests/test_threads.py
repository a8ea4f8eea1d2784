"""The GIL is released while rendering, progress arrives on the calling thread, Ctrl-C stops a
render within a second."""

import os
import signal
import threading
import time

import pytest

import pmrender as pm
from conftest import SCENES


def slow_scene():
    return pm.load_file(SCENES / "interior-diffuse.toml", width=160, height=120)


def test_another_thread_keeps_running_during_a_render():
    scene = slow_scene()
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.005)

    t = threading.Thread(target=tick)
    t.start()
    start = time.monotonic()
    pm.render(scene, spp=16)
    took = time.monotonic() - start
    stop.set()
    t.join()
    during = [x for x in ticks if start <= x <= start + took]
    # Held GIL would allow none; released, the thread ticks every few milliseconds.
    assert len(during) > took / 0.05, (len(during), took)


def test_progress_receives_fractions_in_order_on_the_calling_thread():
    seen = []
    caller = threading.get_ident()
    pm.render(slow_scene(), spp=16, progress=lambda f: seen.append((f, threading.get_ident())))
    fractions = [f for f, _ in seen]
    assert len(fractions) >= 2
    assert all(0.0 <= f <= 1.0 for f in fractions)
    assert fractions == sorted(fractions)
    assert fractions[-1] == 1.0
    assert {t for _, t in seen} == {caller}


def test_keyboard_interrupt_stops_a_render_within_a_second():
    scene = slow_scene()
    timer = threading.Timer(0.4, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        pm.render(scene, spp=1024, noise=0)
    assert time.monotonic() - start < 0.4 + 1.0
    # The module is usable after an interrupt.
    assert pm.render(pm.load_file(SCENES / "cornell-caustics.toml", width=16, height=12), spp=1).image.size
