"""The in-memory metrics inside mmengine and torchmetrics (`roneld_eval.frameworks`, the [train]
extra): the numbers `roneld_eval.metric` gives, in one process and across two (gloo, CPU), with
nothing written. Skipped where the extra is not installed, except under RONELD_EVAL_TRAIN=1
(`.ci/run`'s train step), where a missing package fails."""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np
import pytest

import roneld_eval
from roneld_eval.benchmarks.culane.reader import labels_path
from roneld_eval.benchmarks.culane.synth import synth_culane
from roneld_eval.lanes_io import read_lines_txt


def _need(module: str):
    if os.environ.get("RONELD_EVAL_TRAIN") == "1":
        return __import__(module)
    return pytest.importorskip(module)


@pytest.fixture(scope="module")
def culane_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("frameworks")
    synth_culane(root / "set", clips=3, frames=5, seed=12, maps_format="lanes")
    data, pred = root / "set" / "data", root / "set" / "maps"
    frames = roneld_eval.metric("culane", data_root=data).core.frames
    lanes = {frame: [lane.points for lane in read_lines_txt(labels_path(pred, frame))] for frame in frames}
    return data, lanes


def _expected(data: Path, lanes: dict, **options) -> dict[str, float]:
    metric = roneld_eval.metric("culane", data_root=data, **options)
    metric.update_many(list(lanes), list(lanes.values()))
    return metric.compute()


def test_mmengine_metric_built_from_a_config_gives_the_in_memory_numbers(culane_set, tmp_path, monkeypatch):
    _need("mmengine")
    from mmengine.registry import METRICS

    import roneld_eval.frameworks.mmengine_metric  # noqa: F401  registers RoneldLaneMetric

    data, lanes = culane_set
    monkeypatch.chdir(tmp_path)
    metric = METRICS.build(dict(type="RoneldLaneMetric", benchmark="culane", data_root=str(data), iou="0.3,0.5"))
    frames = list(lanes)
    random.Random(2).shuffle(frames)
    for k in range(0, len(frames), 4):
        metric.process({}, [{"frame": f, "lanes": lanes[f]} for f in frames[k:k + 4]])
    got = metric.evaluate(len(frames))
    assert got == _expected(data, lanes, iou="0.3,0.5") and got["F1@50"] > 0
    again = [{"frame": f, "lanes": lanes[f]} for f in frames]
    metric.process({}, again)
    assert metric.evaluate(len(frames)) == got  # a second epoch: the same numbers
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_clrernet_samples_and_keys_score_as_the_files_its_metric_writes(culane_set, tmp_path):
    _need("mmengine")
    from roneld_eval.frameworks.mmengine_metric import RoneldLaneMetric

    data, lanes = culane_set

    def clrernet_lane(points: np.ndarray):
        """A CLRerNet Lane: x in [0, 1) of y in [0, 1), by interpolation of the points."""
        order = np.argsort(points[:, 1])
        ys, xs = points[order, 1] / 590, points[order, 0] / 1640
        return lambda y: np.where((y < ys[0]) | (y > ys[-1]), -2.0, np.interp(y, ys, xs))

    samples = [{"lanes": [clrernet_lane(p) for p in lanes[f] if len(p) >= 2], "metainfo": {"sub_img_name": f}}
               for f in lanes]
    # the .lines.txt CLRerNet's get_prediction_string writes of these lanes (4bd8e7d), scored from files
    written = tmp_path / "tmp"
    ys = np.arange(0, 590, 2) / 590
    for sample in samples:
        lines = []
        for lane in sample["lanes"]:
            xs = lane(ys)
            valid = (xs >= 0) & (xs < 1)
            lane_xs, lane_ys = (xs * 1640)[valid][::-1], (ys[valid] * 590)[::-1]
            if len(lane_xs) >= 2:
                lines.append(" ".join("{:.5f} {:.5f}".format(x, y) for x, y in zip(lane_xs, lane_ys)))
        path = labels_path(written, sample["metainfo"]["sub_img_name"])
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + ("\n" if lines else ""))
    score = roneld_eval.score_culane(data, written, iou="0.1,0.5,0.75")

    metric = RoneldLaneMetric("culane", data_root=str(data), iou="0.1,0.5,0.75", names="clrernet",
                              sample=dict(style="clrernet", width=1640, height=590))
    metric.process({}, samples)
    got = metric.evaluate(len(samples))
    rows = {(r[1], r[2]): r for r in score.official_rows.rows}
    for label, name in (("0.10", "0.1"), ("0.50", "0.5"), ("0.75", "0.75")):
        _, _, _, tp, fp, fn, precision, recall, f1 = rows[("all", label)]
        assert (got[f"TP{name}"], got[f"FP{name}"], got[f"FN{name}"]) == (tp, fp, fn)
        assert (got[f"Precision{name}"], got[f"Recall{name}"], got[f"F1_{name}"]) == (precision, recall, f1)
        assert got[f"F1_test0_normal_{name}"] == rows[("normal", label)][8]
    categories = {r[1] for r in score.official_rows.rows} - {"all"}
    stems = {path.stem.split("_", 1)[1]: path.stem for path in (data / "list" / "test_split").glob("test*_*.txt")}
    assert len(categories) >= 3 and {f"F1_{stems[c]}_0.75" for c in categories} <= set(got)
    assert got["F1_0.5"] > 0 and len(got) == 6 * 3 + 3 * len(categories)


