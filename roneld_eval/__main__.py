"""`python -m roneld_eval` is `roneld-eval`."""

from .cli import main

main()
