"""Shared fixtures: tiny hand-written trees, the bundled fixture, and the real data in ../shared."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest

# A suite started in the background (`pytest &`, nohup, a runner that ignores Ctrl-C) inherits
# SIGINT ignored, and so does every Python it starts: the Ctrl-C tests then failed, testing only
# that an ignored signal is ignored. Python's own handler, as in a terminal; the Pythons the tests
# start get the default action, and install that handler themselves.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RONELD_SHARED", REPO.parent / "shared")) / "data"
# Expected values from the official tools or by hand (each with its source) ...
GOLDEN = Path(__file__).parent / "golden"
# ... and output the tool itself wrote, kept to catch unintended changes (see snapshots/README.md).
SNAPSHOTS = Path(__file__).parent / "snapshots"


@pytest.fixture
def shared_data() -> Path:
    """../shared/data, or a clean skip where it is absent."""
    if not SHARED.is_dir():
        pytest.skip("real data (../shared/data) is not available")
    return SHARED


@pytest.fixture
def real_clip(shared_data) -> Path:
    path = shared_data / "culane-scnn-clip"
    if not path.is_dir():
        pytest.skip("culane-scnn-clip is not available")
    return path


def clip_frames(real_clip: Path) -> list[str]:
    return sorted({p.name[:5] for p in real_clip.glob("*_1_avg.png")})


@pytest.fixture
def real_clip_tree(real_clip, tmp_path) -> tuple[Path, Path]:
    """A CULane tree of symlinks around the real clip: (data root, maps root)."""
    video = "driver_37_30frame/05181432_0203.MP4"
    data, maps = tmp_path / "data", tmp_path / "maps"
    (data / video).mkdir(parents=True)
    (maps / video).mkdir(parents=True)
    frames = clip_frames(real_clip)
    for name in frames:
        (data / video / f"{name}.lines.txt").symlink_to(real_clip / f"{name}.lines.txt")
        for k in range(1, 5):
            (maps / video / f"{name}_{k}_avg.png").symlink_to(real_clip / f"{name}_{k}_avg.png")
        (maps / video / f"{name}.exist.txt").symlink_to(real_clip / f"{name}.exist.txt")
    (data / "list").mkdir()
    (data / "list" / "test.txt").write_text("".join(f"/{video}/{name}.jpg\n" for name in frames))
    return data, maps


def env_importing(first: Path = REPO) -> dict[str, str]:
    """This process's environment with `first` ahead on PYTHONPATH: a Python started with it imports
    this checkout's roneld_eval (or what lies in `first`)."""
    return dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(first), os.environ.get("PYTHONPATH")])))


def write_culane_tree(root: Path, frames: dict[str, str], categories: dict[str, list[str]] | None = None,
                      list_text: str | None = None) -> Path:
    """A CULane root with the given relpath -> .lines.txt content (None: no file)."""
    for relpath, content in frames.items():
        path = root / (relpath.rsplit(".", 1)[0] + ".lines.txt")
        path.parent.mkdir(parents=True, exist_ok=True)
        if content is not None:
            path.write_text(content)
    (root / "list").mkdir(parents=True, exist_ok=True)
    (root / "list" / "test.txt").write_text(list_text if list_text is not None else "".join(f"/{r}\n" for r in frames))
    for number, (name, members) in enumerate((categories or {}).items()):
        split = root / "list" / "test_split"
        split.mkdir(exist_ok=True)
        (split / f"test{number}_{name}.txt").write_text("".join(f"{m} \n" for m in members))
    return root


def lane_map(height: int = 288, width: int = 800, xs=None, value: int = 220, sigma: float = 2.0) -> np.ndarray:
    """One (H, W) uint8 channel with a ridge at x = xs[row] (NaN rows empty)."""
    plane = np.zeros((height, width), np.float64)
    columns = np.arange(width)
    for row in range(height):
        x = xs[row]
        if np.isfinite(x):
            plane[row] = value * np.exp(-((columns - x) ** 2) / (2 * sigma**2))
    return np.rint(plane).astype(np.uint8)


def curving_frames(frames: int = 12, height: int = 288, width: int = 800) -> list[np.ndarray]:
    """SCNN-sized maps of two ego lanes bending right near the horizon, and an outer lane."""
    distance = (height - 1 - np.arange(height)).astype(np.float64)
    clip = []
    for frame in range(frames):
        maps = np.zeros((4, height, width), np.uint8)
        centre = width / 2 + 3 * frame
        for channel, side in ((1, -1), (2, 1)):
            xs = centre + side * (150 - distance) + 0.0035 * distance**2
            xs[: height // 4] = np.nan
            maps[channel] = lane_map(height, width, xs, value=200, sigma=3)
        xs = centre - 420 + 0.6 * distance + 0.0035 * distance**2
        xs[: height // 3] = np.nan
        maps[0] = lane_map(height, width, xs, value=120, sigma=3)
        clip.append(maps)
    return clip


@pytest.fixture(autouse=True, scope="session")
def _truth_cache(tmp_path_factory):
    """The ground truth the tests draw is cached in a folder of the session, not the user's (whose
    newest entries it would push out); commands the tests start in processes inherit it."""
    os.environ["RONELD_EVAL_TRUTH_CACHE"] = str(tmp_path_factory.mktemp("truth-cache"))


@pytest.fixture(scope="session")
def fixture_run(tmp_path_factory):
    """One run of the bundled CULane fixture with the ablation and lanes, shared by tests."""
    from roneld_eval import api

    out = tmp_path_factory.mktemp("fixture-run")
    config = api.default_config("culane").with_overrides(pft_ablation=True, save_lanes=True, workers=1)
    result = api.run(config, out, progress=False)
    return result, out


def interrupt_after(monkeypatch, finished: int, inside_kernel: bool = False):
    """Make the next run stop (as Ctrl-C) when it starts clip number `finished` + 1; with
    `inside_kernel`, as Ctrl-C landing inside a numba kernel comes out of it: a SystemError it caused."""
    from roneld_eval import evaluation

    original, calls = evaluation.evaluate_clip, []

    def interrupting(clip, context, *rest):
        calls.append(clip.clip_id)
        if len(calls) == finished + 1:
            if not inside_kernel:
                raise KeyboardInterrupt
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as error:
                raise SystemError("CPUDispatcher(<function row_argmax>) returned a result with an exception "
                                  "set") from error
        return original(clip, context, *rest)

    monkeypatch.setattr(evaluation.one_clip, "evaluate_clip", interrupting)
    return lambda: monkeypatch.setattr(evaluation.one_clip, "evaluate_clip", original)


@pytest.fixture(scope="module")
def culane_set(tmp_path_factory):
    """A generated CULane set of 5 clips of 6 frames with a detector's lane files (maps/): what
    the shard and cluster tests split and merge."""
    from click.testing import CliRunner

    from roneld_eval.cli import main

    out = tmp_path_factory.mktemp("lanes") / "set"
    result = CliRunner().invoke(main, ["synth", "--dataset", "culane", "--out", str(out), "--clips", "5", "--frames",
                                       "6", "--maps-format", "lanes"])
    assert result.exit_code == 0, result.output
    return out


def pytest_collection_modifyitems(items):
    # The long tests first: spread over pytest-xdist's workers (-n auto), the suite then ends with
    # short tests on every worker, not with one worker alone on a 40 s test while the others wait.
    items.sort(key=lambda item: item.get_closest_marker("long") is None)  # stable: the rest keep their order
