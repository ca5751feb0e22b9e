"""`roneld-eval score NAME`, one driver for every benchmark: a benchmark declares its command as
data (`ScoreCommand`: its options in order, which of them its scorer takes and how, what it prints),
and `built` makes the click command from it. The options every scorer shares (its prediction
roots, --strict, --workers, --out, the shard options, --quiet, --debug) are made here, so their
flags and wording are one thing across benchmarks.

    from roneld_eval.score_commands import Option, ScoreCommand, out, pred_roots, quiet, ...
    COMMAND = ScoreCommand("mine", "Official Mine F1 ...", options=(Option("--labels", ...), ...),
                           positional=("labels", "pred_roots"), report=print_mine)

and in the benchmark object: `score_command = declared_command(".command")`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import click

Echo = Callable[..., None]


@dataclass(frozen=True)
class Option:
    """One option as click shows and parses it. `flags`: "--list" (or "--temporal/--no-temporal");
    `name`: the value's name where it is not the flag's; `kind`: "text", "path", "float", "int",
    "flag", "choice" or "out" (an output folder); `parse`: turns the text given (None when not
    given) into the value, a ValueError saying what is wrong."""

    flags: str
    help: str
    name: str | None = None
    kind: str = "text"
    required: bool = False
    multiple: bool = False
    metavar: str | None = None
    default: Any = None
    show_default: bool = False
    choices: tuple[str, ...] = ()
    int_range: tuple[int | None, int | None] | None = None
    parse: Callable[[str | None], Any] | None = None
    flag_value: str | None = None  # the value of the option given without one (its value is optional)


@dataclass(frozen=True)
class Sharding:
    """--shard, --executor and --scheduler; `units` says what a command's whole units are."""

    units: str


@dataclass(frozen=True)
class ScoreCommand:
    """A benchmark's `score NAME`. `positional`: the names of the option values handed to its scorer
    as positional arguments, in order (the command line has options only); every other
    option's value is passed by its name, but for `driver_only` ones (and --quiet, --debug, the
    shard options, which the driver passes itself as progress/announce/shard). `prepare` adjusts the
    values first (one option becoming the scorer's argument of another name); `report` prints the
    score (warnings are printed before it, --quiet or not). `quiet_says_nothing`: --quiet also
    silences the warnings; `keeps_collections`: the process's last garbage collections run (the
    others skip them at exit: a fifth of a second)."""

    name: str
    help: str
    options: tuple[Option | Sharding, ...]
    positional: tuple[str, ...]
    report: Callable[[Any, Mapping[str, Any], Echo], None]
    prepare: Callable[[dict[str, Any]], dict[str, Any]] | None = None
    driver_only: tuple[str, ...] = ()
    progress: bool = True
    quiet_says_nothing: bool = False
    keeps_collections: bool = False
    scorer_keywords: Mapping[str, str] = field(default_factory=dict)  # option name -> the scorer's name

    @property
    def sharded(self) -> bool:
        """Whether it has the shard options (--shard, --executor, --scheduler), its scorer a `shard`."""
        return any(isinstance(option, Sharding) for option in self.options)


# ---- the options every scorer shares -------------------------------------------------------

def strict(help: str) -> Option:
    return Option("--strict", help, kind="flag")


WORKERS = Option("--workers", "Worker processes. Default: all cores.", kind="int", int_range=(1, None))


def out(help: str) -> Option:
    return Option("--out", help, kind="out")


def quiet(help: str = "No progress bar or table (warnings are still shown).") -> Option:
    return Option("--quiet", help, kind="flag")


def pred_roots(help: str, required: bool = True, metavar: str = "DIR|NAME=DIR") -> Option:
    return Option("--pred-root", help, name="pred_roots", required=required, multiple=True, metavar=metavar)


def closing_options(strict_help: str, out_help: str, units: str) -> tuple[Option | Sharding, ...]:
    """What a parallel scorer's command ends with, in this order: --strict, --workers, --out, the
    shard options, --quiet."""
    return strict(strict_help), WORKERS, out(out_help), Sharding(units), quiet()


def diagnosis(score_sweep: str | None = None) -> tuple[Option, ...]:
    """--diagnose and --loc-iou, and --score-sweep where predictions carry scores (`score_sweep`
    says which lanes a threshold keeps and where their scores are)."""
    from .metrics.lane_errors import DEFAULT_LOC_IOU, DEFAULT_SCORE_SWEEP

    options = [
        Option("--diagnose", "Also say why F1 is not higher: each false positive and false negative as an error "
               "type (Loc, Dupe, Bkg; Loc, Miss) with the F1 gained by fixing every error of that type "
               "(errors.csv, errors.md, errors.png), every frame's counts (frames.csv.gz), and the worst frames "
               "for `roneld-eval show --run OUT` (gallery.json). The official tables stay as they are.", kind="flag"),
        Option("--loc-iou", f"With --diagnose: a false positive whose IoU with its ground-truth lane is at least "
               f"this is a localisation error (Loc), below it background (Bkg). Default: {DEFAULT_LOC_IOU}.",
               kind="float", metavar="IOU"),
    ]
    if score_sweep is not None:
        options.append(Option(
            "--score-sweep", f"Precision, recall and F1 at each score threshold in one pass ({score_sweep}): "
            f"sweep_scores.csv and the PR curve sweep_scores.png, the best F1 marked as chosen on the test set. "
            f"Without a value: {DEFAULT_SCORE_SWEEP}.", metavar="START:STOP:STEP", flag_value=DEFAULT_SCORE_SWEEP))
    return tuple(options)


