"""`roneld_eval.RoneldTracker` on a vehicle (issue 50): `update` gives, frame for frame, the
Prediction the run's RONELD gives on the same maps (the fixture, the real clip, synthetic VIL-100
and LLAMAS videos); frames are checked and a refused one changes nothing; trackers are
independent; EgoLanes' masks map into SCNN's channels as documented; `update` imports and
compiles nothing once the tracker is built. No timings are asserted (scripts/bench_online.py)."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import curving_frames, env_importing

import roneld_eval
from roneld_eval import api
from roneld_eval.cli import main
from roneld_eval.config import EvalConfig, RoneldParams
from roneld_eval.api import plan_run
from roneld_eval.extract.online import FrameRefused, egolanes_as_scnn, egolanes_split_column
from roneld_eval.extract.protocol import Prediction
from roneld_eval.extract.roneld import RoneldExtractor
from roneld_eval.geometry import MapGeometry

RoneldTracker = roneld_eval.RoneldTracker


# ---- the same lanes as the run's RONELD ---------------------------------------------------------


def run_predictions(config: EvalConfig, monkeypatch) -> list[list[Prediction]]:
    """Every Prediction the run's RONELD (with PFT) returned, per clip in clip order."""
    calls: dict[RoneldExtractor, list[Prediction]] = {}
    original = RoneldExtractor.__call__

    def recording(self, maps):
        prediction = original(self, maps)
        calls.setdefault(self, []).append(prediction)
        return prediction

    monkeypatch.setattr(RoneldExtractor, "__call__", recording)
    roneld_eval.evaluate(config.with_overrides(workers=1, methods=["roneld"]), progress=False)
    monkeypatch.setattr(RoneldExtractor, "__call__", original)
    return list(calls.values())


def tracked_predictions(config: EvalConfig, preset: str, as_float: bool = False) -> list[list[Prediction]]:
    """The same clips' maps, loaded as the run loads them, through one `update` tracker per clip."""
    planned = plan_run(config)
    out = []
    for clip in planned.clips:
        tracker = RoneldTracker.from_preset(preset, image_size=clip.frames[0].image_size)
        predictions = []
        for frame in clip.frames:
            maps = planned.context.load(frame).probabilities
            predictions.append(tracker.update(maps.astype(np.float32) / 255 if as_float else maps))
        out.append(predictions)
    return out


def assert_same(ours: list[list[Prediction]], theirs: list[list[Prediction]]) -> int:
    """Lane for lane, point for point; returns the number of lanes compared."""
    assert len(ours) == len(theirs)
    lanes = 0
    for clip_ours, clip_theirs in zip(ours, theirs):
        assert len(clip_ours) == len(clip_theirs)
        for mine, run in zip(clip_ours, clip_theirs):
            assert mine.spline == run.spline
            assert len(mine.lanes) == len(run.lanes)
            for a, b in zip(mine.lanes, run.lanes):
                np.testing.assert_array_equal(a.points, b.points)
            for a, b in zip(mine.active, run.active):
                assert (a is None) == (b is None)
                if a is not None:
                    np.testing.assert_array_equal(a.points, b.points)
                    lanes += 1
    return lanes


def test_the_fixture_gives_the_runs_lanes(monkeypatch):
    config = api.with_fixture(api.default_config("culane"))
    theirs = run_predictions(config, monkeypatch)
    assert assert_same(tracked_predictions(config, "scnn-culane"), theirs) > 20


def test_float_probabilities_give_the_runs_lanes(monkeypatch):
    """Floats are converted as the loader converts them (float32 * 255, rounded half to even)."""
    config = api.with_fixture(api.default_config("culane"))
    theirs = run_predictions(config, monkeypatch)
    assert assert_same(tracked_predictions(config, "scnn-culane", as_float=True), theirs) > 20


def test_the_real_clip_gives_the_runs_lanes(real_clip_tree, monkeypatch):
    data, maps = real_clip_tree
    config = EvalConfig.preset("scnn-culane").with_overrides(**{
        "dataset.data_root": str(data), "maps.root": str(maps), "maps.format": "scnn-png"})
    theirs = run_predictions(config, monkeypatch)
    assert [len(clip) for clip in theirs] == [90]
    assert assert_same(tracked_predictions(config, "scnn-culane"), theirs) > 150


