#!/usr/bin/env python3
"""Where a whole `firn run` spends its time, by stage, from a `perf record` of the process.

    perf record -F 250 -o OUT.data -- build/firn run scenes/NAME.toml --threads 2 --quiet \\
        --out OUT --set simulation.end_time=T
    /usr/bin/python3 bench/profile_stages.py OUT.data [OUT.data ...] [--markdown]
    /usr/bin/python3 bench/profile_stages.py --serial OUT.data [--top N]

Each sampled symbol (perf report --sort symbol, self time) is put in the first stage whose
pattern it matches; the stages follow solver/step.cc (P2G with the grid's topology, the grid
update with its colliders, G2P, plasticity with the constitutive models, re-bucketing, the sleep
pass) plus what runs around the step loop (basal drag, diagnostics and trackers, output, setup
and settling's own bookkeeping) and the thread pool's idle spinning. Settling runs the same
kernels as the run: summary.json's settle_wall_seconds against wall_seconds splits the two.

--serial: what the main thread runs alone. perf samples each thread at the same rate, and a TBB
worker runs only parallel work, so per symbol the main thread's samples beyond the workers' mean
are serial (or imbalance); listed with their seconds at the recording's frequency, per stage and
per symbol. Record at a fixed rate (-F) so that samples convert to seconds.
"""
import re
import subprocess
import sys

# (stage, regex on the demangled symbol); first match wins, so specific patterns come first.
STAGES = [
    ("G2P", r"g2p<|gatherPadded|gatherParticle|xpic<|subtractXpic"),
    ("P2G", r"scatterLeaves|scatterParticle|mergeBlocks|p2g<|p2gTwoFields|Grid::rebuild|findKey|"
            r"retopologise|_M_fill_assign|Grid::mass|Grid::velocity|Grid::aux|__memset"),
    ("plasticity", r"applyPlasticity|hencky|staysElastic|leftStretch|leftEigen|svd|selfadjoint|"
                   r"returnMap|projectCamClay|camClay|kirchhoff|mohrCoulomb|frictionAngle|"
                   r"inertialNumber|markFractureTime|__expm1|__log|__sinh|__cosh|__atan2|"
                   r"__sincos|__cos|__sin|__exp|__pow|__ieee754|elasticFastPath|Hencky|seriesBatch"),
    ("grid update", r"updateGridVelocity|StickyWalls|Collider::|nearestOnProfile|heightAt|"
                    r"gradientAt|Heightfield|resolveSlipContact|slipNormal|applyBoundary|NodeContacts"),
    ("re-bucketing", r"bucketByLeaf|gatherInPlace|merge_sort|__merge|introsort|"
                     r"__insertion_sort|stable_sort|leafOf|__memmove|__memcpy"),
    ("sleep pass", r"updateSleep|meanBlockVelocity|neighbourLeaves"),
    ("basal drag", r"applyBasalDrag|BasalDrag|unordered_map|_Hashtable|_Hash_node"),
    ("diagnostics, trackers", r"computeDiagnostics|Diagnostics|Tracker|tracking|CrackArrival|"
                              r"SlabFracture|PeakFields|peak|StabilityWatch|kineticEnergy"),
    ("output", r"openvdb|vdb|Vdb|blosc|LZ4|lz4|zlib|deflate|png|Metrics|Json|writeFile|"
               r"rasterize|printf|vfprintf|__write|fwrite"),
    ("thread pool (idle, scheduling)", r"tbb::detail::r1|sched_yield|\[k\]|0x0000|"
                                      r"_raw_spin|do_syscall|schedule|futex"),
    ("setup, settling, other", r"."),
]


def samples_by_symbol(data):
    out = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "dso,symbol",
                          "--stdio", "--percent-limit", "0"], capture_output=True, text=True,
                         check=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"\s+([0-9.]+)%\s+(\S+)\s+(\[.\])\s+(.*)$", line)
        if m:
            pct, dso, kind, sym = float(m.group(1)), m.group(2), m.group(3), m.group(4).strip()
            rows.append((pct, ("[k] " if kind == "[k]" else "") + sym, dso))
    return rows


