"""Show that a change of the code changed nothing a user sees: every file and every console line
that roneld-eval's commands write, the same at two commits, byte for byte (issue 48: a refactor
must leave every output as it was).

    .venv/bin/python scripts/same_outputs.py                      # HEAD~1 against HEAD
    .venv/bin/python scripts/same_outputs.py --old main --new WORKTREE --keep /tmp/same

Each side (--old, --new: a commit, or WORKTREE for the working tree as it is) is checked out with
`git worktree add --detach` into a temporary folder (removed at the end, on Ctrl-C too) and run
by this interpreter with PYTHONPATH=<side's site folder>:<checkout>, so no installation per side is
needed. The site folder holds what an installation would add: a `roneld_eval-*.dist-info` with the
checkout's own entry points (pyproject.toml), found by importlib.metadata before the installed
distribution's, and a sitecustomize.py that drops an editable install's import hook (it would
import `roneld_eval.configs` from the installed tree, not the checkout). Each side is checked
first: roneld_eval, its presets and every benchmark's module come from its checkout, and
`score --help` lists its benchmarks.

Both sides run the same commands (the *_commands functions below: the help texts, `synth` of every benchmark,
`score` of each synthetic set with several methods, an IoU grid, shards 1/2 and 2/2 and `merge`,
`run` on the bundled fixture and on the CULane, TuSimple, VIL-100 and LLAMAS sets, `compare`,
`show` and `replay`), each into its own folder, with fixed seeds and PYTHONHASHSEED. The synthetic
sets are made once, by the old side's `synth`, and both sides read that copy; the new side's
`synth` output is compared with the old side's like any other. Every file (and each command's
stdout, stderr and exit status) is then compared after the side's own folders in it are replaced
by a placeholder and the clock times in it are masked (MASKS below, each with its reason).

Prints one line per command and `N commands, M files compared, all identical`; exits 1 on any
difference (or a side that cannot be set up). --keep DIR keeps the outputs (DIR/old, DIR/new) and
the synthetic sets (DIR/inputs). Standard library only, plus OpenCV (a dependency of the project)
to read `replay`'s video.
"""

from __future__ import annotations

import argparse
import fnmatch
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the project depends on tomli there
    import tomli as tomllib  # type: ignore[no-redef]

WORKTREE = "WORKTREE"
BENCHMARKS = ("culane", "tusimple", "vil100", "openlane", "curvelanes", "llamas")
WORKERS = "2"


# ---------------------------------------------------------------------------------------------
# The commands: `python -m roneld_eval ARGS` with {out} (this command's folder), {outs} (the
# side's folder of command outputs: other commands' results) and {in} (the synthetic sets).


@dataclass(frozen=True)
class Command:
    slug: str  # its folder under OUT and its console files' name
    args: tuple[str, ...]
    makes_folder: bool = False  # {out} is created first (the command writes a file into it)


def command(slug: str, *args: str, makes_folder: bool = False) -> Command:
    return Command(slug, tuple(args), makes_folder)


def help_commands() -> list[Command]:
    groups = [(), ("run",), ("synth",), ("score",), ("merge",), ("compare",), ("show",), ("replay",)]
    groups += [("score", name) for name in BENCHMARKS]
    return [command("help-" + "-".join(group or ("main",)), *group, "--help") for group in groups] + [
        command("version", "--version")]


# name, benchmark, clips, seed, further synth options: the sets every later command reads from
# {in}/NAME. The same benchmark and seed give the same labels in any maps format (but TuSimple's,
# whose lanes come in another order: each of its sets is scored against its own labels).
SETS = (
    ("culane", "culane", "2", "1", ()),
    ("culane-png", "culane", "2", "1", ("--maps-format", "scnn-png")),
    ("culane-lanes", "culane", "2", "1", ("--maps-format", "lanes")),
    ("tusimple", "tusimple", "2", "2", ()),
    ("tusimple-lanes", "tusimple", "2", "2", ("--maps-format", "lanes")),
    ("vil100", "vil100", "2", "3", ("--frames", "10")),
    ("vil100-lanes", "vil100", "2", "3", ("--frames", "10", "--maps-format", "lanes")),
    ("openlane", "openlane", "2", "4", ()),
    ("curvelanes", "curvelanes", "4", "5", ()),
    ("llamas", "llamas", "2", "6", ()),
    ("llamas-png", "llamas", "2", "6", ("--maps-format", "llamas-png")),
)