def echo_diagnosis(score: Any, values: Mapping[str, Any], echo: Echo, label: str | None = None) -> None:
    """What a score's --diagnose and --score-sweep say on the console (nothing without them), at
    threshold `label` (default its first), naming their files where --out was given."""
    diagnosed = getattr(score, "diagnosed", None)
    if diagnosed is None:
        return
    from .report.diagnosis import console_lines

    for line in console_lines(diagnosed, label or diagnosed.labels[0], values.get("out") is not None):
        echo(line)


def width(help: str) -> Option:
    from .config import MAX_LINE_THICKNESS

    return Option("--width", help, kind="int", default=30, show_default=True, int_range=(2, MAX_LINE_THICKNESS))


# ---- the click command ----------------------------------------------------------------------

def _parameters(option: Option | Sharding) -> list[click.Parameter]:
    from .cli import OUT_FOLDER, sharding_options

    if isinstance(option, Sharding):
        collected = sharding_options(option.units)(lambda **_: None)
        return list(reversed(_params_of(collected)))
    kind: Any = {"path": click.Path(path_type=Path), "float": float, "out": OUT_FOLDER, "text": None}.get(option.kind)
    if option.kind == "int":
        low, high = option.int_range or (None, None)
        kind = click.IntRange(min=low, max=high)
    elif option.kind == "choice":
        kind = click.Choice(option.choices)
    declarations = [option.flags] + ([option.name] if option.name else [])
    settings: dict[str, Any] = dict(help=option.help)
    if option.kind == "flag":
        settings["is_flag"] = True
    elif kind is not None:
        settings["type"] = kind
    for key in ("required", "multiple", "metavar", "show_default"):
        if getattr(option, key):
            settings[key] = getattr(option, key)
    if option.default is not None:
        settings["default"] = option.default
    if option.flag_value is not None:
        settings.update(is_flag=False, flag_value=option.flag_value)
    if option.parse is not None:
        settings["callback"] = _callback(option.parse)
    return [click.Option(declarations, **settings)]


def _params_of(decorated: Callable[..., Any]) -> list[click.Parameter]:
    """The options click's decorators attached to a function, last first."""
    return decorated.__click_params__  # type: ignore[attr-defined]


def _callback(parse: Callable[[str | None], Any]):
    def callback(context, parameter, value):
        try:
            return parse(value)
        except ValueError as error:
            raise click.BadParameter(str(error)) from None
    return callback


def built(spec: ScoreCommand, scorer: Callable[[], Callable[..., Any]]) -> click.Command:
    """The click command of `spec`; `scorer()` gives the function it calls (imported when run)."""
    from .cli import debug_option

    parameters = [parameter for option in spec.options for parameter in _parameters(option)]
    parameters += _params_of(debug_option(lambda **_: None))

    def run(**values: Any) -> None:
        _score(spec, scorer(), values)

    return click.Command(spec.name, params=parameters, callback=run, help=spec.help)


def command_of(spec: ScoreCommand, scorer: Callable[..., Any]) -> click.Command:
    """A third party's `score_command()` (roneld_eval.kit): the click command of its declaration,
    calling `scorer` with the options' values and printing what `spec.report` says of its result.
    A declaration that does not fit the scorer's signature is a ConfigError here, when the command
    is built; what the scorer or the report raises besides the tool's own errors is one line
    naming it."""
    from dataclasses import replace

    from .errors import ConfigError

    problem = declaration_problem(spec, scorer)
    if problem is not None:
        raise ConfigError(f"score {spec.name}: its ScoreCommand does not fit {_named(scorer)}: {problem}")
    guarded = replace(spec, report=_one_line_failures(spec.name, spec.report))
    return built(guarded, lambda: _one_line_failures(spec.name, scorer))


# What the driver adds to every command, or takes for itself: a declaration may not give these.
RESERVED_FLAGS = frozenset({"--debug", "--help", "-h", "--shard", "--executor", "--scheduler"})
RESERVED_NAMES = frozenset({"debug", "shard", "executor", "scheduler"})


def declaration_problem(spec: ScoreCommand, scorer: Callable[..., Any]) -> str | None:
    """Why `scorer` cannot take the arguments `spec` hands it (its positional values, the other
    options by name, progress/announce and shard where declared), or why the options cannot be a
    command (a flag or value given twice, one the driver gives), or None. The scorer of a
    declaration with a `prepare` step, which may rename values, is not checked."""
    import inspect

    problem = _options_problem(spec)
    if problem is not None or spec.prepare is not None:
        return problem
    names = {_value_name(option) for option in spec.options if isinstance(option, Option)} - {"quiet"}
    unknown = [name for name in spec.positional if name not in names]
    if unknown:
        given = ", ".join(sorted(names))
        return f"positional names {', '.join(unknown)}, which no option gives (the options give {given})"
    try:
        inspect.signature(scorer).bind(*(None for _ in spec.positional), **_keywords_handed(spec, names))
    except TypeError as error:
        return str(error)
    except ValueError:  # a builtin without a signature: nothing to check it against
        return None
    return None


