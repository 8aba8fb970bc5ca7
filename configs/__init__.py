"""Run configurations (CLI option sets) shipped with snakesim."""
