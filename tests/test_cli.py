"""The command line: help on everything, one-line errors with exit 2, synth, score."""

import hashlib
import json
import os
import shlex
import subprocess

import click
import numpy as np
import pytest
from click.testing import CliRunner

from roneld_eval.cli import main


def all_commands(group, prefix=()):
    for name, command in group.commands.items():
        yield prefix + (name,), command
        if isinstance(command, click.Group):
            yield from all_commands(command, prefix + (name,))


def test_every_command_and_option_has_help():
    for path, command in all_commands(main):
        assert command.help, f"{' '.join(path)} has no help"
        for parameter in command.params:
            if isinstance(parameter, click.Option):
                assert parameter.help, f"{' '.join(path)} {parameter.opts[0]} has no help"
        result = CliRunner().invoke(main, list(path) + ["--help"])
        assert result.exit_code == 0 and "Usage:" in result.output


@pytest.mark.parametrize("args, message", [
    (["run", "--data-root", "nowhere", "--maps-root", "nowhere"], "nowhere: maps root not found"),
    (["run", "--data-root", "x"], "give both --data-root and --maps-root"),
    (["run", "--config", "no-such-preset"], "no such config file or preset"),
    (["run", "--methods", "baseline,magic"], "unknown method 'magic'"),
    (["run", "--config", "scnn-culan"], "scnn-culan: no such config file or preset (did you mean scnn-culane?)"),
    (["run", "--methods", "roneld,basline"], "unknown method 'basline' (did you mean baseline?)"),
    (["run", "--thresholds", "0.3:0.5:0.07"], "does not divide"),
    (["run", "--set", "paper.thickness_rule=diagonal"], "thickness_rule must be"),
    (["score", "tusimple", "--labels", "nope.json", "--pred", "nope.json"], "nope.json: file not found"),
    # click's own usage errors took three lines and more (usage, a hint, the choices one per line)
    (["show"], "Missing option '--run'. (see roneld-eval show --help)"),
    (["score", "culane", "--data-root", "x", "--pred-root", "y", "--width", "1"],
     "Invalid value for '--width': 1 is not in the range 2<=x<=1000. (see roneld-eval score culane --help)"),
    (["synth", "--dataset", "culan"], "'culan' is not one of 'apollo3d', 'culane', 'curvelanes', 'llamas', "),
    (["runn"], "No such command 'runn'. Did you mean 'run'? (see roneld-eval --help)"),
    # raised before the command's own context: they named the group's help
    (["synth", "--dataset", "culane", "--out"], "Option '--out' requires an argument. (see roneld-eval synth --help)"),
    (["score", "culane", "--width"], "Option '--width' requires an argument. (see roneld-eval score culane --help)"),
])
def test_bad_input_is_one_line_and_exit_2(args, message, tmp_path):
    result = CliRunner().invoke(main, args + (["--out", str(tmp_path / "out")] if args[0] == "run" else []),
                                prog_name="roneld-eval")
    assert result.exit_code == 2, result.output
    assert result.output.count("\n") == 1, result.output
    assert message in result.output
    assert "Traceback" not in result.output
    assert result.output.startswith("error: ")
    assert not (tmp_path / "out" / "accuracy.csv").exists()


def test_debug_shows_the_traceback(tmp_path):
    result = CliRunner().invoke(main, ["run", "--config", "nope", "--debug", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "Traceback" in result.output


def _digest(folder):
    digest = hashlib.sha256()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(folder)).encode() + path.read_bytes())
    return digest.hexdigest()


