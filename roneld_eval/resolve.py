"""Where a benchmark's name becomes its object: once, where work enters the library (a command,
a public function, a run folder read back), and that object is then handed to each stage. The
stages (evaluation, datasets, report, cache) and the configuration never look a benchmark up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import ConfigError

if TYPE_CHECKING:
    from .benchmarks import Benchmark
    from .config import EvalConfig


def benchmark_named(name: str) -> "Benchmark":
    """The installed benchmark `name`; a ConfigError naming the installed ones for any other."""
    from .benchmarks import benchmark_for

    return benchmark_for(name)


def benchmark_of(dataset: Any) -> "Benchmark":
    """A public function's `dataset`: a benchmark's name, or the benchmark itself (as another
    function of the library handed it on); anything else is a ConfigError, as an unknown name is."""
    from .benchmarks import names

    if isinstance(dataset, str):
        return benchmark_named(dataset)
    name = getattr(dataset, "name", None)
    if isinstance(name, str) and name in names() and benchmark_named(name) is dataset:
        return dataset
    raise ConfigError(f"unknown dataset {dataset!r}; choose from {', '.join(names())}")


def configured(config: "EvalConfig", source: str | None = None) -> tuple["EvalConfig", "Benchmark"]:
    """The configuration with its benchmark's facts filled in (the benchmark bundling the fixture
    where it names none, the image size where it gives 0), checked against them, and that
    benchmark. A problem names `source`, else the file the configuration was read from."""
    from .benchmarks import default_name, names

    source = source or config.source
    try:
        name = config.dataset.name or default_name()
        if name not in names():
            raise ConfigError(f"dataset must be one of {', '.join(names())}, got {name!r}")
        benchmark = benchmark_named(name)
        width, height = benchmark.image_size
        filled = config.with_overrides(**{
            "dataset.name": name if config.dataset.name != name else None,
            "dataset.image_width": width if config.dataset.image_width == 0 else None,
            "dataset.image_height": height if config.dataset.image_height == 0 else None,
        })
    except ConfigError as error:
        raise ConfigError(f"{source}: {error}" if source else str(error)) from None
    return filled, benchmark
