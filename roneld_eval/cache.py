"""The resume cache: finished clips of an interrupted run, kept as plain JSON that cannot lie.

Each finished clip is one file in `<out>/.roneld-cache/`. A cached clip is reused only when
all of these match the new run: the configuration (all but the worker count and the clip
limit), the tool's version, the clip's frame list, and a fingerprint (path, size, mtime) of
every file the clip reads (maps and labels). The file holds no pickle, only data that is
checked field by field on load, and a keyed checksum (HMAC-SHA256 with a per-user secret):
an edited or truncated file, or one from elsewhere, is recomputed with a note, never trusted
and never a traceback.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import shutil
import stat
from collections import Counter
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .benchmarks import Benchmark
from .secret_key import secret_key as _secret_key
from .config import EvalConfig
from .errors import InputError
from .limits import CACHE_ENTRY
from .evaluation import ClipResult, FrameOutcome
from .extract.registry import file_digest
from .lanes_io import read_at_most
from .json_fields import json_number, read_count, read_float, read_list, read_string
from .model import Clip, Lane
from .output import CACHE

FORMAT = "roneld-eval clip cache"
FORMAT_VERSION = 2  # 2: the plug-ins' loaded source files (plugin_code)


class ResultCache:
    """Finished clips of a run in `<out>/.roneld-cache/` (see the module docstring).

    Without `resume` the folder starts empty. `summary()` says how many clips were reused and
    why the others were computed.
    """

    def __init__(self, out: str | Path, config: EvalConfig, benchmark: Benchmark, version: str, resume: bool,
                 note: Callable[[str], None] | None = None):
        self.config_key = config_key(config, version)
        self.benchmark = benchmark
        self.folder = Path(out) / CACHE
        self.note = note or (lambda message: None)
        self.reasons: Counter[str] = Counter()
        self.reused = 0
        self._secret = _secret_key(self.note)
        if self.folder.is_symlink():
            self.folder.unlink()  # never write through a link to somewhere else
        if not resume:
            self.discard()
        # A finished run keeps no cache: resuming into one (or into nothing) has nothing to reuse.
        self.nothing_kept = not self.folder.is_dir()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(self.folder, f"cannot write here: {error.strerror}") from None

    def _path(self, clip_id: str) -> Path:
        return self.folder / (hashlib.sha256(clip_id.encode("utf-8", "surrogateescape")).hexdigest()[:32] + ".json")

    def load(self, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> ClipResult | None:
        """The cached result of this clip if it is valid and made from the same inputs, else None.
        `inputs()` lists the clip's input files: asked only when an entry is there to check."""
        path = self._path(clip.clip_id)
        try:
            raw = self._entry_bytes(path)
            if raw is None:
                return None
            entry = self._verified(raw, clip)
            stale = self._stale(entry, clip, inputs)
            if stale is not None:
                self.reasons[stale] += 1
                return None
            result = decode_result(entry["result"], self.benchmark)
            if any(file_digest(Path(path)) != digest for path, digest in result.plugin_code.items()):
                self.reasons["plug-in code changed"] += 1  # a module it imported on its way, too
                return None
            if result.clip_id != clip.clip_id:
                raise ValueError("it holds another clip")
        except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError, RecursionError,
                UnicodeError) as error:
            self._invalid(path, str(error) or type(error).__name__)
            return None
        self.reused += 1
        return result

    def _entry_bytes(self, path: Path) -> bytes | None:
        """The entry's bytes; None where there is none (the clip is not finished)."""
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            self.reasons["not finished"] += 1
            return None
        except OSError as error:
            raise ValueError(error.strerror or str(error)) from None
        if not stat.S_ISREG(info.st_mode):
            raise ValueError("not a regular file")
        if info.st_size > CACHE_ENTRY.bytes:
            raise ValueError(CACHE_ENTRY.problem(info.st_size))
        with open(path, "rb") as handle:
            return read_at_most(handle, CACHE_ENTRY.bytes, info.st_size)

    def _verified(self, raw: bytes, clip: Clip) -> dict:
        """The entry this run wrote for this clip (ValueError where it is not one)."""
        document = json.loads(raw)
        if not isinstance(document, dict) or set(document) != {"body", "mac"}:
            raise ValueError("not a cache entry")
        body = document["body"]
        expected = self._mac(body)
        if not isinstance(document["mac"], str) or not hmac.compare_digest(document["mac"], expected):
            raise ValueError("its checksum does not match (edited, or written elsewhere)")
        entry = json.loads(body)
        if entry.get("format") != FORMAT or entry.get("format_version") != FORMAT_VERSION:
            raise ValueError("unknown format")
        if entry.get("clip_id") != clip.clip_id:
            raise ValueError("it holds another clip")
        return entry

    def _stale(self, entry: dict, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> str | None:
        """Why a sound entry no longer holds this run's result of the clip, or None."""
        if entry.get("config") != self.config_key:
            return "configuration or version changed"
        if entry.get("frames") != [frame.relpath for frame in clip.frames]:
            return "frame list changed"
        if entry.get("inputs") != fingerprint(inputs()):
            return "maps or labels changed"
        return None

    def store(self, clip: Clip, inputs: Sequence[Path], result: ClipResult) -> None:
        """Keep a finished clip (atomically: a reader sees the whole entry or none)."""
        body = json.dumps({
            "format": FORMAT, "format_version": FORMAT_VERSION, "clip_id": clip.clip_id,
            "config": self.config_key, "frames": [frame.relpath for frame in clip.frames],
            "inputs": fingerprint(inputs), "result": encode_result(result),
        }, allow_nan=False, separators=(",", ":"))
        path = self._path(clip.clip_id)
        temporary = path.with_name(path.name + ".tmp")
        try:
            with open(temporary, "w", encoding="utf-8") as handle:
                json.dump({"body": body, "mac": self._mac(body)}, handle)
            os.replace(temporary, path)
        except OSError as error:
            raise InputError(path, f"cannot keep this clip's results: {error.strerror}") from None

    def _mac(self, body: str) -> str:
        return hmac.new(self._secret, body.encode("utf-8", "surrogateescape"), hashlib.sha256).hexdigest()

    def _invalid(self, path: Path, problem: str) -> None:
        """Say why an entry is not used, count it, and remove it: a folder in its place would
        otherwise stop the run where the recomputed clip is kept (the cache's folder is the
        tool's own, removed whole when a run finishes)."""
        self.note(f"note: {path}: cache entry ignored ({problem}); recomputing that clip")
        self.reasons["invalid cache entry"] += 1
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)

    def summary(self) -> str:
        """'reused 3 clips; computed 2 (1 not finished, 1 maps or labels changed)'."""
        computed = sum(self.reasons.values())
        if self.nothing_kept and not self.reused:
            return (f"nothing to resume: this folder keeps no unfinished run (a finished one keeps no clips); "
                    f"computing all {computed} clip{'s' if computed != 1 else ''}")
        why = ", ".join(f"{count} {reason}" for reason, count in sorted(self.reasons.items()))
        return f"reused {self.reused} finished clip{'s' if self.reused != 1 else ''}; computing {computed}" + \
            (f" ({why})" if why else "")

    def count(self) -> int:
        try:
            return sum(1 for entry in self.folder.iterdir() if entry.suffix == ".json")
        except OSError:
            return 0

    def discard(self) -> None:
        if self.folder.is_symlink():
            self.folder.unlink()
        else:
            shutil.rmtree(self.folder, ignore_errors=True)


