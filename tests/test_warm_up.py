"""Kernels compile before a run, never inside it; numba's cache lives outside the package.

After `kernels.warm_up()`, evaluating (RONELD with and without PFT, the baseline, every score)
must add no compiled signature to any numba kernel: otherwise the first frame that needs it
compiles inside the timed region. Checked on the real clip, the bundled fixtures and a synthetic
clip that enters RONELD's curve mode, on writable and read-only (memory-mapped .npy) maps.
No timings here.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO, curving_frames, env_importing
from test_run_integrity import alive, children_of, wait_for

import roneld_eval
from roneld_eval import api, kernels
from roneld_eval._numba_cache import cache_dir, in_cache
from roneld_eval.config import BaselineParams, EvalConfig, PaperMetricParams, RoneldParams
from roneld_eval.extract import RoneldTracker, baseline_lanes, curving_clip
from roneld_eval.geometry import MapGeometry
from roneld_eval.metrics.lane_iou_f1 import match_frame, official_masks
from roneld_eval.metrics.paper import ego_masks, side_ious
from roneld_eval.model import FrameMaps, Lane

PACKAGE = Path(roneld_eval.__file__).resolve().parent


def compiled() -> dict[str, set]:
    return {name: set(kernel.signatures) for name, kernel in kernels.dispatchers().items()}


def added_since(before: dict[str, set]) -> dict[str, list[str]]:
    """Signatures compiled since `before`, per kernel (empty when nothing compiled)."""
    return {name: [str(s) for s in signatures - before.get(name, set())]
            for name, signatures in compiled().items() if signatures - before.get(name, set())}


@pytest.fixture
def warm():
    kernels.warm_up()
    return compiled()


# ---- nothing compiles after warm_up --------------------------------------------------------------


def test_the_real_clip_compiles_nothing_after_warm_up(real_clip_tree, warm):
    data, maps = real_clip_tree
    config = EvalConfig.preset("scnn-culane").with_overrides(**{
        "dataset.data_root": str(data), "maps.root": str(maps), "maps.format": "scnn-png", "pft_ablation": True,
        "workers": 1})
    roneld_eval.evaluate(config, progress=False)
    assert added_since(warm) == {}


@pytest.mark.parametrize("dataset", ["culane", "tusimple"])
def test_the_bundled_fixtures_compile_nothing_after_warm_up(dataset, warm):
    config = api.with_fixture(api.default_config(dataset).with_overrides(pft_ablation=True, workers=1))
    roneld_eval.evaluate(config, progress=False)
    assert added_since(warm) == {}


def test_a_clip_in_curve_mode_compiles_nothing_after_warm_up(warm):
    geometry = MapGeometry(1640, 590, 800, 288)
    paper = PaperMetricParams()
    truth = [Lane(np.array([[500.0, 589], [700, 300]])), Lane(np.array([[1200.0, 589], [900, 300]]))]
    gt_masks = ego_masks(truth, geometry, paper, 0.5)
    official_truth = official_masks(truth, 1640, 590, 30)
    with_pft = RoneldTracker(RoneldParams(), geometry)
    without_pft = RoneldTracker(RoneldParams(), geometry, pft=False)
    modes = []
    for maps in curving_frames():
        for frame in (maps, read_only(maps)):
            lanes = with_pft(frame)
            modes.append(lanes.curve_mode)
            predictions = [
                [lanes.left, lanes.right],
                [without_pft(frame).left, without_pft(frame).right],
                baseline_lanes(FrameMaps(frame), BaselineParams(), geometry)[1:3],
            ]
            for active in predictions:
                side_ious(gt_masks, active, geometry, paper, spline=True)
                found = [lane for lane in active if lane is not None]
                match_frame(truth, found, 1640, 590, 30, gt_masks=official_truth,
                                      pred_masks=official_masks(found, 1640, 590, 30))
    assert modes[-1] and not modes[0], "the clip must enter curve mode (its spline path) part-way"
    assert added_since(warm) == {}


def read_only(maps: np.ndarray) -> np.ndarray:
    view = maps.view()
    view.flags.writeable = False
    return view


def test_the_warm_up_clip_reaches_curve_mode():
    tracker = RoneldTracker(RoneldParams())
    lanes = [tracker(maps) for maps in curving_clip()]
    assert lanes[-1].curve_mode and not lanes[0].curve_mode
    assert len(lanes[-1].left.points) > 2 and len(lanes[-1].right.points) > 2  # spline samples, not a line


def test_warm_up_leaves_the_curve_spline_to_the_first_curve():
    """scipy.interpolate (0.15 s, a third of a worker's warm-up) is imported at the first curve a
    clip draws, not in warm-up: most clips never reach curve mode. Its time is left out of that
    frame's (test_run.py)."""
    program = ("import sys\nfrom roneld_eval import kernels\nkernels.warm_up()\n"
               "print('scipy.interpolate' in sys.modules)")
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


def test_the_extractors_own_warm_up_stays_importable():
    from roneld_eval.extract import warm_up

    warm_up()
    warm_up(("baseline",))


# ---- kernels rewritten to compile faster give numpy's answers -------------------------------------


@pytest.mark.parametrize("seed", range(20))
def test_stable_argsort_is_numpys_stable_argsort(seed):
    """The insertion sort that replaced np.argsort(kind="mergesort") (seconds of compiling):
    ties keep their order, NaN sorts last, -0.0 equals 0.0."""
    from roneld_eval.extract import _kernels

    rng = np.random.default_rng(seed)
    keys = rng.choice([-1.5, -0.0, 0.0, 2.0, np.nan, np.inf, -np.inf, 7.25], size=int(rng.integers(0, 40)))
    keys = np.where(rng.random(keys.size) < 0.5, keys, rng.normal(size=keys.size))
    for kernel in (_kernels.stable_argsort, _kernels.stable_argsort.py_func):
        np.testing.assert_array_equal(kernel(keys), np.argsort(keys, kind="stable"))


# ---- prepare: what a run needs, when it is said --------------------------------------------------


def test_groups_follow_the_methods_and_the_dataset():
    from roneld_eval.benchmarks import benchmark_for
    from roneld_eval.config import EvalConfig
    from roneld_eval.extract.registry import methods_of

    def groups(methods, dataset):
        config = EvalConfig.preset(f"scnn-{dataset}").with_overrides(methods=methods)
        return kernels.groups_for(methods_of(config), benchmark_for(dataset))

    assert groups(["baseline", "roneld"], "culane") == ("baseline", "roneld", "official", "paper")
    assert groups(["roneld-nopft"], "tusimple") == ("roneld", "paper")
    # A plug-in brings no kernels of ours; the benchmark and the paper's protocol still do.
    plugin = EvalConfig.preset("scnn-culane").with_overrides(methods=["baseline"]).with_plugin("mine", "x:y")
    assert kernels.groups_for(methods_of(plugin), benchmark_for("culane")) == ("baseline", "official", "paper")
    # PNG maps are decoded by a kernel of their own; other formats need none.
    config = EvalConfig.preset("scnn-culane")
    assert kernels.groups_for(methods_of(config), benchmark_for("culane"), "scnn-png")[-1] == "maps"
    # LLAMAS's PNGs go through the same decoder: compiled (and announced) before the workers.
    assert kernels.groups_for(methods_of(config), benchmark_for("llamas"), "llamas-png")[-1] == "maps"
    assert "maps" not in kernels.groups_for(methods_of(config), benchmark_for("culane"), "npz")
    with pytest.raises(ValueError, match="unknown kernel groups"):
        kernels.warm_up(["roneld", "sideways"])


_CANVAS_COMPILED = """
from roneld_eval import api, evaluate
from roneld_eval.metrics import _kernels
from roneld_eval.metrics.raster import official_mask_set
from roneld_eval.model import Lane
for dataset in ("culane", "tusimple"):
    evaluate(api.with_fixture(api.default_config(dataset).with_overrides(pft_ablation=True, workers=1)),
             progress=False)
canvas = (_kernels.short_quad_extras, _kernels.official_lane_runs, _kernels.map_lane_runs)
print([len(kernel.signatures) for kernel in canvas])
comb = Lane.from_xy([100 + 60 * k for k in range(20)], [100, 200] * 10)  # rows of more runs than a row holds
official_mask_set([comb], 1640, 590, 2)
print([len(kernel.signatures) for kernel in canvas])
"""


def test_a_run_compiles_the_canvas_only_where_a_lane_needs_it(tmp_path):
    # About a fifth of a first run's compile: no lane of the fixtures or of real CULane labels needs it.
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", _CANVAS_COMPILED], env=env, capture_output=True, text=True,
                          timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == ["[0, 0, 0]", "[1, 1, 0]"]


_MAIN_PROCESS_KERNELS = """
import sys
from roneld_eval import api
from roneld_eval.maps._kernels import unfilter_grey
config = api.default_config("culane").with_overrides(**{
    "dataset.data_root": sys.argv[1], "maps.root": sys.argv[2], "maps.format": "scnn-png", "workers": 2})
api.run(config, out=sys.argv[3], progress=False)
print(len(unfilter_grey.signatures))
"""


def test_a_run_on_png_maps_decodes_them_in_the_workers_only(tmp_path):
    # The main process checks the first frame's map size from a PNG header: it loads no decoding
    # kernel, nor numba's machinery with it (0.3 s and 50 MB before the workers could start).
    from roneld_eval.benchmarks.culane.synth import synth_culane

    made = synth_culane(tmp_path / "set", clips=2, frames=3, maps_format="scnn-png")
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", _MAIN_PROCESS_KERNELS, str(made.data_root), str(made.maps_root),
                           str(tmp_path / "out")], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["0"]
    assert (tmp_path / "out" / "accuracy.csv").is_file()


