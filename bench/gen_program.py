#!/usr/bin/env python3
"""Writes a large, realistic finishing program: a zig-zag raster over a
100 x 80 mm pocket with a gently curved floor (Z varies on every line), with
a G2/G3 arc turn at every row end, like a mould finishing pass.

usage: gen_program.py LINES > program.ngc
"""
import math
import sys

lines = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
out = sys.stdout
out.write("%\n(volcomp benchmark program)\nG21 G17 G90 G94 G54\nG0 Z5.0000\nG0 X0.0000 Y0.0000\nG1 Z0.0000 F1200\n")
n = 6
step_x = 0.5
stepover = 0.2
row = 0
x, y = 0.0, 0.0
while n < lines - 3:
    direction = 1 if row % 2 == 0 else -1
    for _ in range(200):
        x += direction * step_x
        z = -0.5 + 0.3 * math.sin(x / 15.0) * math.cos(y / 11.0)
        out.write(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f}\n")
        n += 1
    # turn with a half circle of diameter `stepover`
    y2 = y + stepover
    code = "G3" if direction == 1 else "G2"
    out.write(f"{code} X{x:.4f} Y{y2:.4f} I0.0000 J{stepover / 2:.4f}\n")
    n += 1
    y = y2
    row += 1
    if y > 80:
        y = 0.0
        out.write("G0 Z5.0000\nG0 X0.0000 Y0.0000\nG1 Z0.0000\n")
        x = 0.0
        n += 3
out.write("G0 Z5.0000\nM2\n%\n")
