"""Numbers read from a CSV data file (trajectories, friction measurements): finite floats, or an error
that says where.

A data file is written by hand or by a logger; a bad cell must name its file, line and column and
show what it holds, never surface as a bare ``float()`` error or a NaN that spoils a fit later.
"""

from __future__ import annotations

import math


def finite_number(cell: str, where: str, error: type[Exception] = ValueError) -> float:
    """``float(cell)`` when it is a finite number; else ``error`` prefixed with ``where``
    (``file:line: column 'name'``), quoting the cell as written."""
    try:
        value = float(cell)
    except ValueError:
        raise error(f"{where}: '{cell.strip()}' is not a number") from None
    if not math.isfinite(value):
        raise error(f"{where}: {cell.strip()} (values must be finite)")
    return value