def test_prepare_announces_compiling_only_when_something_is_missing(monkeypatch):
    said, compiled = [], []
    monkeypatch.setattr(kernels, "_compile_in_parallel",
                        lambda order, processes, announce, total: compiled.append((order, processes)))
    steps = kernels._steps(("roneld", "paper"))
    monkeypatch.setattr(kernels, "missing_steps", lambda needed: steps)
    kernels.prepare(announce=said.append, needed=("roneld", "paper"), processes=2)
    assert len(said) == 1 and said[0].startswith("compiling ") and " numba kernels for this installation in 2 " \
        "processes (once: later runs and installs of this version load them from the cache)" in said[0]
    assert " about " not in said[0]  # no duration it cannot keep
    assert compiled == [(kernels.in_order(steps), 2)]

    said.clear()
    monkeypatch.setattr(kernels, "missing_steps", lambda needed: [])
    kernels.prepare(announce=said.append)
    assert said == []


_COMPILE_WITH_PROGRESS = """
import sys
from roneld_eval import kernels
kernels.PROGRESS_EVERY_S = 0.2
kernels.prepare(announce=print, needed=("baseline",), processes=1)
print("missing", kernels.missing_steps(("baseline",)))
"""


def test_a_compile_says_how_far_it_is_and_a_copy_elsewhere_reuses_it(tmp_path):
    # The first run was silent for 95 s after promising 35; and every clone or virtual
    # environment of the same version compiled everything again.
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    first = subprocess.run([sys.executable, "-c", _COMPILE_WITH_PROGRESS], env=env, capture_output=True, text=True,
                           timeout=300, cwd=REPO)
    assert first.returncode == 0, first.stderr
    lines = first.stdout.splitlines()
    assert lines[0].startswith("compiling ") and "numba kernels for this installation in 1 process" in lines[0]
    progress = [line for line in lines if line.startswith("compiling kernels: ")]
    assert progress and all(" done, " in line for line in progress), lines
    total = int(lines[0].split()[1])
    assert lines[-2].startswith(f"compiling kernels: {total} of {total} done, ")  # the last line says it is over
    assert lines[-1] == "missing []"
    copy = tmp_path / "elsewhere"
    copy.mkdir()
    import shutil

    shutil.copytree(PACKAGE, copy / "roneld_eval", ignore=shutil.ignore_patterns("__pycache__"))
    again = subprocess.run([sys.executable, "-c", "import roneld_eval, sys; from roneld_eval import kernels; "
                            "print(roneld_eval.__file__); print(kernels.missing_steps(('baseline',)))"],
                           env=env, capture_output=True, text=True, timeout=120, cwd=copy)
    assert again.returncode == 0, again.stderr
    assert again.stdout.splitlines() == [str(copy / "roneld_eval" / "__init__.py"), "[]"]


