#!/usr/bin/env python3
"""Markdown tables from broad_phase_bench's JSON output (the dated runs in bench/results/).

    build/bench/broad_phase_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \\
        --benchmark_out=bp.json --benchmark_out_format=json
    bench/broad_phase_tables.py bp.json

Means of the repetitions (--statistic median for medians). Single-threaded rows are compared on
CPU time (the work the thread did; a preempted thread's wall time is longer), crowd rows on wall
time with each thread's CPU time beside it. "vs peer" is the better peer's time over ours, each
peer in its cheaper variant (count only) unless the row says otherwise; "vs all-pairs" the
all-pairs loop's time over ours. The clips' table gives the first pass (the _cold rows: the
thread's CPU time per frame of one pass by a method made afresh) beside the warm figures, and
leaves rows labelled "held pose" out of its ranges, listing them apart.
"""
import json
import math
import sys

STATISTIC = "mean"
from collections import defaultdict


def load(path):
    with open(path) as f:
        data = json.load(f)
    rows = {}
    for b in data["benchmarks"]:
        if b.get("aggregate_name", STATISTIC) != STATISTIC or b.get("error_occurred"):
            continue
        name = b.get("run_name", b["name"])
        for suffix in ("/real_time", "/manual_time"):
            if name.endswith(suffix):
                name = name[: -len(suffix)]
        rows[name] = b
    return data.get("context", {}), rows


def us(b, key):
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b.get("time_unit", "ns")]
    return b[key] * scale


def fmt(t):
    if t is None:
        return "-"
    if t >= 1000:
        return f"{t / 1000:.2f} ms"
    if t >= 100:
        return f"{t:.0f} µs"
    if t >= 10:
        return f"{t:.1f} µs"
    return f"{t:.2f} µs"


def ratio(peer, ours):
    if peer is None or ours is None or ours <= 0:
        return "-"
    return f"**{peer / ours:.1f}×**" if peer / ours >= 1 else f"{peer / ours:.2f}×"


def group(rows):
    """{scenario: {method: bench}} for names scenario/.../method."""
    g = defaultdict(dict)
    for name, b in rows.items():
        scenario, _, method = name.rpartition("/")
        g[scenario][method] = b
    return g


def cpu(g, method):
    b = g.get(method)
    return us(b, "cpu_time") if b else None


