#!/usr/bin/env python3
"""Blocks of a G-code file: lines with more than comments and blanks
(parenthesised and ';' comments removed; '%' lines do not count)."""
import re, sys
def blocks(path):
    n = 0
    with open(path, 'rb') as f:
        for raw in f:
            s = re.sub(rb'\([^)]*\)', b'', raw)
            s = s.split(b';', 1)[0].strip()
            if s and s != b'%':
                n += 1
    return n
if __name__ == '__main__':
    for p in sys.argv[1:]:
        print(blocks(p), p)
