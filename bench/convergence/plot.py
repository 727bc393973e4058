#!/usr/bin/env python3
"""Draws the convergence charts from bench/results/convergence.csv and
convergence_slopes.csv (written by convergence_bench): one log-log chart per
scene, relMAE against seconds (best of each budget's renders) with error bars
of one standard deviation over the seeds, one line per method, each method's
least-squares slope of log relMSE against log seconds in its legend label
(ideal -1) with its spread over the seeds. Line style by integrator (solid:
path = NEE + MIS, dotted: nomis = NEE without MIS, dashed: bsdf), point type
by sampler (square: independent, triangle: stratified, circle: sobol).
Uses gnuplot (Debian: gnuplot-nox); standard library only.
Usage: plot.py [results_dir=bench/results] [images_dir=docs/images]"""
import csv
import os
import subprocess
import sys
import tempfile

results = sys.argv[1] if len(sys.argv) > 1 else "bench/results"
images = sys.argv[2] if len(sys.argv) > 2 else "docs/images"
os.makedirs(images, exist_ok=True)

points = {}  # scene -> method -> [(seconds, relmae, relmae_sd)]
with open(os.path.join(results, "convergence.csv")) as f:
    for r in csv.DictReader(f):
        points.setdefault(r["scene"], {}).setdefault(r["method"], []).append(
            (float(r["seconds"]), float(r["relmae"]), float(r.get("relmae_sd") or 0)))
slopes = {}
with open(os.path.join(results, "convergence_slopes.csv")) as f:
    for r in csv.DictReader(f):
        slopes[(r["scene"], r["method"])] = (float(r["slope_relmse_seconds"]),
                                             float(r.get("slope_relmse_seconds_sd") or "nan"))

titles = {
    "default": "Default scene (Cornell box, SF11 prism, gold and frosted spheres), 64x64",
    "many_lights": "Many-lights scene (1000 small emitters), 64x64",
    "env_spheres": "MetalRoughSpheresNoTextures under chinese_garden HDR, 64x64",
    "tiny_light": "Tiny light (radius 1e-3 of the scene, a normal light's power) over diffuse and glossy spheres, 64x64",
    "caustic": "Caustics: smooth and rough glass spheres under a small light, 64x64",
    "env_sun": "DamagedHelmet under chinese_garden HDR plus a distant sun, 64x64",
    "prism": "Dispersive N-SF11 prism: small white lamp, slit, spectrum on a screen (spectral), 64x64",
}
colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
           "#bcbd22", "#7f7f7f", "#000000", "#aec7e8", "#ff9896", "#98df8a"]


def style_of(method):
    integ = method.split("/")[0]
    dash = {"path": 1, "nomis": 3, "bsdf": 2}.get(integ, 1)
    pt = 9 if "/stratified" in method else 7 if "/sobol" in method else 5
    return dash, pt


with tempfile.TemporaryDirectory() as tmp:
    for scene, methods in points.items():
        plots = []
        for i, (method, pts) in enumerate(sorted(methods.items())):
            dat = os.path.join(tmp, f"{scene}_{i}.dat")
            with open(dat, "w") as d:
                for s, e, sd in sorted(pts):
                    lo = max(e - sd, e * 0.05)
                    d.write(f"{s} {e} {lo} {e + sd}\n")
            slope, slope_sd = slopes.get((scene, method), (float("nan"), float("nan")))
            dash, pt = style_of(method)
            spread = f" +-{slope_sd:.2f}" if slope_sd == slope_sd and slope_sd > 0 else ""
            label = f"{method}  (slope {slope:+.2f}{spread})"
            colour = colours[i % len(colours)]
            plots.append(f"'{dat}' using 1:2:3:4 with yerrorlines lw 2 dt {dash} pt {pt} ps 0.8 "
                         f"lc rgb '{colour}' title '{label}'")
        out = os.path.join(images, f"convergence_{scene}.png")
        script = "\n".join([
            "set terminal pngcairo size 1250,650 font 'DejaVu Sans,10' noenhanced",
            f"set output '{out}'",
            f"set title \"{titles.get(scene, scene)}\\nbars: 1 s.d. over seeds; legend: slope of log relMSE "
            f"against log time (ideal -1) +- s.d. over seeds\"",
            "set logscale xy",
            "set xlabel 'render time (s, 2 threads, loaded machine)'",
            "set ylabel 'relative mean absolute error'",
            "set grid xtics ytics mxtics mytics",
            "set key outside right top box opaque font ',9' spacing 1.1",
            "set format x '%g'",
            "set format y '%g'",
            "plot " + ", \\\n  ".join(plots),
        ])
        subprocess.run(["gnuplot"], input=script, text=True, check=True)
        print(f"wrote {out}")

