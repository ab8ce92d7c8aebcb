#!/usr/bin/env python3
"""Fit a character, play one of its clips, and read the contacts as numpy arrays (docs/PYTHON.md).

    quickstart.py Character.glb [clip] [--fast]
"""
import sys

import numpy as np

import skinspheres as ss

path = sys.argv[1]
clip = sys.argv[2] if len(sys.argv) > 2 and not sys.argv[2].startswith("--") else 0
spheres = ss.fit(path)  # the sphere set (spheres.save("x.ssb") keeps it)
result = ss.play(path, clip=clip, mode="fast" if "--fast" in sys.argv else "exact")
parts = result["part_contacts"]  # one row per frame and touching body-part pair
names = result["part_names"]
print(f"{path}: {len(spheres)} spheres; clip {result['clip']!r}: {result['frames']} frames")
print(f"frames with contacts: {len(np.unique(parts['frame']))}")
print(f"frames penetrating: {len(ss.penetrating_frames(result))}")
for p in parts[parts["kind"] == ss.PENETRATING][:5]:
    print(f"  frame {p['frame']}: {names[p['part_a']]} - {names[p['part_b']]}, depth {p['depth']:.4g}")
