"""Where a benchmark's name becomes its object: once, where work enters the library (a command,
a public function, a run folder read back), and that object is then handed to each stage. The
stages (evaluation, datasets, report, cache) and the configuration never look a benchmark up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import ConfigError

if TYPE_CHECKING:
    from .benchmarks import Benchmark
    from .config import EvalConfig


def benchmark_named(name: str | None) -> "Benchmark":
    """The installed benchmark `name` ("" or None: the one bundling the fixture, what `run`
    evaluates when told none); a ConfigError naming the installed ones for any other name."""
    from .benchmarks import benchmark_for, default_name

    return benchmark_for(name or default_name())


def configured(config: "EvalConfig", source: str | None = None) -> tuple["EvalConfig", "Benchmark"]:
    """The configuration with its benchmark's facts filled in (its name where it gives none, its
    image size where it gives 0), checked against them, and that benchmark. A problem names
    `source` (the file the configuration was read from) as reading it does."""
    from .benchmarks import names

    try:
        if config.dataset.name and config.dataset.name not in names():
            raise ConfigError(f"dataset must be one of {', '.join(names())}, got {config.dataset.name!r}")
        benchmark = benchmark_named(config.dataset.name)
        width, height = benchmark.image_size
        filled = config.with_overrides(**{
            "dataset.name": benchmark.name if config.dataset.name != benchmark.name else None,
            "dataset.image_width": width if config.dataset.image_width == 0 else None,
            "dataset.image_height": height if config.dataset.image_height == 0 else None,
        })
    except ConfigError as error:
        raise ConfigError(f"{source}: {error}" if source else str(error)) from None
    return filled, benchmark
