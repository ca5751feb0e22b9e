"""Shards and merge: `--shard I/N` scores whole clips in list order and writes a part; `merge` of
every part gives the unsharded command's files byte for byte, and refuses parts that do not
belong together in one line."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from roneld_eval.cli import main
from roneld_eval.errors import ConfigError
from roneld_eval.shards import Shard, parse_shard, shard_range


@given(sizes=st.lists(st.integers(0, 50), max_size=40), count=st.integers(1, 12))
def test_shards_cut_the_clips_into_contiguous_runs_in_order(sizes, count):
    ranges = [shard_range(sizes, Shard(k, count)) for k in range(1, count + 1)]
    assert [i for r in ranges for i in r] == list(range(len(sizes)))  # every clip once, in order
    total = sum(sizes)
    for k, r in enumerate(ranges, start=1):  # each starts at the first clip past (k-1)/count of the frames
        before = sum(sizes[:r.start])
        assert k == 1 or before * count >= (k - 1) * total
        assert k == 1 or r.start == 0 or sum(sizes[:r.start - 1]) * count < (k - 1) * total or sizes[r.start - 1] == 0


@pytest.mark.parametrize("text", ["0/3", "4/3", "1", "a/b", "1/0", "-1/2"])
def test_a_bad_shard_is_refused(text):
    with pytest.raises(ConfigError, match="shard"):
        parse_shard(text)


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _score(culane_set, out, *extra):
    result = _invoke("score", "culane", "--data-root", culane_set / "data", "--pred-root", f"a={culane_set / 'maps'}",
                     "--pred-root", f"b={culane_set / 'maps'}", "--iou", "0.3:0.7:0.1", "--workers", "1", "--quiet",
                     "--out", out, *extra)
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.parametrize("count", [1, 2, 3, 7])  # 7 shards of 5 clips: some shards are empty
def test_merged_shards_are_the_unsharded_files_byte_for_byte(culane_set, tmp_path, count):
    whole = _score(culane_set, tmp_path / "whole")
    parts = [_score(culane_set, tmp_path / f"part{k}", "--shard", f"{k}/{count}") for k in range(1, count + 1)]
    assert sorted(p.name for p in parts[0].iterdir() if not p.name.startswith(".")) == ["part.json", "part.npz"]
    result = _invoke("merge", *reversed(parts), "--out", tmp_path / "merged")  # any order on the command line
    assert result.exit_code == 0, result.output
    for name in ("official.csv", "summary.csv", "summary.md"):
        assert (tmp_path / "merged" / name).read_bytes() == (whole / name).read_bytes(), name
    categories = {line.split(",")[1] for line in (whole / "official.csv").read_text().splitlines()[1:]}
    assert len(categories) > 2  # the synthetic set's category lists are merged too


@pytest.fixture(scope="module")
def three_parts(culane_set, tmp_path_factory):
    folder = tmp_path_factory.mktemp("parts")
    return [_score(culane_set, folder / f"p{k}", "--shard", f"{k}/3") for k in (1, 2, 3)]


def _refused(tmp_path, *parts) -> str:
    result = _invoke("merge", *parts, "--out", tmp_path / "merged")
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert not (tmp_path / "merged" / "official.csv").exists()
    assert len(result.output.strip().splitlines()) == 1
    return result.output


def _resealed(folder):
    """part.json's digests made those of the part's files as they are now: what an edit that
    rewrites the digests too leaves, so that only the merge's checks of the contents can refuse it."""
    from roneld_eval.shards import content_digest, sealed_manifest

    manifest = json.loads((folder / "part.json").read_text())
    manifest.pop("digest", None)
    files = {name: content_digest((folder / name).read_bytes()) for name in manifest.pop("files")}
    (folder / "part.json").write_bytes(sealed_manifest(manifest, files))
    return folder


