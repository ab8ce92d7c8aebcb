#!/usr/bin/env python3
"""Where the union of a fit stands off the body: the mean boundary distance split by body part.

    PYTHONPATH=build/python python3 bench/python/standoff_by_part.py \
        builtin ../shared/assets/{CesiumMan,Soldier,RobotExpressive,Xbot}.glb --piece-edge 0 0.02 0.01 0.005

Each character is fitted through the Python module (`skinspheres.fit`, `--target-standoff 0` and
the budget, as docs/FIT_REPORT.md's curve), once per piece edge. The figures are computed here,
apart from the fitter and its evaluator (lib/src/metrics/):
- the rest pose: the mesh skinned with the set's rest transforms in double, by the Python tests'
  skin() (tests/python/gltf_sampler.py);
- the union's boundary: 256 Fibonacci directions on every sphere, kept where the point lies inside
  no other sphere, each standing for 4 pi r^2 / 256 of area;
- its distance to the surface: the exact distance to the nearest triangle, by brute force over
  every triangle (the nearer of its edges and, where the point projects inside it, its plane), in
  double.
The mean boundary distance is the area-weighted mean over the kept points, relative to the body
height (the set's rest extent along +Y, as the fitter reports it). Per part (the part of the sphere
a point lies on): spheres, share of the boundary area, share of the distance summed over it, and
its own mean ("n/a" where it has no exposed boundary). With --spheres PART, each sphere of that part
too, from the top down, on standard error: its centre's height, its radius, its depth (the distance
from its centre to the nearest triangle) and the mean distance of its exposed surface, all relative
to the body height. A minute or so per fit on characters of 10,000 triangles; Xbot's 49,112 take
several.
"""
import argparse
import pathlib
import sys

import numpy as np
import skinspheres

# The Python tests' skinning in float64 (tests/python/gltf_sampler.py), sharing no code with the library.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "tests" / "python"))
from gltf_sampler import skin  # noqa: E402

DIRECTIONS = 256


def fibonacci(n):
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5 ** 0.5) * i
    return np.c_[np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)]


def distance_to_triangles(points, a, b, c):
    """Distance from each point to the nearest triangle (a, b, c), in double, every triangle, in
    chunks that keep the temporaries near 100 MB: the nearer of the three edges (as segments) and,
    where the point projects inside the triangle, its plane. Degenerate triangles (zero area) are
    their edges."""
    normal = np.cross(b - a, c - a)
    nn = (normal ** 2).sum(-1)
    has_area = nn > 0
    unit = np.where(has_area[:, None], normal / np.sqrt(np.where(has_area, nn, 1.0))[:, None], 0.0)
    edges = [(a, b - a), (b, c - b), (c, a - c)]
    out = np.empty(len(points))
    step = max(1, 400_000 // len(a))
    for k in range(0, len(points), step):
        p = points[k:k + step, None, :]
        best = np.full((len(p), len(a)), np.inf)
        for start, along in edges:
            length2 = (along ** 2).sum(-1)
            t = np.clip(((p - start) * along).sum(-1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
            best = np.minimum(best, (((p - start) - t[..., None] * along) ** 2).sum(-1))
        # Inside when the point lies on the inner side of all three edges, seen along the normal.
        inside = has_area[None].repeat(len(p), 0)
        for start, along in edges:
            inside &= (np.cross(along, p - start) * normal).sum(-1) >= 0
        plane = ((p - a) * unit).sum(-1) ** 2
        best = np.where(inside, np.minimum(best, plane), best)
        out[k:k + step] = np.sqrt(best.min(1))
    return out


def measure(sphere_set, height, list_part=None):
    x = skin(sphere_set.mesh, sphere_set.joint_rest_world.astype(np.float64))
    t = sphere_set.triangles.astype(np.int64)
    centers = sphere_set.centers.astype(np.float64)
    radii = sphere_set.radii.astype(np.float64)
    u = fibonacci(DIRECTIONS)
    points, owner = [], []
    for s in range(len(radii)):
        q = centers[s] + radii[s] * u
        inside = ((q[:, None, :] - centers[None]) ** 2).sum(-1) < radii[None] ** 2
        inside[:, s] = False
        q = q[~inside.any(1)]
        points.append(q)
        owner.append(np.full(len(q), s))
    points, owner = np.concatenate(points), np.concatenate(owner)
    dist = distance_to_triangles(points, x[t[:, 0]], x[t[:, 1]], x[t[:, 2]])
    area = 4 * np.pi * radii[owner] ** 2 / DIRECTIONS
    part = sphere_set.sphere_part.astype(np.int64)
    rows = []
    total_a, total_e = area.sum(), (area * dist).sum()
    for p, name in enumerate(sphere_set.part_names):
        k = part[owner] == p
        a, e = area[k].sum(), (area[k] * dist[k]).sum()
        rows.append((name, int((part == p).sum()), a / total_a, e / total_e, e / a / height if a > 0 else None))
    if list_part is not None:
        p = sphere_set.part_names.index(list_part)
        mine = np.flatnonzero(part == p)
        depth = distance_to_triangles(centers[mine], x[t[:, 0]], x[t[:, 1]], x[t[:, 2]])
        print(f"{list_part}: centre y · radius · depth · exposed mean, relative to the height", file=sys.stderr)
        for s, d in sorted(zip(mine, depth), key=lambda sd: -centers[sd[0], 1]):
            k = owner == s
            exposed = f"{100 * (area[k] * dist[k]).sum() / area[k].sum() / height:.2f}%" if k.any() else "n/a"
            print(f"  sphere {s}: {centers[s, 1] / height:.3f} · {100 * radii[s] / height:.2f}% · "
                  f"{100 * d / height:.2f}% · {exposed}", file=sys.stderr)
    return total_e / total_a / height, rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("characters", nargs="+", help="character files; 'builtin' for the built-in character")
    ap.add_argument("--piece-edge", type=float, nargs="+", default=[0.0])
    ap.add_argument("--max-spheres", type=int, default=200)
    ap.add_argument("--target-standoff", type=float, default=0.0)
    ap.add_argument("--spheres", metavar="PART", help="also list the spheres of this part")
    args = ap.parse_args()
    print("| character | piece edge | spheres | mean | part: spheres · area share · distance share · mean |")
    print("|---|---|---|---|---|")
    for path in args.characters:
        for edge in args.piece_edge:
            fitted = skinspheres.fit(None if path == "builtin" else path, target_standoff=args.target_standoff,
                                     max_spheres=args.max_spheres, piece_edge=edge)
            if args.spheres is not None and args.spheres not in fitted.part_names:
                print(f"{path}: no part '{args.spheres}' (parts: {', '.join(fitted.part_names)})", file=sys.stderr)
                return 2
            height = fitted.fit_report["body_height"]
            mean, rows = measure(fitted, height, args.spheres)
            parts = "; ".join(f"{n} {s} · {100 * a:.0f}% · {100 * e:.0f}% · "
                              + ("n/a" if m is None else f"{100 * m:.2f}%") for n, s, a, e, m in rows)
            name = path.rsplit("/", 1)[-1]
            print(f"| {name} | {edge:g} | {len(fitted)} | {100 * mean:.2f}% | {parts} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
