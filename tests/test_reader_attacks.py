"""The attack classes of issue 47 tried on every reader of lane files (`score openlane`,
`curvelanes`, `llamas`, `tusimple`, `vil100`): a 400-digit integer (valid JSON) and 1e308 in any
number, a coordinate beyond 2^24 px, a number written as a string where the format holds numbers,
a key given twice in one JSON object, a projection that divides by zero. Each is one line
`error: <file>: <problem>` and exit 2: never a traceback, a numpy warning, or a file read one way
here and another way by another JSON parser (Python's keeps the last of a repeated key, cJSON the
first)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main
from roneld_eval.benchmarks.curvelanes.synth import synth_curvelanes
from roneld_eval.benchmarks.llamas.synth import synth_llamas
from roneld_eval.benchmarks.openlane.synth import synth_openlane
from roneld_eval.benchmarks.tusimple.synth import synth_tusimple
from roneld_eval.benchmarks.vil100.synth import synth_vil100

DIGITS_400 = 10**400 - 1


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("attacks")
    synth_openlane(root / "openlane", clips=1, frames=1)
    synth_curvelanes(root / "curvelanes", clips=1)
    synth_llamas(root / "llamas", clips=1, frames=2)
    synth_llamas(root / "llamas-maps", clips=1, frames=1, maps_format="llamas-png")
    synth_tusimple(root / "tusimple", clips=1, frames=20, maps_format="lanes")
    labels = root / "tusimple" / "data" / "test_label.json"
    shutil.copy(labels, root / "tusimple" / "predictions.json")  # the labels as a detector's lanes
    synth_vil100(root / "vil100", clips=1, frames=2, maps_format="lanes")
    return root


def _command(name: str, root: Path) -> list[str]:
    if name == "openlane":
        return ["score", "openlane", "--labels", root / "labels", "--pred-root", root / "predictions", "--workers", "1"]
    if name == "curvelanes":
        return ["score", "curvelanes", "--labels", root / "labels", "--pred-root", root / "predictions",
                "--image-root", root / "images", "--workers", "1"]
    if name == "llamas":
        return ["score", "llamas", "--labels", root / "labels", "--pred-root", root / "predictions", "--workers", "1"]
    if name == "llamas-maps":
        return ["score", "llamas", "--labels", root / "labels", "--maps", root / "predictions", "--workers", "1"]
    if name == "tusimple":  # one process whatever: no --workers
        return ["score", "tusimple", "--labels", root / "data" / "test_label.json", "--pred", root / "predictions.json"]
    assert name == "vil100"
    return ["score", "vil100", "--labels", root / "data" / "anno_txt", "--pred-root", root / "maps", "--sizes",
            root / "data" / "sizes.json", "--no-temporal", "--workers", "1"]


# Where each set's first label and first prediction lie (the file a case corrupts).
FILES = {
    ("openlane", "label"): "labels/**/*.json", ("openlane", "prediction"): "predictions/**/*.json",
    ("curvelanes", "label"): "labels/*.lines.json", ("curvelanes", "prediction"): "predictions/*.lines.json",
    ("llamas", "label"): "labels/**/*.json", ("llamas", "prediction"): "predictions/**/*.lines.txt",
    ("llamas-maps", "label"): "labels/**/*.json",
    ("tusimple", "label"): "data/test_label.json", ("tusimple", "prediction"): "predictions.json",
    ("vil100", "sizes"): "data/sizes.json",
}


def _json_edit(change):
    """A corruption of a JSON file through its parsed value (json.dumps writes 10**400 in full)."""
    def edit(text: str) -> str:
        if "\n{" in text.strip():  # TuSimple: JSON lines, the first one changed
            first, rest = text.split("\n", 1)
            return edit(first) + "\n" + rest
        record = json.loads(text)
        change(record)
        return json.dumps(record)
    return edit


def _uv(value):
    return _json_edit(lambda r: r["lane_lines"][0]["uv"][0].__setitem__(0, value))


def _curvelanes_x(value):
    def change(record):
        lane = record["Lines"][0]
        (lane["points"] if isinstance(lane, dict) else lane)[0]["x"] = value
    return _json_edit(change)


def _marker(field: str, axis: str, value):
    return _json_edit(lambda r: r["lanes"][0]["markers"][0][field].__setitem__(axis, value))


def _first_x(value):
    def change(record):
        lane = record["lanes"][0]
        lane[next(i for i, x in enumerate(lane) if x >= 0)] = value
    return _json_edit(change)


def _repeat_first_key(text: str, key: str, value: str) -> str:
    """`"key": value, ` put before the first `"key":` of the text: the key twice in one object."""
    return text.replace(f'"{key}":', f'"{key}": {value}, "{key}":', 1)


# (set, file, corruption of its text, words the one line must hold)
CASES = [
    # 400-digit integers: OverflowError tracebacks before
    ("openlane", "label", _uv(DIGITS_400), "`uv` holds a value that is not a finite float32"),
    ("openlane", "prediction", _uv(DIGITS_400), "`uv` holds a value that is not a finite float32"),
    ("openlane", "label", _json_edit(lambda r: r["lane_lines"][0].__setitem__("category", DIGITS_400)),
     "`category` must be a number, got 99999"),
    ("curvelanes", "label", _curvelanes_x(DIGITS_400), "x 99999"),
    ("curvelanes", "prediction", _curvelanes_x(DIGITS_400), "is not a finite number of pixels"),
    ("curvelanes", "prediction", _json_edit(lambda r: r["Lines"][0].__setitem__("score", DIGITS_400)),
     "score 99999"),
    ("llamas", "label", _marker("pixel_start", "x", DIGITS_400), "pixel_start.x 99999"),
    ("llamas", "label", _marker("pixel_end", "y", DIGITS_400), "pixel_end.y 99999"),
    ("llamas-maps", "label", _json_edit(lambda r: r["projection_matrix"][0].__setitem__(0, DIGITS_400)),
     "projection_matrix holds an entry that is not a finite number"),
    # 1e308 and far coordinates: OverflowError tracebacks, numpy's RuntimeWarnings, or accepted
    ("llamas", "label", _marker("pixel_start", "x", 1e308), "pixel_start.x 1e+308 lies more than 2^24 px"),
    ("llamas", "label", _marker("pixel_end", "x", 1e30), "pixel_end.x 1e+30 lies more than 2^24 px"),
    ("llamas", "prediction", lambda text: "1e308 600 500 650 520 700\n" + text, "lies more than 2^24 px"),
    ("llamas", "prediction", lambda text: "1e30 600 500 650 520 700\n" + text, "lies more than 2^24 px"),
    ("openlane", "label", _uv(1e30), "lies more than 2^24 px"),
    ("tusimple", "label", _first_x(1e308), "lane 0: x = 1e+308 lies more than 2^24 px"),
    ("tusimple", "prediction", _first_x(1e30), "lane 0: x = 1e+30 lies more than 2^24 px"),
    # a number as a string: int("345") and float("3.2") read it, so it counted
    ("llamas", "label", _marker("pixel_start", "x", "345"), "pixel_start.x '345' is not a number but a string"),
    ("llamas", "label", _marker("world_start", "z", "3.2"), "world_start.z '3.2' is not a number but a string"),
    # a degenerate projection: every marker drawn nowhere, an AP of an empty label
    ("llamas-maps", "label", _json_edit(lambda r: r.__setitem__("projection_matrix", [[0, 0, 0]] * 3)),
     "projection_matrix's last row is all zeros"),
    ("llamas-maps", "label", _json_edit(lambda r: r["projection_matrix"].__setitem__(2, [0.0, 0.0, 0.0])),
     "projection_matrix's last row is all zeros"),
    # a key twice in one object: read last-wins
    ("openlane", "label", lambda text: _repeat_first_key(text, "category", "7"), "key 'category' appears twice"),
    ("openlane", "prediction", lambda text: _repeat_first_key(text, "lane_lines", "[]"),
     "key 'lane_lines' appears twice"),
    ("curvelanes", "label", lambda text: _repeat_first_key(text, "x", '"5"'), "key 'x' appears twice"),
    ("curvelanes", "prediction", lambda text: _repeat_first_key(text, "Lines", "[]"), "key 'Lines' appears twice"),
    ("llamas", "label", lambda text: _repeat_first_key(text, "y", "700"), "key 'y' appears twice"),
    ("tusimple", "label", lambda text: _repeat_first_key(text, "lanes", "[]"), "key 'lanes' appears twice"),
    ("tusimple", "prediction", lambda text: _repeat_first_key(text, "lanes", "[]"), "key 'lanes' appears twice"),
    ("vil100", "sizes", lambda text: _repeat_first_key(text, "width", "1280"), "key 'width' appears twice"),
]


@pytest.mark.parametrize("name, which, corrupt, said", CASES,
                         ids=[f"{c[0]} {c[1]}: {c[3][:40]}" for c in CASES])
def test_an_attack_is_one_line_naming_the_file(base, tmp_path, name, which, corrupt, said):
    root = tmp_path / name
    shutil.copytree(base / name, root)
    path = sorted(root.glob(FILES[(name, which)]))[0]
    path.write_text(corrupt(path.read_text()))
    result = CliRunner().invoke(main, [str(part) for part in _command(name, root)] + ["--quiet"])
    assert result.exit_code == 2, result.output
    assert re.match(rf"error: {re.escape(str(path))}(:\d+)?: ", result.output), result.output
    assert said in result.output and result.output.count("\n") == 1, result.output


@pytest.mark.parametrize("name, synth", [("openlane", synth_openlane), ("llamas", synth_llamas)])
def test_a_score_written_inside_the_labels_is_not_read_as_labels_next_time(tmp_path, name, synth):
    # --out inside a label folder: its .roneld-run.json was read as a label (a .json) the next time
    synth(tmp_path / "set", clips=1)
    common = ["score", name, "--labels", tmp_path / "set" / "labels", "--pred-root", tmp_path / "set" / "predictions",
              "--workers", "1"]
    first = CliRunner().invoke(main, [str(a) for a in common + ["--out", tmp_path / "set" / "labels" / "scores"]])
    assert first.exit_code == 0, first.output
    again = CliRunner().invoke(main, [str(a) for a in common + ["--out", tmp_path / "again"]])
    assert again.exit_code == 0, again.output
    assert first.output == again.output  # the same frames, counted the same
    for written in (tmp_path / "again").iterdir():
        if not written.name.startswith("."):
            assert written.read_bytes() == (tmp_path / "set" / "labels" / "scores" / written.name).read_bytes()