def test_what_this_process_holds_counts_as_cached(warm):
    from roneld_eval.extract import _kernels

    kernel, signature = _kernels.ENTRY_SIGNATURES["roneld"][0]
    assert in_cache(kernel, signature) is True
    assert kernels.missing_steps() == []


def test_every_entry_is_compiled_by_one_step_and_callees_come_first():
    by_steps = [(kernel, signature) for step in kernels.STEPS if not step.callees_only
                for kernel, signature in kernels._step_entries(step)]
    entries = kernels._entries(kernels.GROUPS)
    assert sorted(map(repr, by_steps)) == sorted(map(repr, dict.fromkeys(entries)))  # each once, none left out
    assert all(kernels._step_entries(step) for step in kernels.STEPS)  # no step names a kernel it lacks
    for needed in (kernels.GROUPS, ("official",), ("baseline", "paper"), ("roneld",)):
        order = kernels.in_order(kernels._steps(needed))
        for position, step in enumerate(order):
            assert all(name in [earlier.name for earlier in order[:position]] for name in step.after)
    assert [step.name for step in kernels._steps(("roneld",))] == ["roneld"]
    assert "matching" not in [step.name for step in kernels._steps(("paper",))]  # official scores only


def test_a_step_of_callees_is_compiled_only_for_the_steps_that_call_them(monkeypatch):
    cached = {"lane sets": True, "lane runs": False, "lane pixels": False}

    def in_cache(kernel, signature):
        step = next(step for step in kernels.STEPS if kernel.__name__ in step.kernels)
        return cached.get(step.name, True)

    monkeypatch.setattr(kernels, "in_cache", in_cache)
    assert kernels.missing_steps(("official",)) == []  # lane_set_runs holds its callees' code
    cached["lane sets"] = False
    assert [step.name for step in kernels.missing_steps(("official",))] == ["lane runs", "lane pixels", "lane sets"]