def test_a_missing_or_repeated_shard_is_refused(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    assert "shard 3 of 3 is missing" in _refused(tmp_path, p1, p2)
    assert "given twice" in _refused(tmp_path, p1, p2, p2, p3)


def test_parts_of_other_settings_or_another_split_are_refused(culane_set, three_parts, tmp_path):
    p1, p2, p3 = three_parts
    other = _score(culane_set, tmp_path / "other", "--shard", "2/3", "--width", "20")
    assert "settings" in _refused(tmp_path, p1, other, p3)
    split = _score(culane_set, tmp_path / "split", "--shard", "2/4")
    assert "another split" in _refused(tmp_path, p1, split, p3)


def test_parts_of_another_list_are_refused(culane_set, three_parts, tmp_path):
    p1, p2, p3 = three_parts
    data = tmp_path / "data"
    shutil.copytree(culane_set / "data", data)
    listing = data / "list" / "test.txt"
    listing.write_text("".join(listing.read_text().splitlines(keepends=True)[:-1]))  # one frame fewer
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", f"a={culane_set / 'maps'}", "--pred-root",
                     f"b={culane_set / 'maps'}", "--iou", "0.3:0.7:0.1", "--quiet", "--out", tmp_path / "o",
                     "--shard", "3/3")
    assert result.exit_code == 0, result.output
    assert "ground truth" in _refused(tmp_path, p1, p2, tmp_path / "o")


def _copy_with_arrays(part, copy):
    """A copy of `part` at `copy`, and the arrays of its part.npz to edit."""
    shutil.copytree(part, copy)
    with np.load(part / "part.npz") as loaded:
        return copy, {name: loaded[name] for name in loaded.files}


