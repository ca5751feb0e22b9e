"""The runs of one model on one dataset (a Group) and how tables name and order their methods:
what compare's grids and each benchmark's official table (Benchmark.official_comparison) share."""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal
from typing import Iterable, Sequence, TypeVar

from ..benchmarks import names as benchmark_names
from ..methods import ABLATION_PAIR, METHOD_TABLE, PAPER_PAIR, facts_of
from ..report.tables import display_name
from .runs import Run
from .tables import Stat, wrap_words

PAPER_METHODS = PAPER_PAIR  # the paper's pair: the model's own extraction, and RONELD
ABLATION_METHOD = ABLATION_PAIR[0]  # RONELD without preceding-frame tracking (Table IV)
KNOWN_METHODS = tuple(METHOD_TABLE)
Found = TypeVar("Found")


@dataclass(frozen=True, eq=False)
class Group:
    """The runs of one model (label) on one dataset: one run, or several seeds or checkpoints."""

    dataset: str
    label: str
    runs: tuple[Run, ...]

    @property
    def n(self) -> int:
        return len(self.runs)

    @property
    def methods(self) -> tuple[str, ...]:
        return self.runs[0].methods

    @property
    def dataset_name(self) -> str:
        """How tables and titles name its dataset: its benchmark's display name."""
        return self.runs[0].dataset_name

    def title(self) -> str:
        return self.label if self.n == 1 else f"{self.label}, n = {self.n}"

    def accuracy(self, method: str, threshold: Decimal) -> Stat:
        return Stat(tuple(_accuracy_of(run, method)[threshold] for run in self.runs))


def _groups(runs: Sequence[Run]) -> list[Group]:
    """Runs grouped by dataset (the installed benchmarks in their order, then others) and label,
    in the order given."""
    order = {name: index for index, name in enumerate(benchmark_names())}
    datasets = sorted(dict.fromkeys(r.dataset for r in runs),
                      key=lambda d: (order.get(d, len(order)), [r.dataset for r in runs].index(d)))
    groups = []
    for dataset in datasets:
        members = [r for r in runs if r.dataset == dataset]
        for label in dict.fromkeys(r.label for r in members):
            groups.append(Group(dataset, label, tuple(r for r in members if r.label == label)))
    return groups


def ordered_methods(methods: Iterable[str]) -> list[str]:
    methods = list(dict.fromkeys(methods))
    return [m for m in KNOWN_METHODS if m in methods] + [m for m in methods if m not in KNOWN_METHODS]


def _accuracy_of(run: Run, method: str) -> dict[Decimal, float]:
    return run.column(method, "accuracy")


def _column_of(run: Run, method: str, column: str) -> dict[Decimal, float]:
    return run.column(method, column)


def method_header(method: str, label: str) -> tuple[str, ...]:
    """A method's header lines under its model's spanning header."""
    facts = facts_of(method)
    return wrap_words(method) if facts is None else facts.header


def method_name(method: str, label: str) -> str:
    """A method's name in Markdown headers and legends: 'SCNN + RONELD', 'SCNN polyfit'."""
    name = display_name(method, label)
    return name if method in KNOWN_METHODS or name.startswith(label) else f"{label} {name}"


def all_found(found: Sequence[Found | None]) -> list[Found] | None:
    """`found` when every run has the value, else None (the table shows a dash)."""
    present = [f for f in found if f is not None]
    return present if len(present) == len(found) else None
