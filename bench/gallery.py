#!/usr/bin/python3
"""Release gallery: every shipped scene run by an older and the current Firn, compared.

    /usr/bin/python3 bench/gallery.py --old REV [--firn build/firn] [--out DIR] [--quick]
                                      [--scenes default,pst] [--time-scale S] [--dx-scale S]

Builds revision REV in a git worktree (OUT/old/src, CMake Release into OUT/old/build, target
firn only), runs each scenes/*.toml of this checkout with both versions at a review resolution
(end time scaled by --time-scale, dx by --dx-scale), runs `firn compare OLD NEW` (the current
binary) per scene, and writes OUT/gallery.html: one row per scene with both run times, the
verdict and a link to the scene's compare.html, and OUT/gallery.json with the same.

An old version that cannot run the current scene file (a key it does not know) gets a second
try with its own copy of the scene, when it has one; when that fails too the row says
"old version could not run it: <its message>". A failed build marks every scene.

--quick: a tenth of each scene's end time, 320x180 renders of every second frame; for a sanity
check of the pipeline, not a review. Default OUT: build/gallery-<REV>.
"""
import argparse
import glob
import html
import json
import os
import subprocess
import sys
import time
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def git(*args, cwd=ROOT):
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                          text=True).stdout.strip()


def describe(rev):
    """'abc1234 subject' of a revision, for the page."""
    return git("log", "-1", "--format=%h %s", rev)


def last_line(text):
    """The last non-empty line of a tool's stderr: where the reason usually is."""
    lines = [line.strip() for line in text.replace("\r", "\n").splitlines() if line.strip()]
    return lines[-1] if lines else "no message"


def build_old(rev, out, jobs):
    """Checks REV out into OUT/old/src and builds its firn. Returns (binary, error)."""
    src = os.path.join(out, "old", "src")
    build = os.path.join(out, "old", "build")
    commit = git("rev-parse", rev)
    if os.path.isdir(src):
        if git("rev-parse", "HEAD", cwd=src) != commit:
            git("checkout", "--detach", commit, cwd=src)
    else:
        os.makedirs(os.path.dirname(src), exist_ok=True)
        git("worktree", "add", "--detach", src, commit)
    steps = [["cmake", "-S", src, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
              "-DFIRN_TESTS=OFF", "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"],
             ["cmake", "--build", build, "--target", "firn", f"-j{jobs}"]]
    for step in steps:
        print(f"gallery: {' '.join(step)}", file=sys.stderr)
        done = subprocess.run(step, capture_output=True, text=True)
        if done.returncode != 0:
            return None, f"build failed: {last_line(done.stdout + done.stderr)}"
    return os.path.join(build, "firn"), None


def scene_value(path, table, key, default):
    with open(path, "rb") as f:
        return tomllib.load(f).get(table, {}).get(key, default)


def review_overrides(scene, args):
    end_time = float(scene_value(scene, "simulation", "end_time", 1.0))
    overrides = ["--set", f"simulation.end_time={end_time * args.time_scale:.6g}"]
    if args.dx_scale != 1.0:
        dx = float(scene_value(scene, "grid", "dx", 0.05))
        overrides += ["--set", f"grid.dx={dx * args.dx_scale:.6g}"]
    return overrides


def run(firn, scene, out, overrides, timeout):
    """Runs one scene; returns (wall seconds, error or None)."""
    command = [firn, "run", scene, "--out", out, "--quiet", *overrides]
    start = time.monotonic()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"no result within {timeout} s"
    seconds = time.monotonic() - start
    if done.returncode != 0:
        return seconds, f"exit {done.returncode}: {last_line(done.stderr)}"
    return seconds, None


def run_old(firn, scene, old_src, out, overrides, timeout):
    """The current scene file, else the old checkout's own copy of it."""
    seconds, error = run(firn, scene, out, overrides, timeout)
    if not error:
        return seconds, None, ""
    own = os.path.join(old_src, "scenes", os.path.basename(scene))
    if not os.path.isfile(own):
        return None, error, ""
    seconds, second_error = run(firn, own, out, overrides, timeout)
    if second_error:
        return None, error, ""
    return seconds, None, "old version ran its own copy of the scene (the current one: " + \
        error + ")"


