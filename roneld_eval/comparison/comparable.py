"""Which runs a comparison takes, under which names, and whether they can be compared."""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence


from ..config import LANES_MODEL
from ..errors import ConfigError, InputError
from ..wording import counted
from .runs import Run, frames_of
from .tables import grid_text


# ---- which runs, under which names -----------------------------------------------------------

def check_outside_runs(out: Path, runs: Sequence[str | Path]) -> None:
    """Refuse an OUT inside a compared run's folder: the run would then hold files it did not
    write, and a later run into that folder would refuse it."""
    try:
        parents = out.resolve().parents
    except (OSError, RuntimeError):
        return
    for run in runs:
        if any(_same_folder(parent, run) for parent in parents):
            raise InputError(out, f"lies inside the run folder {run}: write the comparison outside it")


def _same_folder(a: str | Path, b: str | Path) -> bool:
    if str(a) == str(b):
        return True
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symlink loop (Python < 3.13)
        return False


def run_labels(runs: Sequence[str | Path], labels: Mapping[str | Path, str]) -> dict[int, str]:
    """Run index -> label, for every run a `labels` key names."""
    chosen: dict[int, str] = {}
    for key, label in labels.items():
        if not isinstance(label, str) or not label.strip():
            raise ConfigError(f"--label {key}=: a label must not be empty")
        if not label.isprintable():
            raise ConfigError(f"--label {key}={label!a}: a label must not hold control characters")
        matches = [k for k, path in enumerate(runs) if _same_folder(path, key)]
        if not matches:
            raise ConfigError(f"--label {key}={label}: {key} is not one of the run folders compared")
        for k in matches:
            if chosen.get(k, label.strip()) != label.strip():
                raise ConfigError(f"--label {key}={label}: {key} has the label {chosen[k]!r} already; give each "
                                  "run one --label")
            chosen[k] = label.strip()
    return chosen


def parse_label_options(options: Sequence[str], runs: Sequence[str | Path]) -> dict[str, str]:
    """`RUN=LABEL` texts (the CLI's --label) -> {run: label}; RUN may itself hold '='."""
    out: dict[str, str] = {}
    for option in options:
        cuts = [k for k, char in enumerate(option) if char == "="]
        for cut in cuts:  # the first '=' after which the left part names a run folder
            if any(_same_folder(run, option[:cut]) for run in runs):
                key, label = option[:cut], option[cut + 1:]
                if out.get(key, label).strip() != label.strip():  # a dict would keep the last without a word
                    raise ConfigError(f"--label {option}: {key} has the label {out[key]!r} already; give each "
                                      "run one --label")
                out[key] = label
                break
        else:
            if not cuts:
                raise ConfigError(f"--label {option}: write RUN=LABEL, e.g. --label runs/enet=ENet-SAD")
            raise ConfigError(f"--label {option}: {option[:cuts[0]]} is not one of the run folders compared")
    return out


def run_title(run: Run, runs: Sequence[Run]) -> str:
    """The label, with the folder's name when another run of that dataset shares the label."""
    twins = [r for r in runs if r.label == run.label and r.dataset == run.dataset]
    return run.label if len(twins) == 1 else f"{run.label} ({run.path.name or run.path})"


def run_pair(runs: Sequence[Run], pair: str | tuple[str, str]) -> tuple[Run, Run]:
    names = [p.strip() for p in pair.split(",")] if isinstance(pair, str) else [str(p).strip() for p in pair]
    if len(names) != 2 or not all(names):
        raise ConfigError(f"--pair {pair}: name two runs, A,B (a run folder, or a label only one run has)")
    a, b = (_named_run(runs, name, pair) for name in names)
    if a is b:
        raise ConfigError(f"--pair {pair}: names one run twice")
    if a.dataset != b.dataset or a.frames_key != b.frames_key or a.truth_key != b.truth_key:
        raise ConfigError(f"--pair {pair}: {a.name()} and {b.name()} were not scored on the same frames and "
                          f"ground truth, so no paired difference exists")
    if not [m for m in a.methods if m in b.methods]:
        raise ConfigError(f"--pair {pair}: the two runs have no method in common")
    return a, b


def _named_run(runs: Sequence[Run], name: str, pair) -> Run:
    """The one run `name` names in --pair: by its folder, else by its label, else by its folder's
    own name (`culane2` for runs/culane2, as a first-time user named it)."""
    match = ([r for r in runs if _same_folder(r.path, name)] or [r for r in runs if r.label == name]
             or [r for r in runs if r.path.name == name])
    if not match:
        raise ConfigError(f"--pair {pair}: {name} is neither a run folder compared, nor a run's label, nor the "
                          "name of a run's folder")
    if len(match) > 1:
        raise ConfigError(f"--pair {pair}: {name} names {len(match)} runs; name one by its folder's path")
    return match[0]


# ---- comparability ---------------------------------------------------------------------------

