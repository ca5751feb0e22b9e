"""compare's official table for benchmarks whose official.csv has rows per method, lanes ('all',
'ego') and threshold: a row per model, method and lanes, a column per (threshold, score)."""

from __future__ import annotations

from typing import Sequence


def lanes_grid(groups, wanted: Sequence[tuple[str, str]], headers: Sequence[str]):
    """`wanted`: (threshold label as official.csv writes it, column) of each grid column, shown in
    percent under `headers`."""
    from ..comparison.groups import all_found, method_name, ordered_methods
    from ..comparison.tables import EMPTY, Cell, Column, Grid, Stat, Text

    rows: list[tuple[Cell, ...]] = []
    for group in groups:
        for method in ordered_methods(group.methods):
            title = method_name(method, group.label) + ("" if group.n == 1 else f" (n = {group.n})")
            for lanes in ("all", "ego"):
                cells: list[Cell] = [Text(title), Text(lanes)]
                for threshold, column in wanted:
                    hits = []
                    for run in group.runs:
                        table = run.official
                        hit = table[(table["method"] == method) & (table["category"] == lanes)
                                    & (table["threshold"] == threshold)]
                        hits.append(None if hit.empty or column not in hit.columns else hit.iloc[0])
                    found = all_found(hits)
                    cells.append(EMPTY if found is None else
                                 Stat(tuple(float(f[column]) for f in found), decimals=2, scale=100))
                rows.append(tuple(cells))
    columns = tuple(Column(f"{header} (%)", (header,)) for header in headers)
    return Grid((Column("Method", ("Method",)), Column("Lanes", ("Lanes",))), columns, tuple(rows))
