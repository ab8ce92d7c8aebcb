#!/usr/bin/env python3
"""What the sphere-level exclusions hide: intersecting triangle pairs that one fit of a character
reports and its default fit does not.

    bench/hidden_contacts.py build/samples/skinspheres builtin.glb \
        ../shared/assets/{CesiumMan,Soldier,RobotExpressive}.glb

For each character, four fits (`skinspheres fit`): the default; `--no-bind-overlap`; `--piece-edge
0.03`; and both. Each plays every clip of the file (`play --clip NAME --dump`, exact refit, 30 fps),
and each reports only what its narrow phase finds behind sphere pairs its exclusions allow
(runtime/narrow_phase.h, rule 1: same joint, adjacent joints, overlapping at rest, all stated on
sphere pairs). `play --verify` shows each of those answers equal to the brute-force oracle under
the same exclusions, so every pair listed is a real intersection of the skinned mesh.

A triangle's joint is the one its three vertices weigh most in sum (ties: the lower index). A
pair is FAR when the two triangles' joints are more than the fit's adjacent_hops (1) bones apart,
which rule 1 means to report. The script counts, per character over every clip, the far
triangle-frame pairs any of the four fits reports, how many of those the default fit reports, and
those it hides by how far apart the two triangles were in the rest pose (relative to the body
height; the default's rule 3 already drops pairs that intersect at rest), with the part and joint
pairs hiding most at 5% or more. Python's standard library only; a few minutes per character.
"""
import argparse
import collections
import json
import math
import pathlib
import re
import subprocess
import sys
import tempfile

VARIANTS = {"default": [], "no bind overlap": ["--no-bind-overlap"], "pieces": ["--piece-edge", "0.03"],
            "both": ["--no-bind-overlap", "--piece-edge", "0.03"]}
REST_BINS = [0.01, 0.05, math.inf]  # rest distance / height: < 1%, 1-5%, >= 5%


def run(args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


# ---- geometry (the set's JSON: column-major 4x4 matrices, flat position and index arrays)

def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def lerp(a, d, s):
    return (a[0] + d[0] * s, a[1] + d[1] * s, a[2] + d[2] * s)


def closest_on_triangle(p, a, b, c):  # Ericson, Real-Time Collision Detection 5.1.5
    ab, ac, ap = sub(b, a), sub(c, a), sub(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0 and d2 <= 0:
        return a
    bp = sub(p, b)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return lerp(a, ab, d1 / (d1 - d3))
    cp = sub(p, c)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return lerp(a, ac, d2 / (d2 - d6))
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        return lerp(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)))
    denom = 1.0 / (va + vb + vc)
    return lerp(lerp(a, ab, vb * denom), ac, vc * denom)


def segment_distance(p1, q1, p2, q2):  # Ericson 5.1.9
    d1, d2, r = sub(q1, p1), sub(q2, p2), sub(p1, p2)
    a, e, f = dot(d1, d1), dot(d2, d2), dot(d2, r)
    if a <= 1e-30 and e <= 1e-30:
        return math.sqrt(dot(r, r))
    if a <= 1e-30:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = dot(d1, r)
        if e <= 1e-30:
            s, t = min(max(-c / a, 0.0), 1.0), 0.0
        else:
            b = dot(d1, d2)
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den != 0 else 0.0
            t = (b * s + f) / e
            if t < 0:
                s, t = min(max(-c / a, 0.0), 1.0), 0.0
            elif t > 1:
                s, t = min(max((b - c) / a, 0.0), 1.0), 1.0
    d = sub(lerp(p1, d1, s), lerp(p2, d2, t))
    return math.sqrt(dot(d, d))


def triangle_distance(A, B):
    """Distance between two triangles that do not intersect (vertex-face and edge-edge)."""
    best = math.inf
    for P, Q in ((A, B), (B, A)):
        for p in P:
            d = sub(p, closest_on_triangle(p, *Q))
            best = min(best, math.sqrt(dot(d, d)))
    for i in range(3):
        for j in range(3):
            best = min(best, segment_distance(A[i], A[(i + 1) % 3], B[j], B[(j + 1) % 3]))
    return best


