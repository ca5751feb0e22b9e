"""Bundled configuration presets (TOML); installed as the package roneld_eval.configs."""