def compare(firn, old_out, new_out, out, args):
    command = [firn, "compare", old_out, new_out, "--out", out, "--quiet"]
    if args.quick:
        command += ["--size", "320x180", "--frame-step", "2"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode in (0, 5):
        return done.stdout.splitlines()[0].split(":")[0], done.stdout
    return "compare failed", f"exit {done.returncode}: {last_line(done.stderr)}"


def review_scene(scene, firn_old, firn_new, old_src, build_error, args):
    name = os.path.splitext(os.path.basename(scene))[0]
    base = os.path.join(args.out, "runs", name)
    overrides = review_overrides(scene, args)
    row = {"scene": name, "overrides": " ".join(overrides[1::2]), "old_seconds": None,
           "new_seconds": None, "verdict": "", "notes": [], "page": None}
    print(f"gallery: {name}: new version", file=sys.stderr)
    row["new_seconds"], new_error = run(firn_new, scene, os.path.join(base, "new"), overrides,
                                        args.timeout)
    if new_error:
        row["verdict"] = "not compared"
        row["notes"].append(f"new version could not run it: {new_error}")
    if build_error:
        row["verdict"] = "not compared"
        row["notes"].append(f"old version could not run it: {build_error}")
        return row
    print(f"gallery: {name}: old version", file=sys.stderr)
    row["old_seconds"], old_error, note = run_old(firn_old, scene, old_src,
                                                  os.path.join(base, "old"), overrides,
                                                  args.timeout)
    if note:
        row["notes"].append(note)
    if old_error:
        row["verdict"] = "not compared"
        row["notes"].append(f"old version could not run it: {old_error}")
    if row["verdict"]:
        return row
    print(f"gallery: {name}: compare", file=sys.stderr)
    page_dir = os.path.join(args.out, "compare", name)
    row["verdict"], text = compare(firn_new, os.path.join(base, "old"), os.path.join(base, "new"),
                                   page_dir, args)
    if row["verdict"] == "compare failed":
        row["notes"].append(text)
    else:
        row["page"] = os.path.relpath(os.path.join(page_dir, "compare.html"), args.out)
        moved = [line.strip() for line in text.splitlines() if line.startswith("  moved")]
        if moved:
            row["notes"].append(f"{len(moved)} moved, first: {moved[0][6:]}")
    return row


STYLE = """
body { font-family: sans-serif; max-width: 1400px; margin: 1em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
td.num { text-align: right; font-family: monospace; }
.moved { color: #b00; font-weight: bold; } .identical { color: #2a7; } .within { color: #27a; }
.failed { color: #888; }
"""


def seconds_text(value):
    return "—" if value is None else f"{value:.1f} s"


def write_gallery(rows, old_rev, new_label, args):
    body = []
    for r in rows:
        cls = {"moved": "moved", "identical": "identical", "within tolerance": "within"}.get(
            r["verdict"], "failed")
        verdict = html.escape(r["verdict"])
        if r["page"]:
            verdict = f'<a href="{html.escape(r["page"])}">{verdict}</a>'
        ratio = ("" if not (r["old_seconds"] and r["new_seconds"]) else
                 f"{r['old_seconds'] / r['new_seconds']:.2f}x")
        body.append(f"<tr><td>{html.escape(r['scene'])}</td>"
                    f"<td class=num>{seconds_text(r['old_seconds'])}</td>"
                    f"<td class=num>{seconds_text(r['new_seconds'])}</td>"
                    f"<td class=num>{ratio}</td><td class={cls}>{verdict}</td>"
                    f"<td>{'<br>'.join(html.escape(n) for n in r['notes'])}</td></tr>")
    page = ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8><title>Firn release "
            f"gallery</title><style>{STYLE}</style></head><body>\n<h1>Firn release gallery</h1>\n"
            f"<p>Old: <code>{html.escape(old_rev)}</code><br>New: <code>"
            f"{html.escape(new_label)}</code><br>Review resolution: end time × {args.time_scale:g}"
            f", dx × {args.dx_scale:g}{' (--quick)' if args.quick else ''}. Run times are wall "
            "clock on this machine, including setup and output.</p>\n"
            "<table>\n<tr><th>scene</th><th>old run</th><th>new run</th><th>speed-up</th>"
            "<th>verdict (link: compare.html)</th><th>notes</th></tr>\n" + "\n".join(body) +
            "\n</table>\n</body></html>\n")
    path = os.path.join(args.out, "gallery.html")
    with open(path + ".tmp", "w", encoding="utf-8") as f:
        f.write(page)
    os.replace(path + ".tmp", path)
    with open(os.path.join(args.out, "gallery.json"), "w", encoding="utf-8") as f:
        json.dump({"old": old_rev, "new": new_label, "rows": rows}, f, indent=2)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", required=True, help="git revision of the older version")
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"),
                        help="the current firn binary (default: build/firn of this checkout)")
    parser.add_argument("--out", help="output folder (default build/gallery-<REV>)")
    parser.add_argument("--scenes", help="comma-separated scene names (default: all)")
    parser.add_argument("--quick", action="store_true", help="a fast sanity run")
    parser.add_argument("--time-scale", type=float, help="end time factor (default 0.5; "
                                                         "--quick 0.1)")
    parser.add_argument("--dx-scale", type=float, default=1.0, help="dx factor (default 1)")
    parser.add_argument("--timeout", type=float, default=1800.0, help="s per run")
    parser.add_argument("--jobs", type=int, default=2, help="build jobs (default 2)")
    args = parser.parse_args()
    if args.time_scale is None:
        args.time_scale = 0.1 if args.quick else 0.5
    safe_rev = args.old.replace("/", "_").replace("~", "-").replace("^", "-")
    args.out = os.path.abspath(args.out or os.path.join(ROOT, "build", f"gallery-{safe_rev}"))
    os.makedirs(args.out, exist_ok=True)
    if not os.access(args.firn, os.X_OK):
        print(f"gallery: error: no firn binary at {args.firn} (build this checkout first, or "
              "give --firn)", file=sys.stderr)
        return 1
    try:
        old_rev = describe(args.old)
    except subprocess.CalledProcessError as e:
        print(f"gallery: error: unknown revision '{args.old}': {e.stderr.strip()}",
              file=sys.stderr)
        return 1
    new_label = f"{describe('HEAD')} ({args.firn})"
    firn_old, build_error = build_old(args.old, args.out, args.jobs)
    old_src = os.path.join(args.out, "old", "src")

    scenes = sorted(glob.glob(os.path.join(ROOT, "scenes", "*.toml")))
    if args.scenes:
        wanted = set(args.scenes.split(","))
        scenes = [s for s in scenes if os.path.splitext(os.path.basename(s))[0] in wanted]
    rows = [review_scene(s, firn_old, args.firn, old_src, build_error, args) for s in scenes]
    path = write_gallery(rows, old_rev, new_label, args)
    for r in rows:
        print(f"{r['scene']:16s} old {seconds_text(r['old_seconds']):>9s}  new "
              f"{seconds_text(r['new_seconds']):>9s}  {r['verdict']}"
              + (f"  ({'; '.join(r['notes'])})" if r["notes"] else ""))
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