def _two_ranks(target, *args) -> None:
    """`target(rank, *args)` in two processes joined by a gloo group."""
    torch = _need("torch")
    import torch.multiprocessing as mp

    mp.spawn(target, args=args, nprocs=2, join=True)
    del torch


def _mmengine_rank(rank: int, init: str, data: str, lanes: dict, out: str) -> None:
    import torch.distributed as dist

    from roneld_eval.frameworks.mmengine_metric import RoneldLaneMetric

    dist.init_process_group("gloo", init_method=init, rank=rank, world_size=2)
    frames = list(lanes)
    mine = frames[rank::2] + ([frames[0]] if rank == 1 and len(frames) % 2 else [])  # a sampler's padding
    metric = RoneldLaneMetric("culane", data_root=data, iou="0.5")
    metric.process({}, [{"frame": f, "lanes": lanes[f]} for f in mine])
    got = metric.evaluate(len(frames))
    Path(out, f"rank{rank}.txt").write_text(repr(sorted(got.items())))
    dist.destroy_process_group()


def _mmengine_refusing_rank(rank: int, init: str, data: str, lanes: dict, out: str) -> None:
    import torch.distributed as dist

    from roneld_eval.frameworks.mmengine_metric import RoneldLaneMetric

    dist.init_process_group("gloo", init_method=init, rank=rank, world_size=2)
    frames = list(lanes)
    # rank 1 gives frame 0 (rank 0's) with frame 1's lanes in place of frame 1: within the
    # dataset's size, so mmengine's truncation of a sampler's padding does not drop it
    mine = frames[0::2] if rank == 0 else [frames[0], *frames[3::2]]
    metric = RoneldLaneMetric("culane", data_root=data, iou="0.5")
    metric.process({}, [{"frame": f, "lanes": lanes[f] if (rank, f) != (1, frames[0]) else lanes[frames[1]]}
                        for f in mine])
    try:
        metric.evaluate(len(frames))
        said = "no error"
    except roneld_eval.MetricInputError as error:
        said = str(error)
    Path(out, f"rank{rank}.txt").write_text(said)
    dist.destroy_process_group()


def test_a_refused_frame_is_one_error_on_every_rank_not_a_hang(culane_set, tmp_path, monkeypatch):
    _need("mmengine")
    data, lanes = culane_set
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    _two_ranks(_mmengine_refusing_rank, f"file://{tmp_path}/init", str(data), lanes, str(tmp_path / "out"))
    said = [(tmp_path / "out" / f"rank{rank}.txt").read_text() for rank in (0, 1)]
    assert said[0] == said[1] and "recorded twice with different lanes" in said[0] and list(lanes)[0] in said[0]


def test_mmengine_metric_over_two_ranks_equals_one_process(culane_set, tmp_path, monkeypatch):
    _need("mmengine")
    data, lanes = culane_set
    assert len(lanes) % 2 == 1  # rank 1 gets a padded frame
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    _two_ranks(_mmengine_rank, f"file://{tmp_path}/init", str(data), lanes, str(tmp_path / "out"))
    expected = repr(sorted(_expected(data, lanes, iou="0.5").items()))
    assert (tmp_path / "out" / "rank0.txt").read_text() == expected
    assert (tmp_path / "out" / "rank1.txt").read_text() == expected  # broadcast to every rank
    assert not (tmp_path / ".dist_test").exists()  # mmengine's cpu collection folder: not used


