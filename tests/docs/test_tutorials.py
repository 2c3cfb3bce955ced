#!/usr/bin/python3
"""Runs a tutorial page's commands as written, so that a page that no longer works fails CI.

Every fenced block marked ```sh on the page runs, in page order, with bash -e in a scratch folder
that looks like the checkout (scenes/, docs/, bench/, render/ linked, build/firn the binary
under test, out/ its own). HTML comments, invisible on the site, steer the block after them (one
of each kind, on the lines right before it):
  <!-- test-set: grid.dx=0.1 simulation.end_time=0.2 -->
      adds `--set KEY=VALUE` for each to every `firn run` and `firn check` of the block, so that a
      long run is tested at a coarse resolution or a short end time;
  <!-- test-expect: FRAGMENT | FRAGMENT -->
      each fragment must appear in what the block prints (stdout and stderr): the lines of the
      output the page shows that do not depend on the machine, so a page whose output drifted
      from the code fails;
  <!-- test-skip: REASON -->
      skips the block (a GUI, a server); the reason is required.
Usage: test_tutorials.py PAGE.md --firn BIN --source DIR --work DIR
"""
import argparse
import os
import re
import shutil
import subprocess
import sys

FENCE = re.compile(r"^```(\S*)\s*$")
DIRECTIVE = re.compile(r"^<!--\s*test-(set|skip|expect):\s*(.*?)\s*-->\s*$")
FIRN_COMMAND = re.compile(r"(build/firn\s+(?:run|check)\s+\S+)")


def blocks(page_text):
    """(line number, language, text, directives {kind: value}) of every fenced block."""
    lines = page_text.split("\n")
    out, directive, i = [], {}, 0
    while i < len(lines):
        d = DIRECTIVE.match(lines[i])
        if d:
            directive[d.group(1)] = d.group(2)
            i += 1
            continue
        f = FENCE.match(lines[i])
        if f:
            start, lang, body = i + 1, f.group(1), []
            i += 1
            while i < len(lines) and not FENCE.match(lines[i]):
                body.append(lines[i])
                i += 1
            out.append((start, lang, "\n".join(body), directive))
            directive = {}
        elif lines[i].strip():
            directive = {}  # a directive steers only the block right after it
        i += 1
    return out


def with_sets(command_text, sets):
    if not sets:
        return command_text
    extra = " ".join("--set " + s for s in sets.split())
    return FIRN_COMMAND.sub(lambda m: m.group(1) + " " + extra, command_text)


def scratch(source, firn, work):
    if os.path.exists(work):
        shutil.rmtree(work)
    os.makedirs(os.path.join(work, "build"))
    for name in ("scenes", "docs", "bench", "render"):
        os.symlink(os.path.join(source, name), os.path.join(work, name))
    os.symlink(os.path.abspath(firn), os.path.join(work, "build", "firn"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("page")
    ap.add_argument("--firn", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    text = open(a.page, encoding="utf-8").read()
    scratch(os.path.abspath(a.source), a.firn, a.work)
    ran = 0
    for line, lang, body, directive in blocks(text):
        if lang != "sh":
            continue
        if "skip" in directive:
            if not directive["skip"]:
                sys.exit(f"{a.page}:{line}: test-skip needs a reason")
            print(f"{a.page}:{line}: skipped ({directive['skip']})")
            continue
        script = with_sets(body, directive.get("set", ""))
        print(f"{a.page}:{line}:\n{script}", flush=True)
        r = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=a.work,
                           capture_output=True, text=True)
        if r.returncode != 0:
            print(r.stdout[-3000:])
            print(r.stderr[-3000:])
            sys.exit(f"{a.page}:{line}: the block failed with exit code {r.returncode}")
        printed = r.stdout + r.stderr
        expected = [f.strip() for f in directive.get("expect", "").split(" | ") if f.strip()]
        missing = [f for f in expected if f not in printed]
        if missing:
            print(printed[-3000:])
            sys.exit(f"{a.page}:{line}: the block's output lacks what the page shows: "
                     + "; ".join(repr(f) for f in missing))
        if expected:
            print(f"{a.page}:{line}: {len(expected)} expected fragments found")
        ran += 1
    if ran == 0:
        sys.exit(f"{a.page}: no ```sh block ran: a tutorial without commands tests nothing")
    print(f"{a.page}: {ran} blocks ran")


if __name__ == "__main__":
    main()
