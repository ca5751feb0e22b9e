"""The built-in methods' facts live in one table (roneld_eval/methods.py) that every stage reads,
and each accuracy gain a run reports is bootstrapped once."""

from __future__ import annotations

import ast
from pathlib import Path

from roneld_eval import api, evaluation, methods
from roneld_eval.config import EGO_LANES_ONLY, METHODS
from roneld_eval.extract.registry import methods_of

PACKAGE = Path(methods.__file__).parent


def test_config_and_registry_take_the_built_in_methods_from_the_table():
    assert METHODS == tuple(methods.METHOD_TABLE)
    assert EGO_LANES_ONLY == {"roneld", "roneld-nopft"}
    config = api.default_config().with_overrides(methods="baseline,roneld,roneld-nopft")
    built = methods_of(config)
    assert [(m.name, m.entry, m.kernel_groups) for m in built] == [
        (facts.name, facts.entry, facts.kernel_groups) for facts in methods.METHOD_TABLE.values()]


def test_no_other_module_keeps_a_table_of_the_built_in_methods():
    """A dict literal keyed by two or more built-in method names, one of them roneld-nopft, is a
    second method table ("baseline" and "roneld" alone also name configuration sections and
    kernel groups)."""
    names = set(methods.METHOD_TABLE)
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "methods.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Dict):
                keys = {key.value for key in node.keys if isinstance(key, ast.Constant)}
                if len(keys & names) >= 2 and methods.RONELD_NOPFT.name in keys:
                    found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert found == []


def test_each_gain_is_bootstrapped_once(tmp_path, monkeypatch):
    calls = []
    real = evaluation.tables.paired_bootstrap

    def counted(per_frame, thresholds, method, reference="roneld", **kwargs):
        calls.append((method, reference))
        return real(per_frame, thresholds, method, reference=reference, **kwargs)

    monkeypatch.setattr(evaluation.tables, "paired_bootstrap", counted)
    config = api.default_config().with_overrides(methods="baseline,roneld,roneld-nopft", workers=1)
    result = api.run(config, tmp_path / "out", progress=False)
    assert len(calls) == len(set(calls)) == 5  # roneld over both others; every method over baseline and roneld
    pairs = set(zip(result.gains["method"], result.gains["reference"]))
    assert pairs == {("roneld", "baseline"), ("roneld-nopft", "baseline"), ("baseline", "roneld"),
                     ("roneld-nopft", "roneld")}
