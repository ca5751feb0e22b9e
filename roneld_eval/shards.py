"""Shards: a command's work split by whole clips over N processes or machines (`--shard I/N`),
each writing a partial result, and `merge` turning the parts back into the files one unsharded
command writes, byte for byte.

Shard I of N is a contiguous run of clips, in the dataset's order, cut where the frames so far
pass I/N of all frames: every shard's share is fixed by the list alone, the parts concatenated
in shard order hold the frames in the order one command scores them, and lane metrics (sums
over frames) merge exactly.

A part is two files in its --out folder: `part.json` (what was scored, how, by which version,
which shard; small) and `part.npz` (the per-frame numbers, no pickles). Both are untrusted input
to `merge`, checked field by field. part.json also seals the part: the SHA-256 of every other file
of it that merge reads, and a digest of all its own fields, so that a part edited or damaged since
its shard wrote it is refused even where the edit keeps its form (a count changed, an IoU within
[0, 1]). The digests are plain, not keyed with the user's secret (secret_key.py): parts travel
between the machines (and users) of a cluster, and what they guard against is an accidental or
silent change, not someone who rewrites the digests as well.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import numpy as np

from .errors import ConfigError, InputError

if TYPE_CHECKING:
    from .limits import SizeLimit

PART_FORMAT = "roneld-eval partial result"
PART_VERSION = 2  # 1 (ca5cdc9 and before): no digests of the part's files
MANIFEST_NAME = "part.json"
ARRAYS_NAME = "part.npz"
FILES_KEY = "files"  # in part.json: name -> SHA-256 of each other file of the part that merge reads
SEAL_KEY = "digest"  # in part.json: the digest of all its other fields
MAX_SHARDS = 100_000
CHANGED = ("changed since its shard wrote it (its SHA-256 is not the one part.json records): run that shard's "
           "command again")

# A prediction tree's files of a frame (tree m of the command's trees, a frame's list entry), as
# the command reads them: what a part's fingerprint of its predictions covers.
FilesOf = Callable[[int, str], Iterable[Path]]


@dataclass(frozen=True)
class Shard:
    """Shard `index` (1-based) of `count`."""

    index: int
    count: int

    def __str__(self) -> str:
        return f"{self.index}/{self.count}"


def parse_shard(text: str) -> Shard:
    """'I/N' with 1 <= I <= N."""
    match = re.fullmatch(r"\s*([0-9]{1,9})\s*/\s*([0-9]{1,9})\s*", text, re.ASCII)
    if match is None:
        raise ConfigError(f"--shard takes I/N (shard I of N, counted from 1), got {text!r}")
    index, count = int(match.group(1)), int(match.group(2))
    if not 1 <= index <= count or count > MAX_SHARDS:
        raise ConfigError(f"--shard {text}: I must be 1..N and N at most {MAX_SHARDS:,}")
    return Shard(index, count)


def shard_range(sizes: Sequence[int], shard: Shard) -> range:
    """The clips (indexes into `sizes`, each clip's frame count) of a shard: contiguous, cut
    where the frames before a clip reach index/count of all (a shard may be empty)."""
    total = sum(sizes)
    bounds, before = [], 0
    for size in sizes:
        bounds.append(before)
        before += size

    def start(k: int) -> int:  # first clip whose frames before it reach k/count of the total
        goal = k * total
        return next((c for c, b in enumerate(bounds) if b * shard.count >= goal), len(sizes))

    first = 0 if shard.index == 1 else start(shard.index - 1)
    end = len(sizes) if shard.index == shard.count else start(shard.index)
    return range(first, max(first, end))


def files_fingerprint(paths) -> str:
    """A digest of each file's absolute path, size and modification time (missing ones included):
    what parts compare to have read the same labels. Not the change time or inode, which a copy
    with `cp -a` or a `chmod` changes and an edit hardly ever leaves alone."""
    hasher = hashlib.sha256()
    for path in paths:
        try:
            info = os.stat(path)
            record = f"{os.path.abspath(path)}\0{info.st_size}\0{info.st_mtime_ns}\n"
        except (OSError, ValueError):
            record = f"{os.path.abspath(path)}\0missing\n"
        hasher.update(record.encode("utf-8", "surrogateescape"))
    return hasher.hexdigest()


def digest(value: Any) -> str:
    """SHA-256 of a JSON-able value, keys sorted: what parts compare to belong together."""
    return hashlib.sha256(json.dumps(value, sort_keys=True, ensure_ascii=False).encode("utf-8")).hexdigest()


def content_digest(data: bytes) -> str:
    """SHA-256 of a file's bytes: what part.json records of each other file of the part."""
    return hashlib.sha256(data).hexdigest()


def sealed_manifest(manifest: dict, files: dict[str, str]) -> bytes:
    """part.json's bytes: the manifest, the SHA-256 of each other file of the part (`files`: name
    -> content_digest) and the digest of all that."""
    sealed = {**manifest, FILES_KEY: dict(sorted(files.items()))}
    sealed[SEAL_KEY] = digest(sealed)
    return (json.dumps(sealed, indent=1, sort_keys=True, ensure_ascii=False) + "\n").encode("utf-8")


def predictions_fingerprint(trees: Sequence, files_of: FilesOf | None, frames: Sequence[str]) -> list[list[str]]:
    """[method, root, fingerprint] of each prediction tree: its files of these frames (path, size,
    modification time, as the labels'). Stat, not content: on 34,680 CULane prediction files
    (scripts/bench_part_fingerprint.py) their contents took 1.2-1.6 s to hash in the page cache
    and 9-10 s from disk, their stat 0.3-0.7 s either way, and a merge pays it again to re-check."""
    assert files_of is not None or not trees
    return [[tree.method, os.path.abspath(tree.root), _tree_fingerprint(files_of, m, frames)]
            for m, tree in enumerate(trees)]


def _tree_fingerprint(files_of, m: int, frames: Sequence[str]) -> str:
    return files_fingerprint(path for relpath in frames for path in files_of(m, relpath))


def check_predictions(where: Path, recorded: Any, trees: Sequence, files_of: FilesOf | None, frames: Sequence[str],
                      present_only: bool = False) -> None:
    """A part's predictions are still those its shard scored: each tree's files of its frames
    (`present_only`: only the trees still where the part says; a merge elsewhere cannot see them)."""
    if not isinstance(recorded, list) or len(recorded) != len(trees):
        raise InputError(where, "its record of the predictions it scored is not one entry a prediction tree")
    for m, (tree, record) in enumerate(zip(trees, recorded)):
        if present_only and not os.path.isdir(tree.root):
            continue
        if record != [tree.method, os.path.abspath(tree.root), _tree_fingerprint(files_of, m, frames)]:
            raise InputError(where, f"the predictions of {tree.method} ({tree.root}) changed since this shard scored "
                                    "them (a file's size or modification time, or a file added or removed): run "
                                    "that shard's command again")


@dataclass(frozen=True)
class Part:
    """One read part: its manifest and arrays, checked for form (not yet against the others)."""

    path: Path
    manifest: dict
    arrays: dict[str, np.ndarray]

    @property
    def shard(self) -> Shard:
        index, count = self.manifest["shard"]
        return Shard(index, count)

    def read(self, name: str, limit: SizeLimit) -> bytes:
        """A file of the part (a relative name), refused unless it is the one its shard wrote."""
        return _sealed_bytes(self.path, self.manifest[FILES_KEY], name, limit)


def _sealed_bytes(folder: Path, files: dict, name: str, limit: SizeLimit) -> bytes:
    from .lanes_io import read_bytes

    path = folder / name
    if name not in files:
        raise InputError(path, f"not a file its {MANIFEST_NAME} records: not written by this part's shard")
    data = read_bytes(path, limit=limit)
    if content_digest(data) != files[name]:
        raise InputError(path, CHANGED)
    return data


def write_part(staging, manifest: dict, arrays: dict[str, np.ndarray]) -> None:
    """part.json and part.npz into an output folder's staging (output.Staging)."""
    from .synth import npz_bytes

    data = npz_bytes(arrays)
    staging.write_bytes(ARRAYS_NAME, data)
    staging.write_bytes(MANIFEST_NAME, sealed_manifest(manifest, {ARRAYS_NAME: content_digest(data)}))


def read_part(folder: Path) -> Part:
    """A part's manifest and arrays (InputError naming the file for anything malformed)."""
    from .lanes_io import check_folder, parse_json, read_bytes
    from .limits import CONFIG, MAP

    from .output import JOURNAL

    folder = Path(folder)
    path = folder / MANIFEST_NAME
    if os.path.lexists(folder / JOURNAL):
        raise InputError(folder, "its part is incomplete (the command that wrote it was killed while putting it "
                                 "in place): run the shard's command again into this folder")
    check_folder(folder, "not found", ": give the folder of a shard's part")
    if not path.exists():
        raise InputError(folder, f"not a partial result (no {MANIFEST_NAME}: written by a command given --shard I/N)")
    data = read_bytes(path, limit=CONFIG)
    assert data is not None
    manifest = _part_manifest(parse_json(data, path, "not a partial result", "not a partial result"), path)
    files = _sealed_files(path, manifest)
    _check_manifest_fields(manifest, path)
    # a part of a command that keeps per-frame numbers (not `run`'s)
    arrays = _load_arrays(_sealed_bytes(folder, files, ARRAYS_NAME, MAP), folder / ARRAYS_NAME) \
        if ARRAYS_NAME in files else {}
    return Part(folder, manifest, arrays)


def _part_manifest(manifest: Any, path: Path) -> dict:
    """part.json's record, of this version's format."""
    if not isinstance(manifest, dict) or manifest.get("format") != PART_FORMAT:
        raise InputError(path, "not a partial result of roneld-eval")
    if manifest.get("format_version") == 1:
        raise InputError(path, "a part written by an older roneld-eval, without the digests that show an edit of its "
                               "files: run the shard's command again with this version")
    if manifest.get("format_version") != PART_VERSION:
        raise InputError(path, f"a partial result of format {manifest.get('format_version')!r}; this version "
                               f"reads format {PART_VERSION}: run the shard's command again with this version")
    return manifest


def _check_manifest_fields(manifest: dict, path: Path) -> None:
    """Its shard [I, N], and its command, version, settings and ground truth."""
    shard = manifest.get("shard")
    if (not isinstance(shard, list) or len(shard) != 2 or any(type(v) is not int for v in shard)
            or not 1 <= shard[0] <= shard[1] <= MAX_SHARDS):
        raise InputError(path, "its shard is not [I, N] with 1 <= I <= N")
    for key in ("command", "version", "settings", "ground_truth"):
        if key not in manifest:
            raise InputError(path, f"a partial result without its {key!r}")
    if not all(isinstance(manifest[key], str) for key in ("command", "version", "ground_truth")):
        raise InputError(path, "its command, version and ground truth are not text")


def _sealed_files(path: Path, manifest: dict) -> dict[str, str]:
    """The digests of the part's files, once part.json itself is as its shard wrote it."""
    unsealed = {key: value for key, value in manifest.items() if key != SEAL_KEY}
    if manifest.get(SEAL_KEY) != digest(unsealed):
        raise InputError(path, "changed since its shard wrote it (its fields do not match the digest it records): "
                               "run that shard's command again")
    files = manifest.get(FILES_KEY)
    if not isinstance(files, dict) or not all(isinstance(value, str) for value in files.values()):
        raise InputError(path, "its digests of the part's files are not names and digests")
    return files


def _load_arrays(raw: bytes, path: Path) -> dict[str, np.ndarray]:
    import io
    import zipfile

    from .limits import MAP

    out: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            members = archive.infolist()
            # every member's name and the inflated total checked before anything is inflated
            for info in members:
                if not re.fullmatch(r"[a-z_0-9]{1,64}\.npy", info.filename):
                    raise InputError(path, f"an unexpected member {info.filename[:80]!r}")
            if len(members) > 64 or sum(info.file_size for info in members) > MAP.bytes:
                raise InputError(path, f"its members inflate to more than {MAP.rule()}")
            for info in members:
                with archive.open(info) as member:
                    array = np.lib.format.read_array(io.BytesIO(member.read(MAP.bytes + 1)),
                                                     allow_pickle=False)
                out[info.filename[:-4]] = array
    except InputError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError) as error:
        raise InputError(path, f"not a readable part.npz ({error})") from None
    return out