def config_key(config: EvalConfig, version: str) -> str:
    """What a clip's results depend on beyond its inputs: the configuration (but the worker count
    and the clip limit, which change no clip's results), the version and the plug-ins' code."""
    settings = config.to_dict()
    settings.pop("workers", None)
    settings["dataset"].pop("limit", None)
    # A plug-in's results change with its code, which the configuration does not hold.
    from .extract.registry import methods_of, source_fingerprint

    code = {method.name: source_fingerprint(method) for method in methods_of(config) if not method.built_in}
    return _digest(json.dumps([settings, version, code], sort_keys=True, default=str))


def fingerprint(paths: Sequence[Path]) -> str:
    """A digest of each input file's path, size, modification and change times and inode (missing
    files included)."""
    hasher = hashlib.sha256()
    for path in paths:
        try:
            info = os.stat(path)
            # ctime as well: `touch -r` or os.utime can restore a file's mtime after an edit, not its ctime.
            record = f"{path}\0{info.st_size}\0{info.st_mtime_ns}\0{info.st_ctime_ns}\0{info.st_ino}\n"
        except OSError as error:
            record = f"{path}\0missing {error.errno}\n"
        hasher.update(record.encode("utf-8", "surrogateescape"))
    return hasher.hexdigest()


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()


# ---- plain-data form of a clip's results ------------------------------------------------


