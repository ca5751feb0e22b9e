"""`--executor dask`: a command's shards run on a dask.distributed cluster (a LocalCluster here, or
one given by --scheduler) and merge into the files the command writes in one process."""

from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main

distributed = pytest.importorskip("distributed")  # the [cluster] extra, which the test command installs


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _same_files(whole, other, skip=()) -> list[str]:
    names = sorted(p.name for p in whole.iterdir() if not p.name.startswith(".") and p.is_file())
    assert sorted(p.name for p in other.iterdir() if not p.name.startswith(".") and p.is_file()) == names
    for name in names:
        if name not in skip:
            assert (other / name).read_bytes() == (whole / name).read_bytes(), name
    return names


def _score(culane_set, out, *extra):
    return _invoke("score", "culane", "--data-root", culane_set / "data", "--pred-root", f"a={culane_set / 'maps'}",
                   "--pred-root", f"b={culane_set / 'maps'}", "--iou", "0.3:0.7:0.1", "--out", out, *extra)


def test_score_on_a_local_dask_cluster_writes_the_files_of_one_process(culane_set, tmp_path):
    assert _score(culane_set, tmp_path / "here", "--workers", "1", "--quiet").exit_code == 0
    # two worker processes, each told --workers 2: a Dask worker is daemonic and scores in itself
    result = _score(culane_set, tmp_path / "dask", "--executor", "dask", "--workers", "2")
    assert result.exit_code == 0, result.output
    assert "dask: 2 shards on tcp://" in result.output and "(2 workers, 2 threads)" in result.output
    assert "official.csv" in _same_files(tmp_path / "here", tmp_path / "dask")


def test_a_run_on_a_given_scheduler_is_the_run_here_but_for_its_clock(tmp_path):
    here = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "here")
    assert here.exit_code == 0, here.output
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster:
        result = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "dask", "--executor", "dask",
                         "--scheduler", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    # one worker of two threads: two shards, run one after the other in that worker
    names = _same_files(tmp_path / "here", tmp_path / "dask",
                        skip={"runtime.csv", "runtime.md", "runtime.tex", "report.html", "summary.json"})
    assert {"accuracy.csv", "per_frame.csv", "official.csv", "config.toml"} <= set(names)


@pytest.mark.long
def test_vil100_on_dask_merges_its_sequences_as_one_process_scores_them(tmp_path):
    from test_shards import _vil100_set

    args = _vil100_set(tmp_path, "png")
    assert _invoke(*args, "--quiet", "--out", tmp_path / "here").exit_code == 0
    result = _invoke(*args, "--quiet", "--out", tmp_path / "dask", "--executor", "dask")
    assert result.exit_code == 0, result.output
    assert "temporal.csv" in _same_files(tmp_path / "here", tmp_path / "dask")


@pytest.mark.parametrize("extra, said", [
    (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler is the address of a Dask scheduler: give it with "
                                              "--executor dask"),
    (["--executor", "dask", "--shard", "1/2"], "cuts the command into shards itself"),
])
def test_executor_options_that_do_not_go_together_are_one_line(culane_set, tmp_path, extra, said):
    result = _score(culane_set, tmp_path / "o", *extra)
    assert result.exit_code == 2 and said in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_run_on_dask_refuses_what_a_merge_cannot_give(tmp_path):
    for extra, said in ((["--overlays", "2"], "without --resume, --overlays"),
                        (["--no-timings"], "or --no-timings"),
                        (["--method", "mine=plugin_extractors:shifted"], "a merge imports no code a part names")):
        result = _invoke("run", "--executor", "dask", "--out", tmp_path / "o", *extra)
        assert result.exit_code == 2 and said in result.output, result.output
    result = _invoke("score", "tusimple", "--labels", tmp_path / "l.json", "--pred", tmp_path / "p.json",
                     "--executor", "dask")
    assert result.exit_code == 2 and "give --out" in result.output


def test_a_scheduler_that_does_not_answer_is_one_line(culane_set, tmp_path, monkeypatch):
    import roneld_eval.cluster as cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    result = _score(culane_set, tmp_path / "o", "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9")
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error: --scheduler tcp://127.0.0.1:9: no Dask scheduler answers there")
    assert not (tmp_path / "o" / "official.csv").exists()


def test_a_foreign_out_is_refused_before_a_cluster_starts(culane_set, tmp_path, monkeypatch):
    import roneld_eval.cluster as cluster

    def no_cluster(*args, **kwargs):
        raise AssertionError("a cluster was started before --out was checked")

    monkeypatch.setattr(cluster, "_client", no_cluster)
    (tmp_path / "thesis").mkdir()
    (tmp_path / "thesis" / "thesis.tex").write_text("mine")
    result = _score(culane_set, tmp_path / "thesis", "--executor", "dask")
    assert result.exit_code == 2 and "holds files roneld-eval did not write" in result.output, result.output


def test_without_dask_the_extra_to_install_is_named(culane_set, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    result = _score(culane_set, tmp_path / "o", "--executor", "dask")
    assert result.exit_code == 2 and "pip install 'roneld-eval[cluster]'" in result.output


def test_a_shards_input_error_is_one_line_and_leaves_no_folder(culane_set, tmp_path):
    # The workers' log printed each failed task's traceback (four blocks for one bad --pred-root
    # pattern), and the folder created to check --out before the cluster started stayed behind.
    out = tmp_path / "sweep" / "deeper"
    done = subprocess.run([sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root",
                           str(culane_set / "data"), "--pred-root", str(tmp_path / "work_dirs" / "epoch_*" / "lines"),
                           "--executor", "dask", "--workers", "2", "--quiet", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    said = done.stdout + done.stderr
    assert "Traceback" not in said and "distributed.worker" not in said, said
    assert said.strip().splitlines()[-1].endswith("epoch_*/lines: no folder matches this pattern"), said
    assert not (tmp_path / "sweep").exists()
