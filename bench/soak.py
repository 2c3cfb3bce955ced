#!/usr/bin/env python3
"""Soak test: does a long run's memory stay flat?

Runs a scene (default: the 3D PST, scenes/pst3d.toml) for several times its normal end time,
samples the process's resident memory (VmRSS) every few seconds, and reports it after the first
frame, at the end and at its peak, with the growth between the second quarter of the run and the
end (after start-up allocations have settled). Not a CI test: it takes tens of minutes.

    /usr/bin/python3 bench/soak.py [--scene scenes/pst3d.toml] [--factor 10] [--threads 2]
        [--firn build/firn] [--out /tmp/firn-soak] [--set key=value ...]

Writes OUT/rss.csv (seconds, frame, rss_bytes) and prints a summary line per quantity.
"""
import argparse
import csv
import os
import subprocess
import sys
import time
import tomllib


def rss_bytes(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def frames_written(out):
    try:
        with open(os.path.join(out, "metrics.csv")) as f:
            return max(0, sum(1 for _ in f) - 2)
    except OSError:
        return -1


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=os.path.join(root, "scenes", "pst3d.toml"))
    ap.add_argument("--factor", type=float, default=10.0, help="times the scene's end_time")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--firn", default=os.path.join(root, "build", "firn"))
    ap.add_argument("--out", default="/tmp/firn-soak")
    ap.add_argument("--interval", type=float, default=2.0, help="seconds between samples")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="passed to firn run (e.g. grid.dx=0.045 for a cheaper soak)")
    args = ap.parse_args()

    with open(args.scene, "rb") as f:
        end_time = tomllib.load(f).get("simulation", {}).get("end_time", 1.0)
    cmd = [args.firn, "run", args.scene, "--out", args.out, "--quiet", "--threads",
           str(args.threads), "--set", f"simulation.end_time={end_time * args.factor}",
           "--set", "output.particles=false", "--checkpoint-every", "0"]
    for kv in args.set:
        cmd += ["--set", kv]
    print(" ".join(cmd), file=sys.stderr)
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    proc = subprocess.Popen(cmd)
    samples = []
    while proc.poll() is None:
        rss = rss_bytes(proc.pid)
        if rss is not None:
            samples.append((time.time() - t0, frames_written(args.out), rss))
        time.sleep(args.interval)
    if proc.returncode != 0:
        sys.exit(f"firn exited with {proc.returncode}")
    with open(os.path.join(args.out, "rss.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seconds", "frame", "rss_bytes"])
        w.writerows(samples)
    running = [s for s in samples if s[1] >= 1]  # after the first frame: setup is done
    if len(running) < 4:
        sys.exit("too few samples after the first frame; lower --interval")
    quarter = running[len(running) // 4]
    last = running[-1]
    peak = max(s[2] for s in running)
    mb = 1e-6
    print(f"wall {last[0]:.0f} s, {last[1]} frames, {len(samples)} samples")
    print(f"RSS after the first frame {running[0][2] * mb:.1f} MB, at a quarter "
          f"{quarter[2] * mb:.1f} MB, at the end {last[2] * mb:.1f} MB, peak {peak * mb:.1f} MB")
    growth = (last[2] - quarter[2]) / quarter[2]
    print(f"growth from a quarter to the end: {100 * growth:+.1f} %")


if __name__ == "__main__":
    main()
