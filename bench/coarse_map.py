#!/usr/bin/env python3
"""A held-out map of a worn machine, unlike example/ripple/shop: large
reversal values, unequal per axis (X 12, Y 15, Z 10 um, each varying by
1.5 um along its axis), a coarse table (every 25 mm), squareness errors and
straightness that switches with the direction on every axis.

* Positioning: a pitch slope (X 0.01, Y -0.008, Z 0.012 um/mm) and a wave of
  150 mm period, 2 um.
* Squareness (docs/design.md, "The 21-component model": X the reference, Y
  moves along (S_xy, 1, 0), Z along (S_zx, S_yz, 1)): S_xy = 25 urad,
  S_zx = -15 urad, S_yz = 20 urad, written as straightness linear in the
  moving axis' position (e_x += S_xy y in Y's table, e_x += S_zx z and
  e_y += S_yz z in Z's), since a squareness is exactly that.
* Straightness that switches with the direction: every off-axis column is
  +s forward and -s in reverse (s 1-2.5 um), on top of a 0.6 um wave.
Axis-table CSV (docs/design.md, "The axis-table map"): X 0-600, Y 0-400,
Z 0-300 mm; `E_aa^forward < E_aa^reverse` (backlash)."""
import math

print("# coarse map: bench/coarse_map.py")
print("axis,direction,position_mm,ex_um,ey_um,ez_um")
S_XY, S_ZX, S_YZ = 25.0, -15.0, 20.0  # urad
# axis: (index, length mm, reversal um, slope um/mm, switching straightness [sx, sy, sz] um)
spec = {"X": (0, 600, 12.0, 0.010, [0.0, 2.0, -1.5]),
        "Y": (1, 400, 15.0, -0.008, [2.5, 0.0, 1.0]),
        "Z": (2, 300, 10.0, 0.012, [1.5, -2.0, 0.0])}
for axis, (a, length, back, slope, switch) in spec.items():
    for d in ("forward", "reverse"):
        sign = 1.0 if d == "forward" else -1.0
        for k in range(0, length // 25 + 1):
            p = 25.0 * k
            e = [0.6 * math.cos(p / 60.0 + o) + sign * switch[o] for o in range(3)]
            e[a] = slope * p + 2.0 * math.sin(2 * math.pi * p / 150.0)
            if d == "reverse":
                e[a] += back + 1.5 * math.sin(p / 90.0)
            if axis == "Y":
                e[0] += S_XY * p * 1e-3
            if axis == "Z":
                e[0] += S_ZX * p * 1e-3
                e[1] += S_YZ * p * 1e-3
            print(f"{axis},{d},{p:g},{e[0]:.4f},{e[1]:.4f},{e[2]:.4f}")
