#!/usr/bin/env python3
"""A short program whose while-loop executes N motions (default 1,000,000).

Parameters, expressions and an o-word loop: the interpreter evaluates every
line on every pass, so this measures the cost of reading a program whose
motion comes from control flow (BENCHMARKS.md, "Control flow").
A zig-zag raster: N/2 passes of two feed moves, X from 0 to 100 mm and back,
stepping Y by 0.01 mm, the Z floor a function of Y.
"""
import sys

n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
print(f"""(raster of {n} feed moves from one while loop)
G21 G90 G17 G94
#<passes> = {n // 2}
#<step> = 0.01
#1 = 0
G0 X0 Y0 Z5
G1 Z0 F1200
o100 while [#1 LT #<passes>]
  #<y> = [#1 * 2 * #<step>]
  G1 X100 Y#<y> Z[-0.5 * SIN[#<y> * 3]]
  G1 X0 Y[#<y> + #<step>]
  #1 = [#1 + 1]
o100 endwhile
G0 Z5
M2""")
