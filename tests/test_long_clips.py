"""Long clips cut into segments: RONELD's tracking state travels from one segment to the next,
segments are scored in any worker, and nothing a run writes depends on the cut or on --workers.

The segment length is lowered to a few frames so that tracking crosses many cuts, curve mode
and vanishing ego lanes included (the synthetic clips' styles), on a set that runs in seconds.
"""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import pytest

from roneld_eval import api, evaluation
from roneld_eval.errors import InputError
from roneld_eval.synth import synth_culane

SEGMENT = 4  # frames per segment in these tests: every clip but the short one is cut
OUTPUTS = ("accuracy.csv", "per_frame.csv", "official.csv", "gains.csv")


def structure() -> list[tuple[str, list[str]]]:
    # One clip of each synthetic style (normal, curve, lane change, vanishing ego lanes), and
    # one too short to be cut.
    lengths = [23, 30, 26, 19, 5]
    clips = [f"driver_1_30frame/clip{k}.MP4" for k in range(len(lengths))]
    return [(clip, [f"{clip}/{30 * i:05d}.jpg" for i in range(n)]) for clip, n in zip(clips, lengths)]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("long-clips") / "set"
    synth_culane(root, structure=structure(), seed=5)
    return root


@pytest.fixture
def dataset(base, tmp_path):
    shutil.copytree(base, tmp_path / "set")
    return tmp_path / "set"


def config_for(root: Path, workers: int, **overrides):
    values = {"dataset.data_root": str(root / "data"), "maps.root": str(root / "maps"), "workers": workers,
              "methods": "baseline,roneld,roneld-nopft", "save_lanes": True}
    values.update(overrides)
    return api.default_config("culane").with_overrides(**values)


def files(folder: Path) -> dict[str, bytes]:
    kept = [path for path in sorted(folder.rglob("*")) if path.is_file()
            and (path.name in OUTPUTS or "lanes" in path.relative_to(folder).parts)]
    return {str(path.relative_to(folder)): path.read_bytes() for path in kept}


def runs(root: Path, tmp_path: Path, monkeypatch, **overrides) -> dict[str, tuple]:
    """The same run whole (clips never cut) with one worker, and cut with one and two workers."""
    out = {}
    for name, segment, workers in (("whole", 10_000, 1), ("cut-1", SEGMENT, 1), ("cut-2", SEGMENT, 2)):
        monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", segment)
        folder = tmp_path / name
        result = api.run(config_for(root, workers, **overrides), folder, progress=False)
        out[name] = (files(folder), result.counts, result.skipped, list(result.runtime["frames"]))
    return out


def test_segments_are_real(base, monkeypatch):
    monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", SEGMENT)
    context = evaluation.RunContext(config_for(base, 2), base / "maps")
    clips = [evaluation.segments_of(clip, context) for clip in _clips(base)]
    assert [len(parts) for parts in clips] == [6, 8, 7, 5, 1]
    for parts, (_, relpaths) in zip(clips, structure()):
        assert [frame.relpath for part in parts for frame in part.frames] == relpaths


def test_cutting_and_workers_change_no_byte(base, tmp_path, monkeypatch):
    found = runs(base, tmp_path, monkeypatch)
    whole = found.pop("whole")
    assert any("lanes" in name for name in whole[0]) and "per_frame.csv" in whole[0]
    for name, other in found.items():
        assert other[0] == whole[0], name
        assert other[1:] == whole[1:], name


def test_skipped_frames_and_labels_are_listed_alike(dataset, tmp_path, monkeypatch):
    stems = [relpath[:-4] for relpath in structure()[1][1]]
    (dataset / "maps" / f"{stems[9]}.npy").write_bytes(b"not a map")  # inside the third segment
    (dataset / "data" / f"{stems[13]}.lines.txt").write_text("1 2 three\n")
    found = runs(dataset, tmp_path, monkeypatch, on_error="skip")
    whole = found.pop("whole")
    assert len(whole[2]) == 2 and "labels skipped" in whole[2][0] and "frame skipped" in whole[2][1]
    for name, other in found.items():
        assert other == whole, name


def test_an_error_in_a_segment_is_the_error_of_one_worker(dataset, tmp_path, monkeypatch):
    stems = [relpath[:-4] for relpath in structure()[2][1]]
    broken = dataset / "maps" / f"{stems[17]}.npy"
    broken.write_bytes(b"not a map")
    monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", SEGMENT)
    messages = []
    for workers in (1, 2):
        with pytest.raises(InputError) as caught:
            api.run(config_for(dataset, workers), tmp_path / f"out{workers}", progress=False)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and str(broken) in messages[0]


def test_tracking_state_survives_pickling(base):
    """Extracting a clip in two halves, the state pickled between them, predicts what one pass does."""
    config = config_for(base, 1)
    context = evaluation.RunContext(config, base / "maps", base / "data", data_root=base / "data")
    clip = evaluation.segments_of(_clips(base)[1], context)[0]  # the curved clip, whole (default segments)
    whole = evaluation.extract_segment(clip, context, evaluation.Tracking())
    middle = len(clip.frames) // 2
    tracking = evaluation.Tracking()
    first = evaluation.extract_segment(_part(clip, 0, middle), context, tracking)
    tracking = pickle.loads(pickle.dumps(tracking))
    second = evaluation.extract_segment(_part(clip, middle, None), context, tracking)
    halves = first.labelled + second.labelled
    assert len(halves) == len(whole.labelled) == len(clip.frames)
    for (frame, predicted), (frame_again, expected) in zip(halves, whole.labelled):
        assert frame.relpath == frame_again.relpath
        for method, prediction in expected.items():
            assert _points(predicted[method]) == _points(prediction), (frame.relpath, method)


def test_plug_ins_keep_their_clips_whole(base, monkeypatch):
    monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", SEGMENT)
    clips = _clips(base)
    built_in = evaluation.RunContext(config_for(base, 2), base / "maps")
    assert evaluation.work_units(clips, built_in) == 6 + 8 + 7 + 5 + 1
    with_plugin = config_for(base, 2, methods="baseline").with_plugin("mine", "plugin_extractors:no_op")
    assert evaluation.work_units(clips, evaluation.RunContext(with_plugin, base / "maps")) == len(clips)


def test_progress_counts_every_frame_once(base, monkeypatch):
    monkeypatch.setattr(evaluation, "SEGMENT_FRAMES", SEGMENT)
    config = config_for(base, 2, save_lanes=False)
    clips = _clips(base)
    context = evaluation.RunContext(config, base / "maps", base / "data", data_root=base / "data")
    told: list[int] = []
    results = list(evaluation._clip_results(clips, context, 2, advance=told.append))
    assert [result.clip_id for result in results] == [clip.clip_id for clip in clips]
    assert sum(told) == sum(len(clip.frames) for clip in clips) and len(told) == 6 + 8 + 7 + 5 + 1


def _clips(root: Path):
    from roneld_eval.datasets import read_dataset

    return list(read_dataset("culane", root / "data", None, None, labels=False).clips)


def _part(clip, start, stop):
    from dataclasses import replace

    return replace(clip, frames=clip.frames[start:stop])


def _points(prediction) -> tuple:
    lanes = tuple(lane.points.tobytes() for lane in prediction.lanes)
    active = tuple(None if lane is None else lane.points.tobytes() for lane in prediction.active)
    return lanes, active