def check_together(parts: Sequence[Part]) -> list[Part]:
    """The parts in shard order, once each checked to belong to one command: the same command,
    version, settings and ground truth, and every shard 1..N exactly once."""
    if not parts:
        raise ConfigError("merge needs the folders of every shard's part")
    first = parts[0]
    for part in parts[1:]:
        for key, what in (("command", "command differs from that"),
                          ("version", "roneld-eval version differs from that"),
                          ("ground_truth", "ground truth (its frames, categories and label files) differs from that"),
                          ("settings", "settings (methods, thresholds, widths) differ from those")):
            if part.manifest[key] != first.manifest[key]:
                raise InputError(part.path, f"this part's {what} of {first.path}: parts of different commands "
                                            "cannot be merged")
        if part.shard.count != first.shard.count:
            raise InputError(part.path, f"shard {part.shard} of another split than {first.path}'s {first.shard}")
    from .version import __version__

    if first.manifest["version"] != __version__:
        raise InputError(first.path, f"written by roneld-eval {first.manifest['version']}, this is {__version__}: "
                                     "merge the parts with the version that wrote them")
    by_index: dict[int, Part] = {}
    for part in parts:
        if part.shard.index in by_index:
            raise InputError(part.path, f"shard {part.shard} given twice (also {by_index[part.shard.index].path})")
        by_index[part.shard.index] = part
    missing = [str(k) for k in range(1, first.shard.count + 1) if k not in by_index]
    if missing:
        shown = ", ".join(missing[:8]) + (", ..." if len(missing) > 8 else "")
        which = f"shard {shown} of {first.shard.count} is" if len(missing) == 1 else \
            f"shards {shown} of {first.shard.count} are"
        raise ConfigError(f"{which} missing: merge needs every shard's part")
    return [by_index[k] for k in sorted(by_index)]


