"""What every registered benchmark must do, from one parametrised list: a new benchmark gets these
tests by being registered, and a third party's gets them from one line (roneld_eval.kit.check_benchmark,
whose steps roneld_eval.contract lists: synth -> run or score -> shards merged -> compare)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from conftest import env_importing

from roneld_eval import benchmarks
from roneld_eval.kit import ContractBroken, check_benchmark

TOY = Path(__file__).parent / "toy_benchmark"


@pytest.mark.parametrize("name", benchmarks.names())
def test_every_registered_benchmark_keeps_the_contract(tmp_path, name):
    check_benchmark(name, tmp_path)


def test_a_third_partys_benchmark_keeps_it_from_one_line_in_its_tests(tmp_path):
    line = f"from roneld_eval.kit import check_benchmark; check_benchmark('toy', {str(tmp_path)!r})"
    done = subprocess.run([sys.executable, "-c", line], capture_output=True, text=True, env=env_importing(TOY),
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "compared" / "table_official.md").is_file()  # it went through every step


def test_a_broken_step_names_itself_its_command_and_what_it_printed(tmp_path, monkeypatch):
    # A merge that gives another table than the whole set's: the contract says which step and shows both.
    from roneld_eval import contract

    real = contract._official

    def other_table_for_merge(command, out, step):
        text = real(command, out, step)
        return text.replace("\n", "\nextra row\n", 1) if command[0] == "merge" else text

    monkeypatch.setattr(contract, "_official", other_table_for_merge)
    with pytest.raises(ContractBroken, match="culane: two shards merged give another official table"):
        check_benchmark("culane", tmp_path)


def test_a_failing_command_is_named_with_its_output(tmp_path):
    with pytest.raises(ContractBroken, match=r"(?s)its synthetic set is scored: roneld-eval run .* exited 2:.*error"):
        from roneld_eval import contract

        contract._official(["run", "--dataset", "culane", "--data-root", str(tmp_path / "none"), "--maps-root",
                            str(tmp_path / "none")], tmp_path / "out", "its synthetic set is scored")


def test_a_benchmark_that_does_not_load_breaks_the_contract_in_one_line(tmp_path):
    with pytest.raises(ContractBroken, match="^nosuch: unknown dataset 'nosuch'; choose from "):
        check_benchmark("nosuch", tmp_path)


def test_lanes_a_benchmark_cannot_write_break_the_contract(tmp_path):
    # a lane_file that raises was not seen by the contract (the helper's third-party trial): runs save lanes now
    from test_benchmark_plugins import _method, _variant

    path = _variant(tmp_path / "pkg", "nolanes", _method("lane_file(self, method, frame, lanes)",
                                                           "raise RuntimeError('lane_file broken')"))
    line = f"from roneld_eval.kit import check_benchmark; check_benchmark('nolanes', {str(tmp_path / 'c')!r})"
    done = subprocess.run([sys.executable, "-c", line], capture_output=True, text=True, env=env_importing(path),
                          timeout=600)
    assert done.returncode == 1
    assert "ContractBroken: a run of ModelA: roneld-eval run --dataset nolanes" in done.stderr
    assert "lane_file() raised RuntimeError: lane_file broken" in done.stderr


def test_a_benchmark_whose_preset_is_another_ones_is_refused_not_run_as_that_one(tmp_path):
    # An attack pass: a copied preset naming `toy` made `run --dataset copied` evaluate the toy, and the
    # contract passed.
    from test_benchmark_plugins import _variant

    toy_preset = TOY / "toy_lanes" / "toy.toml"
    path = _variant(tmp_path / "pkg", "copied", f"    default_preset = {str(toy_preset)!r}\n")
    line = f"from roneld_eval.kit import check_benchmark; check_benchmark('copied', {str(tmp_path / 'c')!r})"
    done = subprocess.run([sys.executable, "-c", line], capture_output=True, text=True, env=env_importing(path),
                          timeout=600)
    assert done.returncode == 1
    assert ("ContractBroken: its synthetic set is scored: roneld-eval run --dataset copied" in done.stderr
            and f"error: benchmark 'copied': its default preset ({toy_preset}) is for dataset 'toy', not for it"
            in done.stderr), done.stderr


def test_ctrl_c_in_a_step_stops_the_contract_as_ctrl_c(tmp_path, monkeypatch):
    from roneld_eval import contract

    class Interrupted:
        exit_code, output = 130, "Interrupted\n"

    monkeypatch.setattr("click.testing.CliRunner.invoke", lambda *args, **kwargs: Interrupted())
    with pytest.raises(KeyboardInterrupt):
        contract._invoke("a step", ["run"])