def synth_commands() -> list[Command]:
    return [command(f"synth-{name}", "synth", "--dataset", benchmark, "--clips", clips, "--seed", seed, *extra,
                    "--out", "{out}")
            for name, benchmark, clips, seed, extra in SETS]


def sharded(slug: str, *args: str, whole: bool = True) -> list[Command]:
    """The command whole (unless not `whole`), as shards 1/2 and 2/2, and the shards merged."""
    parts = [command(f"{slug}-shard-{k}", *args, "--shard", f"{k}/2", "--out", "{out}") for k in (1, 2)]
    merge = command(f"{slug}-merged", "merge", *(f"{{outs}}/{part.slug}" for part in parts), "--out", "{out}")
    return [command(slug, *args, "--out", "{out}")] * whole + [*parts, merge]


def score_commands() -> list[Command]:
    w = ("--workers", WORKERS)
    culane = ("score", "culane", "--data-root", "{in}/culane/data", "--pred-root", "detector={in}/culane-lanes/maps",
              "--pred-root", "truth={in}/culane/data", "--iou", "0.3:0.5:0.1", *w)
    tusimple = ("score", "tusimple", "--labels", "{in}/tusimple-lanes/data/test_label.json",
                "--pred", "{in}/tusimple-predictions/detector.json",
                "--pred", "truth={in}/tusimple-lanes/data/test_label.json")
    vil100 = ("score", "vil100", "--labels", "{in}/vil100/data/anno_txt",
              "--pred-root", "detector={in}/vil100-lanes/maps", "--pred-root", "truth={in}/vil100/data/anno_txt",
              "--sizes", "{in}/vil100/data/sizes.json",
              "--iou", "0.5:0.8:0.1", *w)
    openlane = ("score", "openlane", "--labels", "{in}/openlane/labels", "--pred-root", "{in}/openlane/predictions",
                "--pred-root", "truth={in}/openlane/labels", "--iou", "0.3,0.5", *w)
    curvelanes = ("score", "curvelanes", "--labels", "{in}/curvelanes/labels",
                  "--pred-root", "detector={in}/curvelanes/predictions", "--pred-root", "truth={in}/curvelanes/labels",
                  "--image-root", "{in}/curvelanes/images", "--best-of", "0.3,0.5,0.7", *w)
    llamas = ("score", "llamas", "--labels", "{in}/llamas/labels", "--pred-root", "detector={in}/llamas/predictions",
              "--maps", "segmentation={in}/llamas-png/predictions", "--iou", "0.5:0.95:0.15", *w)
    return [
        *sharded("score-culane", *culane),
        command("score-culane-clrnet", "score", "culane", "--data-root", "{in}/culane/data",
                "--pred-root", "{in}/culane-lanes/maps", "--preset", "clrnet", *w, "--out", "{out}"),
        command("score-culane-sweep", "score", "culane", "--data-root", "{in}/culane/data",
                "--pred-root", "{in}/sweep/epoch_*/lines", "--preset", "clrnet", *w, "--out", "{out}"),
        command("score-culane-sweep-list", "score", "culane", "--data-root", "{in}/culane/data",
                "--pred-roots-from", "{in}/sweep/checkpoints.txt", "--preset", "clrnet", *w, "--out", "{out}"),
        command("compare-sweeps", "compare", "{outs}/score-culane-sweep", "{outs}/score-culane-sweep-list",
                "--label", "{outs}/score-culane-sweep-list=from-list", "--out", "{out}"),
        *sharded("score-tusimple", *tusimple),
        *sharded("score-vil100", *vil100),
        command("score-vil100-one-threshold", *vil100[:-4], "--iou", "0.5", "--no-temporal", *w, "--out", "{out}"),
        *sharded("score-openlane", *openlane),
        command("score-openlane-any-category", *openlane, "--any-category", "--out", "{out}"),
        *sharded("score-curvelanes", *curvelanes),
        *sharded("score-llamas", *llamas),
    ]