def _torchmetrics_rank(rank: int, init: str, data: str, lanes: dict, out: str) -> None:
    import torch.distributed as dist

    from roneld_eval.frameworks.torchmetrics_metric import LaneMetric

    dist.init_process_group("gloo", init_method=init, rank=rank, world_size=2)
    frames = list(lanes)
    mine = frames[rank::2] + ([frames[0]] if rank == 1 and len(frames) % 2 else [])
    metric = LaneMetric("culane", data_root=data, preset="clrnet")
    for k in range(0, len(mine), 3):
        metric.update(mine[k:k + 3], [lanes[f] for f in mine[k:k + 3]])
    Path(out, f"rank{rank}.txt").write_text(repr(sorted(metric.compute().items())))
    dist.destroy_process_group()


def test_torchmetrics_metric_in_one_process_and_over_two(culane_set, tmp_path):
    _need("torchmetrics")
    from roneld_eval.frameworks.torchmetrics_metric import LaneMetric

    data, lanes = culane_set
    expected = _expected(data, lanes, preset="clrnet")
    metric = LaneMetric("culane", data_root=str(data), preset="clrnet")
    frames = list(lanes)
    metric.update(frames[:6], [lanes[f] for f in frames[:6]])
    metric.update(frames[6:], [lanes[f] for f in frames[6:]])
    assert metric.compute() == expected and expected["mF1"] > 0
    metric.reset()
    metric.update(frames, list(lanes.values()))
    assert metric.compute() == expected  # the next epoch
    with pytest.raises(roneld_eval.MetricInputError, match="not a frame"):
        metric.update(["nowhere.jpg"], [[]])

    (tmp_path / "out").mkdir()
    _two_ranks(_torchmetrics_rank, f"file://{tmp_path}/init", str(data), lanes, str(tmp_path / "out"))
    for rank in (0, 1):
        assert (tmp_path / "out" / f"rank{rank}.txt").read_text() == repr(sorted(expected.items()))


def test_a_record_of_other_lanes_for_a_frame_is_refused(culane_set):
    data, lanes = culane_set
    metric = roneld_eval.metric("culane", data_root=data)
    frame, other = list(lanes)[:2]
    records = [metric.record(frame, lanes[frame]), metric.record(frame, lanes[frame])]
    metric.add_records(records)  # the same lanes twice: kept once
    with pytest.raises(roneld_eval.MetricInputError, match="recorded twice with different lanes"):
        metric.add_records([metric.record(frame, lanes[other])])
    assert metric.frames_updated == 1


def _readme_block(containing: str) -> str:
    import re

    from conftest import REPO

    readme = (REPO / "README.md").read_text(encoding="utf-8")
    return next(b for b in re.findall(r"^```python\n(.*?)^```", readme, flags=re.S | re.M) if containing in b)


def test_the_readmes_mmengine_config_runs_as_written(culane_set, tmp_path, monkeypatch):
    _need("mmengine")
    from mmengine.config import Config
    from mmengine.registry import METRICS
    from mmengine.utils import import_modules_from_strings

    data, lanes = culane_set
    monkeypatch.chdir(tmp_path)
    config_file = tmp_path / "config.py"
    config_file.write_text(_readme_block("val_evaluator").replace("/data/CULane", str(data)), encoding="utf-8")
    config = Config.fromfile(str(config_file))
    import_modules_from_strings(**config.custom_imports)
    metric = METRICS.build(config.test_evaluator)

    def clrernet_lane(points: np.ndarray):
        order = np.argsort(points[:, 1])
        ys, xs = points[order, 1] / 590, points[order, 0] / 1640
        return lambda y: np.where((y < ys[0]) | (y > ys[-1]), -2.0, np.interp(y, ys, xs))

    metric.process({}, [{"lanes": [clrernet_lane(p) for p in lanes[f] if len(p) >= 2],
                         "metainfo": {"sub_img_name": f}} for f in lanes])
    got = metric.evaluate(len(lanes))
    assert {"F1_0.1", "F1_0.5", "F1_0.75", "Precision0.5", "Recall0.5", "TP0.5", "F1_test0_normal_0.5"} <= set(got)
    assert 0 < got["F1_0.5"] <= 1
    assert [path.name for path in tmp_path.iterdir()] == ["config.py"]  # nothing written