@pytest.mark.parametrize("dataset, maps_format", [("culane", "npy"), ("tusimple", "npz"), ("culane", "scnn-png")])
def test_synth_is_byte_identical_for_a_seed(dataset, maps_format, tmp_path):
    args = ["synth", "--dataset", dataset, "--clips", "2", "--frames", "3", "--seed", "7", "--maps-format", maps_format]
    first = CliRunner().invoke(main, args + ["--out", str(tmp_path / "a")])
    second = CliRunner().invoke(main, args + ["--out", str(tmp_path / "b")])
    assert first.exit_code == 0 and second.exit_code == 0 and "roneld-eval run --dataset" in first.output
    assert _digest(tmp_path / "a") == _digest(tmp_path / "b")
    other = CliRunner().invoke(main, ["synth", "--dataset", dataset, "--clips", "2", "--frames", "3", "--seed", "8",
                                      "--maps-format", maps_format, "--out", str(tmp_path / "c")])
    assert other.exit_code == 0 and _digest(tmp_path / "a") != _digest(tmp_path / "c")


def test_synth_then_run_as_printed(tmp_path):
    # As a shell reads the line pasted: the paths quoted (they held spaces, and "$" would expand).
    result = CliRunner().invoke(main, ["synth", "--dataset", "culane", "--clips", "2", "--frames", "4",
                                       "--out", str(tmp_path / "my set $HOME")])
    command = shlex.split(result.output.strip().splitlines()[-1])
    assert command[:2] == ["roneld-eval", "run"]
    ran = CliRunner().invoke(main, command[1:] + ["--out", str(tmp_path / "out"), "--quiet", "--workers", "1"])
    assert ran.exit_code == 0, ran.output
    assert (tmp_path / "out" / "accuracy.csv").exists()


def test_synth_writes_only_into_a_folder_of_its_own_and_replaces_its_own_set(tmp_path):
    # `synth --out /etc` wrote data/ and maps/ into it, as into a folder holding a user's thesis.
    own = tmp_path / "own"
    own.mkdir()
    (own / "thesis.tex").write_text("chapter 1")
    args = ["synth", "--dataset", "culane", "--clips", "1", "--frames", "3"]
    result = CliRunner().invoke(main, args + ["--out", str(own)])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "holds files roneld-eval did not write (thesis.tex)" in result.output
    assert sorted(os.listdir(own)) == ["thesis.tex"]
    made = tmp_path / "set"
    for clips, frames in (("3", 9), ("1", 3)):  # the second set replaces the first whole
        result = CliRunner().invoke(main, args[:3] + ["--clips", clips, "--frames", "3", "--out", str(made)])
        assert result.exit_code == 0, result.output
        assert len((made / "data" / "list" / "test.txt").read_text().splitlines()) == frames
        assert len([p for p in (made / "maps").rglob("*.npy")]) == frames
    assert f"--data-root {made / 'data'} --maps-root {made / 'maps'}" in result.output  # not the staging folder


def test_score_culane_on_its_own_ground_truth(tmp_path):
    CliRunner().invoke(main, ["synth", "--dataset", "culane", "--clips", "1", "--frames", "3", "--out", str(tmp_path)])
    result = CliRunner().invoke(main, ["score", "culane", "--data-root", str(tmp_path / "data"), "--pred-root",
                                       str(tmp_path / "data"), "--iou", "0.30:0.50:0.10", "--out", str(tmp_path / "o"),
                                       "--workers", "1"])
    assert result.exit_code == 0, result.output
    table = (tmp_path / "o" / "official.csv").read_text().splitlines()
    assert table[0] == "method,category,threshold,tp,fp,fn,precision,recall,f1"
    assert table[-1].startswith("data,all,0.50,") and ",0,0,1.0,1.0,1.0" in table[-1]
    assert (tmp_path / "o" / "summary.csv").exists()  # the sweep is in official.csv, one row per threshold