def stage_of(symbol, dso):
    # tbb::detail::d1::start_for<..., firn::X ...>: the body's name tells the stage.
    for stage, pattern in STAGES:
        if re.search(pattern, symbol):
            if stage.startswith("thread pool") and "firn::" in symbol:
                continue
            return stage
    return STAGES[-1][0]


def shares(data):
    totals = {stage: 0.0 for stage, _ in STAGES}
    for pct, sym, dso in samples_by_symbol(data):
        if dso.startswith("libtbb") and "firn::" not in sym:
            totals["thread pool (idle, scheduling)"] += pct
        else:
            totals[stage_of(sym, dso)] += pct
    return totals


def samples_by_thread(data):
    """{symbol: {tid: samples}} from perf script (the first frame of each sample)."""
    out = subprocess.run(["perf", "script", "-i", data, "-F", "tid,ip,sym"], capture_output=True,
                         text=True, check=True).stdout
    counts, tid, want = {}, None, False
    for line in out.splitlines():
        head = re.match(r"^(\d+)\s*$", line)
        if head:
            tid, want = head.group(1), True
            continue
        if want and line.strip():
            parts = line.strip().split(" ", 1)
            sym = parts[1] if len(parts) > 1 else parts[0]
            counts.setdefault(sym, {}).setdefault(tid, 0)
            counts[sym][tid] += 1
            want = False
    return counts


def recorded_frequency(data):
    header = subprocess.run(["perf", "report", "-i", data, "--header-only"], capture_output=True,
                            text=True).stdout
    m = re.search(r"sample_freq\s*}?\s*=\s*(\d+)", header) or re.search(r"freq = (\d+)", header)
    return int(m.group(1)) if m else None


def serial(data, top):
    counts = samples_by_thread(data)
    tids = sorted({t for per in counts.values() for t in per}, key=int)
    if len(tids) < 2:
        print("one thread only: nothing to compare")
        return
    main_tid, workers = tids[0], tids[1:]
    hz = recorded_frequency(data) or 1
    unit = "s" if hz > 1 else "samples"
    rows, by_stage = [], {stage: 0.0 for stage, _ in STAGES}
    for sym, per in counts.items():
        alone = per.get(main_tid, 0) - sum(per.get(t, 0) for t in workers) / len(workers)
        if alone <= 0:
            continue
        rows.append((alone / hz, sym))
        by_stage[stage_of(sym, "")] += alone / hz
    total = {t: sum(per.get(t, 0) for per in counts.values()) / hz for t in tids}
    print(f"main thread {total[main_tid]:.2f} {unit}, workers " +
          ", ".join(f"{total[t]:.2f}" for t in workers) + f" {unit}")
    print("the main thread alone, by stage:")
    for stage, secs in sorted(by_stage.items(), key=lambda kv: -kv[1]):
        if secs > 0:
            print(f"  {stage:32s} {secs:7.2f} {unit}")
    print(f"the main thread alone, top {top} symbols:")
    for secs, sym in sorted(rows, reverse=True)[:top]:
        print(f"  {secs:7.2f} {unit}  {sym[:100]}")


def main(argv):
    if "--serial" in argv:
        files = [a for a in argv if a.endswith(".data")]
        top = int(argv[argv.index("--top") + 1]) if "--top" in argv else 20
        for f in files:
            print(f)
            serial(f, top)
        return 0
    files = [a for a in argv if not a.startswith("--")]
    if not files:
        print(__doc__)
        return 1
    table = {f: shares(f) for f in files}
    names = [f.rsplit("/", 1)[-1].removesuffix(".data") for f in files]
    if "--markdown" in argv:
        print("| stage | " + " | ".join(names) + " |")
        print("| --- |" + " --- |" * len(names))
        for stage, _ in STAGES:
            print(f"| {stage} | " + " | ".join(f"{table[f][stage]:.1f} %" for f in files) + " |")
    else:
        for f, n in zip(files, names):
            print(n)
            for stage, _ in STAGES:
                print(f"  {stage:32s} {table[f][stage]:5.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
