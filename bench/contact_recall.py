#!/usr/bin/python3
"""Contact recall: an independent check of the triangle contacts `skinspheres play` reports.

Written apart from the product (Python 3.11, numpy and the standard library only). It uses the tool
only to fit, to play (its --dump is what is checked) and to write the played clips as a GLB
(`play --export-glb`, which holds the character's node tree and every clip the tool played,
retargeted clips included). Everything else is done here, in float64:

  * the poses: the exported GLB is read and sampled by the Python tests' own glTF sampler
    (tests/python/gltf_sampler.py: LINEAR with slerp, STEP, CUBICSPLINE) at each dumped frame's
    clip_time; the world matrices are composed down the node tree. They are checked against the rest transforms the set
    stores and against the joint positions the tool dumps (max deviation printed).
  * the mesh: read from the sphere set JSON the tool writes (bind positions, bind entries with
    inverse binds, influences, triangles, the skeleton's parents and rest world transforms), and
    skinned here by linear blend skinning: p = sum_k w_k * G[joint(k)] * IBM_k * p_bind.
  * the contacts: every triangle pair whose boxes overlap (a sort-and-sweep broad phase of its own)
    that is not excluded by rule 1 (a vertex with the same rest position) or rule 2 (triangle
    joints at most `hops` bones apart in the skin's joint tree) is tested for intersection with a
    separating-axis test on 17 axes (both normals, the 9 edge-edge cross products, and the 6
    in-plane edge normals for coplanar pairs); touching counts. An intersecting pair is dropped by
    rule 3 when, at rest, the triangles intersect or lie closer than the rest gap (1% of the rest
    height, the extent along +Y of the mesh at rest), by an exact float64 triangle-triangle distance
    (9 segment-segment and 6 point-triangle distances).

The product's contact code is never called (not through the tool, not through the Python module).

Comparison, per frame: mine (the pairs above) against the tool's (`--dump` "contacts"/"triangles").
A disagreement is "near tolerance" when it is within TAU = 1e-6 of the rest height of flipping:
a pair I find intersecting by at most TAU (its separating-axis overlap) that the tool leaves out, or a
pair the tool reports that I find apart by at most TAU. Reported pairs I find further apart are
precision failures ("apart"); reported pairs I find intersecting but excluded by a rule are counted
by rule; pairs I find that the tool leaves out and that hold a zero-area triangle (a repeated vertex)
are counted apart (triangle_contact.h says such a triangle never intersects; the three rules do not).
The strict subset: my pairs at least 1% of the rest height apart at rest and more than one bone apart.

A case fits the character three times (default; --max-spheres N, N = the parts that own triangles;
--piece-edge 0.02), dumps every frame of every clip given in each mode with each fit, compares the
three fits' pairs on every dumped frame, and checks my pairs on at most --budget frames (each clip's
share, frames spread evenly over it: round(linspace(0, n - 1, k))). Tool outputs are cached in --work.

Usage (Debian's /usr/bin/python3, which has numpy):
  contact_recall.py case CHARACTER --tool T --work DIR --name NAME --clip-indices 0,1 [--clips FILE]
                         [--budget 40] [--modes exact,fast] --out RESULT.json
      (with --clips, the other file's clips come after the character's own: `play --clip N` lists them)
  contact_recall.py investigate --set S.json --glb G.glb --dump D.jsonl --clip C --frame F T U
      (one pair: both triangles' coordinates, my answers, the tool's)
  contact_recall.py table RESULT.json ...      (markdown table of the results)
  contact_recall.py selftest                    (the geometry against independent tests)
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

TAU_SHARE = 1e-6  # near-tolerance band, share of the rest height
GAP_SHARE = 0.01  # rule 3's rest gap, share of the rest height (the brief's rule)
HOPS = 1  # rule 2


# ----------------------------------------------------------------------------------------------
# Poses: the Python tests' glTF sampler (tests/python/gltf_sampler.py: numpy, no product code)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "python"))
from gltf_sampler import Gltf  # noqa: E402


def world(glb, anim=None, t=0.0):
    """Every node's world matrix, (nodes, 4, 4) float64, at t seconds of animation anim (None: rest)."""
    return np.stack(glb.world(anim, t))


# ----------------------------------------------------------------------------------------------
# The sphere set's mesh and skeleton


def colmajor(m16):
    return np.array(m16, np.float64).reshape(4, 4).T


