"""`score NAME` built from a declaration (roneld_eval.score_commands): a third party's declaration is
checked against its scorer when the command is built, and its scorer's failures are one line."""

from __future__ import annotations

import importlib

import pytest
from click.testing import CliRunner

from roneld_eval import benchmarks
from roneld_eval.errors import ConfigError
from roneld_eval.kit import Option, ScoreCommand, command_of
from roneld_eval.score_commands import declaration_problem


def _spec(*options: Option, positional=("data_root", "pred_file"), progress=False) -> ScoreCommand:
    return ScoreCommand("dots", "Dots.", options=options, positional=positional,
                        report=lambda score, values, echo: echo(f"scored {score}"), progress=progress)


DATA = Option("--data-root", "Root.", kind="path", required=True)
PRED = Option("--pred-file", "Predictions.", kind="path", required=True)


def score_dots(data_root, pred_file):
    return f"{data_root} {pred_file}"


def test_a_declaration_that_fits_its_scorer_is_a_command_that_calls_it(tmp_path):
    command = command_of(_spec(DATA, PRED), score_dots)
    done = CliRunner().invoke(command, ["--data-root", "a", "--pred-file", "b"])
    assert (done.exit_code, done.output) == (0, "scored a b\n")


@pytest.mark.parametrize("spec, scorer, problem", [
    # the helper's careless author: option --preds, but the scorer's argument named pred_file
    (_spec(DATA, Option("--preds", "P.", required=True)), score_dots,
     "positional names pred_file, which no option gives (the options give data_root, preds)"),
    (_spec(DATA, PRED, positional=()), lambda data_root, predictions: None,
     "missing a required argument: 'predictions'"),
    (_spec(DATA, PRED, positional=()), lambda data_root, predictions=None: None,
     "got an unexpected keyword argument 'pred_file'"),
    (_spec(DATA, PRED, Option("--width", "W.", kind="int")), score_dots,
     "got an unexpected keyword argument 'width'"),
    (_spec(DATA, PRED, progress=True), score_dots, "got an unexpected keyword argument 'progress'"),
    (_spec(DATA, positional=("data_root",)), score_dots, "missing a required argument: 'pred_file'"),
    # an attack pass: options click would take twice or the driver takes for itself
    (_spec(DATA, DATA, PRED), score_dots, "flag --data-root is declared more than once"),
    (_spec(DATA, Option("--other", "O.", name="data_root"), PRED), score_dots,
     "option value data_root is declared more than once"),
    (_spec(DATA, PRED, Option("--debug", "D.", kind="flag")), score_dots,
     "flag --debug is the driver's own (every command has it): give it another name"),
    (_spec(DATA, PRED, Option("--verbose/--help", "H.", kind="flag")), score_dots,
     "flag --help is the driver's own (every command has it): give it another name"),
    (_spec(DATA, PRED, positional=("data_root", "data_root")), score_dots,
     "positional data_root is declared more than once"),
])
def test_a_declaration_that_does_not_fit_its_scorer_is_refused_when_built(spec, scorer, problem):
    with pytest.raises(ConfigError, match="^score dots: its ScoreCommand does not fit ") as refused:
        command_of(spec, scorer)
    assert str(refused.value).endswith(problem)


def _failing(data_root, pred_file):
    return undefined_name  # noqa: F821  # the bug of a plug-in scorer


def test_a_scorer_that_fails_is_one_line_naming_it():
    command = command_of(_spec(DATA, PRED), _failing)
    done = CliRunner().invoke(command, ["--data-root", "a", "--pred-file", "b"])
    assert done.exit_code == 2
    assert done.output == (f"error: score dots: {__name__}._failing raised NameError: name 'undefined_name' is not "
                           "defined\n")
    done = CliRunner().invoke(command, ["--data-root", "a", "--pred-file", "b", "--debug"])  # where: the traceback
    assert done.exit_code == 2 and "Traceback" in done.output and "return undefined_name" in done.output


@pytest.mark.parametrize("name", benchmarks.names())
def test_every_built_in_declaration_fits_its_scorer(name):
    benchmark = benchmarks.benchmark_for(name)
    if benchmarks.origin(name) != "built in":
        pytest.skip("another package's benchmark")
    module = importlib.import_module(type(benchmark).__module__.rpartition(".")[0] + ".command")
    assert declaration_problem(module.COMMAND, benchmark.scorer()) is None


def _bad_report(score, values, echo):
    raise KeyError("no such column")


def _missing_somewhere(data_root, pred_file):
    raise FileNotFoundError("nope")


@pytest.mark.parametrize("spec, scorer, said", [
    (ScoreCommand("dots", "D.", options=(DATA, PRED), positional=("data_root", "pred_file"), report=_bad_report,
                  progress=False), score_dots, f"{__name__}._bad_report raised KeyError: 'no such column'"),
    (_spec(DATA, PRED), lambda data_root, pred_file: None, None),  # None: the report prints it (no crash)
    (_spec(DATA, PRED), _missing_somewhere, f"{__name__}._missing_somewhere raised FileNotFoundError: nope"),
])
def test_a_plug_ins_report_and_file_errors_are_one_line_naming_it(spec, scorer, said):
    done = CliRunner().invoke(command_of(spec, scorer), ["--data-root", "a", "--pred-file", "b"])
    if said is None:
        assert (done.exit_code, done.output) == (0, "scored None\n")
    else:
        assert (done.exit_code, done.output) == (2, f"error: score dots: {said}\n")


def test_a_file_a_plug_in_names_is_said_as_the_tool_says_files():
    def missing(data_root, pred_file):
        raise FileNotFoundError(2, "No such file or directory", "/nowhere/pred.json")

    done = CliRunner().invoke(command_of(_spec(DATA, PRED), missing), ["--data-root", "a", "--pred-file", "b"])
    assert (done.exit_code, done.output) == (2, "error: /nowhere/pred.json: No such file or directory\n")
