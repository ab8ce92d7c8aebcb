"""The GIL is released while the library works, two characters run at once on two threads with the
answers they give alone, and 10,000 frames neither leak Python objects nor grow the process."""

import gc
import os
import threading
import tracemalloc

import numpy as np

import skinspheres as ss


def resident_kib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def test_play_releases_the_gil():
    # While one thread is inside play(), this thread keeps running Python. With the GIL held for
    # the whole call, the counter could not move between the worker's two reads of it.
    counter = [0]
    done = threading.Event()
    reads = {}

    def worker():
        reads["before"] = counter[0]
        reads["result"] = ss.play(clip="walk", mode="exact", frames=120)
        reads["after"] = counter[0]
        done.set()

    thread = threading.Thread(target=worker)
    thread.start()
    while not done.is_set():
        counter[0] += 1
    thread.join()
    assert reads["result"]["frames"] == 120
    moved = reads["after"] - reads["before"]
    print(f"the main thread counted {moved} times while play() ran")
    assert moved > 1000


def frames_for(spheres, count, seed):
    rng = np.random.default_rng(seed)
    rest = spheres.joint_rest_world.astype(np.float64)
    out = []
    for _ in range(count):
        world = rest.copy()
        world[:, :3, 3] += rng.normal(scale=0.04, size=(len(world), 3))
        out.append(world)
    return out


def run_frames(asset, frames):
    inst = asset.instance()
    got = []
    for world in frames:
        inst.update_fast(world)
        pairs = inst.sphere_pairs()
        contacts = inst.contacts()
        got.append((pairs.tobytes(), contacts.parts.tobytes(), contacts.triangles.tobytes()))
    return got


def test_two_characters_on_two_threads_give_what_they_give_alone():
    a = ss.Asset(ss.fit())
    b = ss.Asset(ss.fit(max_spheres=40))
    fa = frames_for(a.sphere_set, 150, 1)
    fb = frames_for(b.sphere_set, 150, 2)
    alone = [run_frames(a, fa), run_frames(b, fb)]
    assert sum(len(p) for p, _, _ in alone[0]) > 0
    together = [None, None]

    def run(k, asset, frames):
        together[k] = run_frames(asset, frames)

    threads = [threading.Thread(target=run, args=(0, a, fa)), threading.Thread(target=run, args=(1, b, fb))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert together == alone


def test_ten_thousand_frames_do_not_leak():
    asset = ss.Asset(ss.fit())
    inst = asset.instance()
    frames = frames_for(asset.sphere_set, 50, 5)
    positions_frames = 0

    def frame(k):
        inst.update_fast(frames[k % len(frames)])
        inst.sphere_pairs()
        inst.contacts()
        _ = inst.spheres

    for k in range(1000):  # warm-up: buffers reach their size
        frame(k)
    gc.collect()
    tracemalloc.start()
    traced_before = tracemalloc.get_traced_memory()[0]
    rss_before = resident_kib()
    for k in range(10000):
        frame(k)
        positions_frames += 1
    gc.collect()
    traced_after = tracemalloc.get_traced_memory()[0]
    rss_after = resident_kib()
    tracemalloc.stop()
    print(f"{positions_frames} frames: Python heap {traced_after - traced_before:+d} B, RSS {rss_after - rss_before:+d} KiB")
    assert traced_after - traced_before < 64 * 1024
    if not os.environ.get("SKINSPHERES_SANITIZED"):  # ASan's quarantine grows the RSS by itself
        assert rss_after - rss_before < 4 * 1024
