"""Progress bars on stderr, the same for every command: drawn only where stderr is a terminal (in
a pipe or a log a bar is one line that grows by a redraw every tenth of a second: 30 KB for `synth
--dataset vil100`), and never standing above an error: a bar that a failure (or Ctrl-C) stops
part way is cleared, so that the command's one line saying why stands alone."""

from __future__ import annotations

import contextlib
import sys
from typing import Any, Iterator


def stderr_is_terminal() -> bool:
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced by an object without isatty, or closed
        return False


@contextlib.contextmanager
def progress_bar(total: int, unit: str, desc: str, wanted: bool = True) -> Iterator[Any]:
    """A tqdm bar of `total` `unit`s, drawn when `wanted` (not --quiet) and stderr is a terminal;
    otherwise one that counts and draws nothing."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit=unit, desc=desc, disable=not (wanted and stderr_is_terminal()), dynamic_ncols=True)
    try:
        yield bar
    except BaseException:
        bar.leave = False  # closing erases the line
        raise
    finally:
        bar.close()