def run_commands() -> list[Command]:
    w = ("--workers", WORKERS)
    culane = ("run", "--dataset", "culane", "--data-root", "{in}/culane/data", "--maps-root", "{in}/culane/maps",
              "--pft-ablation", "--save-lanes", *w)
    clip = "driver_100_30frame/05181432_0203.MP4"
    return [
        command("run-fixture", "run", "--pft-ablation", "--overlays", "2", *w, "--out", "{out}"),
        command("run-fixture-no-timings", "run", "--pft-ablation", "--no-timings", *w, "--out", "{out}"),
        command("run-culane", *culane, "--overlays", "2", "--out", "{out}"),
        *sharded("run-culane-parts", *culane, whole=False),  # the whole is run-culane, with --overlays too
        command("run-culane-png", "run", "--config", "scnn-culane", "--data-root", "{in}/culane-png/data",
                "--maps-root", "{in}/culane-png/maps", "--maps-format", "scnn-png", "--pft-ablation",
                "--set", "model=ENet-SAD", "--set", "baseline.threshold=0.5", *w, "--out", "{out}"),
        command("run-culane-lanes", "run", "--data-root", "{in}/culane-lanes/data", "--maps-root",
                "{in}/culane-lanes/maps", "--maps-format", "lanes", "--set", "model=CLRNet", "--save-lanes", *w,
                "--out", "{out}"),
        command("run-tusimple", "run", "--dataset", "tusimple", "--data-root", "{in}/tusimple/data",
                "--maps-root", "{in}/tusimple/maps", "--pft-ablation", "--save-lanes", *w, "--out", "{out}"),
        command("run-vil100", "run", "--dataset", "vil100", "--data-root", "{in}/vil100/data",
                "--maps-root", "{in}/vil100/maps", "--maps-format", "npy", "--pft-ablation", "--save-lanes", *w,
                "--out", "{out}"),
        command("run-llamas", "run", "--dataset", "llamas", "--data-root", "{in}/llamas-png/labels",
                "--maps-root", "{in}/llamas-png/predictions", "--maps-format", "llamas-png", "--pft-ablation",
                "--save-lanes", *w, "--out", "{out}"),
        command("compare-runs", "compare", "{outs}/run-culane", "{outs}/run-culane-png", "{outs}/run-tusimple",
                "{outs}/run-vil100", "{outs}/run-llamas", "--pair", "{outs}/run-culane,{outs}/run-culane-png",
                "--out", "{out}"),
        command("show-culane", "show", "--run", "{outs}/run-culane", "--worst", "2", "--out", "{out}"),
        command("replay-culane", "replay", "--dataset", "culane", "--data-root", "{in}/culane/data",
                "--maps-root", "{in}/culane/maps", "--clip", clip, "--quiet", "--video", "{out}/replay.mp4",
                makes_folder=True),
    ]


def prepare_inputs(outs: Path, inputs: Path) -> None:
    """{in}: a copy of the old side's synthetic sets, and a checkpoint sweep made of two of them."""
    for name, *_ in SETS:
        shutil.copytree(outs / f"synth-{name}", inputs / name)
    sweep = inputs / "sweep"
    for epoch, source in (("epoch_2", inputs / "culane-lanes" / "maps"), ("epoch_10", inputs / "culane" / "data")):
        shutil.copytree(source, sweep / epoch / "lines", ignore=lambda folder, names: [
            n for n in names if not n.endswith(".lines.txt") and not (Path(folder) / n).is_dir()])
    (sweep / "checkpoints.txt").write_text("epoch_2/lines\nepoch_10/lines\n")
    # TuSimple's detector file holds every frame of a clip (as `run --maps-format lanes` reads it);
    # `score tusimple` takes the labelled frames only
    every_frame = (inputs / "tusimple-lanes" / "maps" / "predictions.json").read_text().splitlines(keepends=True)
    (inputs / "tusimple-predictions").mkdir()
    (inputs / "tusimple-predictions" / "detector.json").write_text(
        "".join(line for line in every_frame if json.loads(line)["raw_file"].endswith("/20.jpg")))