def _encode_lane(lane: Lane | None) -> Any:
    return None if lane is None else [[json_number(x), json_number(y)] for x, y in lane.points]


def _decode_lane(value: Any) -> Lane | None:
    if value is None:
        return None
    points = [(read_float(x), read_float(y)) for x, y in read_list(value)]
    return Lane(np.array(points, np.float64).reshape(-1, 2))


def _decode_found_lane(value: Any) -> Lane:
    """A lane of a frame's lane list, where every entry is a lane (only active lanes may be missing)."""
    lane = _decode_lane(value)
    if lane is None:
        raise TypeError("a lane of the lane list is null")
    return lane


def encode_result(result: ClipResult) -> dict:
    """A clip's results as JSON-ready plain data (non-finite numbers as strings)."""
    return {
        "clip_id": result.clip_id,
        "outcomes": [{
            "relpath": o.relpath, "method": o.method,
            "ious": {side: json_number(iou) for side, iou in o.ious.items()},
            "official": o.official.to_json(),
            "lanes": [_encode_lane(lane) for lane in o.lanes],
            "active": [_encode_lane(lane) for lane in o.active],
        } for o in result.outcomes],
        "extract_ms": {method: [json_number(v) for v in values] for method, values in result.extract_ms.items()},
        "load_ms": [json_number(v) for v in result.load_ms],
        "n_frames": result.n_frames, "n_scored": result.n_scored, "n_gt_lanes": result.n_gt_lanes,
        "skipped": list(result.skipped),
        "map_size": None if result.map_size is None else list(result.map_size),
        "plugin_code": dict(result.plugin_code),
    }


def decode_result(data: Any, benchmark: Benchmark) -> ClipResult:
    """The inverse of encode_result, checking every field's type (TypeError/ValueError if wrong)."""
    record = _record(data, "result")
    map_size = record["map_size"]
    if map_size is not None:
        map_size = tuple(read_count(v) for v in read_list(map_size))
        if len(map_size) != 2:
            raise ValueError("map_size is not a pair")
    return ClipResult(
        plugin_code={read_string(path): read_string(digest)
                     for path, digest in _record(record["plugin_code"], "plugin_code").items()},
        clip_id=read_string(record["clip_id"]),
        outcomes=[_decode_outcome(item, benchmark) for item in read_list(record["outcomes"])],
        extract_ms={read_string(m): [read_float(v) for v in read_list(values)]
                    for m, values in _record(record["extract_ms"], "extract_ms").items()},
        load_ms=[read_float(v) for v in read_list(record["load_ms"])],
        n_frames=read_count(record["n_frames"]), n_scored=read_count(record["n_scored"]),
        n_gt_lanes=read_count(record["n_gt_lanes"]),
        skipped=[read_string(line) for line in read_list(record["skipped"])],
        map_size=map_size,
    )


def _record(value: Any, name: str) -> dict:
    if not isinstance(value, dict):
        raise TypeError(f"{name} is not a record")
    return value


def _decode_outcome(item: Any, benchmark: Benchmark) -> FrameOutcome:
    ious = _record(item["ious"], "ious")
    active = tuple(_decode_lane(lane) for lane in read_list(item["active"]))
    if len(active) != 2:
        raise ValueError("active lanes are not a pair")
    return FrameOutcome(
        relpath=read_string(item["relpath"]), method=read_string(item["method"]),
        ious={read_string(side): read_float(iou) for side, iou in ious.items()},
        official=benchmark.decode(item["official"]),
        lanes=tuple(_decode_found_lane(lane) for lane in read_list(item["lanes"])),
        active=active,
    )