def test_score_tusimple(tmp_path):
    rows = list(range(160, 720, 10))
    label = {"lanes": [[500] * 56], "h_samples": rows, "raw_file": "clips/a/20.jpg"}
    (tmp_path / "labels.json").write_text(json.dumps(label) + "\n")
    (tmp_path / "pred.json").write_text(json.dumps({"raw_file": "clips/a/20.jpg", "lanes": [[505] * 56]}) + "\n")
    result = CliRunner().invoke(main, ["score", "tusimple", "--labels", str(tmp_path / "labels.json"),
                                       "--pred", str(tmp_path / "pred.json"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0 and "Accuracy 1  FP 0  FN 0" in result.output
    (tmp_path / "pred.json").write_text("")
    result = CliRunner().invoke(main, ["score", "tusimple", "--labels", str(tmp_path / "labels.json"),
                                       "--pred", str(tmp_path / "pred.json")])
    assert result.exit_code == 2 and "no prediction for 1 of 1 labelled frames" in result.output


def test_run_without_out_writes_where_git_ignores_it(tmp_path, monkeypatch):
    # The default was results/, the committed copy: `roneld-eval run` in a clone rewrote 23
    # tracked files.
    from conftest import REPO

    from roneld_eval.output import DEFAULT_OUT

    ignored = subprocess.run(["git", "check-ignore", "-q", DEFAULT_OUT], cwd=REPO)
    if ignored.returncode == 128:
        pytest.skip("not a git checkout")
    assert ignored.returncode == 0, f"{DEFAULT_OUT} is not ignored by git"
    assert subprocess.run(["git", "ls-files", "--error-unmatch", DEFAULT_OUT], cwd=REPO,
                          capture_output=True).returncode != 0, f"{DEFAULT_OUT} holds tracked files"
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["run", "--quiet", "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / DEFAULT_OUT / "accuracy.csv").is_file()
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("number, said", [(2, "interrupted"), (15, "terminated (SIGTERM)"), (1, "terminated (SIGHUP)")])
def test_a_signal_before_any_command_runs_is_one_line_and_128_plus_n(monkeypatch, number, said):
    # Ctrl-C while click started gave "Aborted!" and exit 1; SIGTERM or SIGHUP then ended the
    # process with no word.
    import os

    group = type(main)
    original = group.resolve_command

    def signalled(self, ctx, args):
        os.kill(os.getpid(), number)
        return original(self, ctx, args)

    monkeypatch.setattr(group, "resolve_command", signalled)
    result = CliRunner().invoke(main, ["score", "tusimple", "--labels", "x", "--pred", "y"])
    assert result.output.strip() == said and result.exit_code == 128 + number, (result.output, result.exit_code)


def test_a_dry_run_checks_and_says_what_would_be_scored_and_writes_nothing(tmp_path, monkeypatch):
    from roneld_eval.benchmarks.culane.synth import synth_culane

    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["run", "--dry-run"])
    assert result.exit_code == 0, result.output
    assert "dry run: culane, 4 clips, 40 frames (40 labelled, scored) with baseline, roneld; maps npz in " in \
        result.output and "nothing evaluated or written" in result.output
    assert "geometry: maps 800x288" in result.output
    assert list(tmp_path.iterdir()) == []
    synth_culane(tmp_path / "set", clips=2, frames=2, seed=1)
    next((tmp_path / "set" / "maps").rglob("00000.npy")).unlink()
    args = ["run", "--dry-run", "--data-root", str(tmp_path / "set" / "data"), "--maps-root",
            str(tmp_path / "set" / "maps")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and "maps missing for 1 frame of 1 clip" in result.output, result.output
    result = CliRunner().invoke(main, args + ["--on-error", "skip"])
    assert result.exit_code == 0 and "1 clip, 2 frames" in result.output and "would skip: " in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]


def test_a_clip_skipped_for_maps_of_another_format_says_which_format_it_found(tmp_path):
    # Without --on-error skip the run said "found 00000.npz: use --maps-format npz"; with it, only
    # "maps missing ... 00000.npy".
    from roneld_eval.benchmarks.culane.synth import synth_culane

    made = synth_culane(tmp_path / "set", clips=2, frames=2, seed=1, maps_format="npz")
    args = ["run", "--data-root", str(made.data_root), "--maps-root", str(made.maps_root), "--on-error", "skip",
            "--quiet", "--out", str(tmp_path / "out")]
    for extra in (["--dry-run"], []):
        result = CliRunner().invoke(main, args + extra)
        assert "00000.npy (found 00000.npz: use --maps-format npz) (clip skipped)" in result.output, result.output


@pytest.mark.parametrize("level", ["deeper", "higher"])
def test_a_maps_root_one_level_off_names_the_folder_that_holds_the_maps(tmp_path, level):
    from roneld_eval.benchmarks.culane.synth import synth_culane

    synth_culane(tmp_path / "set", clips=1, frames=2, seed=1)
    maps = tmp_path / "set" / "maps"
    given = next(maps.iterdir()) if level == "deeper" else tmp_path / "set"
    result = CliRunner().invoke(main, ["run", "--data-root", str(tmp_path / "set" / "data"), "--maps-root", str(given),
                                       "--quiet", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.output.rstrip().endswith(f"did you mean --maps-root {maps} (it holds them)?")


def test_maps_stored_height_width_channels_say_how_to_transpose(tmp_path):
    from roneld_eval.benchmarks.culane.synth import synth_culane

    synth_culane(tmp_path / "set", clips=1, frames=2, seed=1)
    first = sorted((tmp_path / "set" / "maps").rglob("*.npy"))[0]
    np.save(first, np.load(first).transpose(1, 2, 0).copy())
    result = CliRunner().invoke(main, ["run", "--data-root", str(tmp_path / "set" / "data"), "--maps-root",
                                       str(tmp_path / "set" / "maps"), "--quiet", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.output.strip() == (f"error: {first}: has 288 channels, expected 4 (it looks like (height, width, "
                                     "channels) = (288, 800, 4): store (channels, height, width), e.g. "
                                     "np.transpose(maps, (2, 0, 1)))")


def test_resuming_into_a_finished_run_says_there_is_nothing_to_resume(tmp_path):
    out = tmp_path / "out"
    assert CliRunner().invoke(main, ["run", "--out", str(out), "--quiet", "--workers", "1"]).exit_code == 0
    result = CliRunner().invoke(main, ["run", "--out", str(out), "--resume", "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert ("resume: nothing to resume: this folder keeps no unfinished run (a finished one keeps no clips); "
            "computing all 4 clips") in result.output
    assert "not finished" not in result.output


def test_compare_says_how_many_frames_two_runs_do_not_share(tmp_path):
    for name, extra in (("a", []), ("b", ["--set", "dataset.limit=2"])):
        result = CliRunner().invoke(main, ["run", "--out", str(tmp_path / name), "--quiet", "--workers", "1", *extra])
        assert result.exit_code == 0, result.output
    result = CliRunner().invoke(main, ["compare", str(tmp_path / "a"), str(tmp_path / "b"), "--out",
                                       str(tmp_path / "c"), "--quiet"])
    assert result.exit_code == 2
    assert ("scored different frames (of the 40 frames with a ground-truth ego lane in either, 20 are in one run "
            "only, e.g. driver_102_30frame/05182066_0205.MP4/00000.jpg)") in result.output


def test_an_empty_out_is_refused_by_every_command_not_taken_for_the_current_folder(tmp_path, monkeypatch):
    # --out "$OUT" with OUT unset wrote a whole run into the current folder.
    from roneld_eval.cli import OUT_FOLDER

    monkeypatch.chdir(tmp_path)
    for args in (["run", "--out", ""], ["score", "culane", "--data-root", "d", "--pred-root", "p", "--out", " "]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, result.output
        assert "Invalid value for '--out': is empty: name a folder (write . for the current one)" in result.output
    assert list(tmp_path.iterdir()) == []

    def commands(group, path=()):
        context = click.Context(group)
        for name in group.list_commands(context):  # score's benchmarks come from their entry points
            command = group.get_command(context, name)
            if isinstance(command, click.Group):
                yield from commands(command, path + (name,))
            elif command is not None:
                yield path + (name,), command

    outs = {path: param for path, command in commands(main) for param in command.params if param.name == "out"}
    from roneld_eval import benchmarks

    assert len(benchmarks.names()) >= 8
    assert len(outs) == 5 + len(benchmarks.names())  # run, merge, synth, show, compare and each benchmark's score
    assert [path for path, param in outs.items() if param.type is not OUT_FOLDER] == []


@pytest.mark.parametrize("raised", ["KeyboardInterrupt()", "ImportError('initialization failed')"])
def test_ctrl_c_while_the_command_starts_is_one_line(raised):
    """The first 0.1-0.3 s import the command line's modules: Ctrl-C there printed Python's
    traceback (7 of 15 SIGINTs sent 0.05-0.22 s after start). Here it lands as click is imported;
    as an extension module's initialisation, it comes out as an ImportError it caused."""
    import sys
    import tomllib

    from conftest import REPO, env_importing

    program = (
        "import sys\n"
        "class Interrupting:\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name == 'click':\n"
        "            try:\n"
        "                raise KeyboardInterrupt\n"
        "            except KeyboardInterrupt as error:\n"
        f"                raise ({raised}) from error\n"
        "sys.meta_path.insert(0, Interrupting())\n"
        "import runpy\n"
        "runpy.run_module('roneld_eval', run_name='__main__')\n")
    env = env_importing()
    done = subprocess.run([sys.executable, "-c", program, "run"], capture_output=True, text=True, env=env)
    assert (done.returncode, done.stderr, done.stdout) == (130, "interrupted\n", "")
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["roneld-eval"] == "roneld_eval.console:main"  # the command, as python -m runs it


def test_no_command_draws_a_progress_bar_where_stderr_is_not_a_terminal(tmp_path, monkeypatch):
    # `score` and `synth` drew theirs into pipes and logs (`synth --dataset vil100`: one 30 KB
    # line), `run` not: all alike now, a bar on a terminal only.
    from roneld_eval import progress

    lanes = tmp_path / "openlane"
    assert CliRunner().invoke(main, ["synth", "--dataset", "openlane", "--out", str(lanes)]).exit_code == 0
    commands = {
        "generating": ["synth", "--dataset", "vil100", "--out", str(tmp_path / "set")],  # 300 frames
        "scoring": ["score", "openlane", "--labels", str(lanes / "labels"), "--pred-root", str(lanes / "predictions"),
                    "--workers", "1"],
        "evaluating": ["run", "--workers", "1", "--out", str(tmp_path / "run")],
    }
    for bar, args in commands.items():
        result = CliRunner().invoke(main, args)  # stderr: not a terminal
        assert result.exit_code == 0, result.output
        assert bar not in result.output and "\r" not in result.output, (args, result.output[-300:])
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)
    for bar, args in commands.items():
        result = CliRunner().invoke(main, args + (["--out", str(tmp_path / "score")] if bar == "scoring" else []))
        assert result.exit_code == 0, result.output
        assert f"\r{bar}: 100%" in result.output, (args, result.output[-300:])


@pytest.mark.parametrize("number", [15, 1])  # SIGTERM, SIGHUP
def test_a_signal_while_the_command_starts_is_one_line(number):
    # Before the command's handling started, SIGTERM or SIGHUP ended the process without a word.
    import sys

    from conftest import env_importing

    program = (
        "import os, sys\n"
        "class Signalling:\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name == 'click':\n"
        f"            os.kill(os.getpid(), {number})\n"
        "sys.meta_path.insert(0, Signalling())\n"
        "import runpy\n"
        "runpy.run_module('roneld_eval', run_name='__main__')\n")
    done = subprocess.run([sys.executable, "-c", program, "run"], capture_output=True, text=True,
                          env=env_importing(), timeout=120)
    name = "SIGTERM" if number == 15 else "SIGHUP"
    assert (done.returncode, done.stderr, done.stdout) == (128 + number, f"terminated ({name})\n", "")


def test_signals_once_the_command_is_over_do_not_kill_its_exit():
    # Python gives a signal back to its default action as it shuts down: SIGTERM or SIGHUP in the
    # last tens of ms of an exit ended a finished command without a word (2 of 106 `score
    # openlane` signalled in their last second), Ctrl-C printed a traceback.
    import sys

    from conftest import env_importing
    from roneld_eval.version import __version__

    program = (
        "import atexit, os, signal, sys\n"
        "atexit.register(lambda: [os.kill(os.getpid(), n) for n in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)])\n"
        "sys.argv[0] = 'roneld-eval'\n"
        "from roneld_eval.console import main\n"
        "main()\n")
    done = subprocess.run([sys.executable, "-c", program, "--version"], capture_output=True, text=True,
                          env=env_importing(), timeout=120)
    assert (done.returncode, done.stderr, done.stdout) == (0, "", f"roneld-eval, version {__version__}\n")


def test_a_signal_after_the_results_are_committed_says_they_are_complete(tmp_path, monkeypatch):
    # It said "terminated (SIGTERM): no result was written" of results already in place.
    import signal

    from roneld_eval.benchmarks.openlane import score as openlane_score

    lanes = tmp_path / "set"
    assert CliRunner().invoke(main, ["synth", "--dataset", "openlane", "--out", str(lanes)]).exit_code == 0
    original = openlane_score.score_openlane

    def signalled_on_return(*args, **kwargs):
        score = original(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)  # on its way back to the command line, past the folder's end
        return score

    monkeypatch.setattr(openlane_score, "score_openlane", signalled_on_return)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["score", "openlane", "--labels", str(lanes / "labels"), "--pred-root",
                                       str(lanes / "predictions"), "--out", str(out), "--quiet"])
    assert (result.exit_code, result.output) == (143, "terminated (SIGTERM): the results are complete\n")
    assert sorted(path.name for path in out.iterdir()) == [".roneld-run.json", "official.csv", "summary.md"]


def test_ctrl_c_while_numba_initialises_is_an_interruption():
    # Cut short in the initialisation of numba's C extensions, numba printed the interruption and
    # failed for good: "ImportError: numba._devicearray failed to import", a traceback, exit 1.
    import sys

    from conftest import env_importing

    program = (
        "import os, signal, sys\n"
        "class Interrupting:\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name == 'numba._devicearray':\n"
        "            os.kill(os.getpid(), signal.SIGINT)\n"
        "sys.meta_path.insert(0, Interrupting())\n"
        "import runpy\n"
        "runpy.run_module('roneld_eval', run_name='__main__')\n")
    done = subprocess.run([sys.executable, "-c", program, "score", "openlane", "--labels", "x", "--pred-root", "y"],
                          capture_output=True, text=True, env=env_importing(), timeout=120)
    assert (done.returncode, done.stderr.strip(), done.stdout) == (130, "interrupted", ""), done.stderr


def test_ctrl_c_that_left_an_exec_of_a_string_ends_in_the_status_said(tmp_path):
    # CPython ends `python -m` with SIGINT at exit once a KeyboardInterrupt has left an exec() of a
    # string (numba's, dataclasses' and namedtuple's generated code), however it was handled:
    # "interrupted: no result was written" and then death by SIGINT, status -2, not 130.
    import sys

    from conftest import env_importing

    probe = tmp_path / "probe"
    probe.mkdir()
    (probe / "__init__.py").write_text("")
    (probe / "__main__.py").write_text(
        "from roneld_eval import api\n"
        "def interrupted(*args, **kwargs):\n"
        "    exec('raise KeyboardInterrupt')\n"
        "api.synthesize = interrupted\n"
        "from roneld_eval.console import main\n"
        "main()\n")
    env = env_importing()
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env["PYTHONPATH"]])
    done = subprocess.run([sys.executable, "-m", "probe", "synth", "--dataset", "openlane", "--out",
                           str(tmp_path / "unused")], capture_output=True, text=True, env=env, timeout=120)
    assert (done.returncode, done.stderr, done.stdout) == (130, "interrupted: no result was written\n", "")
