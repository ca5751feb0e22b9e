"""`run --shard I/N` and the merge of its parts (see roneld_eval.shards).

A run's shard evaluates its share of the clips exactly as the whole run would (each clip is the
unit of state), and keeps each finished clip's results as the resume cache keeps them (plain
data, checked field by field when read back) with the fingerprint of the files it read. Merging
plans the run again from the part's configuration, over the whole dataset, then takes every
clip's results from the parts instead of computing them: the tables, per-frame rows, intervals,
gains and lane files are those of one unsharded run, byte for byte. A part whose clip read other
maps or labels than the merge finds (path, size, modification time), or a clip in no part, is
refused; so is a clip file or config.toml that is not the one the shard wrote (part.json records
their SHA-256, shards.sealed_manifest).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable, Sequence

from .benchmarks import Benchmark
from .cache import config_key, decode_result, encode_result, fingerprint
from .config import EvalConfig
from .errors import InputError
from .evaluation import ClipResult
from .lanes_io import parse_json
from .limits import CACHE_ENTRY
from .model import Clip, Dataset
from .shards import MANIFEST_NAME, PART_FORMAT, PART_VERSION, Part, Shard, content_digest, digest, sealed_manifest

CLIPS = "clips"  # the part's folder of finished clips, one JSON file each
CONFIG = "config.toml"


def ground_truth(dataset: Dataset) -> str:
    """What the parts of one run share: its clips and their frames, in order, and the categories."""
    return digest({"clips": [[clip.clip_id, [frame.relpath for frame in clip.frames]] for clip in dataset.clips],
                   "categories": [[name, sorted(members)] for name, members in dataset.categories.items()]})


class PartWriter:
    """The ClipCache of a shard: nothing to reuse, every finished clip written into the part."""

    def __init__(self, staging):
        self.staging = staging
        self.clip_ids: list[str] = []
        self.digests: dict[str, str] = {}  # each clip file's, for part.json

    def load(self, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> ClipResult | None:
        return None

    def store(self, clip: Clip, inputs: Sequence[Path], result: ClipResult) -> None:
        entry = {"clip_id": clip.clip_id, "frames": [frame.relpath for frame in clip.frames],
                 "inputs": fingerprint(inputs), "result": encode_result(result)}
        name = f"{CLIPS}/{len(self.clip_ids):06d}.json"
        data = json.dumps(entry, allow_nan=False).encode("utf-8")
        self.staging.write_bytes(name, data)
        self.digests[name] = content_digest(data)
        self.clip_ids.append(clip.clip_id)


def write_run_part(staging, config: EvalConfig, requested: EvalConfig, shard: Shard, dataset: Dataset,
                   writer: PartWriter, version: str, wall_time_s: float) -> None:
    """part.json (beside the clips the writer wrote) and the configuration as requested: `config`
    is the one it ran, the bundled fixture's paths filled in where `requested` names no data."""
    manifest = {
        "format": PART_FORMAT, "format_version": PART_VERSION, "command": "run", "version": version,
        "shard": [shard.index, shard.count], "settings": config_key(config, version),
        "ground_truth": ground_truth(dataset), "clips": writer.clip_ids, "wall_time_s": round(wall_time_s, 3),
    }
    config_toml = requested.to_toml().encode("utf-8")
    staging.write_bytes(CONFIG, config_toml)
    digests = {**writer.digests, CONFIG: content_digest(config_toml)}
    staging.write_bytes(MANIFEST_NAME, sealed_manifest(manifest, digests))


class PartsCache:
    """The ClipCache of a merge: every clip's results from the part that holds it, checked."""

    def __init__(self, parts: Sequence[Part], config: EvalConfig, benchmark: Benchmark):
        self.benchmark = benchmark
        self.methods = tuple(config.methods)
        self.where: dict[str, tuple[Part, Path]] = {}
        for part in parts:
            clip_ids = part.manifest.get("clips")
            if not isinstance(clip_ids, list) or not all(isinstance(c, str) for c in clip_ids):
                raise InputError(part.path / MANIFEST_NAME, "its list of clips is not a list of names")
            for k, clip_id in enumerate(clip_ids):
                if clip_id in self.where:
                    raise InputError(part.path, f"clip {clip_id} is also in {self.where[clip_id][0].path}: "
                                                "shards of one run never share a clip")
                self.where[clip_id] = (part, part.path / CLIPS / f"{k:06d}.json")
        self.used: set[str] = set()

    def load(self, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> ClipResult | None:
        if clip.clip_id not in self.where:
            raise InputError(None, f"clip {clip.clip_id} is in no part: merge needs every shard's part")
        part, path = self.where[clip.clip_id]
        data = part.read(path.relative_to(part.path).as_posix(), CACHE_ENTRY)
        entry = parse_json(data, path, "not a clip of a partial result", "not a clip of a partial result")
        try:
            if not isinstance(entry, dict) or entry.get("clip_id") != clip.clip_id:
                raise ValueError(f"it does not hold clip {clip.clip_id}")
            if entry.get("frames") != [frame.relpath for frame in clip.frames]:
                raise ValueError("its frames are not the clip's frames now")
            result = decode_result(entry.get("result"), self.benchmark)
            if result.clip_id != clip.clip_id:
                raise ValueError(f"it does not hold clip {clip.clip_id}")
            self._check(result, clip)
        except (ValueError, TypeError, KeyError, IndexError, AttributeError, RecursionError) as error:
            raise InputError(path, f"not a clip of a partial result ({error})") from None
        if entry.get("inputs") != fingerprint(inputs()):
            raise InputError(path, f"the maps or labels of clip {clip.clip_id} changed since its shard was run "
                                   "(their size, modification or change time, as --resume checks them): run that "
                                   "shard again where the merge runs")
        self.used.add(clip.clip_id)
        return result

    def _check(self, result: ClipResult, clip: Clip) -> None:
        """What the run would have given: each scored frame of the clip once per method, IoUs in [0, 1]."""
        frames = {frame.relpath for frame in clip.frames}
        if result.n_frames != len(clip.frames) or not result.n_scored <= result.n_frames:
            raise ValueError("its frame counts are not the clip's")
        if not self._one_outcome_a_frame_and_method(result, frames):
            raise ValueError("its outcomes are not one per scored frame and method")
        if not all(math.isnan(v) or 0 <= v <= 1 for o in result.outcomes for v in o.ious.values()):
            raise ValueError("an IoU outside [0, 1]")

    def _one_outcome_a_frame_and_method(self, result: ClipResult, frames: set[str]) -> bool:
        pairs = [(o.relpath, o.method) for o in result.outcomes]
        scored = {relpath for relpath, _ in pairs}
        return (len(set(pairs)) == len(pairs) and scored <= frames and len(scored) == result.n_scored
                and len(pairs) == len(scored) * len(self.methods) and not {m for _, m in pairs} - set(self.methods))

    def store(self, clip: Clip, inputs: Sequence[Path], result: ClipResult) -> None:
        raise AssertionError("a merge computes no clip")  # load gives every clip or stops the merge

    def unused(self) -> list[str]:
        return [clip_id for clip_id in self.where if clip_id not in self.used]



def shards_wall_time(parts: Sequence[Part]) -> float:
    """The shards' wall times added up (what the merged run's summary.json reports as its own)."""
    total = 0.0
    for part in parts:
        value = part.manifest.get("wall_time_s")
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0 <= value < 1e9:
            raise InputError(part.path / MANIFEST_NAME, "its wall_time_s is not a number of seconds")
        total += float(value)
    return total