def test_the_announced_count_is_of_the_kernels_compiled_not_the_callees_loaded(monkeypatch):
    # With the callees in the cache and their caller missing, 5 were announced where 2 compile.
    cached = {"lane sets": False}

    def in_cache(kernel, signature):
        step = next(step for step in kernels.STEPS if kernel.__name__ in step.kernels)
        return cached.get(step.name, True)

    monkeypatch.setattr(kernels, "in_cache", in_cache)
    totals, said = [], []
    monkeypatch.setattr(kernels, "_compile_in_parallel",
                        lambda order, processes, announce, total: totals.append(total))
    kernels.prepare(announce=said.append, needed=("official",), processes=1)
    callers = kernels._step_entries(kernels._STEP_NAMED["lane sets"])
    assert totals == [len(callers)] == [2] and said[0].startswith("compiling 2 numba kernels")


_ONE_PROCESS_DIES = """
import os, sys
from roneld_eval import kernels
kernels.PROGRESS_EVERY_S = 0.2
compile_step = kernels._compile_step


def dies_once(step, done=None):
    if step.name == "maps" and not os.path.exists(sys.argv[1]):
        open(sys.argv[1], "w").close()
        os._exit(9)  # as a kill -9 of this compiling process
    compile_step(step, done)


kernels._compile_step = dies_once  # the compiling processes are forked: they see it
kernels.prepare(announce=print, needed=("maps", "baseline"), processes=2)  # the two shortest steps
print("missing", [step.name for step in kernels.missing_steps(("maps", "baseline"))])
"""


def test_a_compiling_process_that_dies_hands_its_step_to_the_other(tmp_path):
    # One killed compiling process ended the healthy one too, and the rest compiled silently.
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", _ONE_PROCESS_DIES, str(tmp_path / "died")], env=env,
                          capture_output=True, text=True, timeout=300, cwd=REPO)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert (tmp_path / "died").exists()
    ended = lines.index("a compiling process ended (exit status 9): its work goes to the other")
    assert lines[-1] == "missing []"  # the other process compiled the dead one's step, here nothing
    assert any(line.startswith("compiling kernels: ") for line in lines[ended:]), lines  # still said


_INDEX_WITHOUT_CODE = """
import sys
from roneld_eval import kernels
if sys.argv[1] == "compile":
    kernels.prepare(needed=("baseline",), processes=1)
print([step.name for step in kernels.missing_steps(("baseline",))])
"""


def test_a_cache_index_whose_machine_code_was_deleted_counts_as_missing(tmp_path):
    # It was taken for present, and the run then compiled silently where the kernel was loaded.
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def missing(*args):
        done = subprocess.run([sys.executable, "-c", _INDEX_WITHOUT_CODE, *args], env=env, capture_output=True,
                              text=True, timeout=300, cwd=REPO)
        assert done.returncode == 0, done.stderr
        return done.stdout.strip()

    assert missing("compile") == "[]"
    code = list((tmp_path / "cache").rglob("*.nbc"))
    assert code and list((tmp_path / "cache").rglob("*.nbi"))
    for path in code:
        path.unlink()
    assert missing("look") == "['baseline']"


_LOAD_BASELINE = """
import numpy as np
from roneld_eval import kernels
kernels.warm_up(("baseline",))
from roneld_eval.extract import _kernels
print("loaded")
"""


def _load_baseline(cache: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", _LOAD_BASELINE], env={**os.environ, "NUMBA_CACHE_DIR": str(cache)},
                          capture_output=True, text=True, timeout=300, cwd=REPO)