def test_the_readmes_lightning_example_runs_in_a_trainer(culane_set, tmp_path):
    _need("lightning")
    import torch
    from lightning import LightningModule, Trainer

    data, lanes = culane_set
    names = {"LightningModule": LightningModule}
    exec(compile(_readme_block("class LitLanes").replace("/data/CULane", str(data)), "README.md", "exec"), names)
    frames = list(lanes)
    batches = [{"relpaths": frames[k:k + 4]} for k in range(0, len(frames), 4)]

    class Model(names["LitLanes"]):  # the README's model with a detector that returns the set's lanes
        def predict_lanes(self, batch):
            return [lanes[f] for f in batch["relpaths"]]

    loader = torch.utils.data.DataLoader(batches, batch_size=None, collate_fn=lambda batch: batch)
    trainer = Trainer(accelerator="cpu", devices=1, logger=False, enable_progress_bar=False,
                      enable_model_summary=False, default_root_dir=str(tmp_path))
    trainer.validate(Model(), loader, verbose=False)
    trainer.validate(Model(), loader, verbose=False)  # a second epoch
    logged = {key: float(value) for key, value in trainer.callback_metrics.items()}
    assert logged == pytest.approx(_expected(data, lanes, preset="clrnet"), abs=0, rel=1e-7)
    assert logged["mF1"] > 0


def test_torchmetrics_refuses_a_clash_at_update_and_forward_only_updates(culane_set):
    torch = _need("torch")
    _need("torchmetrics")
    from roneld_eval.frameworks.torchmetrics_metric import LaneMetric

    data, lanes = culane_set
    frames = list(lanes)
    metric = LaneMetric("culane", data_root=str(data), iou="0.5")
    assert metric(frames[:5], [lanes[f] for f in frames[:5]]) is None  # forward: an update, no batch score
    metric.update(frames[:2], [lanes[f] for f in frames[:2]])  # the same lanes again: kept once
    with pytest.raises(roneld_eval.MetricInputError, match="given twice with different lanes"):
        metric.update([frames[5], frames[0]], [lanes[frames[5]], []])  # the batch refused whole
    # tensors, with gradients, are lanes too
    metric.update(frames[5:], [[torch.tensor(p, requires_grad=True) for p in lanes[f]] for f in frames[5:]])
    assert metric.compute() == _expected(data, lanes, iou="0.5")
    with pytest.raises(roneld_eval.MetricInputError, match="offers no key names 'nope'"):
        LaneMetric("culane", data_root=str(data), names="nope")


def test_torchmetrics_update_takes_a_benchmarks_fields_per_frame(tmp_path):
    _need("torchmetrics")
    from roneld_eval.benchmarks.openlane.reader import json_path, read_lanes
    from roneld_eval.benchmarks.openlane.synth import synth_openlane
    from roneld_eval.frameworks.torchmetrics_metric import LaneMetric

    synth_openlane(tmp_path / "set", clips=2, frames=3, seed=4)
    labels, predictions = tmp_path / "set" / "labels", tmp_path / "set" / "predictions"
    metric = LaneMetric("openlane", labels=str(labels))
    frames = list(metric.lane_metric.core.frames)
    read = [read_lanes(json_path(predictions, f)) for f in frames]
    metric.update(frames, [[lane.points for lane in r.lanes] for r in read], categories=[r.categories for r in read])
    expected = roneld_eval.metric("openlane", labels=labels)
    for f, r in zip(frames, read):
        expected.update(f, [lane.points for lane in r.lanes], categories=r.categories)
    assert metric.compute() == expected.compute() and expected.compute()["F1@30"] > 0


def test_mmengine_metric_refuses_bad_settings_when_built(culane_set):
    _need("mmengine")
    from mmengine.registry import METRICS

    import roneld_eval.frameworks.mmengine_metric  # noqa: F401

    data, _ = culane_set
    with pytest.raises(roneld_eval.MetricInputError, match="offers no key names 'clrnet'"):
        METRICS.build(dict(type="RoneldLaneMetric", benchmark="culane", data_root=str(data), names="clrnet"))
    with pytest.raises(roneld_eval.MetricInputError, match="sample's width must be a whole number of pixels"):
        METRICS.build(dict(type="RoneldLaneMetric", benchmark="culane", data_root=str(data),
                           sample=dict(style="clrernet", width="1640", height=590)))
    with pytest.raises(roneld_eval.ConfigError, match="unknown option iou_thr"):
        METRICS.build(dict(type="RoneldLaneMetric", benchmark="culane", data_root=str(data), iou_thr=0.5))
