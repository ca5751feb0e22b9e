"""Progress bars on stderr that never stand above an error: a bar that a failure (or Ctrl-C)
stops part way is cleared, so that the command's one line saying why stands alone."""

from __future__ import annotations

import contextlib
from typing import Any, Iterator


@contextlib.contextmanager
def progress_bar(total: int, unit: str, desc: str, disable: bool | None) -> Iterator[Any]:
    """A tqdm bar of `total` `unit`s; `disable=None` shows it only where stderr is a terminal."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit=unit, desc=desc, disable=disable, dynamic_ncols=True)
    try:
        yield bar
    except BaseException:
        bar.leave = False  # closing erases the line
        raise
    finally:
        bar.close()