SCORE_COMMAND = "score "  # a part's command: "run", or "score NAME" for the benchmark NAME's scorer


def _merger(part: Part):
    """The function merging the parts of this part's command: `run`'s, or the benchmark's own
    part merger (`Benchmark.merge_parts`, taking the checked parts in shard order and the output
    folder), or None where the benchmark's scorer runs again on the parts' arrays (merge_by_rerun)."""
    command = part.manifest["command"]
    if command == "run":
        from .api import merge_run

        return merge_run
    benchmark = _scored_benchmark(part)
    return getattr(benchmark, "merge_parts", None)


def _scored_benchmark(part: Part):
    command = part.manifest["command"]
    name = command[len(SCORE_COMMAND):] if isinstance(command, str) and command.startswith(SCORE_COMMAND) else None
    from .benchmarks import names
    from .resolve import benchmark_named

    benchmark = benchmark_named(name) if name in names() else None
    if benchmark is None or not hasattr(benchmark, "scorer"):
        raise InputError(part.path / MANIFEST_NAME, f"parts of {command!r}, which this version cannot merge")
    return benchmark


def merge(folders: Sequence[str | Path], out: str | Path):
    """Read every part, check they are the shards of one command, and write its results to `out`."""
    parts = check_together([read_part(Path(folder)) for folder in folders])
    target = Path(out)
    for part in parts:
        if target.exists() and target.resolve() == part.path.resolve():
            raise InputError(target, "is one of the parts being merged: give another --out")
    if (target / MANIFEST_NAME).exists():
        raise InputError(target, f"holds a part ({MANIFEST_NAME}): give another --out, the parts stay as they are")
    command = parts[0].manifest["command"]
    merger = _merger(parts[0])
    if merger is None:
        return command, merge_by_rerun(parts, out)
    return command, merger(parts, out)


