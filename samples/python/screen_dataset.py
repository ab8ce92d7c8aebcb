#!/usr/bin/env python3
"""Screens a motion dataset: every clip of every animation file in a folder, retargeted onto one
character, played frame by frame; the frames where the character penetrates itself go to a CSV.

    screen_dataset.py CHARACTER.glb CLIP_FOLDER -o penetrating.csv [--mode fast] [--min-depth 0.005]

One row per penetrating frame and part pair: file, clip, frame, time (s), part_a, part_b, depth (the
character's units) and depth_share (of its rest height). The character is fitted once; each clip
runs in C++ (skinspheres.play), without the GIL. A file that cannot be read or retargeted is named
on stderr in one line and skipped; the exit code is then 2 (1 for bad arguments), else 0.
"""

import argparse
import csv
import os
import sys
import tempfile

import skinspheres as ss

EXTENSIONS = (".glb", ".gltf", ".fbx", ".bvh", ".dae")
FIELDS = ["file", "clip", "frame", "time", "part_a", "part_b", "depth", "depth_share"]


def screen(character, folder, mode="fast", fps=30.0, min_depth=0.0, errors=None):
    """The penetrating frames of every clip in folder, as dicts with FIELDS; files that fail are
    appended to errors as (file, message)."""
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        spheres = os.path.join(scratch, "character.ssb")
        ss.fit(character).save(spheres)
        for name in sorted(os.listdir(folder)):
            path = os.path.join(folder, name)
            if not name.lower().endswith(EXTENSIONS) or not os.path.isfile(path):
                continue
            try:
                clips = ss.clip_names(path)
                for k, clip in enumerate(clips):
                    result = ss.play(character, path, clip=k, mode=mode, fps=fps, spheres=spheres)
                    rows.extend(penetrating_rows(result, name, clip, min_depth))
            except ss.Error as e:
                if errors is not None:
                    errors.append((name, str(e)))
    return rows


def penetrating_rows(result, file, clip, min_depth):
    """The rows of one play() result: part pairs penetrating at least min_depth of the height."""
    parts = result["part_contacts"]
    height = result["body_height"] or 1.0
    names = result["part_names"]
    keep = parts[(parts["kind"] == ss.PENETRATING) & (parts["depth"] >= min_depth * height)]
    return [
        {
            "file": file,
            "clip": clip,
            "frame": int(p["frame"]),
            "time": round(float(result["times"][p["frame"]]), 6),
            "part_a": names[p["part_a"]],
            "part_b": names[p["part_b"]],
            "depth": float(p["depth"]),
            "depth_share": float(p["depth"]) / height,
        }
        for p in keep
    ]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("character", help="the character the clips are played on (glTF, GLB, FBX, ...)")
    parser.add_argument("folder", help="a folder of animation files")
    parser.add_argument("-o", "--output", default="-", help="CSV to write (default: standard output)")
    parser.add_argument("--mode", choices=["fast", "exact"], default="fast")
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--min-depth", type=float, default=0.0, help="share of the height a penetration must reach")
    args = parser.parse_args(argv)
    if not os.path.isdir(args.folder):
        print(f"screen_dataset: {args.folder}: not a folder", file=sys.stderr)
        return 1
    errors = []
    try:
        rows = screen(args.character, args.folder, args.mode, args.fps, args.min_depth, errors)
    except ss.Error as e:  # the character itself
        print(f"screen_dataset: {e}", file=sys.stderr)
        return 2
    out = sys.stdout if args.output == "-" else open(args.output, "w", newline="")
    try:
        writer = csv.DictWriter(out, FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    finally:
        if out is not sys.stdout:
            out.close()
    for file, message in errors:
        print(f"screen_dataset: {file}: skipped: {message}", file=sys.stderr)
    return 2 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
