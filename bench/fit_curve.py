#!/usr/bin/env python3
"""Standoff against sphere count: `skinspheres fit --max-spheres N --target-standoff 0 --metrics`
for a range of budgets on each character, as a markdown table (stdout) and an SVG chart.

    bench/fit_curve.py build/samples/skinspheres --svg docs/images/standoff_curve.svg \
        builtin.glb ../shared/assets/{Xbot,CesiumMan,Soldier,RobotExpressive}.glb

Each budget is a separate fit with the tightening pass splitting while it pays up to the budget
(--target-standoff 0) and merging down to it (lib/src/tighten/merge.cc); the figures are the
independent evaluator's (lib/metrics/fit_metrics.h): union / body volume, and the union boundary's
area-weighted mean and 95th-percentile distance to the surface, relative to the body height.
Python's standard library only.
"""
import argparse
import pathlib
import re
import subprocess
import sys
import tempfile

BUDGETS = [8, 12, 16, 20, 30, 40, 60, 80, 100, 130, 160, 200, 300, 400]
TIGHTNESS = re.compile(r"tightness: (\d+) spheres; union volume / body volume = ([0-9.]+).*"
                       r"boundary to surface: mean ([0-9.]+), p95 ([0-9.]+), max ([0-9.]+)")
TIME = re.compile(r"time: import [0-9.]+ ms, fit ([0-9.]+) ms")


def fit(tool, character, budget, out):
    run = subprocess.run([tool, "fit", character, "-o", out, "--metrics", "--target-standoff", "0",
                          "--max-spheres", str(budget)], capture_output=True, text=True)
    if run.returncode != 0:
        if "is below its" in run.stderr + run.stdout:
            return None  # a budget below the character's part count is refused
        sys.exit(f"{character}: fit --max-spheres {budget} failed:\n{run.stderr}")
    m = TIGHTNESS.search(run.stdout)
    t = TIME.search(run.stdout)
    if not m or not t:
        sys.exit(f"{character}: fit printed no tightness line:\n{run.stdout}")
    spheres, volume, mean, p95, mx = m.groups()
    return {"budget": budget, "spheres": int(spheres), "volume": float(volume), "mean": float(mean),
            "p95": float(p95), "max": float(mx), "ms": float(t.group(1))}


def svg(curves, path, target):
    w, h, left, bottom, top, right = 640, 400, 60, 45, 20, 150
    xs = [r["spheres"] for rows in curves.values() for r in rows]
    ys = [100 * r["mean"] for rows in curves.values() for r in rows]
    x_max = max(200, max(xs) if xs else 0)
    y_max = max(1.0, max(ys) * 1.05 if ys else 0)

    def px(x):
        return left + (w - left - right) * x / x_max

    def py(y):
        return h - bottom - (h - bottom - top) * min(y, y_max) / y_max

    colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" '
           f'font-size="12"><rect width="{w}" height="{h}" fill="white"/>']
    out.append(f'<line x1="{left}" y1="{h - bottom}" x2="{w - right}" y2="{h - bottom}" stroke="black"/>')
    out.append(f'<line x1="{left}" y1="{top}" x2="{left}" y2="{h - bottom}" stroke="black"/>')
    for x in range(0, x_max + 1, 50):
        out.append(f'<text x="{px(x):.1f}" y="{h - bottom + 16}" text-anchor="middle">{x}</text>')
    step = 0.5 if y_max <= 4 else 1.0
    y = 0.0
    while y <= y_max:
        out.append(f'<line x1="{left}" y1="{py(y):.1f}" x2="{w - right}" y2="{py(y):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 6}" y="{py(y) + 4:.1f}" text-anchor="end">{y:g}%</text>')
        y += step
    if target <= y_max:
        out.append(f'<line x1="{left}" y1="{py(target):.1f}" x2="{w - right}" y2="{py(target):.1f}" stroke="black" '
                   f'stroke-dasharray="6 4"/>')
        out.append(f'<text x="{w - right + 10}" y="{py(target) + 4:.1f}">target {target:g}%</text>')
    out.append(f'<text x="{(left + w - right) / 2}" y="{h - 8}" text-anchor="middle">spheres</text>')
    out.append(f'<text x="14" y="{(top + h - bottom) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 14 {(top + h - bottom) / 2})">mean standoff (% of height)</text>')
    for k, (name, rows) in enumerate(curves.items()):
        c = colours[k % len(colours)]
        pts = " ".join(f"{px(r['spheres']):.1f},{py(100 * r['mean']):.1f}" for r in rows)
        out.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="2"/>')
        for r in rows:
            out.append(f'<circle cx="{px(r["spheres"]):.1f}" cy="{py(100 * r["mean"]):.1f}" r="3" fill="{c}"/>')
        out.append(f'<text x="{w - right + 10}" y="{top + 16 + 18 * k}" fill="{c}">{name}</text>')
    out.append("</svg>")
    pathlib.Path(path).write_text("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tool")
    ap.add_argument("characters", nargs="+")
    ap.add_argument("--svg")
    ap.add_argument("--target", type=float, default=0.6, help="a dashed line at this mean standoff (%% of height)")
    a = ap.parse_args()
    curves = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = str(pathlib.Path(tmp) / "set.ssb")
        for character in a.characters:
            name = pathlib.Path(character).stem
            rows = [r for r in (fit(a.tool, character, b, out) for b in BUDGETS) if r]
            # Two budgets that end at the same count: keep the first.
            kept = []
            for r in rows:
                if not kept or r["spheres"] != kept[-1]["spheres"]:
                    kept.append(r)
            curves[name] = kept
            print(f"\n### {name}\n")
            print("| budget | spheres | union / body | mean | p95 | max | fit ms |")
            print("|---|---|---|---|---|---|---|")
            for r in kept:
                print(f"| {r['budget']} | {r['spheres']} | {r['volume']:.3f} | {100 * r['mean']:.2f} % | "
                      f"{100 * r['p95']:.2f} % | {100 * r['max']:.1f} % | {r['ms']:.0f} |")
    if a.svg:
        svg(curves, a.svg, a.target)


if __name__ == "__main__":
    main()
