"""The Munkres (Hungarian) assignment as the `munkres` package (1.1.4) computes it, step for step,
so that of several assignments of the least cost the same one is taken, as ONCE-3DLanes'
evaluator takes it: the matrix padded square with zeros, rows reduced, zeros starred in reading
order, and the search for an uncovered zero resumed where the last ended, taking the last such
zero of the first row that has one (the package scans a whole row before it stops). Costs are
Python floats and every step does the package's arithmetic in its order, so zeros appear (and
ties break) where they appear there. The pairs come as it returns them, by row."""

from __future__ import annotations

import sys
from typing import Sequence


class _Solver:
    def __init__(self, cost: Sequence[Sequence[float]]):
        width = max((len(row) for row in cost), default=0)
        self.n = n = max(width, len(cost))
        self.c = [list(row) + [0] * (n - len(row)) for row in cost] + [[0] * n for _ in range(n - len(cost))]
        self.rows, self.columns = len(cost), len(cost[0]) if cost else 0
        self.row_covered, self.column_covered = [False] * n, [False] * n
        self.marked = [[0] * n for _ in range(n)]  # 1 starred, 2 primed
        self.z0 = (0, 0)

    def solve(self) -> list[tuple[int, int]]:
        step = self._reduce_rows()
        while step != 7:
            step = {2: self._star_zeros, 3: self._cover_starred, 4: self._prime_zeros, 5: self._augment,
                    6: self._adjust}[step]()
        return [(i, j) for i in range(self.rows) for j in range(self.columns) if self.marked[i][j] == 1]

    def _reduce_rows(self) -> int:
        for row in self.c:
            least = min(row)
            for j in range(self.n):
                row[j] -= least
        return 2

    def _star_zeros(self) -> int:
        for i in range(self.n):
            for j in range(self.n):
                if self.c[i][j] == 0 and not self.column_covered[j] and not self.row_covered[i]:
                    self.marked[i][j] = 1
                    self.column_covered[j] = self.row_covered[i] = True
                    break
        self._clear_covers()
        return 3

    def _cover_starred(self) -> int:
        count = 0
        for i in range(self.n):
            for j in range(self.n):
                if self.marked[i][j] == 1 and not self.column_covered[j]:
                    self.column_covered[j] = True
                    count += 1
        return 7 if count >= self.n else 4

    def _prime_zeros(self) -> int:
        row, column = 0, 0
        while True:
            row, column = self._find_zero(row, column)
            if row < 0:
                return 6
            self.marked[row][column] = 2
            starred = self._in_row(row, 1)
            if starred < 0:
                self.z0 = (row, column)
                return 5
            column = starred
            self.row_covered[row] = True
            self.column_covered[column] = False

    def _find_zero(self, i0: int, j0: int) -> tuple[int, int]:
        """The package's __find_a_zero: rows from i0 round, columns from j0 round; in the first row
        with an uncovered zero, the last one met."""
        n = self.n
        found = (-1, -1)
        i = i0
        while True:
            j = j0
            while True:
                if self.c[i][j] == 0 and not self.row_covered[i] and not self.column_covered[j]:
                    found = (i, j)
                j = (j + 1) % n
                if j == j0:
                    break
            if found[0] >= 0:
                return found
            i = (i + 1) % n
            if i == i0:
                return found

    def _in_row(self, row: int, mark: int) -> int:
        return next((j for j in range(self.n) if self.marked[row][j] == mark), -1)

    def _augment(self) -> int:
        path = [self.z0]
        while True:
            row = next((i for i in range(self.n) if self.marked[i][path[-1][1]] == 1), -1)
            if row < 0:
                break
            path.append((row, path[-1][1]))
            path.append((row, self._in_row(row, 2)))
        for i, j in path:
            self.marked[i][j] = 0 if self.marked[i][j] == 1 else 1
        self._clear_covers()
        for marks in self.marked:
            for j in range(self.n):
                if marks[j] == 2:
                    marks[j] = 0
        return 3

    def _adjust(self) -> int:
        least: float = sys.maxsize
        for i in range(self.n):
            for j in range(self.n):
                if not self.row_covered[i] and not self.column_covered[j] and least > self.c[i][j]:
                    least = self.c[i][j]
        changed = 0
        for i in range(self.n):
            for j in range(self.n):
                if self.row_covered[i]:
                    self.c[i][j] += least
                    changed += 1
                if not self.column_covered[j]:
                    self.c[i][j] -= least
                    changed += 1
                if self.row_covered[i] and not self.column_covered[j]:
                    changed -= 2
        if changed == 0:
            raise ValueError("the assignment cannot be solved (a matrix of no finite costs?)")
        return 4

    def _clear_covers(self) -> None:
        self.row_covered = [False] * self.n
        self.column_covered = [False] * self.n


def munkres_pairs(cost: Sequence[Sequence[float]]) -> list[tuple[int, int]]:
    """munkres.Munkres().compute(cost): (row, column) pairs of a least-cost assignment of a
    rectangular matrix, by row."""
    if not cost or not cost[0]:
        return []
    return _Solver(cost).solve()