class Mesh:
    def __init__(self, set_path):
        d = json.load(open(set_path))
        self.doc_version = d["version"]
        self.rules = d.get("contact_rules")
        sk = d["skeleton"]["joints"]
        self.joint_names = [j["name"] for j in sk]
        self.joint_parent = np.array([j["parent"] for j in sk], np.int64)
        self.rest_world = np.stack([colmajor(j["rest_world"]) for j in sk])
        m = d["mesh"]
        self.tris = np.array(m["triangles"], np.int64).reshape(-1, 3)
        self.bind_pos = np.array(m["positions_bind"], np.float64).reshape(-1, 3)
        self.bind_joint = np.array([b["joint"] for b in m["binds"]], np.int64)
        self.ibm = np.stack([colmajor(b["inverse_bind"]) for b in m["binds"]])
        off = np.array(m["influence_offsets"], np.int64)
        ib = np.array(m["influence_binds"], np.int64)
        iw = np.array(m["influence_weights"], np.float64)
        V = len(self.bind_pos)
        K = int(np.diff(off).max()) if V else 0
        self.inf_b = np.zeros((V, K), np.int64)
        self.inf_w = np.zeros((V, K), np.float64)
        cnt = np.diff(off)
        for k in range(K):
            has = cnt > k
            self.inf_b[has, k] = ib[off[:-1][has] + k]
            self.inf_w[has, k] = iw[off[:-1][has] + k]
        self.parts = d["parts"]
        self.sphere_part = [s["part"] for s in d["spheres"]]
        self.sphere_tris = [len(s.get("triangles", [])) for s in d["spheres"]]
        # parts with triangles (the --max-spheres floor)
        have = set()
        for p, n in zip(self.sphere_part, self.sphere_tris):
            if n:
                have.add(p)
        self.parts_with_triangles = len(have)
        self.pieces = any("pieces" in s for s in d["spheres"])

    def signature(self):
        return (
            self.tris.tobytes(),
            self.bind_pos.tobytes(),
            self.bind_joint.tobytes(),
            self.ibm.tobytes(),
            self.inf_b.tobytes(),
            self.inf_w.tobytes(),
            self.rest_world.tobytes(),
            tuple(self.joint_names),
            self.joint_parent.tobytes(),
        )

    def skin(self, G):
        """G: (J, 4, 4) joint world matrices, float64. Returns (V, 3) float64."""
        M = G[self.bind_joint] @ self.ibm  # (B, 4, 4)
        p = np.zeros_like(self.bind_pos)
        for k in range(self.inf_b.shape[1]):
            Mk = M[self.inf_b[:, k]]
            q = np.einsum("vij,vj->vi", Mk[:, :3, :3], self.bind_pos) + Mk[:, :3, 3]
            p += self.inf_w[:, k : k + 1] * q
        return p


# ----------------------------------------------------------------------------------------------
# The rules' static parts


def triangle_joints(mesh):
    """Per triangle: the joint with the largest weight summed over its 3 vertices (ties: lower joint
    index), -1 for a triangle without weight."""
    J = len(mesh.joint_names)
    T = len(mesh.tris)
    acc = np.zeros((T, J))
    for c in range(3):
        v = mesh.tris[:, c]
        for k in range(mesh.inf_b.shape[1]):
            j = mesh.bind_joint[mesh.inf_b[v, k]]
            np.add.at(acc, (np.arange(T), j), mesh.inf_w[v, k])
    best = acc.max(axis=1)
    tj = np.argmax(acc, axis=1)  # first maximum: the lower joint index
    tj[best <= 0] = -1
    # near ties (for diagnosis): second largest within 1e-6 of the largest
    s = np.sort(acc, axis=1)
    near_tie = (s[:, -1] - s[:, -2] <= 1e-6 * np.maximum(s[:, -1], 1e-30)) & (best > 0) if J > 1 else np.zeros(T, bool)
    return tj, near_tie


def skin_tree_parent(mesh):
    """Per skeleton joint named by a bind entry: its nearest ancestor among those joints (-1)."""
    J = len(mesh.joint_names)
    named = np.zeros(J, bool)
    named[mesh.bind_joint] = True
    par = np.full(J, -1, np.int64)
    for j in range(J):
        if not named[j]:
            continue
        p = mesh.joint_parent[j]
        while p >= 0 and not named[p]:
            p = mesh.joint_parent[p]
        par[j] = p
    return named, par


def near_joint_matrix(mesh, hops):
    J = len(mesh.joint_names)
    named, par = skin_tree_parent(mesh)
    adj = [[] for _ in range(J)]
    for j in range(J):
        if named[j] and par[j] >= 0:
            adj[j].append(par[j])
            adj[par[j]].append(j)
    near = np.zeros((J + 1, J + 1), bool)  # index J: "no joint" (-1), near nothing
    for a in range(J):
        if not named[a]:
            continue
        frontier, seen = [a], {a}
        for _ in range(hops):
            nxt = []
            for x in frontier:
                for y in adj[x]:
                    if y not in seen:
                        seen.add(y)
                        nxt.append(y)
            frontier = nxt
        for b in seen:
            near[a, b] = True
    return near


def tree_distance_matrix(mesh):
    """Bones apart in the skin's joint tree (large when unconnected)."""
    J = len(mesh.joint_names)
    named, par = skin_tree_parent(mesh)
    INF = 10**6
    D = np.full((J + 1, J + 1), INF, np.int64)
    adj = [[] for _ in range(J)]
    for j in range(J):
        if named[j] and par[j] >= 0:
            adj[j].append(par[j])
            adj[par[j]].append(j)
    for a in range(J):
        if not named[a]:
            continue
        D[a, a] = 0
        frontier = [a]
        d = 0
        while frontier:
            d += 1
            nxt = []
            for x in frontier:
                for y in adj[x]:
                    if D[a, y] == INF:
                        D[a, y] = d
                        nxt.append(y)
            frontier = nxt
    return D


def weld_ids(rest):
    r = rest + 0.0  # -0 -> +0
    _, inv = np.unique(r, axis=0, return_inverse=True)
    return inv.reshape(-1)


def shares_vertex(wtri, a, b):
    A, B = wtri[a], wtri[b]
    s = np.zeros(len(a), bool)
    for i in range(3):
        for j in range(3):
            s |= A[:, i] == B[:, j]
    return s


# ----------------------------------------------------------------------------------------------
# Geometry (float64, vectorised over pairs)