# ---------------------------------------------------------------------------------------------
# Masks: what holds clock times, made the same on both sides before comparing.


def mask_csv_ms_columns(text: str) -> str:
    """A CSV's values in columns named *_ms (milliseconds measured) become 'ms', the rest of the
    text as it is (a line with quotes is left whole: a difference in it is shown, not hidden)."""
    lines = text.split("\n")
    timed = {k for k, name in enumerate(lines[0].split(",")) if name.endswith("_ms")}
    return "\n".join([lines[0]] + [line if '"' in line else ",".join(
        "ms" if k in timed and cell else cell for k, cell in enumerate(line.split(","))) for line in lines[1:]])


def mask_json_values(*keys: str) -> Callable[[str], str]:
    """A JSON file's values (whole: a number, a string, a list, an object) under the keys that
    match these regular expressions become "masked"; every other byte is kept."""
    key = re.compile(r'(?<!\\)"(?:' + "|".join(keys) + r')"\s*:\s*')
    decoder = json.JSONDecoder()

    def mask(text: str) -> str:
        pieces, done = [], 0
        for match in key.finditer(text):
            if match.start() < done:  # inside a value masked already
                continue
            _, end = decoder.raw_decode(text, match.end())
            pieces += [text[done:match.end()], '"masked"']
            done = end
        return "".join(pieces) + text[done:]

    return mask


def mask_table_ms_columns(text: str) -> str:
    """Each number in a Markdown table's columns headed '... (ms)' becomes 'ms'."""
    lines = []
    timed: set[int] = set()
    for line in text.split("\n"):
        cells = line.split("|")
        if not line.startswith("|"):
            timed = set()
        elif any("(ms)" in cell for cell in cells):
            timed = {k for k, cell in enumerate(cells) if "(ms)" in cell}
        else:
            line = "|".join(re.sub(r"\d+\.\d+", "ms", cell) if k in timed else cell for k, cell in enumerate(cells))
        lines.append(line)
    return "\n".join(lines)


def mask_table_numbers(text: str) -> str:
    """Every decimal number in the rows of a Markdown or LaTeX table becomes 'ms' (compare's
    Table V, whose every number is a time; its LaTeX header does not say ms)."""
    return "\n".join(re.sub(r"\d+\.\d+", "ms", line) if line.startswith("|") or "&" in line else line
                     for line in text.split("\n"))


def mask_html_runtime(text: str) -> str:
    """report.html: the numbers of its runtime table's (ms) columns, and the note on a mean above
    its 95th percentile."""
    text = SLOW_FRAMES.sub("", text)

    def table(match: re.Match) -> str:
        heads = re.findall(r"<th>(.*?)</th>", match.group(0))
        timed = {k for k, head in enumerate(heads) if "(ms)" in head}
        if not timed:
            return match.group(0)

        def row(row_match: re.Match) -> str:
            cells = re.findall(r"<td>(.*?)</td>", row_match.group(0))
            masked = ("ms" if k in timed else cell for k, cell in enumerate(cells))
            return "<tr>" + "".join(f"<td>{cell}</td>" for cell in masked) + "</tr>"

        return re.sub(r"<tr>(?:<td>.*?</td>)+</tr>", row, match.group(0))

    return re.sub(r"<table>.*?</table>", table, text, flags=re.S)