@pytest.fixture(scope="module")
def baseline_cache(tmp_path_factory) -> Path:
    """A cache that holds the baseline's kernels alone, compiled in a process of its own."""
    cache = tmp_path_factory.mktemp("baseline-cache")
    assert _load_baseline(cache).returncode == 0
    return cache


# What each damage writes over the cache's code (.nbc) or index (.nbi) files.
_DAMAGES = {
    "code emptied": (".nbc", b""),
    "code overwritten": (".nbc", random.Random(7).randbytes(200)),
    # pickle's BINBYTES8 with a length above sys.maxsize: OverflowError, met once in CI's random bytes
    "code with an impossible length": (".nbc", b"\x80\x04\x8e" + b"\xff" * 8 + bytes(20)),
    "index emptied": (".nbi", b""),
}


@pytest.mark.parametrize("damage", list(_DAMAGES))
def test_a_damaged_cache_entry_is_compiled_again_not_an_error(tmp_path, damage, baseline_cache):
    # A truncated .nbc made every worker fail to start ('EOFError: Ran out of input'), and with
    # --workers 1 the run said only 'interrupted'.
    shutil.copytree(baseline_cache, tmp_path / "cache")

    def load():
        return _load_baseline(tmp_path / "cache")

    suffix, damaged = _DAMAGES[damage]
    files = list((tmp_path / "cache").rglob("*" + suffix))
    assert files
    for path in files:
        path.write_bytes(damaged)
    again = load()
    assert again.returncode == 0 and again.stdout.strip() == "loaded", again.stderr
    assert load().returncode == 0  # and written over: sound again


_CALLERS_COMPILED = """
from roneld_eval import kernels
from roneld_eval._numba_cache import compile_now
from roneld_eval.metrics import _kernels
for kernel, signature in _kernels.CALLEE_SIGNATURES:
    compile_now(kernel, signature)  # loaded from the cache, as a first run's callee steps leave them
for step in kernels.in_order(kernels._steps(("official", "paper"))):
    if set(step.after):  # the callers: compiled here, as one compiling process of prepare() does
        kernels._compile_step(step)
for kernel, signature in _kernels.CALLEE_SIGNATURES:
    print(kernel.__name__, len(kernel.signatures), tuple(signature) in kernel.signatures)
"""


def test_the_callees_compiled_first_are_those_their_callers_use(tmp_path, warm):
    # Listed with other argument types than lane_set_runs passes, they would be compiled twice.
    # In a copy of this session's cache that holds the listed callees alone, the callers and
    # every kernel between them and those callees are compiled, so each call is typed again: a
    # callee called with other types than listed then loads (or compiles) a second signature.
    from roneld_eval._numba_cache import kernels_digest
    from roneld_eval.metrics._kernels import CALLEE_SIGNATURES

    if cache_dir() is None:
        pytest.skip("numba has no cache folder here")
    folder = f"kernels-{kernels_digest()}"
    callees = tuple(f"{kernel.__module__.rsplit('.', 1)[-1]}.{kernel.__name__}-" for kernel, _ in CALLEE_SIGNATURES)

    def others(path, names):
        return [name for name in names if os.path.isfile(os.path.join(path, name)) and not name.startswith(callees)]

    shutil.copytree(cache_dir() / folder, tmp_path / "cache" / folder, ignore=others)
    kept = sorted(path.name for path in (tmp_path / "cache").rglob("*.nbi"))
    assert len(kept) == len(CALLEE_SIGNATURES), kept
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", _CALLERS_COMPILED], env=env, capture_output=True, text=True,
                          timeout=600, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:-1] == [f"{name} 1 True" for name in
                                             ("polyline_runs", "official_pixels", "map_spline_pixels")]


def test_every_kernel_is_listed():
    names = set(kernels.dispatchers())
    for module in ("extract", "metrics", "maps"):
        package = PACKAGE / module / "_kernels"
        files = sorted(package.glob("*.py")) if package.is_dir() else [PACKAGE / module / "_kernels.py"]
        source = "".join(path.read_text() for path in files)
        assert source.count("@cached_njit(") == sum(name.startswith(f"roneld_eval.{module}.") for name in names)


# ---- numba's cache lives outside the package ------------------------------------------------------

_CACHE_PATHS = """
import json, sys
if sys.argv[1] == "numba-first":
    import numba  # noqa: F401  (the user imported numba before us)
from roneld_eval import kernels
print(json.dumps({name: kernel._cache._cache_path for name, kernel in kernels.dispatchers().items()}))
"""


