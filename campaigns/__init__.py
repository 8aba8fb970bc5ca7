"""snakesim.campaigns: Monte Carlo dispersions and parameter sweeps (``snakesim sweep``).

dispersions.py  the dispersion file, distributions, per-run seeded samples, LHS and grid designs
metrics.py      a run's metrics: reductions of its recorded signals, values of its reports
runner.py       one run on a worker (build or reuse, run, reduce; never raises)
backends.py     local process pool or Dask distributed, one executor interface
results.py      campaign identity, append-only run records, the Parquet/CSV table
report.py       sensitivity ranking, summary and PNG plots
campaign.py     checks up front, then the run loop with resume and progress
cli.py          ``snakesim sweep``; plugin.py registers it (entry point ``campaigns``)
"""
