"""Speed of the Python surrogate calls (docs/validation/speed.md, "Python package"), on one core:

    taskset -c 0 python python/examples/bench.py
"""

import time

import numpy as np

import beltwin

s = beltwin.Surrogate.load()
s.predict(0.42)  # warm up
calls = []
for d in np.linspace(0.416, 0.424, 1000):
    t = time.perf_counter()
    s.predict(d)
    calls.append(time.perf_counter() - t)
print(f"Surrogate.predict: median {1e3 * np.median(calls):.3f} ms per call "
      f"(p95 {1e3 * np.percentile(calls, 95):.3f} ms), 1000 calls")
pts = np.column_stack([np.linspace(0.416, 0.424, 10_000)])
for samples in (100, 10, 1):
    t = time.perf_counter()
    s.predict_many(pts, samples=samples)
    print(f"Surrogate.predict_many: 10,000 points, {samples} friction samples: "
          f"{time.perf_counter() - t:.2f} s")
