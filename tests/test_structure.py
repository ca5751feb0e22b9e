"""The run's code stays in small stages: mccabe complexity (ruff's C901) within the limits issue
23 set, measured on the source by the linter the test command already installs."""

from __future__ import annotations

import json
import subprocess
import sys

from conftest import REPO


def _too_complex(limit: int, *paths: str) -> list[str]:
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--isolated", "--select", "C901",
                           "--config", f"lint.mccabe.max-complexity = {limit}", "--output-format", "json", *paths],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode in (0, 1), done.stderr
    return [f"{item['filename']}:{item['location']['row']} {item['message']}" for item in json.loads(done.stdout)]


def test_no_stage_of_the_run_is_above_complexity_15():
    assert _too_complex(15, "roneld_eval/evaluation", "roneld_eval/api.py") == []


def test_the_orchestrators_are_at_most_complexity_10():
    found = _too_complex(10, "roneld_eval/api.py", "roneld_eval/evaluation/__init__.py")
    assert [line for line in found if "`run`" in line or "`evaluate`" in line] == []