# ---- score commands whose results are sums over frames (OpenLane, CurveLanes, LLAMAS) ----------
#
# Such a command runs its usual setup (list, labels, prediction trees) and, for a shard, scores its
# share and keeps the arrays it reduces the frames to: `sum_*` arrays (counts) add up over the
# parts, `cat_*` arrays (one row per frame) are concatenated in shard order. Merging calls the same
# command again with the arguments its parts record and those arrays in place of the scoring: its
# setup runs again (the labels and prediction roots must be where the shards found them) and must
# find the frames and prediction trees the shards had.

_NOT_RECORDED = {"out", "workers", "progress", "announce", "shard", "merged"}


@dataclass(frozen=True)
class MergedPart:
    """What a merge checks of one part against the files it finds: the digest of the frames it
    scored (its shard's share) and the fingerprint of their predictions."""

    path: Path
    shard: Shard
    frames: str
    predictions: Any


@dataclass(frozen=True)
class Merged:
    """What a merge hands a score command: the parts' ground truth, their arrays combined, and
    what to check of each part."""

    ground_truth: str
    arrays: dict[str, np.ndarray]
    parts: tuple[MergedPart, ...] = ()


class Sharding:
    """A score command's view of `--shard` (or of a merge calling it again)."""

    def __init__(self, command: str, shard: str | None, out, merged: Merged | None, arguments: dict,
                 paths: Sequence[str] = ("labels", "list_file", "image_root"),
                 roots: Sequence[str] = ("pred_root", "maps")):
        """`arguments`: the command's own, as given; those named in `paths` (a path) and `roots`
        (prediction roots: a path, NAME=DIR, or several) are recorded absolute, so that shards
        started in other folders agree and the merge finds them from anywhere."""
        self.command = command
        self.shard = parse_shard(shard) if shard is not None else None
        self.merged = merged
        if self.shard is not None and out is None:
            raise ConfigError("--shard writes a partial result for `roneld-eval merge`: give --out")
        self.arguments = {}
        for key, value in arguments.items():
            if key in roots:
                value = _absolute_roots(value) if value else []
            elif key in paths and value is not None:
                value = os.path.abspath(value)
            self.arguments[key] = _recorded(value)

    def share(self, keys: Sequence[str], clip_of) -> list[str]:
        """The keys this command scores: all, or the shard's whole clips (runs of keys with one clip_of)."""
        if self.shard is None:
            return list(keys)
        return self._share_of(keys, clip_of, self.shard)

    @staticmethod
    def _share_of(keys: Sequence[str], clip_of, shard: Shard) -> list[str]:
        sizes: list[int] = []
        previous = object()
        for key in keys:
            clip = clip_of(key)
            if clip != previous:
                sizes.append(0)
                previous = clip
            sizes[-1] += 1
        share = shard_range(sizes, shard)
        return list(keys)[sum(sizes[:share.start]):sum(sizes[:share.stop])]

    def ground_truth(self, keys: Sequence[str], trees, labels: Sequence[Path], extra: Any = None) -> str:
        """The frames, the label files (path, size, modification time), the prediction trees and
        `extra` (what else the command read that the shards must agree on, JSON-able)."""
        return digest({"frames": list(keys), "labels": files_fingerprint(labels),
                       "trees": [[t.method, os.path.abspath(t.root), t.found, t.listed] for t in trees],
                       **({} if extra is None else {"extra": extra})})

    def check_merged(self, keys: Sequence[str], trees, labels: Sequence[Path], clip_of, extra: Any = None, *,
                     files_of: FilesOf | None) -> None:
        """In a merge: the frames, labels and prediction trees found now are those the shards
        found, each part scored its shard's share of the frames, and their prediction files
        (`files_of`) are those it scored."""
        assert self.merged is not None
        if self.ground_truth(keys, trees, labels, extra) != self.merged.ground_truth:
            raise InputError(None, f"the labels or prediction trees found now are not those the shards of this "
                                   f"`{self.command}` found (frames, files, sizes or modification times): merge where "
                                   "the shards ran, with the same files")
        for part in self.merged.parts:
            share = self._share_of(keys, clip_of, part.shard)
            if digest(share) != part.frames:
                raise InputError(part.path, f"the part of shard {part.shard} did not score that shard's frames")
            check_predictions(part.path, part.predictions, trees, files_of, share)

    def merged_array(self, name: str, shape: tuple[int, ...], kind: str = "i",
                     within: tuple[float, float] | None = None) -> np.ndarray:
        """A combined array of the parts, of this shape and kind (and its values `within`)."""
        assert self.merged is not None
        array = self.merged.arrays.get(name)
        if (array is None or array.dtype.kind != kind or array.shape != shape
                or within is not None and array.size and not ((array >= within[0]) & (array <= within[1])).all()):
            raise InputError(None, f"the parts' {name} do not fit this `{self.command}` (its methods, thresholds "
                                   "or frames): not its shards")
        return array

    def write_part(self, folder, keys: Sequence[str], trees, labels: Sequence[Path], scored: Sequence[str],
                   arrays: dict[str, np.ndarray], extra: Any = None, *, files_of: FilesOf | None) -> None:
        from .output import Staging
        from .version import __version__

        assert self.shard is not None
        manifest = {"format": PART_FORMAT, "format_version": PART_VERSION, "command": self.command,
                    "version": __version__, "shard": [self.shard.index, self.shard.count],
                    "settings": self.arguments, "ground_truth": self.ground_truth(keys, trees, labels, extra),
                    "share": digest(list(scored)), "predictions": predictions_fingerprint(trees, files_of, scored)}
        write_part(Staging(folder), manifest, arrays)
        folder.commit()


