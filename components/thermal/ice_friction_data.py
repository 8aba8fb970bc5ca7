"""The ice-on-ice kinetic friction table the ice-friction law interpolates, with where each number is from.

Source: E. M. Schulson and A. L. Fortt, "Friction of ice on ice", J. Geophys. Res. 117, B12204 (2012).
What was found and read (its abstract, via the search tool): freshwater polycrystalline ice sliding on
itself at 5e-8 to 1e-3 m/s, 98 to 263 K, normal stress ≤ 98 kPa; "the coefficient of kinetic friction of
smooth surfaces varies from μk = 0.15 to 0.76"; at ≥ 223 K velocity strengthening below 1e-5 to 1e-4 m/s
and velocity weakening above; at 173 and 133 K no significant velocity dependence; at 98 K moderate
strengthening at the lowest and highest velocities, none in between; static friction grows with log hold
time; μk ∝ Ra^0.08.

The paper's figures (the individual points) were NOT available here. The table below is therefore a
coarse anchor set built from the abstract's statements, not a digitisation:
  * the range endpoints 0.15 and 0.76 are the abstract's; which temperature carries which (μk rising as
    the ice gets colder: 0.15 at 263 K, 0.76 at 98 K) is this table's assumption, as are the intermediate
    values (a monotone interpolation between them);
  * the velocity dependence encodes the abstract's shape: at 263 K and 223 K a peak at 1e-5 m/s (inside
    the stated 1e-5 to 1e-4 window) falling on both sides; flat at 173 and 133 K; at 98 K flat in the
    middle and +0.04 at the ends (the "moderate" strengthening's size is assumed).
The scatter the table is held to (``SCATTER``) is also an assumption (±0.05 in μk), not the paper's.
Replace the rows with the paper's figure values when they are at hand; the law and its test read only this.

A second search (issue 28's follow-up: Schulson & Fortt's figures; Kennedy, Schulson & Jones 2000; Maeno et
al. 2003) found no data points either, only abstracts. One abstract gives numbers: ice-on-ice kinetic friction
at 1e-4 to 1e-1 m/s and −1 to −27 °C (Seppyo, J. Japan. Soc. Snow Ice, 61 (6), abstract on J-STAGE,
https://www.jstage.jst.go.jp/browse/seppyo/61/6/_contents/-char/en; the excerpt found names no authors):
μk rises as the speed falls, "from 0.01 at 1e-1 m/s to 0.15 at 1e-4 m/s at −12 °C", lowest at −5 °C.
``CHECK_POINTS`` holds its in-range point, an independent check of the table (test_ice_friction.py). Its
fast point is outside the table: the law keeps the 1e-3 m/s value above 1e-3 m/s (0.156 at 261 K against the
0.01 measured at 0.1 m/s), so faster slip, where frictional melting lubricates, is overestimated.
"""

from __future__ import annotations

import numpy as np

#: velocities of the table's columns, m/s (within the measured 5e-8 .. 1e-3 m/s)
SPEEDS = np.array([5e-8, 1e-6, 1e-5, 1e-4, 1e-3])
#: temperatures of the table's rows, K (the measured 98 .. 263 K)
TEMPERATURES = np.array([98.0, 133.0, 173.0, 223.0, 263.0])
#: μk[row, column]
MU_K = np.array([
    [0.76, 0.72, 0.72, 0.72, 0.76],     # 98 K: moderate strengthening at both ends, flat between (assumed sizes)
    [0.60, 0.60, 0.60, 0.60, 0.60],     # 133 K: no significant velocity dependence
    [0.48, 0.48, 0.48, 0.48, 0.48],     # 173 K: no significant velocity dependence
    [0.30, 0.34, 0.38, 0.34, 0.28],     # 223 K: strengthening to ~1e-5 m/s, weakening above
    [0.17, 0.20, 0.24, 0.19, 0.15],     # 263 K: as 223 K, lower (range end 0.15 at the fastest)
])
#: ± in μk the law must reproduce the table's points within (assumed, see above)
SCATTER = 0.05
#: (T K, v m/s, μk, source) published points not used to build the table, within its range
CHECK_POINTS = ((261.15, 1e-4, 0.15, "Seppyo 61 (6), J-STAGE abstract: -12 C, 1e-4 m/s"),)
CITATION = "Schulson & Fortt, J. Geophys. Res. 117, B12204 (2012), abstract; table values assumed (see module)"
