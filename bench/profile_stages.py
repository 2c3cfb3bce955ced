#!/usr/bin/env python3
"""Where a whole `firn run` spends its time, by stage, from a `perf record` of the process.

    perf record -F 250 -o OUT.data -- build/firn run scenes/NAME.toml --threads 2 --quiet \\
        --out OUT --set simulation.end_time=T
    /usr/bin/python3 bench/profile_stages.py OUT.data [OUT.data ...] [--markdown]

Each sampled symbol (perf report --sort symbol, self time) is put in the first stage whose
pattern it matches; the stages follow solver/step.cc (P2G with the grid's topology, the grid
update with its colliders, G2P, plasticity with the constitutive models, re-bucketing, the sleep
pass) plus what runs around the step loop (basal drag, diagnostics and trackers, output, setup
and settling's own bookkeeping) and the thread pool's idle spinning. Settling runs the same
kernels as the run: summary.json's settle_wall_seconds against wall_seconds splits the two.
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


def main(argv):
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