def given_options(**options) -> dict:
    """Options a part records only when given (--diagnose, --loc-iou, --score-sweep): a part of a
    command without them stays what it was."""
    return {name: value for name, value in options.items() if value not in (None, False)}


def _absolute_roots(value) -> list[list]:
    """Prediction roots as [name or None, absolute folder] pairs (what _root_specs reads back)."""
    from .scoring import _root_specs

    return [[name, os.path.abspath(path)] for name, path in _root_specs(value)]


def _recorded(value):
    """An argument as part.json keeps it (paths as text, mappings as NAME=DIR lists)."""
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        return [f"{name}={path}" for name, path in value.items()]
    if isinstance(value, (list, tuple)):
        return [_recorded(v) for v in value]
    return value


def _combined(parts: Sequence[Part]) -> dict[str, np.ndarray]:
    """`sum_*` arrays added up, `cat_*` arrays concatenated in shard order (all checked alike)."""
    names = set(parts[0].arrays)
    out: dict[str, np.ndarray] = {}
    for part in parts:
        where = part.path / ARRAYS_NAME
        if set(part.arrays) != names or not all(name.startswith(("sum_", "cat_")) for name in names):
            raise InputError(where, f"holds {sorted(part.arrays)}, not the arrays of the other parts")
        for name, array in part.arrays.items():
            _check_like(name, array, parts[0].arrays[name], where)
    for name in names:
        arrays = [part.arrays[name] for part in parts]
        out[name] = np.sum(arrays, axis=0) if name.startswith("sum_") else np.concatenate(arrays)
    return out