@pytest.mark.parametrize("order", ["numba-first", "roneld-first"])
def test_numba_caches_in_the_users_cache_folder(order, tmp_path):
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in [env.get("PYTHONPATH")] if p])
    done = subprocess.run([sys.executable, "-c", _CACHE_PATHS, order], env=env, capture_output=True, text=True,
                          check=True)
    paths = json.loads(done.stdout)
    assert len(paths) == len(kernels.dispatchers())
    for name, path in paths.items():
        assert Path(path).is_relative_to(tmp_path / "xdg" / "roneld-eval" / "numba"), (name, path)


def test_a_numba_cache_dir_the_user_set_is_kept(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in [env.get("PYTHONPATH")] if p])
    done = subprocess.run([sys.executable, "-c", _CACHE_PATHS, "roneld-first"], env=env, capture_output=True,
                          text=True, check=True)
    assert all(Path(p).is_relative_to(tmp_path / "mine") for p in json.loads(done.stdout).values())


def test_a_numba_cache_dir_that_cannot_be_written_is_passed_over(tmp_path):
    # numba fell back to the package's own __pycache__ folders for a NUMBA_CACHE_DIR it could not use.
    (tmp_path / "a-file").write_text("")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "a-file"), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in [env.get("PYTHONPATH")] if p])
    done = subprocess.run([sys.executable, "-c", _CACHE_PATHS, "roneld-first"], env=env, capture_output=True,
                          text=True, check=True)
    paths = json.loads(done.stdout).values()
    assert paths and all(Path(p).is_relative_to(tmp_path / "xdg" / "roneld-eval" / "numba") for p in paths)


def test_this_process_caches_outside_the_package():
    folder = cache_dir()
    assert folder is not None and not folder.resolve().is_relative_to(PACKAGE)
    for name, kernel in kernels.dispatchers().items():
        assert not Path(kernel._cache._cache_path).resolve().is_relative_to(PACKAGE), name


_KILLED_WHILE_COMPILING = """
from roneld_eval import kernels
kernels.prepare(announce=print, needed=("official", "roneld"), processes=1)  # 40 s or more
"""


@pytest.mark.skipif(sys.platform != "linux", reason="the parent-death signal is Linux's")
def test_a_first_run_killed_while_compiling_leaves_no_compiling_process(tmp_path):
    # Compiling processes used to go on for tens of seconds after a kill -9 of the command.
    import time

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    process = subprocess.Popen([sys.executable, "-c", _KILLED_WHILE_COMPILING], env=env, cwd=REPO,
                               stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None and process.stdout.readline().startswith("compiling ")
        assert wait_for(lambda: children_of(process.pid), 30), "no compiling process was started"
        children = children_of(process.pid)
        time.sleep(0.5)  # inside numba's compile by now
        process.kill()
        process.wait(timeout=30)
        wait_for(lambda: not any(alive(child) for child in children), 5)  # what is left compiles for much longer
        assert [child for child in children if alive(child)] == []
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()



@pytest.mark.parametrize("number", [2, 15, 1])  # SIGINT, SIGTERM, SIGHUP
def test_a_signal_during_the_warm_up_waits_for_its_end(monkeypatch, number):
    # Raised inside numba's loading or a kernel's first call, the interruption left half-made
    # objects: the next call into them crashed the process (SIGSEGV, 2 of 100 `score openlane`
    # signalled in their last second) or llvmlite freed one twice at exit (SIGABRT).
    from roneld_eval.metrics import raster
    from roneld_eval.signals import Terminated, terminate_as_interrupt

    loaded, drawn = [], []
    load, draw = raster.compile_now, raster.official_mask_set

    def signalled(kernel, signature):
        loaded.append(kernel)
        if len(loaded) == 1:
            os.kill(os.getpid(), number)
        return load(kernel, signature)

    monkeypatch.setattr(raster, "compile_now", signalled)
    monkeypatch.setattr(raster, "official_mask_set", lambda *args: drawn.append(1) or draw(*args))
    expected = sum(len(raster._kernels.ENTRY_SIGNATURES[group]) for group in ("tables", "official"))
    with pytest.raises(KeyboardInterrupt) as caught, terminate_as_interrupt():
        kernels.warm_up(("official",))
    assert len(loaded) == expected and drawn, "interrupted before every kernel was loaded and run once"
    assert isinstance(caught.value, Terminated) == (number != 2)