@pytest.fixture(scope="module")
def synthetic_videos(tmp_path_factory):
    """VIL-100 (three videos of their own sizes, a detector's lanes) and LLAMAS (PNG maps)."""
    base = tmp_path_factory.mktemp("videos")
    for dataset, layout in (("vil100", "lanes"), ("llamas", "llamas-png")):
        result = CliRunner().invoke(main, ["synth", "--dataset", dataset, "--out", str(base / dataset), "--clips", "3",
                                           "--frames", "10", "--maps-format", layout])
        assert result.exit_code == 0, result.output
    return base


@pytest.mark.parametrize("dataset, preset, data, maps", [
    ("vil100", "lanes-vil100", "data", "maps"),
    ("llamas", "segmentation-llamas", "labels", "predictions"),
])
def test_synthetic_videos_give_the_runs_lanes(synthetic_videos, monkeypatch, dataset, preset, data, maps):
    root = synthetic_videos / dataset
    config = EvalConfig.preset(preset).with_overrides(**{
        "dataset.data_root": str(root / data), "maps.root": str(root / maps)})
    theirs = run_predictions(config, monkeypatch)
    assert len(theirs) == 3
    assert assert_same(tracked_predictions(config, preset), theirs) > 20


def test_the_old_call_still_works_beside_update():
    frames = curving_frames()
    geometry = MapGeometry(1640, 590, 800, 288)
    called, updated = RoneldTracker(RoneldParams(), geometry), RoneldTracker(RoneldParams(), geometry)
    for maps in frames:
        lanes = called(maps)
        prediction = updated.update(maps)
        assert prediction.active[0] is not None and lanes.left is not None
        np.testing.assert_array_equal(prediction.active[0].points, lanes.left.points)


# ---- several trackers -----------------------------------------------------------------------------


def _clip(shift: int) -> list[np.ndarray]:
    return [np.roll(maps, shift, axis=2) for maps in curving_frames()]


def _alone(frames) -> list[Prediction]:
    tracker = RoneldTracker.from_preset("scnn-culane")
    return [tracker.update(maps) for maps in frames]


def test_trackers_interleaved_are_independent():
    first, second = _clip(0), _clip(-60)
    a, b = RoneldTracker.from_preset("scnn-culane"), RoneldTracker.from_preset("scnn-culane", pft=True)
    together_a, together_b = [], []
    for one, other in zip(first, second):
        together_a.append(a.update(one))
        together_b.append(b.update(other))
    assert_same([together_a, together_b], [_alone(first), _alone(second)])