def _check_like(name: str, array: np.ndarray, first: np.ndarray, where: Path) -> None:
    """A part's array `name` combines with the first part's: numbers of its type, a `sum_*` a count
    of its shape, a `cat_*` finite rows of its row shape."""
    if array.dtype != first.dtype or array.dtype.kind not in "if" or array.ndim == 0:
        raise InputError(where, f"its {name} is not an array of numbers like the other parts'")
    if name.startswith("sum_") and (array.shape != first.shape or (array < 0).any() or (array >= 1 << 40).any()):
        raise InputError(where, f"its {name} is not a count of the shape of the other parts'")
    if name.startswith("cat_") and (array.shape[1:] != first.shape[1:] or not np.isfinite(array).all()):
        raise InputError(where, f"its {name} is not a row a frame of the shape of the other parts'")


def merge_by_rerun(parts: Sequence[Part], out: str | Path):
    """The command the parts are shards of, run again with their arguments and arrays."""
    import inspect

    first = parts[0]
    command = first.manifest["command"]
    function = _scored_benchmark(first).scorer()
    arguments = first.manifest["settings"]
    accepted = set(inspect.signature(function).parameters) - _NOT_RECORDED
    if (not isinstance(arguments, dict) or not set(arguments) <= accepted
            or not all(_plain(value) for value in arguments.values())):
        raise InputError(first.path / MANIFEST_NAME, f"its settings are not the arguments of `{command}`")
    if not isinstance(first.manifest["ground_truth"], str):
        raise InputError(first.path / MANIFEST_NAME, "its ground truth is not a digest")
    checked = []
    for part in parts:
        if not isinstance(part.manifest.get("share"), str):
            raise InputError(part.path / MANIFEST_NAME, "its share of the frames is not a digest")
        checked.append(MergedPart(part.path, part.shard, part.manifest["share"], part.manifest.get("predictions")))
    merged = Merged(first.manifest["ground_truth"], _combined(parts), tuple(checked))
    try:
        return function(**arguments, out=out, merged=merged)
    except (TypeError, ValueError, KeyError, IndexError) as error:
        raise InputError(first.path / MANIFEST_NAME,
                         f"its settings or arrays do not fit `{command}` ({error})") from None


def _plain(value) -> bool:
    if value is None or isinstance(value, (str, bool, int, float)):
        return True
    return isinstance(value, list) and all(_plain(v) for v in value)
