"""`python -m snakesim.framework` is the `snakesim` command."""

from .cli import main

main()