def sat_separation(A, B):
    """A, B: (N, 3, 3). Signed separation on 17 axes: > 0 the triangles are apart (a lower bound on
    their distance), <= 0 they intersect or touch (minus the smallest overlap: the depth)."""
    o = A[:, 0:1, :]
    A = A - o
    B = B - o
    eA = np.stack([A[:, 1] - A[:, 0], A[:, 2] - A[:, 1], A[:, 0] - A[:, 2]], axis=1)
    eB = np.stack([B[:, 1] - B[:, 0], B[:, 2] - B[:, 1], B[:, 0] - B[:, 2]], axis=1)
    nA = np.cross(eA[:, 0], -eA[:, 2])
    nB = np.cross(eB[:, 0], -eB[:, 2])
    axes = [nA[:, None, :], nB[:, None, :]]
    axes.append(np.cross(eA[:, :, None, :], eB[:, None, :, :]).reshape(-1, 9, 3))
    axes.append(np.cross(nA[:, None, :], eA))
    axes.append(np.cross(nB[:, None, :], eB))
    ax = np.concatenate(axes, axis=1)  # (N, 17, 3)
    ln = np.linalg.norm(ax, axis=2)
    scale = np.maximum(np.abs(A).max(axis=(1, 2)), np.abs(B).max(axis=(1, 2)))
    valid = ln > 1e-300 + (scale[:, None] ** 2) * 1e-30
    ax = ax / np.where(valid, ln, 1.0)[:, :, None]
    pA = np.einsum("nkc,nvc->nkv", ax, A)
    pB = np.einsum("nkc,nvc->nkv", ax, B)
    gap = np.maximum(pB.min(axis=2) - pA.max(axis=2), pA.min(axis=2) - pB.max(axis=2))
    gap = np.where(valid, gap, -np.inf)
    return gap.max(axis=1)


