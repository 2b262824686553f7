#!/usr/bin/env python3
"""Peak memory of a conversion (goal: 8192x4096 -> 4096^2 within 1.2 x (input +
output)). Run in a fresh process: ru_maxrss is the process's high-water mark, so it includes
the interpreter, numpy and the module (~35 MiB) as well.

Usage: python bench/peak_memory.py [samples]
"""
import resource
import sys

import numpy as np

import spheremap as sm

samples = int(sys.argv[1]) if len(sys.argv) > 1 else 4
src = np.random.default_rng(0).random((4096, 8192, 3), dtype=np.float32)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
out = sm.convert(src, "latlong", "sphere", size=4096, samples=samples)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
total = src.nbytes + out.nbytes
print(f"latlong 8192x4096 -> sphere 4096^2, samples={samples}: input {src.nbytes / 2**20:.0f} MiB, "
      f"output {out.nbytes / 2**20:.0f} MiB, peak RSS {peak / 2**20:.0f} MiB "
      f"(before the call {before / 2**20:.0f} MiB): {peak / total:.3f} x (input + output), goal <= 1.2")