def _options_problem(spec: ScoreCommand) -> str | None:
    """A flag or value name declared twice or one the driver gives itself; a positional named twice."""
    options = [option for option in spec.options if isinstance(option, Option)]
    flags = [flag for option in options for flag in option.flags.split("/")]
    names = [_value_name(option) for option in options]
    for what, given, reserved in (("flag", flags, RESERVED_FLAGS), ("option value", names, RESERVED_NAMES),
                                  ("positional", list(spec.positional), frozenset())):
        twice = sorted({item for item in given if given.count(item) > 1})
        if twice:
            return f"{what} {', '.join(twice)} is declared more than once"
        taken = sorted(set(given) & reserved)
        if taken:
            return f"{what} {', '.join(taken)} is the driver's own (every command has it): give it another name"
    return None


def _keywords_handed(spec: ScoreCommand, names: set[str]) -> dict[str, None]:
    """The keyword arguments the driver hands a scorer of `spec` whose options give `names`."""
    keywords = {spec.scorer_keywords.get(name, name): None for name in names
                if name not in spec.positional and name not in spec.driver_only}
    if spec.progress:
        keywords.update(progress=None, announce=None)
    if spec.sharded:
        keywords["shard"] = None
    return keywords


def _value_name(option: Option) -> str:
    """The name click gives an option's value: its `name`, else its first flag as an identifier."""
    return option.name or option.flags.split("/")[0].lstrip("-").replace("-", "_")


def _named(function: Callable[..., Any]) -> str:
    return f"{getattr(function, '__module__', '?')}.{getattr(function, '__qualname__', repr(function))}"


def _one_line_failures(command: str, function: Callable[..., Any]) -> Callable[..., Any]:
    """`function` (a plug-in's scorer or report), whose failures other than the tool's own errors
    (and Ctrl-C, memory, a file named) are a PluginError naming it: another package's bug is one
    line (--debug: where)."""
    import functools

    from .errors import PluginError, RoneldEvalError

    @functools.wraps(function)
    def guarded(*args: Any, **kwargs: Any) -> Any:
        try:
            return function(*args, **kwargs)
        except OSError as error:
            if getattr(error, "filename", None) is not None:
                raise  # said as "FILE: what" (a prediction file not found)
            failure: BaseException = error
        except (RoneldEvalError, MemoryError):
            raise
        except (Exception, SystemExit) as error:  # not KeyboardInterrupt: Ctrl-C is Ctrl-C
            failure = error
        from .evaluation.plugin_call import raised_text

        raise PluginError(f"score {command}: {_named(function)} raised {raised_text(failure)}") from failure
    return guarded


def _score(spec: ScoreCommand, scorer: Callable[..., Any], values: dict[str, Any]) -> None:
    from .cli import _fail, _guard, _no_collections_at_exit, shard_written
    from .cluster import executed
    from .errors import RoneldEvalError

    if not spec.keeps_collections:
        _no_collections_at_exit()
    debug, quiet = values.pop("debug"), values.pop("quiet", False)
    shard = values.pop("shard") if spec.sharded else None
    executor, scheduler = (values.pop("executor"), values.pop("scheduler")) if spec.sharded else ("local", None)
    given = dict(values)
    args, keywords = _arguments(spec, _guard(spec.prepare, debug, values) if spec.prepare else values, quiet)
    if spec.sharded:
        score = _guard(executed, debug, executor, scheduler, f"score {spec.name}", scorer, *args, **keywords,
                       shard=shard)
    else:  # a command declared without the shard options: its scorer takes no `shard`
        score = _guard(scorer, debug, *args, **keywords)
    if score is None and shard is not None:  # a shard: its part is written
        shard_written(shard, given.get("out"), quiet)
        return
    if quiet and spec.quiet_says_nothing:
        return
    for warning in getattr(score, "warnings", ()):  # never silently, --quiet or not
        click.echo(warning, err=True)
    if not quiet:
        try:
            spec.report(score, given, click.echo)
        except RoneldEvalError as error:  # a plug-in's report that failed (command_of): one line
            _fail(error, debug)


def _arguments(spec: ScoreCommand, values: dict[str, Any], quiet: bool) -> tuple[list[Any], dict[str, Any]]:
    """The scorer's arguments from the options' values: a repeatable option's as a list."""
    from .cli import _announcer

    several = {option.name or option.flags.lstrip("-").replace("-", "_") for option in spec.options
               if isinstance(option, Option) and option.multiple}
    values = {name: list(value) if name in several else value for name, value in values.items()}
    args = [values.pop(name) for name in spec.positional]
    keywords = {spec.scorer_keywords.get(name, name): value for name, value in values.items()
                if name not in spec.driver_only}
    if spec.progress:
        keywords.update(progress=not quiet, announce=_announcer(quiet))
    return args, keywords
