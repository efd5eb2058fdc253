"""What calling `simulate` from Python costs over the Rust call.

1e7 force samples (a 150 Hz sine at 100 kHz, 300 N) through the paper's
SDOF with a Jenkins joint and through the linear SDOF alone. Each round
times `hystid.simulate` from Python (wall time around the call: argument
conversion, the read-only view of the force, the output array) and the
library's own `hystid::sim::simulate` timed inside Rust on the same array
(`_hystid._rust_simulate_seconds`), alternately; the medians are compared.
Prints figures only (no asserts): run it on an idle machine and quote the
load (`uptime`) with them.

    python python/benches/simulate_overhead.py [rounds]
"""

import os
import statistics
import sys
import time

import numpy as np

import hystid
from hystid import _hystid

N = 10_000_000
FS = 100_000.0
ROUNDS = int(sys.argv[1]) if len(sys.argv) > 1 else 9

force = 300.0 * np.sin(2 * np.pi * 150.0 * np.arange(N) / FS)
models = {
    "jenkins": hystid.model(
        {
            "system": {"mass": 10.0, "damping": 200.0, "stiffness": 1e7},
            "joint": {"kind": "jenkins", "kd": 2.4e7, "fd": 246.048},
        }
    ),
    "linear": hystid.model({"system": {"mass": 10.0, "damping": 200.0, "stiffness": 1e7}}),
}

print(f"load average before: {os.getloadavg()}")
for name, m in models.items():
    hystid.simulate(m, force, FS)  # warm-up: pages, caches
    py, rust = [], []
    for _ in range(ROUNDS):
        t0 = time.perf_counter()
        x = hystid.simulate(m, force, FS)
        py.append(time.perf_counter() - t0)
        del x
        rust.append(_hystid._rust_simulate_seconds(m, force, FS))
    p, r = statistics.median(py), statistics.median(rust)
    print(
        f"{name:8s} 1e7 samples: Python {p * 1e3:8.2f} ms, Rust {r * 1e3:8.2f} ms "
        f"(medians of {ROUNDS}), overhead {100 * (p / r - 1):+.2f} % "
        f"[Python min {min(py) * 1e3:.2f} ms, Rust min {min(rust) * 1e3:.2f} ms]"
    )
# a short call, as a Python loop over many small simulations makes it: the
# fixed cost of a call (argument conversion, the worker thread that lets
# Ctrl-C and `progress=` through, the output array)
short = force[:1000]
m = models["jenkins"]
calls = 2000
py, rust = [], []
for _ in range(ROUNDS):
    t0 = time.perf_counter()
    for _ in range(calls):
        hystid.simulate(m, short, FS)
    py.append((time.perf_counter() - t0) / calls)
    rust.append(statistics.median(_hystid._rust_simulate_seconds(m, short, FS) for _ in range(calls)))
p, r = statistics.median(py), statistics.median(rust)
print(f"jenkins  1e3 samples: Python {p * 1e6:8.2f} us, Rust {r * 1e6:8.2f} us per call (medians of {ROUNDS})")
print(f"load average after: {os.getloadavg()}")
