#!/usr/bin/env python3
"""Turns the "STABILITY |" lines the stability suite prints into the markdown
table of docs/stability.md:

    build/tests/prism_test_renders '[stability]' | python3 scripts/stability_table.py
"""
import sys


def main():
    print("| case | method | mean | reference | (mean - ref) / σ | firefly ratio | non-finite | bounded |")
    print("|---|---|---|---|---|---|---|---|")
    for line in sys.stdin:
        if not line.startswith("STABILITY |"):
            continue
        f = [x.strip() for x in line.split("|")[1:]]
        case, method = f[0], f[1]
        val = {}
        for item in f[2:-1]:  # the last field is the free-text note
            k, _, v = item.partition(" ")
            val[k] = v
        note = f[-1]
        bound = val.get("bound", "-")
        bounded = f"firefly ≤ {float(bound):.3g}" if bound not in ("-", "") else "reported"
        if note:
            bounded += f"; {note}"
        z = val.get("z", "")
        print(f"| {case} | {method} | {val.get('mean', '')} ± {val.get('sigma', '')} | {val.get('ref', '')} | {z} "
              f"| {val.get('firefly', '')} | {val.get('non-finite', '')} | {bounded} |")


if __name__ == "__main__":
    main()
