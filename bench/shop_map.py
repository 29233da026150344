#!/usr/bin/env python3
"""A held-out-like shop map: backlash that varies along each axis (X 4-7 um,
Y 2-3 um, Z 5-7 um), positioning and straightness waves of other periods than
the demo's, and straightness that jumps at a reversal."""
import math
print("axis,direction,position_mm,ex_um,ey_um,ez_um")
spec = {"X": (0, 600, 10, 23.0, 5.5, 1.5), "Y": (1, 400, 10, 17.0, 2.5, 0.5), "Z": (2, 300, 10, 13.0, 6.0, 1.0)}
for axis, (a, length, step, period, back, back_var) in spec.items():
    for d in ("forward", "reverse"):
        for k in range(0, length // step + 1):
            p = k * step
            w = math.sin(2 * math.pi * p / period)
            w2 = math.cos(2 * math.pi * p / (period * 2.7))
            e = [0.6 * w2 + 0.3 * math.sin(p / 50.0), 0.8 * w - 0.2 * w2, 0.5 * w2 + 0.4 * w]
            e[a] = 2.0 * w + 0.004 * p
            if d == "reverse":
                b = back + back_var * math.sin(p / 70.0)
                e[a] += b
                for o in range(3):
                    if o != a:
                        e[o] += 0.4 * math.cos(p / 40.0 + o)
            print(f"{axis},{d},{p:g},{e[0]:.4f},{e[1]:.4f},{e[2]:.4f}")