class Character:
    """The mesh of a fitted set: triangles, rest positions, each triangle's joint and part."""

    def __init__(self, set_json):
        d = json.loads(pathlib.Path(set_json).read_text())
        m = d["mesh"]
        t = m["triangles"]
        self.triangles = [t[i:i + 3] for i in range(0, len(t), 3)]
        joints = d["skeleton"]["joints"]
        self.joint_names = [j["name"] for j in joints]
        self.parent = [j["parent"] for j in joints]
        self.hops_limit = d["params"].get("adjacent_hops", 1)

        def mat(x):  # column-major
            return [[x[c * 4 + r] for c in range(4)] for r in range(4)]

        def mul(a, b):
            return [[sum(a[r][k] * b[k][c] for k in range(4)) for c in range(4)] for r in range(4)]

        binds = m["binds"]
        skin = [mul(mat(joints[b["joint"]]["rest_world"]), mat(b["inverse_bind"])) for b in binds]
        p = m["positions_bind"]
        off, ib, iw = m["influence_offsets"], m["influence_binds"], m["influence_weights"]
        self.rest = []
        weight_of = []
        for v in range(len(p) // 3):
            x, acc, w = p[3 * v:3 * v + 3], [0.0, 0.0, 0.0], collections.Counter()
            for k in range(off[v], off[v + 1]):
                s = skin[ib[k]]
                for r in range(3):
                    acc[r] += iw[k] * (s[r][0] * x[0] + s[r][1] * x[1] + s[r][2] * x[2] + s[r][3])
                w[binds[ib[k]]["joint"]] += iw[k]
            self.rest.append(tuple(acc))
            weight_of.append(w)
        ys = [q[1] for q in self.rest]
        self.height = max(ys) - min(ys)
        self.joint = []
        for tri in self.triangles:
            w = collections.Counter()
            for v in tri:
                w.update(weight_of[v])
            self.joint.append(max(sorted(w), key=lambda j: w[j]))
        parts = [q["name"] for q in d["parts"]]
        self.part = {}
        for s in d["spheres"]:
            for tri in s.get("triangles", []):
                self.part[tri] = parts[s["part"]]
            pieces = s.get("pieces", [])
            for k in range(0, len(pieces), 3):
                self.part[pieces[k]] = parts[s["part"]]

    def hops(self, a, b):
        up = {}
        x, n = a, 0
        while x >= 0:
            up[x] = n
            x, n = self.parent[x], n + 1
        x, n = b, 0
        while x not in up:
            x, n = self.parent[x], n + 1
        return up[x] + n

    def far(self, t, u):
        return self.hops(self.joint[t], self.joint[u]) > self.hops_limit

    def rest_distance(self, t, u):
        return triangle_distance([self.rest[v] for v in self.triangles[t]],
                                 [self.rest[v] for v in self.triangles[u]]) / self.height


def clip_names(tool, character, spheres):
    out = run([tool, "play", character, "--spheres", spheres, "--clip", "all"])
    return re.findall(r'^clip "(.*)": \d+ frames', out, re.M)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tool")
    ap.add_argument("characters", nargs="+")
    a = ap.parse_args()
    print("| character | clips, frames | far pairs found (any fit) | default reports | hidden: rest < 1% | 1-5% | >= 5% "
          "| most hidden at >= 5% (part:joint pairs, triangle-frames) |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for character in a.characters:
            name = pathlib.Path(character).stem
            found = {}
            clips, frames = [], 0
            for k, (variant, args) in enumerate(VARIANTS.items()):
                spheres = str(pathlib.Path(tmp) / f"set{k}.json")
                run([a.tool, "fit", character, "-o", spheres] + args)
                if k == 0:
                    ch = Character(spheres)
                    clips = clip_names(a.tool, character, spheres)
                pairs = set()
                for c, clip in enumerate(clips):
                    dump = pathlib.Path(tmp) / "dump.jsonl"
                    run([a.tool, "play", character, "--spheres", spheres, "--clip", clip, "--dump", str(dump)])
                    for line in dump.read_text().splitlines():
                        f = json.loads(line)
                        frames += k == 0
                        for contact in f["contacts"]:
                            for t, u in contact["triangles"]:
                                if ch.far(t, u):
                                    pairs.add((c, f["frame"], min(t, u), max(t, u)))
                found[variant] = pairs
            union = set().union(*found.values())
            default = found["default"]
            hidden = union - default
            bins = [0] * len(REST_BINS)
            worst = collections.Counter()
            distance = {}
            for _, _, t, u in hidden:
                if (t, u) not in distance:
                    distance[(t, u)] = ch.rest_distance(t, u)
                x = distance[(t, u)]
                bins[next(i for i, b in enumerate(REST_BINS) if x < b)] += 1
                if x >= 0.05:
                    pair = sorted(f"{ch.part.get(v, '?')}:{ch.joint_names[ch.joint[v]]}" for v in (t, u))
                    worst[" / ".join(pair)] += 1
            top = "; ".join(f"{p} ({n})" for p, n in worst.most_common(3)) or "-"
            print(f"| {name} | {len(clips)}, {frames} | {len(union)} | {len(default & union)} | {bins[0]} | {bins[1]} | "
                  f"{bins[2]} | {top} |", flush=True)


if __name__ == "__main__":
    main()
