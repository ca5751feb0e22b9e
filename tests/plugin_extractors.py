"""Extractors written as a user would write them, outside the package (tests/test_plugins.py).

Each factory takes (geometry, params) and returns a callable that maps FrameMaps to a
Prediction; the malformed ones break the protocol in one way each.
"""

from __future__ import annotations

import time

import numpy as np

from roneld_eval import Lane, Prediction


def brightest_points(maps, geometry, channel: int, threshold: int, step: int) -> Lane | None:
    """The brightest column of one channel every `step` map rows of its lower half."""
    rows = np.arange(maps.height // 2, maps.height, step)
    columns = maps.probabilities[channel, rows].argmax(axis=1)
    keep = maps.probabilities[channel, rows, columns] > threshold
    if keep.sum() < 2:
        return None
    return Lane(geometry.map_to_image(np.stack([columns[keep], rows[keep]], axis=1)))


def ego_points(geometry, params):
    """A working extractor: the two ego channels' brightest points, stateless."""
    threshold, step = params.get("threshold", 128), params.get("step", 10)

    def extract(maps):
        left, right = (brightest_points(maps, geometry, channel, threshold, step) for channel in (1, 2))
        return Prediction(lanes=[lane for lane in (left, right) if lane is not None], active=(left, right))

    extract.stateless = True
    return extract


class CountingExtractor:
    """Stateful: counts the frames it has seen in its clip and reports nothing."""

    def __init__(self, geometry, params):
        self.seen = 0

    def __call__(self, maps):
        self.seen += 1
        return Prediction()


def no_op(geometry, params):
    """The cheapest possible plug-in: what the runner itself costs per method (bench_plugins)."""
    empty = Prediction()

    def extract(maps):
        return empty

    extract.stateless = True
    return extract


# ---- broken on purpose: each must stop the run with one line (or be skipped) ----------------

def raises(geometry, params):
    def extract(maps):
        raise ZeroDivisionError("division by zero in my post-processing")

    return extract


def wrong_type(geometry, params):
    def extract(maps):
        return [np.zeros((5, 2))]  # a list of arrays, not a Prediction

    return extract


def nan_lanes(geometry, params):
    def extract(maps):
        lane = Lane(np.array([[100.0, 300.0], [np.nan, 400.0], [120.0, 500.0]]))
        return Prediction(lanes=[lane], active=(lane, None))

    return extract


def far_lanes(geometry, params):
    def extract(maps):  # normalised coordinates times the wrong size: far outside the image
        lane = Lane(np.array([[50_000.0, 300.0], [51_000.0, 589.0]]))
        return Prediction(lanes=[lane], active=(None, lane))

    return extract


def normalised_lanes(geometry, params):
    def extract(maps):  # x / W and y / H: inside the image, and a 1x1-pixel corner of it
        lane = Lane(np.array([[0.45, 0.5], [0.48, 0.99]]))
        return Prediction(lanes=[lane], active=(lane, None))

    return extract


def one_point_lanes(geometry, params):
    def extract(maps):
        lane = Lane(np.array([[800.0, 400.0]]))
        return Prediction(lanes=[lane], active=(lane, None))

    return extract


def slow_once(geometry, params):
    """Hangs on its clip's third frame (until the time limit stops it)."""
    seconds = params.get("seconds", 30.0)
    state = {"frames": 0}

    def extract(maps):
        state["frames"] += 1
        if state["frames"] == 3:
            time.sleep(seconds)
        return Prediction()

    return extract


def spins_deaf(geometry, params):
    """On its clip's second frame, ignores SIGALRM and never returns: its worker cannot stop it.
    It loops on short sleeps, not on nothing: the same to every signal and to the main process
    that kills it, without taking a core from the tests beside it for the seconds it waits."""
    import signal

    state = {"frames": 0}

    def extract(maps):
        state["frames"] += 1
        if state["frames"] == 2:
            signal.signal(signal.SIGALRM, signal.SIG_IGN)
            while True:
                time.sleep(0.01)
        return Prediction()

    return extract


def swallows_everything(geometry, params):
    """On its clip's second frame, ignores SIGALRM and SIGTERM and spins, swallowing every
    exception (Ctrl-C's KeyboardInterrupt too); creates the file `spinning` names as it begins."""
    import signal
    from pathlib import Path

    state = {"frames": 0}

    def extract(maps):
        state["frames"] += 1
        if state["frames"] == 2:
            signal.signal(signal.SIGALRM, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            if params.get("spinning"):
                Path(params["spinning"]).touch()
            while True:
                try:
                    time.sleep(0.01)
                except BaseException:
                    pass
        return Prediction()

    return extract


def factory_raises(geometry, params):
    raise KeyError("threshold")


def factory_returns_number(geometry, params):
    return 42


def exits(geometry, params):
    def extract(maps):
        raise SystemExit(0)  # sys.exit(0) deep in someone's code

    return extract


def ends_process(geometry, params):
    """Ends its own process on its clip's second frame, or in the factory (params 'where'):
    os._exit, a signal, or os._exit after forking a process that outlives it ('how')."""
    import os
    import signal

    def end():
        how = params.get("how", "exit")
        if how == "fork":
            if os.fork() == 0:  # holds the worker's pipes open for a while
                time.sleep(20)
                os._exit(0)
            os._exit(params.get("status", 0))
        if how == "exit":
            os._exit(params.get("status", 0))
        os.kill(os.getpid(), signal.SIGKILL)

    if params.get("where") == "factory":
        end()

    def extract(maps):
        extract.calls += 1
        if extract.calls == params.get("on_call", 2):
            end()
        return Prediction()

    extract.calls = 0
    return extract


def writes_maps(geometry, params):
    def extract(maps):
        maps.probabilities[:] = 0  # would blank the maps for the methods after it
        return Prediction()

    return extract


def ignores_the_alarm(geometry, params):
    def extract(maps):
        try:
            time.sleep(params.get("seconds", 2.0))
        except BaseException:  # swallows the time limit's interruption
            time.sleep(params.get("seconds", 2.0))
        return Prediction()

    return extract
