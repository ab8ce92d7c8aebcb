#!/usr/bin/env python3
"""What a frame costs through Python, against the same work in C++, in one process and one run.

    PYTHONPATH=build/python python3 bench/python/python_overhead.py [CHARACTER.glb] [--tool build/samples/skinspheres]

1. The per-frame loop: update_fast((J, 4, 4) float32) + sphere_pairs() + contacts() from Python,
   against Instance._cpp_frame_loop, the same calls in C++ on the same instance and frames with no
   Python between them. Median of rounds, interleaved. The difference is the binding's overhead:
   reading the matrices, the GIL hand-offs, the output arrays.
2. play() against the tool's `play` on the same clip and sphere set (the tool's time includes its
   process start and output; play() includes building its arrays).
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import skinspheres as ss


def posed_frames(spheres_path, count):
    """Joint matrices: the rest pose with every joint moved by a random 1% of the height (the same
    frames for both loops; the contact counts are the rest pose's and a little more)."""
    rest = ss.load(spheres_path).joint_rest_world
    rng = np.random.default_rng(1)
    out = np.repeat(rest[None], count, axis=0).astype(np.float32)
    out[:, :, :3, 3] += rng.normal(scale=0.01 * float(np.ptp(rest[:, 1, 3]) or 1.0), size=out[:, :, :3, 3].shape)
    return out


def python_loop(inst, worlds, contacts):
    start = time.perf_counter()
    for w in worlds:
        inst.update_fast(w)
        inst.sphere_pairs()
        if contacts:
            inst.contacts()
    return (time.perf_counter() - start) / len(worlds)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("character", nargs="?", default=None, help="a character file (default: the built-in one)")
    parser.add_argument("--tool", default=None, help="the skinspheres tool, to time play() against")
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        set_path = f"{scratch}/set.ssb"
        fitted = ss.fit(args.character)
        fitted.save(set_path)
        asset = ss.Asset(ss.load(set_path))
        inst = asset.instance()
        worlds = posed_frames(set_path, args.frames)
        name = args.character or "built-in character"
        print(f"{name}: {len(fitted)} spheres, {args.frames} frames a round, {args.rounds} rounds (median)")
        for contacts in (False, True):
            py, cpp = [], []
            for _ in range(args.rounds):
                cpp.append(inst._cpp_frame_loop(worlds, contacts))
                py.append(python_loop(inst, worlds, contacts))
            p, c = statistics.median(py), statistics.median(cpp)
            what = "update_fast + sphere_pairs + contacts" if contacts else "update_fast + sphere_pairs"
            print(f"  {what:40s} C++ {c * 1e6:8.2f} us   Python {p * 1e6:8.2f} us   overhead {(p - c) * 1e6:6.2f} us"
                  f" ({p / c:.2f}x)")
        if args.tool:
            character = args.character or f"{scratch}/builtin.glb"
            if not args.character:
                subprocess.run([args.tool, "export-builtin", character], check=True, capture_output=True)
            for mode in ("fast", "exact"):
                tool_t, play_t = [], []
                for _ in range(args.rounds):
                    start = time.perf_counter()
                    subprocess.run([args.tool, "play", character, "--spheres", set_path, "--mode", mode],
                                   check=True, capture_output=True)
                    tool_t.append(time.perf_counter() - start)
                    start = time.perf_counter()
                    result = ss.play(character, spheres=set_path, mode=mode)
                    play_t.append(time.perf_counter() - start)
                t, p = statistics.median(tool_t), statistics.median(play_t)
                print(f"  play(), {mode:5s} mode, {result['frames']} frames: the tool {t * 1e3:7.1f} ms (a process)"
                      f"   play() {p * 1e3:7.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
