#!/usr/bin/env python3
"""The f64 arithmetic a callgrind profile executed in one binary.

    scripts/flops.py PROFILE BINARY

PROFILE is a callgrind output written with `--dump-instr=yes --dump-line=no`; BINARY the
profiled program. Prints two numbers: the instructions executed in BINARY's own code, and
the f64 operations among them: each lane of an add, subtract, multiply, divide, square
root, minimum or maximum counts one, each lane of a fused multiply-add two (scalar `sd`
one lane, `pd` two on xmm and four on ymm registers). Moves, shuffles, comparisons and
conversions count none. Used by `scripts/bench-methods.sh --instructions`.
"""

import re
import subprocess
import sys
from collections import defaultdict

ARITHMETIC = re.compile(r"^v?(add|sub|mul|div|sqrt|min|max)(sd|pd)$")
FUSED = re.compile(r"^vf(n?m(add|sub)|maddsub|msubadd)(132|213|231)(sd|pd)$")


def executed(profile, binary):
    """Instructions executed per address of `binary` (its file addresses)."""
    counts = defaultdict(int)
    objects, current, address, skip = {}, None, 0, False
    with open(profile) as lines:
        for line in lines:
            if line.startswith(("ob=", "cob=")):
                # An object's name comes with its first id, in either kind of line.
                m = re.match(r"c?ob=\((\d+)\)\s*(.*)", line.strip())
                if m.group(2):
                    objects[m.group(1)] = m.group(2)
                if line.startswith("ob="):
                    current = objects[m.group(1)]
                continue
            if line.startswith("calls="):
                skip = True
                continue
            head = line[:1]
            if not (head == "+" or head == "-" or head == "*" or line.startswith("0x")):
                continue
            fields = line.split()
            position = fields[0]
            if position.startswith("0x"):
                address = int(position, 16)
            elif position[0] in "+-":
                address += int(position)
            if skip:
                # The line after `calls=` is the callee's inclusive cost at the call site.
                skip = False
                continue
            if current == binary and len(fields) > 1:
                counts[address] += int(fields[1])
    return counts


def lanes(mnemonic, operands):
    """f64 operations of one instruction."""
    width = 4 if "ymm" in operands else 2
    if ARITHMETIC.match(mnemonic):
        return 1 if mnemonic.endswith("sd") else width
    if FUSED.match(mnemonic):
        return 2 * (1 if mnemonic.endswith("sd") else width)
    return 0


def main():
    profile, binary = sys.argv[1], sys.argv[2]
    counts = executed(profile, binary)
    start, stop = min(counts), max(counts) + 16
    dump = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", f"--start-address={start}",
         f"--stop-address={stop}", binary],
        capture_output=True, text=True, check=True,
    ).stdout
    instructions = sum(counts.values())
    operations = 0
    for line in dump.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(\S+)\s*(.*)", line)
        if m and (n := counts.get(int(m.group(1), 16))):
            operations += n * lanes(m.group(2), m.group(3))
    print(instructions, operations)


if __name__ == "__main__":
    main()