# The note runtime tables add when a mean is above its 95th percentile (a frame slowed by the machine)
SLOW_FRAMES = re.compile(r"\s*A mean above its 95th percentile \([^)]*\):[^.]*\.")


def mask_runtime_md(text: str) -> str:
    """runtime.md ends in a newline without that note, and in the note without it."""
    return mask_table_ms_columns(SLOW_FRAMES.sub("", text)).rstrip("\n")


def mask_console(text: str) -> str:
    """Console lines: run's wall time, replay's latency, and numba's compiling messages (they
    depend on the state of numba's cache, shared by both sides, not on the code's results)."""
    text = re.sub(r"(ego lanes); \d+(\.\d+)? s$", r"\1; TIME s", text, flags=re.M)
    text = re.sub(r"^update per frame: .*$", "update per frame: TIME", text, flags=re.M)
    text = re.sub(r"^(compiling \d+ numba kernels|compiling kernels:|a compiling process ended).*\n", "", text,
                  flags=re.M)
    return SLOW_FRAMES.sub("", text)


def video_frames(path: Path) -> str:
    """replay's MP4 decoded: frame count and size, and a digest of each frame's pixels above its
    caption bar (the bottom 48 rows: one caption line, overlays.CAPTION_LINE 36 + 12)."""
    import cv2

    capture = cv2.VideoCapture(str(path))
    digests = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        digests.append(f"{frame.shape} {hashlib.sha256(frame[:-48].tobytes()).hexdigest()}")
    capture.release()
    return f"{len(digests)} frames\n" + "\n".join(digests)


@dataclass(frozen=True)
class Mask:
    pattern: str  # fnmatch pattern of the path relative to the side's folder
    reason: str
    text: Callable[[str], str] | None = None  # the file's text as compared
    read: Callable[[Path], str] | None = None  # or what is compared in place of the file's bytes


MASKS = (
    Mask("out/*/runtime.csv", "mean_ms, median_ms, p95_ms: milliseconds per frame measured on this machine "
         "(method and frames compared)", text=mask_csv_ms_columns),
    Mask("out/*/runtime.md", "the same times in its (ms) columns, and the note on a mean above its p95 drawn "
         "from them", text=mask_runtime_md),
    Mask("out/*/report.html", "its runtime table's (ms) columns and that note", text=mask_html_runtime),
    Mask("out/run-*/summary.json", "wall_time_s: the run's wall-clock time", text=mask_json_values("wall_time_s")),
    Mask("out/run-*-shard-*/part.json", "a run part's wall_time_s, the SHA-256 of its clips/*.json (which hold "
         "timings) and its own digest (over those); config.toml's digest is compared",
         text=mask_json_values("wall_time_s", "digest", r"clips/\d+\.json")),
    Mask("out/run-*-shard-*/clips/*.json", "extract_ms, load_ms: each frame's measured extraction and map "
         "loading times", text=mask_json_values("extract_ms", "load_ms")),
    Mask("out/compare-*/table_runtime.*", "Table V: every number is a mean ms per frame that a run measured",
         text=mask_table_numbers),
    Mask("out/replay-*/replay.mp4", "each frame's caption shows the tracker's measured latency (update p50): "
         "compared as the decoded frames' count, size and pixels above the caption bar", read=video_frames),
    Mask("console/*.out", "run's wall time, replay's latency, numba's compiling messages", text=mask_console),
    Mask("console/*.err", "the same, on stderr", text=mask_console),
)


# ---------------------------------------------------------------------------------------------
# A side: a checkout, its site folder and the environment that imports it.


@dataclass
class Side:
    name: str  # old, new
    rev: str  # as given
    commit: str  # its hash, or WORKTREE
    root: Path  # the side's folder: out/, console/, site/, cache/ (and its checkout, src/)
    checkout: Path
    temporary_checkout: bool
    env: dict[str, str] | None = None

    @property
    def outs(self) -> Path:
        return self.root / "out"


def git(repo: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True).stdout.strip()


