#!/usr/bin/env python3
"""A large program of real CAM output: a bundled program written by a CAM
system, repeated until the result has at least LINES lines.

Every copy but the last loses its final program-end line (M2/M30 and what
follows it), so the machine runs the copies one after the other and the
interpreters read every line. The default source is CAMotics' `tiger.nc`
(a raster height-map program with a LinuxCNC header, 67,426 lines;
GPL-2.0-or-later, tests/corpus/SOURCES.md): 15 copies give 1,011,376
lines.

usage: gen_cam.py LINES [PROGRAM] > program.nc
"""
import os
import re
import sys

lines = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
here = os.path.dirname(os.path.abspath(__file__))
source = (
    sys.argv[2]
    if len(sys.argv) > 2
    else os.path.join(here, "..", "tests", "corpus", "CauldronDevelopmentLLC__CAMotics__tiger.nc")
)
with open(source, "rb") as f:
    text = f.read().splitlines(keepends=True)

end = re.compile(rb"^\s*[Mm]0*(2|30)\b")
cut = next((i for i in range(len(text) - 1, -1, -1) if end.match(text[i])), None)
if cut is None:
    sys.exit(f"{source}: no M2/M30 line to end the copies with")
body, tail = text[:cut], text[cut:]
copies = max(1, -(-(lines - len(tail)) // len(body)))
out = sys.stdout.buffer
for _ in range(copies):
    out.writelines(body)
out.writelines(tail)