def test_trackers_in_threads_give_what_they_give_alone():
    clips = [_clip(shift) for shift in (0, -40, 40, -80)]
    results: dict[int, list[Prediction]] = {}

    def work(index: int) -> None:
        tracker = RoneldTracker.from_preset("scnn-culane")
        results[index] = [tracker.update(maps) for _ in range(5) for maps in clips[index]]

    threads = [threading.Thread(target=work, args=(index,)) for index in range(len(clips))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    expected = []
    for frames in clips:
        tracker = RoneldTracker.from_preset("scnn-culane")
        expected.append([tracker.update(maps) for _ in range(5) for maps in frames])
    assert_same([results[index] for index in range(len(clips))], expected)


# ---- refused frames -------------------------------------------------------------------------------


BAD_FRAMES = {
    "NaN": (lambda m: np.where(m > 100, np.nan, m / 255).astype(np.float32), "maps hold NaN or infinite values"),
    "above 1": (lambda m: m.astype(np.float32), "float maps must hold probabilities in [0, 1], found 0.."),
    "two dimensions": (lambda m: m[0], "maps must be a (channels, height, width) array, got shape (288, 800)"),
    "a batch": (lambda m: m[None], "not a batch: pass maps[0]"),
    "channels last": (lambda m: np.transpose(m, (1, 2, 0)), "pass np.transpose(maps, (2, 0, 1))"),
    "a background channel": (lambda m: np.concatenate([m[:1], m]), "drop a background channel first: maps[1:]"),
    "another size": (lambda m: m[:, :, :-8], "maps of 792x288 differ from this clip's 800x288"),
    "int32": (lambda m: m.astype(np.int32), "maps of dtype int32 are not supported"),
    "text": (lambda m: np.full(m.shape, "x"), "maps of dtype <U1 are not supported"),
    "one channel": (lambda m: m[:1], "maps have 1 channels, expected 4"),
}


@pytest.mark.parametrize("kind", BAD_FRAMES)
def test_a_refused_frame_changes_nothing(kind):
    frames = curving_frames()
    bad, expected = BAD_FRAMES[kind]
    tracker = RoneldTracker.from_preset("scnn-culane")
    before = [tracker.update(maps) for maps in frames[:6]]
    state, latency = tracker.state, tracker.latency()
    with pytest.raises(FrameRefused, match=None) as refused:
        tracker.update(bad(frames[6]))
    assert expected in str(refused.value) and str(refused.value).startswith("frame 7: ")
    assert isinstance(refused.value, ValueError) and isinstance(refused.value, roneld_eval.InputError)
    assert tracker.state is state and tracker.latency() == latency
    after = [tracker.update(maps) for maps in frames[6:]]
    assert_same([before + after], [_alone(frames)])


def test_a_clip_of_another_shape_is_refused_at_its_first_frame():
    tracker = RoneldTracker.from_preset("scnn-culane")
    with pytest.raises(FrameRefused, match=r"^frame 1: maps are 640x320 \(aspect 2.00\), but the configuration "
                                           r"expects 800x288 maps .* or give it a MapGeometry of these maps$"):
        tracker.update(np.zeros((4, 320, 640), np.uint8))
    tracker.update(np.zeros((4, 351, 976), np.uint8))  # another size of the same shape is rescaled
    tracker.reset()
    tracker.update(np.zeros((4, 288, 800), np.uint8))  # a new clip may change size


def test_unknown_channels_are_a_config_error():
    with pytest.raises(roneld_eval.ConfigError, match="channels must be one of scnn, egolanes, got 'rgb'"):
        RoneldTracker(channels="rgb")


# ---- EgoLanes -------------------------------------------------------------------------------------


def test_egolanes_masks_are_scnns_channels_split_at_the_vehicle():
    rng = np.random.default_rng(5)
    masks = rng.integers(0, 256, (3, 6, 11), dtype=np.uint8)
    mapped = egolanes_as_scnn(masks, 0.5)
    split = egolanes_split_column(11, 0.5)
    assert split == 6  # columns 0..5 lie left of x = 5.5
    np.testing.assert_array_equal(mapped[1], masks[0])
    np.testing.assert_array_equal(mapped[2], masks[1])
    np.testing.assert_array_equal(mapped[0, :, :split], masks[2, :, :split])
    np.testing.assert_array_equal(mapped[3, :, split:], masks[2, :, split:])
    assert not mapped[0, :, split:].any() and not mapped[3, :, :split].any()


def test_an_egolanes_tracker_is_an_scnn_tracker_on_the_mapped_channels():
    geometry = MapGeometry(1920, 960, 640, 320)
    frames = [maps[:, 16:, 80:720] for maps in _clip(0)]  # 640x272 of SCNN-ordered lanes ...
    frames = [np.pad(maps, ((0, 0), (48, 0), (0, 0))) for maps in frames]  # ... as 640x320
    ego = RoneldTracker(RoneldParams(), geometry, channels="egolanes")
    scnn = RoneldTracker(RoneldParams(), geometry)
    split = egolanes_split_column(640, 0.5)
    for maps in frames:
        other = np.maximum(maps[0], maps[3])
        masks = np.stack([maps[1], maps[2], other])
        expected = np.stack([np.where(np.arange(640) < split, other, 0), maps[1], maps[2],
                             np.where(np.arange(640) >= split, other, 0)]).astype(np.uint8)
        assert_same([[ego.update(masks)]], [[scnn.update(expected)]])
    assert ego.update(masks).active[0] is not None


# ---- latency --------------------------------------------------------------------------------------


def test_latency_summarises_the_last_calls():
    tracker = RoneldTracker.from_preset("scnn-culane", latency_frames=4)
    empty = tracker.latency()
    assert empty.frames == 0 and np.isnan(empty.p50_ms)
    for maps in curving_frames()[:6]:
        tracker.update(maps)
    latency = tracker.latency()
    assert latency.frames == 4
    assert 0 < latency.p50_ms <= latency.p99_ms <= latency.max_ms
    with pytest.raises(ValueError, match="at least 1 frame"):
        RoneldTracker(latency_frames=0)


# ---- nothing compiled or imported inside update ---------------------------------------------------


PROBE = """
import json, sys
import numpy as np
from roneld_eval import kernels
sys.path.insert(0, {tests!r})
from conftest import curving_frames
from roneld_eval.extract.roneld import RoneldTracker
if {warm}:
    tracker = RoneldTracker.from_preset("scnn-culane")
else:
    tracker = RoneldTracker()
compiled = lambda: {{name: set(map(str, kernel.signatures)) for name, kernel in kernels.dispatchers().items()}}
modules, signatures = set(sys.modules), compiled()
frames = curving_frames()
points = []
for maps in frames + [np.asfortranarray(frames[0]), frames[1].astype(np.float64) / 255, frames[2][:, ::-1]]:
    points += [len(lane) for lane in tracker.update(maps).lanes]
egolanes = RoneldTracker.from_preset("scnn-culane", channels="egolanes", warm=False)
for maps in frames[:3]:
    egolanes.update(maps[1:])
after = compiled()
print(json.dumps({{"imported": sorted(set(sys.modules) - modules), "most_points": max(points),
                  "compiled": {{name: sorted(after[name] - signatures.get(name, set())) for name in after
                               if after[name] - signatures.get(name, set())}}}}))
"""


def _probe(warm: bool) -> dict:
    program = PROBE.format(warm=warm, tests=str(Path(__file__).parent))
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=env_importing(),
                          timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_update_imports_and_compiles_nothing_after_from_preset():
    found = _probe(warm=True)
    assert found["most_points"] > 2  # curve mode reached: its spline was drawn inside update
    assert found["imported"] == [] and found["compiled"] == {}


def test_the_probe_sees_a_tracker_left_cold():
    """Built directly and not warmed, the first curve imports SciPy inside update: what
    from_preset and roneld_eval.warm_up() are for (and what the test above would catch)."""
    found = _probe(warm=False)
    assert "scipy.interpolate" in found["imported"]


# ---- floats: the loader's conversion, bit for bit -------------------------------------------------


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
@pytest.mark.parametrize("seed", range(3))
def test_float_levels_are_the_loaders_bit_for_bit(dtype, seed):
    """In reused buffers, not through the loader's function (its temporaries cost page faults a
    frame): the same levels for any probabilities, halfway values and [0, 1]'s ends included, and
    float64 values just above 1 that float32 rounds to 1 (the loader accepts them)."""
    from roneld_eval.config import MapsConfig
    from roneld_eval.extract.online import FrameBuffers, checked_frame
    from roneld_eval.maps._checks import canonical_probabilities

    rng = np.random.default_rng(seed)
    chosen = np.concatenate([(np.arange(255) + 0.5) / 255, [0.0, -0.0, 1.0, 1 + 1e-12, 1e-30, 0.5]])
    values = np.concatenate([rng.random(4 * 30 * 40 - len(chosen)), chosen])
    array = np.clip(values, None, 1 if dtype != np.float64 else None).astype(dtype).reshape(4, 30, 40)
    buffers = FrameBuffers()
    for frame in (array, array[:, ::-1], np.asfortranarray(array)):
        expected = canonical_probabilities(frame, "x", MapsConfig())
        np.testing.assert_array_equal(checked_frame(frame, "scnn", 4, "x", buffers), expected)


def test_the_readmes_vehicle_loop_runs_as_written():
    import re

    from conftest import REPO

    readme = (REPO / "README.md").read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"^```python\n(.*?)^```", readme, flags=re.S | re.M)
                 if ".update(" in b and "RoneldTracker" in b)
    assert len(block.splitlines()) <= 15
    frames = curving_frames()
    published, logged = [], []
    names = {"camera": lambda: [(maps, k == 6) for k, maps in enumerate(frames)],
             "model": lambda maps: maps.astype(np.float32) / 255,
             "publish": published.append, "log": logged.append}
    exec(compile(block, "README.md", "exec"), names)
    assert len(logged) == len(frames) and logged[-1].frames == len(frames)
    assert len(published) >= len(frames) and all(points.shape[1] == 2 for points in published)


@pytest.mark.parametrize("size", [(float("nan"), 590), ("1640", 590), (640,), (0, 590), (True, 590), None.__class__])
def test_an_image_size_that_is_not_two_whole_pixels_is_one_config_error(size):
    # (nan, 590) raised int()'s bare "cannot convert float NaN to integer"
    with pytest.raises(roneld_eval.ConfigError, match="image_size must be \\(width, height\\)"):
        RoneldTracker.from_preset("scnn-culane", image_size=size, warm=False)