def check_out(name: str, rev: str, repo: Path, work: Path) -> Side:
    """The side's folder, with the commit checked out in it (or the working tree itself)."""
    root = work / name
    root.mkdir()
    if rev == WORKTREE:
        return Side(name, rev, WORKTREE, root, repo, False)
    commit = git(repo, "rev-parse", "--verify", f"{rev}^{{commit}}")
    git(repo, "worktree", "add", "--detach", str(root / "src"), commit)
    return Side(name, rev, commit, root, root / "src", True)


def write_site(side: Side) -> None:
    """The side's site folder: a dist-info with its checkout's entry points, and the sitecustomize
    that keeps an editable install of roneld-eval out of its imports."""
    project = tomllib.loads((side.checkout / "pyproject.toml").read_text())["project"]
    groups = dict(project.get("entry-points", {}))
    if "scripts" in project:
        groups["console_scripts"] = project["scripts"]
    site = side.root / "site"
    dist_info = site / f"roneld_eval-{project['version']}.dist-info"
    dist_info.mkdir(parents=True)
    (dist_info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    (dist_info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()) + "\n" for group, points in groups.items()))
    (site / "sitecustomize.py").write_text(
        '"""Written by same_outputs.py: roneld_eval is imported from the checkout on PYTHONPATH alone, not through\n'
        'an editable install\'s import hook (which maps roneld_eval.configs to the installed tree)."""\n'
        "import sys\n\n"
        "sys.meta_path[:] = [f for f in sys.meta_path if not (getattr(f, '__module__', '').startswith('__editable__')\n"
        "                                                     and 'roneld_eval' in getattr(f, '__module__', ''))]\n")
    side.env = {**os.environ, "PYTHONPATH": f"{site}{os.pathsep}{side.checkout}", "PYTHONHASHSEED": "0",
                "RONELD_EVAL_TRUTH_CACHE": str(side.root / "cache"), "COLUMNS": "80"}


def remove_checkout(side: Side, repo: Path) -> None:
    if side.temporary_checkout:
        subprocess.run(["git", "-C", str(repo), "worktree", "remove", "--force", str(side.checkout)],
                       capture_output=True)


PROBE = """
import importlib.metadata, importlib.util, json, sys
import roneld_eval
from roneld_eval import benchmarks
configs = importlib.util.find_spec("roneld_eval.configs")
points = {p.name: p for p in importlib.metadata.entry_points(group="roneld_eval.benchmarks")}
for name in benchmarks.names():
    benchmarks.benchmark_for(name)
modules = {n: getattr(m, "__file__", None) for n, m in sys.modules.items() if n.split(".")[0] == "roneld_eval"}
dists = sorted({str(p.dist.locate_file("")) for p in points.values()})
print(json.dumps({"file": roneld_eval.__file__, "configs": configs and configs.origin, "modules": modules,
                  "names": list(benchmarks.names()), "dists": dists}))
"""


def check_side(side: Side) -> list[str]:
    """Problems with the side's imports: none when roneld_eval, its presets and every benchmark
    come from its checkout, its entry points from its site folder, and `score --help` lists them."""
    probe = subprocess.run([sys.executable, "-c", PROBE], env=side.env, cwd=side.root, capture_output=True, text=True)
    if probe.returncode != 0:
        return [f"cannot import roneld_eval from {side.checkout}:\n{probe.stderr}"]
    found = json.loads(probe.stdout)
    print(f"{side.name}: {side.rev} ({side.commit[:12]}): roneld_eval from {found['file']}")
    inside = str(side.checkout.resolve()) + os.sep
    problems = [f"{name} imported from {file}" for name, file in found["modules"].items()
                if file is not None and not str(Path(file).resolve()).startswith(inside)]
    if found["configs"] is not None and not str(Path(found["configs"]).resolve()).startswith(inside):
        problems.append(f"roneld_eval.configs found at {found['configs']}")
    if found["dists"] != [str(side.root / "site")]:
        problems.append(f"benchmark entry points read from {found['dists']}")
    listing = subprocess.run([sys.executable, "-m", "roneld_eval", "score", "--help"], env=side.env, cwd=side.root,
                             capture_output=True, text=True)
    listed = [name for name in found["names"] if re.search(rf"^\s+{name}\s+built in$", listing.stdout, re.M)]
    if listing.returncode != 0 or listed != found["names"]:
        problems.append(f"score --help lists {listed} of {found['names']}:\n{listing.stdout}{listing.stderr}")
    missing = set(BENCHMARKS) ^ set(found["names"])
    if missing:
        print(f"{side.name}: note: benchmarks registered and exercised differ: {sorted(missing)}")
    return problems