def check_comparable(runs: Sequence[Run], allow_mixed: bool = False) -> list[str]:
    """Raise ConfigError for runs that cannot share a table; return the footnotes of allowed mixes."""
    for k, run in enumerate(runs):
        for other in runs[:k]:
            if _same_folder(run.path, other.path):
                raise ConfigError(f"{run.name()} is given twice")
    _check_same_data(runs)
    for run in runs[1:]:
        if run.thresholds != runs[0].thresholds:
            raise ConfigError(f"cannot compare {runs[0].name()} with {run.name()}: different IoU threshold grids "
                              f"({grid_text(runs[0].thresholds)} and {grid_text(run.thresholds)}); rerun one "
                              f"with the other's --thresholds")
    notes = _protocol_mixes(runs, allow_mixed)
    _check_groups(runs)
    return notes


def _check_same_data(runs: Sequence[Run]) -> None:
    """Runs of one dataset scored the same frames, at the same sizes, against the same ground truth."""
    first: dict[str, Run] = {}
    for run in runs:
        base = first.setdefault(run.dataset, run)
        if run is base:
            continue
        where = f"cannot compare {base.name()} with {run.name()}: both are {run.dataset_name} runs"
        if run.frames_key != base.frames_key:
            a, b = frames_of(base), frames_of(run)
            differ = sorted(a ^ b)
            detail = (f"of the {counted(len(a | b), 'frame')} with a ground-truth ego lane in either, "
                      f"{len(differ)} {'is' if len(differ) == 1 else 'are'} in one run only, e.g. {differ[0]}"
                      if differ else
                      f"{base.counts['labelled_frames']} and {run.counts['labelled_frames']} frames scored")
            raise ConfigError(f"{where} but scored different frames ({detail}); compare runs of one dataset "
                              f"on the same frames")
        if run.clip_sizes != base.clip_sizes:
            clip = sorted(set(base.clip_sizes) ^ set(run.clip_sizes))[0][0]
            sizes = " and ".join(next((f"{w}x{h}" for name, w, h in one.clip_sizes if name == clip), "none")
                                 for one in (base, run))
            raise ConfigError(f"{where} on the same frames but at different frame sizes (clip {clip}: {sizes}); "
                              "evaluate both with one dataset's sizes")
        if run.truth_key != base.truth_key:
            raise ConfigError(f"{where} on the same frames but against different ground truth (ego lanes "
                              f"{base.counts['ego_lanes']} and {run.counts['ego_lanes']}, all lanes "
                              f"{base.counts['gt_lanes']} and {run.counts['gt_lanes']}); evaluate both on one "
                              f"dataset root")


def _protocol_mixes(runs: Sequence[Run], allow_mixed: bool) -> list[str]:
    """The footnote of each paper-protocol setting the runs differ in (allowed with --allow-mixed)."""
    notes = []
    for index, (setting, value) in enumerate(runs[0].protocol):
        values: dict[object, list[Run]] = {}
        for run in runs:
            values.setdefault(run.protocol[index][1], []).append(run)
        if len(values) == 1:
            continue
        (a_value, a_runs), (b_value, b_runs) = list(values.items())[:2]
        if not allow_mixed:
            raise ConfigError(f"cannot compare {a_runs[0].name()} with {b_runs[0].name()}: different paper-protocol "
                              f"settings ({setting} = {a_value!r} and {b_value!r}); rerun one of them, or pass "
                              f"--allow-mixed to compare them anyway (the tables then say so)")
        shown = "; ".join(f"{value!r} for " + ", ".join(f"{r.label} on {r.dataset_name}" for r in members)
                          for value, members in values.items())
        notes.append(f"Compared with --allow-mixed: the runs differ in {setting}: {shown}.")
    return notes


def _check_groups(runs: Sequence[Run]) -> None:
    """Runs averaged as one model's seeds are named, distinct results, of the same methods."""
    groups: dict[tuple[str, str], Run] = {}
    results: dict[tuple[str, str, str], Run] = {}
    for run in runs:
        other = groups.setdefault((run.dataset, run.label), run)
        if other is not run and run.label == run.model == other.model == LANES_MODEL:
            # The tool's name for lane files of an unnamed detector: no claim that they are one model's.
            raise ConfigError(f"cannot average {other.name()} and {run.name()}: both are labelled {LANES_MODEL!r}, "
                              f"the name a lane-file run gets when it names no model; give each its detector's "
                              f"name (--label RUN=NAME, or --set model=NAME when running), one name for seeds "
                              f"of one model")
        twin = results.setdefault((run.dataset, run.label, run.results_key), run)
        if twin is not run:
            raise ConfigError(f"cannot average {twin.name()} and {run.name()} as two runs of {run.label!r}: every "
                              f"IoU of every method is the same in both, so they are one result twice (the same "
                              f"maps in two formats, or a copied run, is the usual cause); compare one of them")
        if other.methods != run.methods:
            raise ConfigError(f"cannot average {other.name()} and {run.name()}: both are {run.label!r} on "
                              f"{run.dataset_name} but ran different methods ({','.join(other.methods)} "
                              f"and {','.join(run.methods)}); give one of them another --label")
