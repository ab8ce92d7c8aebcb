#!/usr/bin/env python3
"""Writes a valid version-2 sphere set of about SIZE_MB megabytes (default 175): a strip of
triangles t = (t, t+1, t+2) over one joint, split between 1000 spheres. Used to measure what
reading a large set costs (docs/LIMITS.md):
    tests/data/make_big_sphere_set.py /tmp/big.spheres.json 175
    /usr/bin/time -v build/samples/skinspheres play <any character> --spheres /tmp/big.spheres.json
(play refuses the set after reading it, since it was not fitted on that character; "Maximum
resident set size" is the reading's peak)."""
import json
import random
import sys

path = sys.argv[1]
size_mb = float(sys.argv[2]) if len(sys.argv) > 2 else 175.0
# About 58 bytes of JSON per triangle (mesh triangles, positions, influences, sphere lists).
triangles = int(size_mb * 1e6 / 58)
vertices = triangles + 2
spheres = 1000
per = triangles // spheres
rng = random.Random(7)
out = open(path, "w")
w = out.write
w('{"format":"skinspheres.sphere_set","version":2,')
w('"source":{"file":"big","vertices":%d,"triangles":%d},"params":{},' % (vertices, spheres * per))
w('"skeleton":{"joints":[{"name":"root","parent":-1,"rest_world":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}]},')
w('"parts":[{"name":"torso","joints":[0]}],"spheres":[')
for s in range(spheres):
    first, last = s * per, (s + 1) * per
    w('%s{"id":%d,"part":0,"joint":0,"level":0,"center":[0,0,0],"radius":1e6,"radius_fast":1e6,' % ("," if s else "", s))
    w('"vertices":[%s],' % ",".join(str(v) for v in range(first, last + 2)))
    w('"triangles":[%s],"influences":[[0,1]]}' % ",".join(str(t) for t in range(first, last)))
w('],"excluded_pairs":[],"mesh":{"triangles":[')
w(",".join("%d,%d,%d" % (t, t + 1, t + 2) for t in range(spheres * per)))
w('],"positions_bind":[')
w(",".join("%.6f" % rng.random() for _ in range(3 * vertices)))
w('],"binds":[{"joint":0,"inverse_bind":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}],')
w('"influence_offsets":[%s],' % ",".join(str(v) for v in range(vertices + 1)))
w('"influence_binds":[%s],' % ",".join("0" for _ in range(vertices)))
w('"influence_weights":[%s]}}' % ",".join("1" for _ in range(vertices)))
out.close()