def run_command(side: Side, cmd: Command, inputs: Path) -> tuple[int, float]:
    """Runs one command on a side: its output in OUT/<slug>, its console in console/<slug>.*"""
    out = side.outs / cmd.slug
    if cmd.makes_folder:
        out.mkdir(parents=True)
    args = [arg.format(out=out, outs=side.outs, **{"in": inputs}) for arg in cmd.args]
    console = side.root / "console"
    console.mkdir(exist_ok=True)
    started = time.monotonic()
    with open(console / f"{cmd.slug}.out", "wb") as stdout, open(console / f"{cmd.slug}.err", "wb") as stderr:
        status = subprocess.run([sys.executable, "-m", "roneld_eval", *args], env=side.env, cwd=side.root,
                                stdout=stdout, stderr=stderr, stdin=subprocess.DEVNULL).returncode
    (console / f"{cmd.slug}.exit").write_text(f"{status}\n")
    return status, time.monotonic() - started


def run_all(side: Side, commands: list[Command], inputs: Path, done: int, total: int) -> int:
    for cmd in commands:
        done += 1
        status, seconds = run_command(side, cmd, inputs)
        failed = f"  EXIT STATUS {status}" if status else ""
        print(f"[{side.name} {done}/{total}] {cmd.slug} {seconds:.1f} s{failed}", flush=True)
    return done


# ---------------------------------------------------------------------------------------------
# Comparing the two sides.


def normalised(side: Side, relative: str) -> bytes:
    """A file of the side as compared: its own folders replaced by placeholders, clock times masked."""
    path = side.root / relative
    mask = next((m for m in MASKS if fnmatch.fnmatch(relative, m.pattern)), None)
    if mask is not None and mask.read is not None:
        return mask.read(path).encode()
    data = path.read_bytes()
    for folder, placeholder in ((side.checkout, b"<CHECKOUT>"), (side.root, b"<SIDE>")):
        for form in {str(folder), str(folder.resolve())}:
            data = data.replace(form.encode(), placeholder)
    if mask is not None and mask.text is not None:
        data = mask.text(data.decode()).encode()
    return data


def files_of(side: Side, cmd: Command) -> set[str]:
    out = side.outs / cmd.slug
    found = {f"console/{cmd.slug}.{kind}" for kind in ("out", "err", "exit")}
    if out.is_dir():
        found |= {str(p.relative_to(side.root)) for p in out.rglob("*") if p.is_file() or p.is_symlink()}
    return found


def first_difference(old: bytes, new: bytes) -> str:
    try:
        old_lines, new_lines = old.decode().split("\n"), new.decode().split("\n")
    except UnicodeDecodeError:
        return f"binary, {len(old)} and {len(new)} bytes"
    for number, (a, b) in enumerate(zip(old_lines, new_lines), 1):
        if a != b:
            return f"line {number}: old {a[:160]!r}, new {b[:160]!r}"
    return f"{len(old_lines)} and {len(new_lines)} lines"


def compare_command(old: Side, new: Side, cmd: Command) -> tuple[int, list[str]]:
    """How many files were compared, and what differs."""
    old_files, new_files = files_of(old, cmd), files_of(new, cmd)
    problems = [f"only in old: {f}" for f in sorted(old_files - new_files)]
    problems += [f"only in new: {f}" for f in sorted(new_files - old_files)]
    for relative in sorted(old_files & new_files):
        a, b = normalised(old, relative), normalised(new, relative)
        if a != b:
            problems.append(f"differs: {relative} ({first_difference(a, b)})")
    return len(old_files | new_files), problems


