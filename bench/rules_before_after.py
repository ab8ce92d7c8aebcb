#!/usr/bin/env python3
"""What the rules on triangles report against the rules on sphere pairs before them, per character.

    bench/rules_before_after.py --before OLD/skinspheres --after build/samples/skinspheres \
        builtin.glb ../shared/assets/{CesiumMan,Soldier,RobotExpressive,Xbot}.glb

Each tool fits the character with its default settings and plays every clip of the file at 30 fps
(`play --clip NAME --dump`, exact refit); Xbot also plays Soldier's clips and Soldier Xbot's
(`--clips`), where their rigs match by name. `--before` is a build of the commit before the rules on
triangles (d579da9: exclusions on sphere pairs: same joint, adjacent joints, overlapping at rest);
`--after` this tree's. Each answer equals its own brute-force oracle (`play --verify`), so every pair
either reports is a real intersection of the skinned mesh.

Counted over every clip, in triangle-frames (a pair of triangles in one frame): what the rules before
report, what the rules now report, what now reports that before hid (by how far apart the two
triangles lay at rest, as a share of the body height: 1-5% and 5% or more; nearer than the rest gap
of 1% is never a contact now, and is counted as a check), and what before reported that now is not
a contact (their joints within one bone of each other, or nearer than 1% at rest: rules 2 and 3).
Per part pair, the frames in which `play` calls it penetrating, before and now. A triangle's joint
is the one its three vertices weigh most in sum (ties: the lower index), as contact_rules.h says.
Python's standard library only; a few seconds per character.
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

REST_BINS = [0.01, 0.05, math.inf]  # rest distance / height: < 1%, 1-5%, >= 5%
CROSS = {"Xbot": "Soldier", "Soldier": "Xbot"}  # rigs whose clips drive each other by name


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
        # The skin's joint tree (contact_rules.h): the joints bind entries name, each under its nearest
        # ancestor among them.
        named = {b["joint"] for b in d["mesh"]["binds"]}
        self.parent = []
        for j in joints:
            p = j["parent"]
            while p >= 0 and p not in named:
                p = joints[p]["parent"]
            self.parent.append(p)
        self.hops_limit = d["params"].get("contact_hops", d["params"].get("adjacent_hops", 1))

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
        while x >= 0 and x not in up:
            x, n = self.parent[x], n + 1
        return up[x] + n if x >= 0 else math.inf  # two trees: never near

    def far(self, t, u):
        return self.hops(self.joint[t], self.joint[u]) > self.hops_limit

    def rest_distance(self, t, u):
        return triangle_distance([self.rest[v] for v in self.triangles[t]],
                                 [self.rest[v] for v in self.triangles[u]]) / self.height


def clip_names(tool, character, spheres, extra):
    out = run([tool, "play", character, "--spheres", spheres, "--clip", "all", "--frames", "1"] + extra)
    return re.findall(r'^clip "(.*)": \d+ frames', out, re.M)


PENETRATING = re.compile(r"^  (\S+ - \S+): penetrating, frames .*?\((\d+) frames", re.M)


def play_all(tool, character, tmp, extra):
    """Fits with the tool's defaults; per clip the triangle-frames (clip, frame, t, u) and penetrating
    frames per part pair, summed over the clips."""
    spheres = str(pathlib.Path(tmp) / "set.json")
    run([tool, "fit", character, "-o", spheres])
    pairs, penetrating, frames = set(), collections.Counter(), 0
    clips = clip_names(tool, character, spheres, extra)
    for c, clip in enumerate(clips):
        dump = pathlib.Path(tmp) / "dump.jsonl"
        out = run([tool, "play", character, "--spheres", spheres, "--clip", clip, "--dump", str(dump)] + extra)
        for part_pair, n in PENETRATING.findall(out):
            penetrating[part_pair] += int(n)
        for line in dump.read_text().splitlines():
            f = json.loads(line)
            frames += 1
            for contact in f["contacts"]:
                for t, u in contact["triangles"]:
                    pairs.add((c, f["frame"], min(t, u), max(t, u)))
    return spheres, clips, frames, pairs, penetrating


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="the tool built from the commit before the rules on triangles")
    ap.add_argument("--after", required=True, help="this tree's tool")
    ap.add_argument("characters", nargs="+")
    a = ap.parse_args()
    rows, parts = [], []
    for character in a.characters:
        name = pathlib.Path(character).stem
        extra = []
        if name in CROSS:
            extra = ["--clips", str(pathlib.Path(character).with_name(CROSS[name] + ".glb"))]
        with tempfile.TemporaryDirectory() as tmp_before, tempfile.TemporaryDirectory() as tmp_after:
            _, clips, frames, before, pen_before = play_all(a.before, character, tmp_before, extra)
            spheres, _, _, now, pen_now = play_all(a.after, character, tmp_after, extra)
            ch = Character(spheres)
            distance = {}

            def rest(t, u):
                if (t, u) not in distance:
                    distance[(t, u)] = ch.rest_distance(t, u)
                return distance[(t, u)]

            hidden = now - before
            bins = [0] * len(REST_BINS)
            for _, _, t, u in hidden:
                x = rest(t, u)
                bins[next(i for i, b in enumerate(REST_BINS) if x < b)] += 1
            dropped = before - now
            near_joints = sum(1 for _, _, t, u in dropped if not ch.far(t, u))
            near_rest = sum(1 for _, _, t, u in dropped if ch.far(t, u) and rest(t, u) < 0.01)
            rows.append(f"| {name} | {len(clips)}, {frames} | {len(before)} | {len(now)} | {len(before & now)} | "
                        f"{bins[0]} | {bins[1]} | {bins[2]} | {near_joints} | {near_rest} | "
                        f"{len(dropped) - near_joints - near_rest} |")
            for pair in sorted(set(pen_before) | set(pen_now)):
                parts.append(f"| {name} | {pair} | {pen_before.get(pair, 0)} | {pen_now.get(pair, 0)} |")
        print(rows[-1], file=sys.stderr, flush=True)
    print("| character | clips, frames | before reports | now reports | both | now, hidden before: rest < 1% "
          "(rule 3: none) | 1-5% | >= 5% | before, not a contact now: joints within one bone | nearer than 1% at rest "
          "| other |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print()
    print("| character | part pair | penetrating frames before | now |")
    print("|---|---|---|---|")
    print("\n".join(parts))


if __name__ == "__main__":
    main()
