#!/usr/bin/env python3
"""The ripple map of crates/volcomp-cli/tests/rs274_corpus.rs as an axis-table
CSV: 3 um positioning and 1 um straightness sine waves of 40, 30 and 25 mm
period on X, Y and Z, tabulated every 5 mm over +-20 m."""
import math
print("axis,direction,position_mm,ex_um,ey_um,ez_um")
for a, axis, period in [(0, "X", 40.0), (1, "Y", 30.0), (2, "Z", 25.0)]:
    for k in range(-4000, 4001):
        p = k * 5.0
        w = math.sin(2.0 * math.pi * p / period)
        e = [w, w, w]
        e[a] = 3.0 * w
        print(f"{axis},both,{p:g},{e[0]:.6f},{e[1]:.6f},{e[2]:.6f}")