def exit_status(side: Side, cmd: Command) -> int:
    return int((side.root / "console" / f"{cmd.slug}.exit").read_text())


def report(old: Side, new: Side, commands: list[Command]) -> bool:
    """One line per command (and one per difference), then the tally; True when all is the same."""
    print("\nmasked before comparing (clock times):")
    for mask in MASKS:
        print(f"  {mask.pattern}: {mask.reason}")
    print()
    files = 0
    differing = failed = 0
    for cmd in commands:
        count, problems = compare_command(old, new, cmd)
        files += count
        statuses = {exit_status(old, cmd), exit_status(new, cmd)}
        if problems:
            differing += 1
            print(f"DIFFERENT  {cmd.slug}")
            for problem in problems:
                print(f"    {problem}")
        elif statuses != {0}:
            failed += 1  # the same failure on both sides proves nothing about the outputs
            print(f"FAILED     {cmd.slug}: exit status {statuses.pop()} on both sides (see console/{cmd.slug}.err)")
        else:
            print(f"identical  {cmd.slug} ({count} files)")
    if differing or failed:
        print(f"\n{len(commands)} commands, {files} files compared: {differing} differ, {failed} failed on both sides")
    else:
        print(f"\n{len(commands)} commands, {files} files compared, all identical")
    return differing == failed == 0


# ---------------------------------------------------------------------------------------------


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--old", default="HEAD~1", help="commit before the change (default HEAD~1)")
    parser.add_argument("--new", default="HEAD", help=f"commit after it, or {WORKTREE} (default HEAD)")
    parser.add_argument("--repo", type=Path, default=Path(__file__).resolve().parent,
                        help="the git repository (default: this script's)")
    parser.add_argument("--keep", type=Path, help="keep the outputs in this new folder")
    return parser.parse_args()


def on_signal(signum: int, _frame) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def main() -> int:
    args = parse_args()
    repo = Path(git(args.repo, "rev-parse", "--show-toplevel"))
    if args.keep is not None and args.keep.exists():
        sys.exit(f"error: --keep {args.keep}: exists already (give a new folder)")
    work = args.keep.resolve() if args.keep else Path(tempfile.mkdtemp(prefix="same-outputs-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"working in {work}", flush=True)
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGHUP, on_signal)
    started = time.monotonic()
    sides: list[Side] = []
    try:
        for name, rev in (("old", args.old), ("new", args.new)):
            sides.append(check_out(name, rev, repo, work))
            write_site(sides[-1])
        old, new = sides
        problems = [f"{side.name}: {problem}" for side in sides for problem in check_side(side)]
        if problems:
            print("cannot run the sides from their checkouts:\n" + "\n".join(problems), file=sys.stderr)
            return 1
        inputs = work / "inputs"
        synth, rest = help_commands() + synth_commands(), score_commands() + run_commands()
        total = 2 * len(synth + rest)
        done = run_all(old, synth, inputs, 0, total)
        prepare_inputs(old.outs, inputs)
        done = run_all(old, rest, inputs, done, total)
        run_all(new, synth + rest, inputs, done, total)
        same = report(old, new, synth + rest)
        print(f"{time.monotonic() - started:.0f} s; outputs kept in {work}" if args.keep else
              f"{time.monotonic() - started:.0f} s")
        return 0 if same else 1
    except subprocess.CalledProcessError as error:  # git: an unknown commit, a checkout that failed
        print(f"error: {' '.join(error.cmd)}: {error.stderr.strip()}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\ninterrupted: removing the checkouts" + ("" if args.keep else " and the outputs"), file=sys.stderr)
        return 130
    finally:
        for side in sides:
            remove_checkout(side, repo)
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
