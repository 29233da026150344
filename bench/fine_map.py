#!/usr/bin/env python3
"""A held-out map of a well-kept machine, unlike example/ripple/shop: small
reversal values (X 1.2, Y 1.8, Z 1.5 um, each varying by 0.3 um along its
axis), a fine table (every 5 mm), positioning waves of short periods that
are no multiple of the spacing (11, 17, 13 mm, 0.8 um) on a pitch slope,
and straightness of 0.4 um that is the same in both directions. Axis-table
CSV (docs/design.md, "The axis-table map"): X 0-600, Y 0-400, Z 0-300 mm;
`E_aa^forward < E_aa^reverse` (backlash: the axis lags its command)."""
import math

print("# fine map: bench/fine_map.py")
print("axis,direction,position_mm,ex_um,ey_um,ez_um")
# axis: (index, length mm, wave period mm, reversal um, slope um/mm)
spec = {"X": (0, 600, 11.0, 1.2, 0.003), "Y": (1, 400, 17.0, 1.8, -0.002), "Z": (2, 300, 13.0, 1.5, 0.004)}
for axis, (a, length, period, back, slope) in spec.items():
    for d in ("forward", "reverse"):
        for k in range(0, length // 5 + 1):
            p = 5.0 * k
            w = math.sin(2 * math.pi * p / period + a)
            e = [0.4 * math.sin(p / 23.0 + o) for o in range(3)]
            e[a] = 0.8 * w + slope * p
            if d == "reverse":
                e[a] += back + 0.3 * math.sin(p / 45.0)
            print(f"{axis},{d},{p:g},{e[0]:.4f},{e[1]:.4f},{e[2]:.4f}")
