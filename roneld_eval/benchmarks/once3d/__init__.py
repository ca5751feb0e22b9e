"""Everything of one benchmark: its object (benchmark.py, the entry point), reader, official
metric, scorer and command, and synthetic set."""