def table_one_space(groups, prefix, title, extra_levels=False):
    lines = [f"#### {title}", ""]
    head = ["scenario", "spheres", "contacts", "skinspheres"]
    if extra_levels:
        head += ["SSE2", "AVX2", "AVX-512", "no cache"]
    head += ["all-pairs", "Bullet count", "Bullet sorted", "FCL count", "FCL sorted", "vs better peer", "vs all-pairs",
             "builds / frame"]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    for scenario in sorted(groups, key=sort_key):
        if not scenario.startswith(prefix):
            continue
        g = groups[scenario]
        ours = cpu(g, "skinspheres")
        if ours is None:
            continue
        b = g["skinspheres"]
        peers = [p for p in (cpu(g, "bullet_count"), cpu(g, "fcl_count")) if p is not None]
        best_peer = min(peers) if peers else None
        cells = [scenario[len(prefix):].strip("/"), f"{b.get('spheres', 0):.0f}", f"{b.get('contacts', 0):.0f}", fmt(ours)]
        if extra_levels:
            cells += [fmt(cpu(g, m)) for m in ("skinspheres_sse2", "skinspheres_avx2", "skinspheres_avx512",
                                                "skinspheres_nocache")]
        cells += [fmt(cpu(g, m)) for m in ("allpairs", "bullet_count", "bullet_sorted", "fcl_count", "fcl_sorted")]
        cells += [ratio(best_peer, ours), ratio(cpu(g, "allpairs"), ours), f"{b.get('builds', 0):.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def sort_key(s):
    parts = []
    for p in s.split("/"):
        k, _, v = p.partition(":")
        try:
            parts.append((k, float(v)))
        except ValueError:
            parts.append((p, 0.0))
    return parts


def slope(points):
    """Least-squares slope of log(time) against log(n)."""
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def table_scale(groups):
    lines = ["#### (c) constant density, 100 to 50,000 spheres", ""]
    head = ["shape", "n", "contacts", "skinspheres", "Bullet count", "FCL count", "all-pairs", "vs better peer",
            "builds / frame"]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    slopes = []
    for shape in ("slab", "cube"):
        series = defaultdict(list)
        for scenario in sorted(groups, key=sort_key):
            if not scenario.startswith(f"c_scale/{shape}/"):
                continue
            g = groups[scenario]
            n = int(scenario.rpartition(":")[2])
            ours = cpu(g, "skinspheres")
            if ours is None:
                continue
            peers = [p for p in (cpu(g, "bullet_count"), cpu(g, "fcl_count")) if p is not None]
            for m in ("skinspheres", "bullet_count", "fcl_count"):
                if cpu(g, m) is not None:
                    series[m].append((n, cpu(g, m)))
            b = g["skinspheres"]
            lines.append("| " + " | ".join([shape, str(n), f"{b.get('contacts', 0):.0f}", fmt(ours),
                                            fmt(cpu(g, "bullet_count")), fmt(cpu(g, "fcl_count")),
                                            fmt(cpu(g, "allpairs")), ratio(min(peers) if peers else None, ours),
                                            f"{b.get('builds', 0):.2f}"]) + " |")
        for m, pts in series.items():
            if len(pts) >= 2:
                slopes.append(f"{shape} {m}: {slope(pts):.2f}")
    lines.append("")
    lines.append("Slope of log time against log n (least squares, 100 to 50,000): " + "; ".join(slopes) + ".")
    return "\n".join(lines) + "\n"


def table_crowds(groups):
    lines = ["#### (d) crowds: each alone (1 and 2 threads) and all in one space", ""]
    head = ["characters", "spheres", "alone, 1 thread (wall / CPU)", "alone, 2 threads (wall)", "2 threads: CPU per thread",
            "alone: Bullet", "alone: FCL", "one space: skinspheres", "one space: Bullet", "one space: FCL",
            "one space: contacts"]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    chars = sorted({int(s.rpartition(":")[2]) for s in groups if s.startswith("d_crowd/")})
    space_pts = []
    for c in chars:
        alone = groups.get(f"d_crowd/alone/chars:{c}", {})
        space = groups.get(f"d_crowd/space/chars:{c}", {})
        t1, t2 = alone.get("skinspheres_threads:1"), alone.get("skinspheres_threads:2")
        per_thread = "-"
        if t2:
            per_thread = " + ".join(f"{t2[k]:.2f}" for k in ("cpu_t0_ms", "cpu_t1_ms") if k in t2) + " ms"
        ours_space = cpu(space, "skinspheres")
        if ours_space:
            space_pts.append((c, ours_space))
        sb = space.get("skinspheres", {})
        lines.append("| " + " | ".join([
            str(c), f"{(t1 or t2 or {}).get('spheres', sb.get('spheres', 0)):.0f}",
            f"{fmt(us(t1, 'real_time'))} / {fmt(us(t1, 'cpu_time'))}" if t1 else "-",
            fmt(us(t2, "real_time")) if t2 else "-", per_thread,
            fmt(cpu(alone, "bullet_count")), fmt(cpu(alone, "fcl_count")),
            fmt(ours_space), fmt(cpu(space, "bullet_count")), fmt(cpu(space, "fcl_count")),
            f"{sb.get('contacts', 0):.0f}"]) + " |")
    if len(space_pts) >= 2:
        lines.append("")
        lines.append(f"One space: slope of log time against log characters: {slope(space_pts):.2f}.")
    return "\n".join(lines) + "\n"


def geomean(values):
    return math.exp(sum(math.log(v) for v in values) / len(values)) if values else None


def table_clips(groups):
    """(b): warm and first-pass (cold) figures, ratios against the better peer, held poses apart."""
    prefix = "b_clip/"
    lines = ["#### (b) the shared characters' clips", ""]
    head = ["scenario", "spheres", "contacts", "skinspheres warm", "cold", "cold / warm", "Bullet count warm", "cold",
            "FCL count warm", "cold", "vs better peer, warm", "vs better peer, cold", "vs all-pairs"]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    ranges = defaultdict(list)  # (excl, temperature) -> ratios, held poses left out
    held = []
    for scenario in sorted(groups, key=sort_key):
        if not scenario.startswith(prefix):
            continue
        g = groups[scenario]
        ours, ours_cold = cpu(g, "skinspheres"), real(g, "skinspheres_cold")
        if ours is None:
            continue
        b = g["skinspheres"]
        warm_peer = min([p for p in (cpu(g, "bullet_count"), cpu(g, "fcl_count")) if p is not None], default=None)
        cold_peer = min([p for p in (real(g, "bullet_count_cold"), real(g, "fcl_count_cold")) if p is not None],
                        default=None)
        is_held = b.get("held_pose", 0) >= 0.5
        name = scenario[len(prefix):] + (" (held pose)" if is_held else "")
        lines.append("| " + " | ".join([
            name, f"{b.get('spheres', 0):.0f}", f"{b.get('contacts', 0):.0f}", fmt(ours), fmt(ours_cold),
            f"{ours_cold / ours:.2f}" if ours_cold else "-", fmt(cpu(g, "bullet_count")),
            fmt(real(g, "bullet_count_cold")), fmt(cpu(g, "fcl_count")), fmt(real(g, "fcl_count_cold")),
            ratio(warm_peer, ours), ratio(cold_peer, ours_cold), ratio(cpu(g, "allpairs"), ours)]) + " |")
        excl = "excl:1" in scenario
        for temp, peer, mine in (("warm", warm_peer, ours), ("cold", cold_peer, ours_cold)):
            if peer and mine and not is_held:
                ranges[(excl, temp)].append(peer / mine)
        if is_held and warm_peer:
            held.append(f"{scenario[len(prefix):]} {warm_peer / ours:.1f}×")
    lines.append("")
    for excl in (True, False):
        for temp in ("warm", "cold"):
            r = ranges[(excl, temp)]
            if r:
                lines.append(f"- {'with' if excl else 'without'} exclusions, {temp}: {min(r):.1f}× to {max(r):.1f}× "
                             f"the better peer, geometric mean {geomean(r):.1f}× over {len(r)} rows")
    if held:
        lines.append("- held pose, left out of the ranges above (warm): " + "; ".join(held))
    return "\n".join(lines) + "\n"


def real(g, method):
    b = g.get(method)
    return us(b, "real_time") if b else None


def main():
    global STATISTIC
    args = sys.argv[1:]
    if len(args) >= 2 and args[0] == "--statistic":
        STATISTIC, args = args[1], args[2:]
    context, rows = load(args[0])
    groups = group(rows)
    print(f"<!-- {context.get('date', '')}, load average {context.get('load_avg', '')} -->\n")
    present = {s.partition("/")[0] for s in groups}
    if "a_cloud" in present:
        print(table_one_space(groups, "a_cloud/", "(a) coherent cloud, no exclusions", extra_levels=True))
    if "b_clip" in present:
        print(table_clips(groups))
    if "c_scale" in present:
        print(table_scale(groups))
    if "d_crowd" in present:
        print(table_crowds(groups))


if __name__ == "__main__":
    main()