def test_an_edited_part_is_refused_naming_its_file(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    edited, arrays = _copy_with_arrays(p2, tmp_path / "edited")
    arrays["matched_iou"] = arrays["matched_iou"] + 2.0
    np.savez(edited / "part.npz", **arrays)
    assert f"{edited / 'part.npz'}: changed since its shard wrote it" in _refused(tmp_path, p1, edited, p3)
    # with part.json's digests rewritten as well, the checks of the contents still refuse it
    assert f"{edited / 'part.npz'}: a matched IoU outside [0, 1]" in _refused(tmp_path, p1, _resealed(edited), p3)
    (edited / "part.npz").write_bytes(b"PK\x03\x04 not a zip")
    assert "not a readable part.npz" in _refused(tmp_path, p1, _resealed(edited), p3)
    manifest = json.loads((p2 / "part.json").read_text())
    manifest["version"] = "0.0.1"
    shutil.copy(p2 / "part.npz", edited / "part.npz")
    (edited / "part.json").write_text(json.dumps(manifest))
    assert f"{edited / 'part.json'}: changed since its shard wrote it" in _refused(tmp_path, p1, edited, p3)
    assert "version" in _refused(tmp_path, p1, _resealed(edited), p3)
    for key, value in (("trees", "x"), ("width", 1), ("categories", [3])):
        broken = json.loads((p2 / "part.json").read_text())
        broken["settings"][key] = value
        for part, folder in ((p1, tmp_path / "b1"), (edited, tmp_path / "b2"), (p3, tmp_path / "b3")):
            shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(part if part is not edited else p2, folder)
            if part is not edited:
                manifest = json.loads((folder / "part.json").read_text())
                manifest["settings"][key] = value  # all three alike: only the merge's own checks can refuse
                (folder / "part.json").write_text(json.dumps(manifest))
            else:
                (folder / "part.json").write_text(json.dumps(broken))
            _resealed(folder)
        assert "its settings are not those" in _refused(tmp_path, tmp_path / "b1", tmp_path / "b2", tmp_path / "b3")
    (edited / "part.json").write_text("{")
    assert "not a partial result" in _refused(tmp_path, p1, edited, p3)
    assert "not a partial result" in _refused(tmp_path, p1, tmp_path, p3)


def test_a_count_edited_in_part_npz_keeping_its_form_is_refused(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    edited, arrays = _copy_with_arrays(p2, tmp_path / "edited")
    arrays["n_pred"] = arrays["n_pred"] + 1  # a lane more in every frame: only false positives more
    arrays["matched_iou"] = np.where(arrays["matched_iou"] > 0.2, 0.99, arrays["matched_iou"])
    np.savez(edited / "part.npz", **arrays)
    output = _refused(tmp_path, p1, edited, p3)
    assert f"error: {edited / 'part.npz'}: changed since its shard wrote it" in output
    # the edit keeps every check of the form: with its digest rewritten too, it merges to other numbers
    assert _invoke("merge", p1, p2, p3, "--out", tmp_path / "plain").exit_code == 0
    assert _invoke("merge", p1, _resealed(edited), p3, "--out", tmp_path / "forged").exit_code == 0
    assert (tmp_path / "forged" / "official.csv").read_bytes() != (tmp_path / "plain" / "official.csv").read_bytes()


def test_a_culane_merge_refuses_predictions_changed_since_the_shards(culane_set, tmp_path):
    maps = tmp_path / "maps"
    shutil.copytree(culane_set / "maps", maps)

    def scored(out, *extra):
        result = _invoke("score", "culane", "--data-root", culane_set / "data", "--pred-root", f"a={maps}",
                         "--workers", "1", "--quiet", "--out", out, *extra)
        assert result.exit_code == 0, result.output
        return out

    whole = scored(tmp_path / "whole")
    parts = [scored(tmp_path / f"p{k}", "--shard", f"{k}/2") for k in (1, 2)]
    with np.load(parts[1] / "part.npz") as loaded:
        frame = str(loaded["frames"][-1])  # a frame of shard 2
    victim = maps / (frame.rsplit(".", 1)[0] + ".lines.txt")
    before = victim.read_bytes()
    victim.write_bytes(b"")  # its lanes gone, after the shards scored them
    output = _refused(tmp_path, *parts)
    assert f"error: {parts[1]}: the predictions of a ({maps}) changed since this shard scored them" in output
    victim.write_bytes(before)  # the same bytes again, but written since: refused all the same
    assert "the predictions of a" in _refused(tmp_path, *parts)
    # merged where the predictions are not (another machine): the parts' own digests are all it can check
    maps.rename(tmp_path / "moved")
    result = _invoke("merge", *parts, "--out", tmp_path / "merged")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "merged" / "official.csv").read_bytes() == (whole / "official.csv").read_bytes()


def test_a_lane_file_merge_refuses_predictions_changed_since_the_shards(tmp_path):
    args = _lane_file_command(tmp_path, "openlane")
    parts = _two_shards(args, tmp_path)
    victim = sorted((tmp_path / "set" / "predictions").rglob("*.json"))[-1]  # a frame of shard 2
    record = json.loads(victim.read_text())
    record["lane_lines"] = record["lane_lines"][:1]  # the same tree, one lane fewer
    victim.write_text(json.dumps(record))
    output = _refused(tmp_path, *parts)
    assert f"error: {parts[1]}: the predictions of " in output and "changed since this shard scored them" in output


def test_a_run_clip_edited_keeping_its_form_is_refused(tmp_path):
    result = _invoke("synth", "--dataset", "culane", "--out", tmp_path / "set", "--clips", "2", "--frames", "3")
    assert result.exit_code == 0, result.output
    data, maps = tmp_path / "set" / "data", tmp_path / "set" / "maps"
    parts = [_run(data, maps, tmp_path / f"p{k}", "--shard", f"{k}/2") for k in (1, 2)]
    clip = parts[1] / "clips" / "000000.json"
    entry = json.loads(clip.read_text())
    for outcome in entry["result"]["outcomes"]:
        outcome["ious"] = {side: 0.99 for side in outcome["ious"]}  # a better method, within [0, 1]
    clip.write_text(json.dumps(entry))
    output = _refused(tmp_path, *parts)
    assert f"error: {clip}: changed since its shard wrote it" in output
    config = parts[0] / "config.toml"
    config.write_text(config.read_text() + "\n")
    assert f"error: {config}: changed since its shard wrote it" in _refused(tmp_path, *parts)


def test_parts_of_an_older_version_without_digests_are_refused(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    old = tmp_path / "old"
    shutil.copytree(p2, old)
    manifest = json.loads((old / "part.json").read_text())
    for key in ("files", "digest", "predictions"):  # what ca5cdc9 wrote: format 1, nothing sealed
        manifest.pop(key, None)
    manifest["format_version"] = 1
    (old / "part.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    output = _refused(tmp_path, p1, old, p3)
    assert f"error: {old / 'part.json'}: a part written by an older roneld-eval" in output


def test_a_shard_needs_an_output_folder(culane_set):
    result = _invoke("score", "culane", "--data-root", culane_set / "data", "--pred-root", culane_set / "maps",
                     "--shard", "1/2")
    assert result.exit_code == 2 and "--out" in result.output


TIMINGS = {"runtime.csv", "runtime.md", "report.html", "summary.json"}  # each run's own clock


def _files(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _run(data, maps, out, *extra, dataset="culane"):
    result = _invoke("run", "--dataset", dataset, "--data-root", data, "--maps-root", maps, "--save-lanes",
                     "--pft-ablation", "--workers", "1", "--quiet", "--out", out, *extra)
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.parametrize("dataset", ["culane", "tusimple"])  # TuSimple: one lane file for all frames
def test_a_merged_run_is_the_unsharded_run_but_for_its_clock(tmp_path, dataset):
    result = _invoke("synth", "--dataset", dataset, "--out", tmp_path / "set", "--clips", "4", "--frames", "5")
    assert result.exit_code == 0, result.output
    data, maps = tmp_path / "set" / "data", tmp_path / "set" / "maps"
    whole = _files(_run(data, maps, tmp_path / "whole", dataset=dataset))
    parts = [_run(data, maps, tmp_path / f"p{k}", "--shard", f"{k}/3", dataset=dataset) for k in (1, 2, 3)]
    assert not (parts[0] / "accuracy.csv").exists()  # a part, not a report
    result = _invoke("merge", *parts, "--out", tmp_path / "merged")
    assert result.exit_code == 0, result.output
    merged = _files(tmp_path / "merged")
    assert set(merged) == set(whole) and any(name.startswith("lanes/") for name in whole)
    assert [name for name in sorted(whole) if name not in TIMINGS and whole[name] != merged[name]] == []
    before, after = (json.loads(files["summary.json"]) for files in (whole, merged))
    assert after.pop("notes") == ["merged from 3 shards: the wall time is the sum of theirs, the timings each "
                                  "shard's own"]
    before.pop("wall_time_s"), after.pop("wall_time_s")
    assert before == after


def test_a_merged_run_of_the_bundled_fixture_names_it_as_the_run_does(tmp_path):
    def fixture_run(out, *extra):
        result = _invoke("run", "--workers", "1", "--quiet", "--out", out, *extra)
        assert result.exit_code == 0, result.output
        return out

    whole = _files(fixture_run(tmp_path / "whole"))
    parts = [fixture_run(tmp_path / f"p{k}", "--shard", f"{k}/2") for k in (1, 2)]
    assert _invoke("merge", *parts, "--out", tmp_path / "merged").exit_code == 0
    merged = _files(tmp_path / "merged")
    assert "bundled CULane fixture" in merged["accuracy.md"].decode()  # not this machine's paths to it
    assert [name for name in sorted(whole) if name not in TIMINGS and whole[name] != merged[name]] == []


def test_a_merge_refuses_a_clip_whose_maps_changed_since_its_shard(culane_set, tmp_path):
    result = _invoke("synth", "--dataset", "culane", "--out", tmp_path / "set", "--clips", "2", "--frames", "3")
    assert result.exit_code == 0, result.output
    data, maps = tmp_path / "set" / "data", tmp_path / "set" / "maps"
    parts = [_run(data, maps, tmp_path / f"p{k}", "--shard", f"{k}/2") for k in (1, 2)]
    changed = sorted(maps.rglob("*.npy"))[-1]
    changed.write_bytes(changed.read_bytes())  # same bytes, a new modification time
    import os

    os.utime(changed, ns=(1, 1))
    output = _refused(tmp_path, *parts)
    assert "changed since its shard was run" in output and str(parts[1]) in output
    output = _refused(tmp_path, parts[0])
    assert "shard 2 of 2 is missing" in output


def test_a_run_shard_refuses_what_it_cannot_give(culane_set, tmp_path):
    for extra in (["--resume"], ["--overlays", "2"]):
        result = _invoke("run", "--out", tmp_path / "o", "--shard", "1/2", *extra)
        assert result.exit_code == 2 and "--shard writes a part" in result.output


def _lane_file_command(tmp_path, dataset):
    result = _invoke("synth", "--dataset", dataset, "--out", tmp_path / "set", "--clips", "4", "--frames", "3")
    assert result.exit_code == 0, result.output
    command = next(line.split("roneld-eval ", 1)[1] for line in result.output.splitlines()
                   if "roneld-eval score" in line)
    args = command.split()
    if dataset == "llamas":  # a model's maps of the same labels too: the AP merges (frame rows, in order)
        result = _invoke("synth", "--dataset", "llamas", "--out", tmp_path / "maps", "--clips", "4", "--frames", "3",
                         "--maps-format", "llamas-png")
        assert result.exit_code == 0, result.output
        args += ["--maps", f"seg={tmp_path / 'maps' / 'predictions'}"]
    return args


@pytest.mark.parametrize("dataset", ["openlane", "curvelanes", "llamas"])
def test_merged_lane_file_scores_are_the_unsharded_files(tmp_path, dataset, monkeypatch):
    args = _lane_file_command(tmp_path, dataset)
    whole = _invoke(*args, "--quiet", "--out", tmp_path / "whole")
    assert whole.exit_code == 0, whole.output
    parts = []
    for k in (1, 2, 3):
        result = _invoke(*args, "--quiet", "--out", tmp_path / f"p{k}", "--shard", f"{k}/3")
        assert result.exit_code == 0, result.output
        parts.append(tmp_path / f"p{k}")
    monkeypatch.chdir(tmp_path / "p1")  # the parts hold absolute paths: a merge from anywhere finds the files
    result = _invoke("merge", *parts, "--out", tmp_path / "merged")
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in (tmp_path / "whole").iterdir() if not p.name.startswith("."))
    assert "official.csv" in names
    for name in names:
        assert (tmp_path / "merged" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name
    if dataset == "llamas":
        official = (tmp_path / "whole" / "official.csv").read_text().splitlines()
        seg = [line for line in official if line.startswith("seg,")]
        assert len(seg) == 1 and 0 < float(seg[0].split(",")[-1]) < 1  # the AP row is there, its mean filled
        assert "AP mean" in (tmp_path / "whole" / "summary.md").read_text()


def _two_shards(args, tmp_path):
    """The parts of the command `args` in two shards, p1 and p2 under tmp_path."""
    parts = []
    for k in (1, 2):
        result = _invoke(*args, "--quiet", "--out", tmp_path / f"p{k}", "--shard", f"{k}/2")
        assert result.exit_code == 0, result.output
        parts.append(tmp_path / f"p{k}")
    return parts


def test_a_lane_file_merge_refuses_files_that_moved_since_the_shards(tmp_path):
    args = _lane_file_command(tmp_path, "openlane")
    parts = _two_shards(args, tmp_path)
    victim = sorted((tmp_path / "set" / "predictions").rglob("*.json"))[0]
    victim.unlink()  # one prediction file fewer: the tree the merge finds is not the shards'
    output = _refused(tmp_path, *parts)
    assert "not those the shards of this `score openlane` found" in output


def test_a_merge_into_one_of_its_parts_is_refused_and_leaves_the_part(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    before = (p2 / "part.npz").read_bytes()
    result = _invoke("merge", p1, p2, p3, "--out", p2)
    assert result.exit_code == 2 and "is one of the parts" in result.output
    assert (p2 / "part.npz").read_bytes() == before


def test_a_part_whose_commit_was_cut_short_is_refused(three_parts, tmp_path):
    p1, p2, p3 = three_parts
    copy = tmp_path / "p2"
    shutil.copytree(p2, copy)
    (copy / ".roneld-commit.json").write_text("{}")  # what a kill during its commit leaves
    assert "its part is incomplete" in _refused(tmp_path, p1, copy, p3)


def test_culane_parts_scored_against_other_labels_are_refused(culane_set, three_parts, tmp_path):
    p1, p2, p3 = three_parts
    data = tmp_path / "data"
    shutil.copytree(culane_set / "data", data)  # the same list, other label files
    result = _invoke("score", "culane", "--data-root", data, "--pred-root", f"a={culane_set / 'maps'}", "--pred-root",
                     f"b={culane_set / 'maps'}", "--iou", "0.3:0.7:0.1", "--quiet", "--out", tmp_path / "o",
                     "--shard", "2/3")
    assert result.exit_code == 0, result.output
    assert "ground truth" in _refused(tmp_path, p1, tmp_path / "o", p3)


def test_lane_file_parts_refuse_edited_labels_and_a_relabelled_copy(tmp_path):
    args = _lane_file_command(tmp_path, "openlane")
    parts = []
    for k in (1, 2, 3):
        result = _invoke(*args, "--quiet", "--out", tmp_path / f"p{k}", "--shard", f"{k}/3")
        assert result.exit_code == 0, result.output
        parts.append(tmp_path / f"p{k}")
    copy = tmp_path / "copy"
    shutil.copytree(parts[1], copy)  # shard 2's numbers presented as shard 3's
    manifest = json.loads((copy / "part.json").read_text())
    manifest["shard"] = [3, 3]
    (copy / "part.json").write_text(json.dumps(manifest))
    assert "did not score that shard's frames" in _refused(tmp_path, parts[0], parts[1], _resealed(copy))
    label = sorted((tmp_path / "set" / "labels").rglob("*.json"))[0]
    label.write_text(label.read_text())  # rewritten after the shards ran
    import os

    os.utime(label, ns=(10**9, 10**9))
    assert "labels or prediction trees found now" in _refused(tmp_path, *parts)


def test_a_run_part_naming_a_plug_in_is_not_imported_by_merge(tmp_path):
    result = _invoke("synth", "--dataset", "culane", "--out", tmp_path / "set", "--clips", "2", "--frames", "2")
    assert result.exit_code == 0, result.output
    data, maps = tmp_path / "set" / "data", tmp_path / "set" / "maps"
    parts = [_run(data, maps, tmp_path / f"p{k}", "--shard", f"{k}/2") for k in (1, 2)]
    evil = tmp_path / "evil.py"
    marker = tmp_path / "imported"
    evil.write_text(f"open({str(marker)!r}, 'w').close()\ndef make():\n    pass\n")
    config = parts[0] / "config.toml"
    config.write_text(config.read_text() + f'\n[methods.evil]\nentry = "{evil}:make"\n')
    output = _refused(tmp_path, *parts)
    assert not marker.exists() and f"{config}: changed since its shard wrote it" in output
    output = _refused(tmp_path, _resealed(parts[0]), parts[1])  # its digest rewritten too
    assert not marker.exists() and ("plug-in" in output or "config" in output)


def test_a_part_npz_of_many_members_is_refused_before_they_are_inflated(three_parts, tmp_path):
    import zipfile

    p1, p2, p3 = three_parts
    edited = tmp_path / "many"
    shutil.copytree(p2, edited)
    with zipfile.ZipFile(edited / "part.npz", "a") as archive:
        for k in range(70):
            archive.writestr(f"junk_{k}.npy", b"x")
    assert "members inflate to more than" in _refused(tmp_path, p1, _resealed(edited), p3)


@pytest.mark.parametrize("dataset, name, value, message", [
    ("openlane", "sum_counts", 2**62, "is not a count"),  # two such parts would overflow
    ("llamas", "cat_curves", -1e300, "do not fit"),  # an AP below 0
])
def test_lane_file_parts_with_impossible_numbers_are_refused(tmp_path, dataset, name, value, message):
    args = _lane_file_command(tmp_path, dataset)
    parts = []
    for k in (1, 2):
        result = _invoke(*args, "--quiet", "--out", tmp_path / f"p{k}", "--shard", f"{k}/2")
        assert result.exit_code == 0, result.output
        parts.append(tmp_path / f"p{k}")
    with np.load(parts[1] / "part.npz") as loaded:
        arrays = {key: loaded[key] for key in loaded.files}
    arrays[name] = np.full_like(arrays[name], value)
    np.savez(parts[1] / "part.npz", **arrays)
    assert message in _refused(tmp_path, parts[0], _resealed(parts[1]))


def _shards_and_merge(tmp_path, args, count: int, tag: str = "") -> tuple:
    """The unsharded command's folder and the merge of its `count` shards."""
    whole = _invoke(*args, "--quiet", "--out", tmp_path / f"whole{tag}")
    assert whole.exit_code == 0, whole.output
    parts = []
    for k in range(1, count + 1):
        result = _invoke(*args, "--quiet", "--out", tmp_path / f"p{tag}{k}", "--shard", f"{k}/{count}")
        assert result.exit_code == 0, result.output
        parts.append(tmp_path / f"p{tag}{k}")
    result = _invoke("merge", *parts, "--out", tmp_path / f"all{tag}")
    assert result.exit_code == 0, result.output
    return tmp_path / f"whole{tag}", tmp_path / f"all{tag}", parts


def _same_files(whole, merged, wanted: set[str]) -> None:
    names = {p.name for p in whole.iterdir() if not p.name.startswith(".")}
    assert wanted <= names
    for name in names:
        assert (merged / name).read_bytes() == (whole / name).read_bytes(), name


def _tusimple_set(tmp_path, clips: int = 5):
    """Labels of `clips` clips and a detector's predictions of the labelled frames, in another
    order than the labels' (a merge must add the frames up in the prediction file's order)."""
    from roneld_eval.benchmarks.tusimple.synth import synth_tusimple

    synth_tusimple(tmp_path / "t", clips=clips, seed=3, maps_format="lanes")
    labels = tmp_path / "t" / "data" / "test_label.json"
    lines = [line for line in (tmp_path / "t" / "maps" / "predictions.json").read_text().splitlines()
             if '/20.jpg"' in line]
    pred = tmp_path / "pred.json"
    pred.write_text("".join(line + "\n" for line in lines[1::2] + lines[0::2]))
    return labels, pred


@pytest.mark.parametrize("count", [2, 3, 7])  # 7 shards of 5 clips: some are empty
def test_merged_tusimple_shards_are_the_unsharded_file(tmp_path, count):
    labels, pred = _tusimple_set(tmp_path)
    whole, merged, _ = _shards_and_merge(tmp_path, ["score", "tusimple", "--labels", labels, "--pred", pred], count)
    _same_files(whole, merged, {"official.csv"})


def test_merged_tusimple_shards_of_several_prediction_files_are_the_unsharded_file(tmp_path):
    labels, pred = _tusimple_set(tmp_path)
    other = tmp_path / "other.json"  # the same frames in the labels' order: each file's own order merges
    other.write_text("".join(sorted(pred.read_text().splitlines(keepends=True),
                                    key=lambda line: json.loads(line)["raw_file"])))
    args = ["score", "tusimple", "--labels", labels, "--pred", pred, "--pred", f"again={other}"]
    whole, merged, _ = _shards_and_merge(tmp_path, args, 3)
    _same_files(whole, merged, {"official.csv"})
    assert [line.split(",")[0] for line in (whole / "official.csv").read_text().splitlines()] == \
        ["method", "pred", "again"]


@pytest.mark.long
def test_tusimple_shards_of_the_real_labels_merge_to_lane_pys_numbers(shared_data, tmp_path):
    from test_score import real_tusimple_labels
    from tusimple_perturbation import perturbed_predictions

    labels = real_tusimple_labels(shared_data, tmp_path)
    pred = tmp_path / "pred.json"  # 2,782 frames whose sums differ in the last bits with the order
    lines = perturbed_predictions(labels.read_text().splitlines(keepends=True), 7, "harsh").splitlines(keepends=True)
    pred.write_text("".join(lines[::-1]))
    whole, merged, parts = _shards_and_merge(tmp_path, ["score", "tusimple", "--labels", labels, "--pred", pred], 4)
    _same_files(whole, merged, {"official.csv"})
    from roneld_eval.benchmarks.tusimple.score import score_tusimple
    from roneld_eval.shards import merge

    _, score = merge(parts, tmp_path / "again")  # to the last bit, frames added in the prediction file's order
    assert score == score_tusimple(labels, pred)


def test_a_tusimple_merge_refuses_an_edited_prediction_file_or_a_part_of_other_frames(tmp_path):
    labels, pred = _tusimple_set(tmp_path)
    _, _, parts = _shards_and_merge(tmp_path, ["score", "tusimple", "--labels", labels, "--pred", pred], 2)
    arrays = dict(np.load(parts[1] / "part.npz"))
    arrays["cat_line"] = arrays["cat_line"] + 1  # the lines of other frames
    np.savez(parts[1] / "part.npz", **arrays)
    assert "not the prediction file's lines" in _refused(tmp_path, parts[0], _resealed(parts[1]))
    pred.write_text(pred.read_text() + "\n")  # the predictions changed since the shards
    assert "not those the shards of this `score tusimple` found" in _refused(tmp_path, *parts)


def _vil100_set(tmp_path, pred_format: str):
    """Three sequences of the golden sets, named for scenarios that pool across shards."""
    from pathlib import Path

    golden = Path(__file__).parent / "golden" / "vil100"
    source, parts = (golden, ("anno_txt", "pred_txt")) if pred_format == "lines" else \
        (golden / "acc_cases", ("anno_txt", "pred_png"))
    sizes = json.loads((source / "test_sizes.json").read_text())
    olds = sorted(sizes)
    names = {f"{code}_{k}_frames": olds[k % len(olds)] for k, code in enumerate(("0", "13", "5", "3"))}
    root = tmp_path / f"vil_{pred_format}"
    for new, old in names.items():
        for part in parts:
            shutil.copytree(source / part / old, root / part / new)
    (root / "sizes.json").write_text(json.dumps({new: sizes[old] for new, old in names.items()}))
    return ["score", "vil100", "--labels", root / parts[0], "--pred-root", f"syn={root / parts[1]}",
            "--pred-root", f"again={root / parts[1]}", "--pred-format", pred_format, "--sizes", root / "sizes.json",
            "--iou", "0.3:0.8:0.1", "--workers", "1"]


@pytest.mark.parametrize("pred_format, count", [("lines", 2), ("lines", 3), ("png", 3), ("lines", 6)])
def test_merged_vil100_shards_are_the_unsharded_files(tmp_path, pred_format, count):
    whole, merged, _ = _shards_and_merge(tmp_path, _vil100_set(tmp_path, pred_format), count)
    _same_files(whole, merged, {"official.csv", "temporal.csv", "acc.csv", "summary.csv", "summary.md"})
    if pred_format == "png":  # MMA-Net's Acc version, which needs every frame's numbers, is there
        assert ",mmanet," in (whole / "acc.csv").read_text()


def test_a_vil100_merge_refuses_other_sizes_than_its_shards_read(tmp_path):
    args = _vil100_set(tmp_path, "lines")
    _, _, parts = _shards_and_merge(tmp_path, args, 2)
    sizes_file = args[args.index("--sizes") + 1]
    sizes = json.loads(sizes_file.read_text())
    for size in sizes.values():
        size["width"] += 2
    sizes_file.write_text(json.dumps(sizes))
    assert "not those the shards of this `score vil100` found" in _refused(tmp_path, *parts)
