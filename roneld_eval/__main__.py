"""`python -m roneld_eval` is `roneld-eval`."""

from .console import main

main()
