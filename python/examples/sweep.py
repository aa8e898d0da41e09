"""Sweep the centre distance with the shipped surrogate and plot the slip distribution.

    python python/examples/sweep.py [out.png]

Needs matplotlib (pip install matplotlib). The looseness knee shows as the rise of slip and
of its spread at the short end of the distance range.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import beltwin

surrogate = beltwin.Surrogate.load()  # the shipped model (default HVAC drive)
d_range = surrogate.ranges["center_distance_m"]
d = np.linspace(d_range[0], d_range[1], 200)
# Loosest installation of the trained box: the knee lies inside the distance range.
tension_n = 180.0
pred = surrogate.predict_many(np.column_stack([d, np.full_like(d, 0.7), np.full_like(d, tension_n)]),
                              allow_extrapolation=True)
q = pred["quantiles_pct"]

fig, ax = plt.subplots(figsize=(7, 4))
ax.fill_between(d * 1e3, q[:, 0], q[:, 4], alpha=0.25, label="p05-p95")
ax.fill_between(d * 1e3, q[:, 1], q[:, 3], alpha=0.45, label="p25-p75")
ax.plot(d * 1e3, pred["mean_slip_pct"], "k-", lw=1.2, label="mean")
outside = pred["extrapolating"]
if outside.any():
    ax.plot(d[outside] * 1e3, pred["mean_slip_pct"][outside], "r.", ms=2, label="extrapolating")
ax.set_xlabel("centre distance d (mm)")
ax.set_ylabel("steady slip (%)")
ax.set_title(f"Shipped surrogate, mu 0.7, installation tension {tension_n:.0f} N")
ax.legend()
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "slip-sweep.png"
fig.savefig(out, dpi=120)
print(f"wrote {out}")