def _seg_seg_dist(p1, q1, p2, q2):
    """Distances between segments p1q1 and p2q2 (N, 3) (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    eps = 1e-300
    denom = a * e - b * b
    s = np.where(denom > 1e-14 * a * e, np.clip((b * f - c * e) / np.where(denom > 0, denom, 1), 0, 1), 0.0)
    t = np.where(e > eps, (b * s + f) / np.where(e > eps, e, 1), 0.0)
    # clamp t and recompute s
    s = np.where(t < 0, np.where(a > eps, np.clip(-c / np.where(a > eps, a, 1), 0, 1), 0.0), s)
    t = np.where(t < 0, 0.0, t)
    s = np.where(t > 1, np.where(a > eps, np.clip((b - c) / np.where(a > eps, a, 1), 0, 1), 0.0), s)
    t = np.where(t > 1, 1.0, t)
    c1 = p1 + d1 * s[:, None]
    c2 = p2 + d2 * t[:, None]
    return np.linalg.norm(c1 - c2, axis=1)


def _pt_tri_dist(p, T):
    """Distance from points p (N, 3) to triangles T (N, 3, 3)."""
    a, b, c = T[:, 0], T[:, 1], T[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 1e-300
    # inside test: the projection lies on the inner side of all three edges
    inside = ok.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, p - u), n) >= 0
    dplane = np.abs(np.einsum("ij,ij->i", p - a, n)) / np.sqrt(np.where(ok, nn, 1.0))
    dedge = np.minimum(
        np.minimum(_seg_seg_dist(p, p, a, b), _seg_seg_dist(p, p, b, c)), _seg_seg_dist(p, p, c, a)
    )
    return np.where(inside, dplane, dedge)


def tri_tri_distance(A, B):
    """Exact distance between disjoint triangles (0 is returned where SAT finds them intersecting)."""
    o = A[:, 0:1, :]
    A = A - o
    B = B - o
    d = np.full(len(A), np.inf)
    for i in range(3):
        for j in range(3):
            d = np.minimum(d, _seg_seg_dist(A[:, i], A[:, (i + 1) % 3], B[:, j], B[:, (j + 1) % 3]))
    for i in range(3):
        d = np.minimum(d, _pt_tri_dist(A[:, i], B))
        d = np.minimum(d, _pt_tri_dist(B[:, i], A))
    return d


def pair_state(P, tris, a, b, chunk=200000):
    """SAT separation and, where apart by the SAT, the exact distance. Returns (sep, dist) where
    dist = 0 for intersecting pairs."""
    sep = np.empty(len(a))
    dist = np.zeros(len(a))
    for s in range(0, len(a), chunk):
        A = P[tris[a[s : s + chunk]]]
        B = P[tris[b[s : s + chunk]]]
        sp = sat_separation(A, B)
        sep[s : s + chunk] = sp
        ap = sp > 0
        if ap.any():
            dd = tri_tri_distance(A[ap], B[ap])
            dist[s : s + chunk][ap] = np.maximum(dd, sp[ap])
    return sep, dist


def broad_pairs(P, tris, pad, keep, chunk_pairs=3_000_000):
    """All pairs a < b of triangles whose boxes (padded by pad) overlap and keep(a, b) holds."""
    V = P[tris]
    lo = V.min(axis=1) - pad
    hi = V.max(axis=1) + pad
    ax = int(np.argmax(hi.max(axis=0) - lo.min(axis=0)))
    order = np.argsort(lo[:, ax], kind="stable")
    slo = lo[order]
    shi = hi[order]
    end = np.searchsorted(slo[:, ax], shi[:, ax], side="right")
    cnt = np.maximum(end - np.arange(len(order)) - 1, 0)
    outa, outb = [], []
    i0 = 0
    N = len(order)
    csum = np.cumsum(cnt)
    while i0 < N:
        base = csum[i0 - 1] if i0 else 0
        i1 = int(np.searchsorted(csum, base + chunk_pairs, side="right"))
        i1 = max(i1, i0 + 1)
        i1 = min(i1, N)
        c = cnt[i0:i1]
        tot = int(c.sum())
        if tot:
            ii = np.repeat(np.arange(i0, i1), c)
            starts = np.repeat(np.cumsum(c) - c, c)
            jj = ii + 1 + (np.arange(tot) - starts)
            ov = np.ones(tot, bool)
            for k in range(3):
                if k == ax:
                    continue
                ov &= (slo[ii, k] <= shi[jj, k]) & (slo[jj, k] <= shi[ii, k])
            ii, jj = ii[ov], jj[ov]
            a = order[ii]
            b = order[jj]
            sw = a > b
            a, b = np.where(sw, b, a), np.where(sw, a, b)
            k = keep(a, b)
            outa.append(a[k])
            outb.append(b[k])
        i0 = i1
    if not outa:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(outa), np.concatenate(outb)


# ----------------------------------------------------------------------------------------------
# The checker for one character


class Checker:
    def __init__(self, mesh):
        self.mesh = mesh
        self.rest = mesh.skin(mesh.rest_world)
        self.H = float(self.rest[:, 1].max() - self.rest[:, 1].min())
        self.gap = GAP_SHARE * self.H
        self.tau = TAU_SHARE * self.H
        self.weld = weld_ids(self.rest)
        self.wtri = self.weld[mesh.tris]
        self.tjoint, self.near_tie = triangle_joints(mesh)
        J = len(mesh.joint_names)
        self.tj_idx = np.where(self.tjoint < 0, J, self.tjoint)
        self.near = near_joint_matrix(mesh, HOPS)
        self.tree_d = tree_distance_matrix(mesh)
        self.rest_cache = {}  # pair key -> rest distance (0: intersecting at rest)
        # zero-area triangles (a repeated vertex, or no area at rest): for diagnosis only; the
        # ground truth tests them like any other triangle (as the segment or point they are)
        R = self.rest[mesh.tris]
        area2 = np.linalg.norm(np.cross(R[:, 1] - R[:, 0], R[:, 2] - R[:, 0]), axis=1)
        t = mesh.tris
        self.zero_area = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2]) | (area2 == 0)

    def key(self, a, b):
        return a.astype(np.int64) * len(self.mesh.tris) + b

    def rule12(self, a, b):
        """Which of rules 1, 2 exclude each pair: 0 none, 1, 2."""
        r = np.zeros(len(a), np.int8)
        r[self.near[self.tj_idx[a], self.tj_idx[b]]] = 2
        r[shares_vertex(self.wtri, a, b)] = 1
        return r

    def rest_distance(self, a, b):
        keys = self.key(a, b)
        out = np.empty(len(a))
        todo = []
        for i, k in enumerate(keys.tolist()):
            v = self.rest_cache.get(k)
            if v is None:
                todo.append(i)
            else:
                out[i] = v
        if todo:
            t = np.array(todo)
            sep, dist = pair_state(self.rest, self.mesh.tris, a[t], b[t])
            out[t] = dist
            for i, v in zip(t.tolist(), dist.tolist()):
                self.rest_cache[int(keys[i])] = v
        return out

    def frame(self, P):
        """Ground truth for posed positions P: dict with pairs (a, b sorted by key), their depth."""
        keep = lambda a, b: self.rule12(a, b) == 0
        a, b = broad_pairs(P, self.mesh.tris, 2 * self.tau, keep)
        sep, dist = pair_state(P, self.mesh.tris, a, b)
        hit = sep <= 0
        # rule 3 on the intersecting ones
        ai, bi = a[hit], b[hit]
        rd = self.rest_distance(ai, bi)
        r3 = rd < self.gap
        mine = ~r3
        res = {
            "a": ai[mine],
            "b": bi[mine],
            "depth": -sep[hit][mine],
            "rest": rd[mine],
            # close misses: not excluded by rules 1, 2 (3 checked below), apart by <= tau
            "near_a": a[(~hit) & (dist <= self.tau)],
            "near_b": b[(~hit) & (dist <= self.tau)],
            "near_d": dist[(~hit) & (dist <= self.tau)],
            "candidates": len(a),
            "excluded_r3": int(r3.sum()),
        }
        if len(res["near_a"]):
            rdn = self.rest_distance(res["near_a"], res["near_b"])
            k = rdn >= self.gap
            res["near_a"], res["near_b"], res["near_d"] = res["near_a"][k], res["near_b"][k], res["near_d"][k]
        return res

    def classify(self, P, a, b):
        """For given pairs: (sep, dist, rule) with rule 0 kept, 1/2/3 excluded."""
        sep, dist = pair_state(P, self.mesh.tris, a, b)
        rule = self.rule12(a, b).astype(np.int64)
        rd = self.rest_distance(a, b)
        rule[(rule == 0) & (rd < self.gap)] = 3
        return sep, dist, rule, rd


# ----------------------------------------------------------------------------------------------
# Running the tool


def run(cmd, log=None):
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if log is not None:
        log.append({"cmd": " ".join(cmd), "rc": r.returncode, "s": round(time.time() - t0, 2)})
    if r.returncode != 0:
        sys.stderr.write(r.stdout + r.stderr)
        raise SystemExit(f"failed: {' '.join(cmd)}")
    return r.stdout


def read_dump(path, frames=None):
    out = {}
    names = None
    with open(path) as f:
        for line in f:
            d = json.loads(line)
            if names is None:
                names = d.get("joint_names")
            fr = d["frame"]
            pairs = set()
            for c in d["contacts"]:
                for t, u in c["triangles"]:
                    pairs.add((min(t, u), max(t, u)))
            rec = {"pairs": pairs, "clip_time": d["clip_time"]}
            if frames is None or fr in frames:
                rec["joints"] = np.array(d["joints"], np.float64)
            out[fr] = rec
    return out, names


def pick_frames(n, k):
    if n <= k:
        return list(range(n))
    return sorted(set(int(round(x)) for x in np.linspace(0, n - 1, k)))


def map_joints(glb, mesh):
    """Set joint index -> GLB node index, by the exporter's naming (repeats get _2, _3; empty:
    joint_<i>); checked on the parents and the rest transforms."""
    byname = {}
    for i, n in enumerate(glb.nodes):
        byname.setdefault(n.get("name", ""), []).append(i)
    seen = {}
    out = []
    for j, name in enumerate(mesh.joint_names):
        nm = name if name else f"joint_{j}"
        c = seen.get(nm, 0) + 1
        seen[nm] = c
        nm2 = nm if c == 1 else f"{nm}_{c}"
        cand = byname.get(nm2, [])
        if len(cand) != 1:
            raise SystemExit(f"joint {j} {name!r}: {len(cand)} nodes named {nm2!r} in the exported GLB")
        out.append(cand[0])
    out = np.array(out)
    for j, p in enumerate(mesh.joint_parent):
        if p >= 0 and glb.parent[out[j]] != out[p]:
            raise SystemExit(f"joint {j}: parent mismatch in the exported GLB")
    return out


def case(args):
    tool = args.tool
    work = args.work
    os.makedirs(work, exist_ok=True)
    log = []
    name = args.name
    char = args.character
    t_start = time.time()
    # --- fits (shared between clip sets of one character)
    base = os.path.join(work, f"{name}.fit_default.json")
    if not os.path.exists(base):
        run([tool, "fit", char, "-o", base], log)
    mesh = Mesh(base)
    nparts = mesh.parts_with_triangles
    fits = {"default": base}
    alt = {
        f"max{nparts}": ["--max-spheres", str(nparts)],
        "piece0.02": ["--piece-edge", "0.02"],
    }
    for k, extra in alt.items():
        p = os.path.join(work, f"{name}.fit_{k}.json")
        if not os.path.exists(p):
            run([tool, "fit", char, "-o", p] + extra, log)
        fits[k] = p
    fit_info = {}
    sig0 = mesh.signature()
    for k, p in fits.items():
        m = mesh if k == "default" else Mesh(p)
        with open(p) as f:
            nsph = len(json.load(f)["spheres"])
        fit_info[k] = {"spheres": nsph, "same_mesh": m.signature() == sig0, "pieces": m.pieces, "rules": m.rules}
    # --- clip list
    clipsfile = ["--clips", args.clips] if args.clips else []
    tag = name + ("__" + os.path.basename(args.clips).split(".")[0] if args.clips else "")
    glb_path = os.path.join(work, f"{tag}.export.glb")
    if not os.path.exists(glb_path):
        run([tool, "play", char, "--spheres", base, "--clip", str(args.clip_indices[0]), "--export-glb", glb_path]
            + clipsfile, log)
    glb = Gltf(glb_path)
    clip_ids = args.clip_indices
    # frames per clip: an even share of the budget
    modes = args.modes
    # --- dumps
    dumps = {}
    for ci in clip_ids:
        for mode in modes:
            for k, p in fits.items():
                out = os.path.join(work, f"{tag}.c{ci}.{mode}.{k}.jsonl")
                if not os.path.exists(out):
                    run([tool, "play", char, "--spheres", p, "--clip", str(ci), "--mode", mode, "--dump", out]
                        + clipsfile, log)
                dumps[(ci, mode, k)] = out
    # frames per clip
    nframes = {}
    for ci in clip_ids:
        with open(dumps[(ci, modes[0], "default")]) as f:
            nframes[ci] = sum(1 for _ in f)
    share = max(1, args.budget // len(clip_ids))
    picks = {ci: pick_frames(nframes[ci], share) for ci in clip_ids}
    # redistribute unused budget to long clips (still even within each clip)
    spare = args.budget - sum(len(v) for v in picks.values())
    while spare > 0:
        grow = [ci for ci in clip_ids if len(picks[ci]) < nframes[ci]]
        if not grow:
            break
        per = max(1, spare // len(grow))
        changed = False
        for ci in grow:
            want = min(nframes[ci], len(picks[ci]) + per)
            np_ = pick_frames(nframes[ci], want)
            if len(np_) > len(picks[ci]) and spare - (len(np_) - len(picks[ci])) >= 0:
                spare -= len(np_) - len(picks[ci])
                picks[ci] = np_
                changed = True
        if not changed:
            break
    chk = Checker(mesh)
    jmap = map_joints(glb, mesh)
    W0 = world(glb)
    rest_dev = float(np.abs(W0[jmap] - mesh.rest_world).max())
    names_of_anim = [a.get("name", "") for a in glb.animations]
    res = {
        "name": name,
        "character": char,
        "clips_file": args.clips,
        "tag": tag,
        "height": chk.H,
        "gap": chk.gap,
        "set_rest_gap": (mesh.rules or {}).get("rest_gap"),
        "tau": chk.tau,
        "triangles": int(len(mesh.tris)),
        "vertices": int(len(mesh.bind_pos)),
        "joints": len(mesh.joint_names),
        "parts_with_triangles": nparts,
        "fits": fit_info,
        "rest_world_dev": rest_dev,
        "near_tie_triangles": int(chk.near_tie.sum()),
        "zero_area_triangles": int(chk.zero_area.sum()),
        "clips": [],
        "modes": {},
        "log": log,
    }
    per_mode = {m: {"frames": 0, "mine": 0, "tool": 0, "both": 0, "missed_near": 0, "missed_far": 0,
                    "missed_zero_area": 0,
                    "extra_near": 0, "extra_apart": 0, "extra_rule": {"1": 0, "2": 0, "3": 0},
                    "strict_mine": 0, "strict_both": 0, "fit_diff_frames_sampled": 0,
                    "fit_diff_frames_all": 0, "all_frames": 0, "mode_diff_frames": 0} for m in modes}
    examples = {m: {"missed": [], "extra": []} for m in modes}
    max_joint_dev = 0.0
    depth_stats = {"min": float("inf"), "below_1e-4": 0, "below_1e-5": 0, "below_tau": 0, "close_misses_within_tau": 0,
                   "candidates": 0, "excluded_rule3": 0}
    for ci in clip_ids:
        if ci >= len(glb.animations):
            raise SystemExit(f"clip {ci}: the exported GLB has {len(glb.animations)} animations")
        loaded = {(ci, m, k): read_dump(dumps[(ci, m, k)], set(picks[ci])) for m in modes for k in fits}
        d0, jnames = loaded[(ci, modes[0], "default")]
        # the dump's joints are the skin joints by name: map to set joints
        # (skin order: the bind entries' joints; names repeat in RobotExpressive, so by position)
        jidx = list(mesh.bind_joint)
        if [mesh.joint_names[j] for j in jidx] != jnames:
            raise SystemExit("the dump's joints are not the bind entries' joints in order")
        clip_rec = {"clip": ci, "anim_name": names_of_anim[ci], "frames_total": nframes[ci], "frames": picks[ci]}
        res["clips"].append(clip_rec)
        # fit independence and mode agreement over all frames
        for m in modes:
            dd = {k: loaded[(ci, m, k)][0] for k in fits}
            nall = len(dd["default"])
            per_mode[m]["all_frames"] += nall
            for fr in dd["default"]:
                ref = dd["default"][fr]["pairs"]
                if any(dd[k].get(fr, {"pairs": None})["pairs"] != ref for k in fits):
                    per_mode[m]["fit_diff_frames_all"] += 1
                    if fr in picks[ci]:
                        per_mode[m]["fit_diff_frames_sampled"] += 1
            if m != modes[0]:
                ref = loaded[(ci, modes[0], "default")][0]
                for fr in dd["default"]:
                    if dd["default"][fr]["pairs"] != ref[fr]["pairs"]:
                        per_mode[m]["mode_diff_frames"] += 1
        for fr in picks[ci]:
            t = d0[fr]["clip_time"]
            W = world(glb, ci, t)
            G = W[jmap]
            dev = float(np.abs(G[jidx, :3, 3] - d0[fr]["joints"]).max())
            max_joint_dev = max(max_joint_dev, dev)
            P = mesh.skin(G)
            gt = chk.frame(P)
            mk = chk.key(gt["a"], gt["b"])
            mine_set = dict(zip(mk.tolist(), range(len(mk))))
            if len(gt["depth"]):
                depth_stats["min"] = min(depth_stats["min"], float(gt["depth"].min()) / chk.H)
                depth_stats["below_1e-4"] += int((gt["depth"] <= 1e-4 * chk.H).sum())
                depth_stats["below_1e-5"] += int((gt["depth"] <= 1e-5 * chk.H).sum())
                depth_stats["below_tau"] += int((gt["depth"] <= chk.tau).sum())
            depth_stats["close_misses_within_tau"] += len(gt["near_a"])
            depth_stats["candidates"] += gt["candidates"]
            depth_stats["excluded_rule3"] += gt["excluded_r3"]
            strict = (gt["rest"] >= GAP_SHARE * chk.H) & (
                chk.tree_d[chk.tj_idx[gt["a"]], chk.tj_idx[gt["b"]]] > 1)
            for m in modes:
                tool = loaded[(ci, m, "default")][0][fr]["pairs"]
                tk = set(int(a) * len(mesh.tris) + int(b) for a, b in tool)
                pm = per_mode[m]
                pm["frames"] += 1
                pm["mine"] += len(mine_set)
                pm["tool"] += len(tk)
                both = tk & set(mine_set)
                pm["both"] += len(both)
                pm["strict_mine"] += int(strict.sum())
                pm["strict_both"] += int(sum(1 for i, k in enumerate(mk.tolist()) if strict[i] and k in tk))
                for k in set(mine_set) - tk:
                    i = mine_set[k]
                    if chk.zero_area[gt["a"][i]] or chk.zero_area[gt["b"][i]]:
                        pm["missed_zero_area"] += 1
                        kind = "missed_zero_area"
                    elif gt["depth"][i] <= chk.tau:
                        pm["missed_near"] += 1
                        kind = "missed_near"
                    else:
                        pm["missed_far"] += 1
                        kind = "missed_far"
                    if len(examples[m]["missed"]) < 400:
                        examples[m]["missed"].append(
                            {"clip": ci, "frame": fr, "t": int(gt["a"][i]), "u": int(gt["b"][i]), "kind": kind,
                             "depth_share": gt["depth"][i] / chk.H, "rest_share": gt["rest"][i] / chk.H})
                extra = sorted(tk - set(mine_set))
                if extra:
                    ea = np.array([k // len(mesh.tris) for k in extra])
                    eb = np.array([k % len(mesh.tris) for k in extra])
                    sep, dist, rule, rd = chk.classify(P, ea, eb)
                    for i in range(len(extra)):
                        if sep[i] > 0:
                            kind = "extra_near" if dist[i] <= chk.tau else "extra_apart"
                            pm[kind] += 1
                        else:
                            kind = f"rule{rule[i]}"
                            pm["extra_rule"][str(int(rule[i]))] = pm["extra_rule"].get(str(int(rule[i])), 0) + 1
                        if len(examples[m]["extra"]) < 400:
                            examples[m]["extra"].append(
                                {"clip": ci, "frame": fr, "t": int(ea[i]), "u": int(eb[i]), "kind": kind,
                                 "sep_share": sep[i] / chk.H, "dist_share": dist[i] / chk.H,
                                 "rest_share": rd[i] / chk.H, "rule": int(rule[i]),
                                 "joints": [int(chk.tjoint[ea[i]]), int(chk.tjoint[eb[i]])]})
            sys.stderr.write(
                f"{tag} clip {ci} frame {fr}: candidates {gt['candidates']}, mine {len(mine_set)}, "
                f"tool[{modes[0]}] {len(loaded[(ci, modes[0], 'default')][0][fr]['pairs'])}, joint dev {dev:.2e}\n")
    res["modes"] = per_mode
    res["examples"] = examples
    res["max_joint_dev"] = max_joint_dev
    res["depth_stats"] = depth_stats
    res["max_joint_dev_share"] = max_joint_dev / chk.H
    res["seconds"] = round(time.time() - t_start, 1)
    with open(args.out, "w") as f:
        json.dump(res, f, indent=1, default=float)
    for m in modes:
        pm = per_mode[m]
        rec = pm["both"] / pm["mine"] if pm["mine"] else float("nan")
        print(f"{tag} {m}: frames {pm['frames']} mine {pm['mine']} tool {pm['tool']} recall {rec:.4f} "
              f"missed near {pm['missed_near']} far {pm['missed_far']} zero-area {pm['missed_zero_area']} "
              f"extra near {pm['extra_near']} "
              f"apart {pm['extra_apart']} rule {pm['extra_rule']} fit-diff frames {pm['fit_diff_frames_all']}"
              f"/{pm['all_frames']}")
    print(f"joint dev max {max_joint_dev:.3e} ({max_joint_dev / chk.H:.2e} of height); rest dev {rest_dev:.2e}")


# ----------------------------------------------------------------------------------------------
# Investigating pairs


def investigate(args):
    """Print both triangles of a pair at a frame: coordinates, my tests' answers, the tool's."""
    mesh = Mesh(args.set)
    glb = Gltf(args.glb)
    chk = Checker(mesh)
    jmap = map_joints(glb, mesh)
    d, _ = read_dump(args.dump, {args.frame})
    fr = d[args.frame]
    G = world(glb, args.clip, fr["clip_time"])[jmap]
    P = mesh.skin(G)
    t, u = sorted((args.t, args.u))
    a, b = np.array([t]), np.array([u])
    sep, dist, rule, rd = chk.classify(P, a, b)
    np.set_printoptions(precision=9, suppress=False, linewidth=150)
    print(f"frame {args.frame} clip_time {fr['clip_time']}: pair ({t}, {u}); height {chk.H:.6g}, tau {chk.tau:.3g}")
    for name, k in (("t", t), ("u", u)):
        print(f"  {name} = {k}: vertices {mesh.tris[k].tolist()}, joint {chk.tjoint[k]} "
              f"({mesh.joint_names[chk.tjoint[k]] if chk.tjoint[k] >= 0 else '-'}), near tie {bool(chk.near_tie[k])}")
        print("   posed (float64):\n", P[mesh.tris[k]])
        print("   rest  (float64):\n", chk.rest[mesh.tris[k]])
    print(f"  mine: SAT separation {sep[0]:.6e} ({sep[0] / chk.H:.3e} of height) -> "
          f"{'intersecting' if sep[0] <= 0 else 'apart'}; distance {dist[0]:.6e}; rest distance {rd[0]:.6e} "
          f"(gap {chk.gap:.6e}); rule {rule[0]}; tree distance {chk.tree_d[chk.tj_idx[t], chk.tj_idx[u]]}")
    print(f"  tool: {'reported' if (t, u) in fr['pairs'] else 'not reported'}")
    # the same test on float32-rounded posed positions (what the tool tests, up to its own rounding)
    P32 = P.astype(np.float32).astype(np.float64)
    s32, d32 = pair_state(P32, mesh.tris, a, b)
    print(f"  mine on float32-rounded positions: separation {s32[0]:.6e} distance {d32[0]:.6e}")


# ----------------------------------------------------------------------------------------------
# Self-test of the geometry (no tool needed)


def _segment_crosses_triangle(p, q, T):
    """Moller-Trumbore on segments: an independent intersection test for triangles in general
    position (an edge of one crosses the other)."""
    e1 = T[:, 1] - T[:, 0]
    e2 = T[:, 2] - T[:, 0]
    d = q - p
    h = np.cross(d, e2)
    a = np.einsum("ij,ij->i", e1, h)
    f = 1.0 / a
    r = p - T[:, 0]
    u = f * np.einsum("ij,ij->i", r, h)
    w = np.cross(r, e1)
    v = f * np.einsum("ij,ij->i", d, w)
    t = f * np.einsum("ij,ij->i", e2, w)
    return (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def selftest(args):
    rng = np.random.default_rng(args.seed)
    n = 20000
    A = rng.normal(size=(n, 3, 3))
    B = rng.normal(size=(n, 3, 3)) * 0.7 + rng.normal(size=(n, 1, 3)) * 1.2
    sep = sat_separation(A, B)
    other = np.zeros(n, bool)
    for i in range(3):
        other |= _segment_crosses_triangle(A[:, i], A[:, (i + 1) % 3], B)
        other |= _segment_crosses_triangle(B[:, i], B[:, (i + 1) % 3], A)
    bad_sat = int(((sep <= 0) != other).sum())
    print(f"SAT vs edge-crossing test on {n} random pairs ({other.mean():.1%} intersecting): {bad_sat} differ")
    d = tri_tri_distance(A, B)
    g = np.linspace(0, 1, 25)
    uu, vv = np.meshgrid(g, g)
    m = uu + vv <= 1
    bar = np.stack([1 - uu[m] - vv[m], uu[m], vv[m]], 1)
    bad_d = 0
    for i in np.where(~other)[0][:300]:
        pa, pb = bar @ A[i], bar @ B[i]
        sampled = np.sqrt(((pa[:, None] - pb[None]) ** 2).sum(-1)).min()
        bad_d += int(d[i] > sampled + 1e-12 or sep[i] > d[i] + 1e-12)
    print(f"distance above a sampled distance, or below the SAT bound, on 300 apart pairs: {bad_d}")
    # touching: a shared vertex, and a vertex moved onto the other's face
    T = rng.normal(size=(1000, 3, 3))
    U = rng.normal(size=(1000, 3, 3))
    U[:, 0] = T[:, 0]
    touch = int((sat_separation(T, U) <= 0).sum())
    print(f"pairs sharing a vertex found touching: {touch} of 1000")
    # broad phase against all pairs on a soup
    P = rng.uniform(size=(3000, 3))
    tris = np.arange(3000).reshape(-1, 3)
    tris = np.concatenate([tris, rng.integers(0, 3000, size=(500, 3))])
    a, b = broad_pairs(P, tris, 0.0, lambda a, b: np.ones(len(a), bool))
    V = P[tris]
    lo, hi = V.min(1), V.max(1)
    ov = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    ia, ib = np.nonzero(np.triu(ov, 1))
    same = set(zip(a.tolist(), b.tolist())) == set(zip(ia.tolist(), ib.tolist()))
    print(f"broad phase: {len(a)} box pairs, all pairs: {len(ia)}, same: {same}")
    ok = bad_sat == 0 and bad_d == 0 and touch == 1000 and same
    print("selftest", "passed" if ok else "FAILED")
    return 0 if ok else 1


# ----------------------------------------------------------------------------------------------
# Tables


def table(args):
    def pct(x, n):
        return "n/a" if n == 0 else f"{100 * x / n:.3f}%"

    print("| character | clips | mode | frames | my pairs | tool's pairs | recall (all) | "
          "recall, strict subset (its size) | reported, I find apart | "
          "near-tolerance disagreements: missed / reported | missed beyond tolerance | missed, zero-area triangle | "
          "reported, excluded by my rules | frames the 3 fits differ (of all dumped) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for p in args.results:
        r = json.load(open(p))
        clipset = "own" if not r["clips_file"] else os.path.basename(r["clips_file"]).split(".")[0] + "'s"
        for m, pm in r["modes"].items():
            print(
                f"| {r['name']} | {clipset} | {m} | {pm['frames']} | {pm['mine']} | {pm['tool']} | "
                f"{pct(pm['both'], pm['mine'])} | {pct(pm['strict_both'], pm['strict_mine'])} ({pm['strict_mine']}) | "
                f"{pm['extra_apart']} | {pm['missed_near']} / {pm['extra_near']} | {pm['missed_far']} | "
                f"{pm.get('missed_zero_area', 0)} | {sum(pm['extra_rule'].values())} | "
                f"{pm['fit_diff_frames_all']} of {pm['all_frames']} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("case")
    c.add_argument("character")
    c.add_argument("--tool", required=True)
    c.add_argument("--work", required=True)
    c.add_argument("--name", required=True)
    c.add_argument("--clips", default=None)
    c.add_argument("--clip-indices", default=None, help="comma-separated clip indices (default: every clip)")
    c.add_argument("--budget", type=int, default=40)
    c.add_argument("--modes", default="exact,fast")
    c.add_argument("--out", required=True)
    i = sub.add_parser("investigate")
    i.add_argument("--set", required=True)
    i.add_argument("--glb", required=True)
    i.add_argument("--dump", required=True)
    i.add_argument("--clip", type=int, required=True)
    i.add_argument("--frame", type=int, required=True)
    i.add_argument("t", type=int)
    i.add_argument("u", type=int)
    t = sub.add_parser("table")
    t.add_argument("results", nargs="+")
    st = sub.add_parser("selftest")
    st.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.cmd == "case":
        args.modes = args.modes.split(",")
        if args.clip_indices is None:
            # every clip of the character (or, with --clips, every clip after the character's own)
            raise SystemExit("--clip-indices is required (see `skinspheres play --clip N` for the list)")
        args.clip_indices = [int(x) for x in args.clip_indices.split(",")]
        case(args)
    elif args.cmd == "investigate":
        investigate(args)
    elif args.cmd == "selftest":
        sys.exit(selftest(args))
    else:
        table(args)


if __name__ == "__main__":
    main()