# The adaptive-sampling comparison (convergence_bench ... adaptive), when it
# has been run: relMSE (left) and relMAE (right) against seconds, uniform
# (solid) against adaptive (dashed), one chart per scene.
adaptive_csv = os.path.join(results, "convergence_adaptive.csv")
if os.path.exists(adaptive_csv):
    apoints = {}
    with open(adaptive_csv) as f:
        for r in csv.DictReader(f):
            apoints.setdefault(r["scene"], {}).setdefault(r["method"], []).append(
                (float(r["seconds"]), float(r["relmse"]), float(r["relmae"])))
    aslopes = {}
    aslopes_csv = os.path.join(results, "convergence_adaptive_slopes.csv")
    if os.path.exists(aslopes_csv):
        with open(aslopes_csv) as f:
            for r in csv.DictReader(f):
                aslopes[(r["scene"], r["method"])] = float(r["slope_relmse_seconds"])
    with tempfile.TemporaryDirectory() as tmp:
        for scene, methods in apoints.items():
            bases = sorted({m[:-len("/adaptive")] if m.endswith("/adaptive") else m for m in methods})
            panels = {2: [], 3: []}
            for i, (method, pts) in enumerate(sorted(methods.items())):
                dat = os.path.join(tmp, f"{scene}_{i}.dat")
                with open(dat, "w") as d:
                    for s, e, a in sorted(pts):
                        d.write(f"{s} {e} {a}\n")
                slope = aslopes.get((scene, method), float("nan"))
                adaptive = method.endswith("/adaptive")
                base = method[:-len("/adaptive")] if adaptive else method
                style = (f"with linespoints lw 2 dt {2 if adaptive else 1} pt {7 if '/sobol' in method else 5} "
                         f"ps 0.8 lc rgb '{colours[bases.index(base) % len(colours)]}'")
                panels[2].append(f"'{dat}' using 1:2 {style} notitle")
                panels[3].append(f"'{dat}' using 1:3 {style} title '{method}  (relMSE slope {slope:+.2f})'")
            out = os.path.join(images, f"convergence_adaptive_{scene}.png")
            script = "\n".join([
                "set terminal pngcairo size 1300,620 font 'DejaVu Sans,10' noenhanced",
                f"set output '{out}'",
                "set multiplot layout 1,2 title \"" + titles.get(scene, scene) +
                "\\nuniform (solid) against adaptive sampling (dashed, targets 1.6 to 0.1, 4 to 1024 spp), "
                "same run\"",
                "set logscale xy",
                "set xlabel 'render time (s, 2 threads, loaded machine)'",
                "set grid xtics ytics mxtics mytics",
                "set format x '%g'",
                "set format y '%g'",
                "unset key",
                "set ylabel 'relMSE'",
                "plot " + ", \\\n  ".join(panels[2]),
                "set key inside bottom left box opaque font ',8' spacing 1.0",
                "set ylabel 'relative mean absolute error'",
                "plot " + ", \\\n  ".join(panels[3]),
                "unset multiplot",
            ])
            subprocess.run(["gnuplot"], input=script, text=True, check=True)
            print(f"wrote {out}")
