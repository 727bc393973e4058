#!/usr/bin/env python3
"""Draws docs/images/traversal.png from bench/results/traversal.csv (written
by traversal_bench): per case (build or ray set) the prism/Embree speed ratio
at 1 and 2 threads as bars, with issue 11's targets as lines (1.0 for builds
on 2 threads and for incoherent and shadow rays, 1.1 for primary rays). The
error bars span the run's spread: the smallest and largest ratio of one
repetition's pair (columns ratio_min and ratio_max; absent in older files).
Uses gnuplot (Debian: gnuplot-nox); standard library only.
Usage: plot_traversal.py [results_dir=bench/results] [images_dir=docs/images]"""
import csv
import os
import subprocess
import sys
import tempfile

results = sys.argv[1] if len(sys.argv) > 1 else "bench/results"
images = sys.argv[2] if len(sys.argv) > 2 else "docs/images"
os.makedirs(images, exist_ok=True)

ratios = {}  # case -> {threads: (ratio, ratio_min, ratio_max)}
order = []
with open(os.path.join(results, "traversal.csv")) as f:
    for r in csv.DictReader(f):
        case = r["case"]
        if case not in ratios:
            ratios[case] = {}
            order.append(case)
        q = float(r["ratio"])
        ratios[case][int(r["threads"])] = (q, float(r.get("ratio_min") or q), float(r.get("ratio_max") or q))
if not order:
    sys.exit("plot_traversal.py: no rows in " + os.path.join(results, "traversal.csv"))

nan = (float("nan"),) * 3  # a thread count the file lacks
with tempfile.NamedTemporaryFile("w", suffix=".dat", delete=False) as d:
    for case in order:
        one = " ".join(str(x) for x in ratios[case].get(1, nan))
        two = " ".join(str(x) for x in ratios[case].get(2, nan))
        label = case.replace("metalroughspheres", "spheres").replace("_", " ")
        d.write(f'"{label}" {one} {two}\n')
    data = d.name
out = os.path.join(images, "traversal.png")
top = max(1.3, max(max(x[2] for x in v.values()) for v in ratios.values()) * 1.1)
script = f"""
set terminal pngcairo size 1100,{240 + 24 * len(order)} font ",10"
set output "{out}"
set title "prism / Embree 3.13.5: speed ratio per case (builds: Embree time / prism time; rays: Mrays/s)\\nprocedural and spheres 1M triangles, slivers 463k; slivers nosplit: prism without pre-splitting\\nslivers hq: Embree at its high build quality (spatial splits); slivers sbvh: the same against prism with spatial splits\\nerror bars: smallest and largest ratio of one repetition's pair (prism and Embree back to back)"
set style data histograms
set style histogram errorbars gap 1 lw 1
set style fill solid 0.8 border -1
set boxwidth 0.9
set yrange [0:{top}]
set ylabel "ratio (> 1: prism faster)"
set xtics rotate by -40 scale 0 font ",9"
set grid ytics
set key top right
set rmargin 12
set bmargin 9
plot "{data}" using 2:3:4:xtic(1) title "1 thread" lc rgb "#4878b8", "" using 5:6:7 title "2 threads" lc rgb "#e08030", \
     1.0 with lines lw 2 dt 2 lc rgb "#202020" title "target 1.0 (incoherent, shadow, 2-thread build)", \
     1.1 with lines lw 1 dt 3 lc rgb "#a00000" title "target 1.1 (primary)"
"""
subprocess.run(["gnuplot"], input=script, text=True, check=True)
os.unlink(data)
print("wrote " + out)
