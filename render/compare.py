#!/usr/bin/python3
"""compare.html for two run folders; `firn compare RUN_A RUN_B` calls it.

Reads what `firn compare` wrote into OUT (data/compare.json, figures.csv, frames.csv,
scene_diff.csv, the weak-layer tables data/a and data/b, the renders a/, b/, diff/, pairs/ and
contact.png) and both runs' metrics.csv and summary.json. Writes OUT/curves.png, the failure maps
OUT/maps_a.png and OUT/maps_b.png (report.py draws them, as in `firn report`) and OUT/compare.html,
one file with the charts and a selection of frames embedded; every frame is linked from it.
"""
import argparse
import csv
import html
import json
import pathlib
import sys

import numpy as np

import report  # render/report.py: the same CSV reader, figure embedding and failure maps

plt = report.plt

# Curves drawn when both runs have them, in this order (metrics.csv columns).
CURVES = (
    ("crack_tip_x", "crack tip x (m)"),
    ("crack_speed", "crack speed (m/s)"),
    ("max_speed", "maximum speed (m/s)"),
    ("kinetic_energy", "kinetic energy (J)"),
    ("energy_drift", "energy drift (J)"),
    ("failed_fraction", "failed fraction"),
    ("front_x", "front x (m)"),
    ("com_x", "centre of mass x (m)"),
)
COLOUR_A, COLOUR_B = "#1f77b4", "#d62728"
# The images of each frame next to the page: folder, file stem, link text.
FRAME_FILES = (("a", "frame", "A"), ("b", "frame", "B"), ("diff", "diff", "difference"),
               ("pairs", "pair", "side by side"))
# Frames embedded in the page besides the contact sheet: the rest are linked.
EMBEDDED_FRAMES = 4


def read_table(path):
    """Rows of a CSV file written by `firn compare` (quoted cells allowed) as dicts."""
    try:
        with open(path, encoding="utf-8", newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        raise report.ReportError(f"cannot read {path}: {e.strerror}") from e


class Comparison:
    def __init__(self, out):
        self.out = pathlib.Path(out)
        data = self.out / "data"
        self.info = report.read_json(data / "compare.json")
        self.figures = read_table(data / "figures.csv")
        self.frames = read_table(data / "frames.csv")
        self.scene = read_table(data / "scene_diff.csv")
        self.run_a = pathlib.Path(self.info["run_a"])
        self.run_b = pathlib.Path(self.info["run_b"])
        self.metrics_a = report.read_csv(self.run_a / "metrics.csv")
        self.metrics_b = report.read_csv(self.run_b / "metrics.csv")

    def moved(self, source, name):
        return any(f["source"] == source and f["name"] == name and f["moved"] == "1"
                   for f in self.figures)


def curves_chart(c, path):
    curves = [(k, label) for k, label in CURVES if k in c.metrics_a and k in c.metrics_b]
    if not curves:
        return None
    columns = 2
    rows = (len(curves) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(12, 3.0 * rows), squeeze=False,
                             constrained_layout=True)
    for ax, (key, label) in zip(axes.flat, curves):
        ax.plot(c.metrics_a["time"], c.metrics_a[key], color=COLOUR_A, lw=1.6, label="run A")
        ax.plot(c.metrics_b["time"], c.metrics_b[key], color=COLOUR_B, lw=1.2, ls="--",
                label="run B")
        moved = c.moved("metrics", key)
        ax.set_title(f"{key}" + ("  (moved)" if moved else ""), fontsize=10,
                     color="#b00" if moved else "black")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for ax in list(axes.flat)[len(curves):]:
        ax.set_visible(False)
    return report.save(fig, path)


def number(text):
    try:
        return f"{float(text):.6g}"
    except ValueError:
        return text


def change_text(f):
    if f["checked"] != "1" and f["abs_change"] in ("", "0") and f["a"] == "":
        return "", ""
    absolute = f["abs_change"]
    relative = f["rel_change"]
    rel = "" if relative == "" else ("∞" if relative == "inf" else f"{100 * float(relative):.3g} %")
    return ("" if absolute == "" else number(absolute)), rel


def tolerance_text(f):
    if f["checked"] != "1":
        return "not compared"
    value = float(f["tolerance"])
    return f"± {value:g}" if f["absolute"] == "1" else f"{100 * value:g} %"


def status_cell(f):
    if f["moved"] == "1":
        return "<td class=moved>moved</td>"
    if f["checked"] != "1":
        return "<td class=info>info</td>"
    if f["identical"] == "1":
        return "<td class=same>identical</td>"
    return "<td class=ok>within</td>"


def figures_table(c, source, value_header):
    rows = []
    for f in c.figures:
        if f["source"] != source:
            continue
        absolute, relative = change_text(f)
        cls = " class=moved-row" if f["moved"] == "1" else ""
        rows.append(f"<tr{cls}><td>{html.escape(f['name'])}</td>"
                    f"<td class=num>{html.escape(number(f['a']))}</td>"
                    f"<td class=num>{html.escape(number(f['b']))}</td>"
                    f"<td class=num>{html.escape(absolute)}</td>"
                    f"<td class=num>{html.escape(relative)}</td>"
                    f"<td>{html.escape(tolerance_text(f))}</td>{status_cell(f)}"
                    f"<td>{html.escape(f['note'])}</td></tr>")
    header = (f"<tr><th>{value_header}</th><th>run A</th><th>run B</th><th>|B − A|</th>"
              "<th>relative</th><th>tolerance</th><th></th><th>note</th></tr>")
    return "<table>\n" + header + "\n" + "\n".join(rows) + "\n</table>"


def scene_section(c):
    if not c.scene:
        return ["<p>The two scene.toml files agree (output.directory aside).</p>"]
    rows = "\n".join(
        f"<tr{' class=moved-row' if d['structural'] == '1' else ''}>"
        f"<td>{html.escape(d['key'])}</td><td class=num>{html.escape(d['a'])}</td>"
        f"<td class=num>{html.escape(d['b'])}</td>"
        f"<td>{'another scene (--force)' if d['structural'] == '1' else 'parameter'}</td></tr>"
        for d in c.scene)
    return ["<p>Keys of scene.toml that differ (output.directory is ignored).</p>",
            "<table>\n<tr><th>key</th><th>run A</th><th>run B</th><th>kind</th></tr>\n" + rows +
            "\n</table>"]


def frames_section(c):
    if c.info.get("render_note"):
        return [f"<p>{html.escape(c.info['render_note'])}</p>"]
    parts = []
    low, high = c.info["color_range_low"], c.info["color_range_high"]
    contact = c.out / "contact.png"
    if contact.is_file():
        parts.append(report.figure(contact, (
            "Run A (left) and run B (middle) rendered with one camera and one colour range "
            f"({low:g} to {high:g}), and their difference (right: black where the pixels are "
            "equal, brighter the more they differ), at evenly spaced frames.")))
    frames = sorted(c.frames, key=lambda f: -float(f["changed_fraction"]))
    picks = [f for f in frames if float(f["changed_fraction"]) > 0][:EMBEDDED_FRAMES]
    for f in sorted(picks, key=lambda f: int(f["frame"])):
        pair = c.out / "pairs" / f"pair.{int(f['frame']):04d}.png"
        parts.append(report.figure(pair, (
            f"Frame {f['frame']}: {100 * float(f['changed_fraction']):.3g} % of the pixels "
            "differ (one of the frames with the most change).")))
    rows = []
    threshold = c.info["pixel_threshold"]
    for f in c.frames:
        n = int(f["frame"])
        changed = float(f["changed_fraction"])
        cls = " class=moved-row" if changed > 0 else ""
        links = " ".join(f'<a href="{folder}/{stem}.{n:04d}.png">{label}</a>'
                         for folder, stem, label in FRAME_FILES)
        rows.append(f"<tr{cls}><td class=num>{n}</td><td class=num>{100 * changed:.3g} %</td>"
                    f"<td class=num>{f['max_channel_difference']}</td><td>{links}</td></tr>")
    parts.append(f"<p>Every frame (pixels count as changed when a channel differs by more than "
                 f"{threshold} of 255 levels); the images lie next to this page.</p>")
    parts.append("<table>\n<tr><th>frame</th><th>changed pixels</th><th>largest channel "
                 "difference</th><th>images</th></tr>\n" + "\n".join(rows) + "\n</table>")
    return parts


def maps_section(c, written):
    note = c.info.get("maps_note")
    if note:
        return [f"<p>{html.escape(note)}</p>"]
    parts = []
    for side, run_dir in (("a", c.run_a), ("b", c.run_b)):
        run = report.Run(run_dir, data_dir=c.out / "data" / side)
        if not run.has_weak_layer:
            return ["<p>No weak layer in this scene: no failure maps.</p>"]
        if not run.has_map_data:
            parts.append(f"<p>Run {side.upper()} wrote no particle cache: no failure maps.</p>")
            continue
        path = c.out / f"maps_{side}.png"
        if run.dimension == 3:
            written.append(report.failure_maps_3d(run, path))
        else:
            written.append(report.failure_maps_2d(run, path))
        parts.append(report.figure(written[-1], (
            f"Run {side.upper()}: failure maps of the weak layer, as in <code>firn report</code> "
            "(failed/elastic, pressure p, slab speed; after Gaume et al. 2019, Fig. A1)" +
            (", at run A's map times." if side == "b" else "."))))
    return parts


STYLE = report.STYLE + """
td.moved, tr.moved-row td:first-child { color: #b00; font-weight: bold; }
td.same { color: #2a7; }
td.ok { color: #27a; }
td.info { color: #888; }
.verdict-moved { color: #b00; }
.verdict-identical { color: #2a7; }
.verdict-within { color: #27a; }
"""


def write_page(c, quiet):
    written = []
    verdict = c.info["verdict"]
    cls = {"moved": "verdict-moved", "identical": "verdict-identical"}.get(verdict,
                                                                           "verdict-within")
    moved = [f for f in c.figures if f["moved"] == "1"]
    caches = ("bitwise equal" if c.info["caches_identical"] else
              f"different ({html.escape(c.info['cache_difference'])})")
    sections = [
        "<h1>Firn compare</h1>",
        f"<p>Run A <code>{html.escape(str(c.run_a))}</code><br>"
        f"Run B <code>{html.escape(str(c.run_b))}</code></p>",
        f"<h2 class={cls}>Verdict: {html.escape(verdict)}</h2>",
        f"<p>Caches: {caches}. {len(moved)} figure(s) beyond tolerance"
        + (": " + ", ".join(html.escape(f"{f['source']} {f['name']}") for f in moved)
           if moved else "") + ".</p>",
        "<h2>Scene</h2>", *scene_section(c),
        "<h2>Rendered frames</h2>", *frames_section(c),
        "<h2>Curves (metrics.csv)</h2>",
    ]
    chart = curves_chart(c, c.out / "curves.png")
    if chart:
        written.append(chart)
        sections.append(report.figure(chart, "Run A (solid) and run B (dashed) against time; "
                                             "titles in red moved beyond tolerance."))
    sections.append(figures_table(c, "metrics", "column"))
    sections += ["<h2>Summary (summary.json)</h2>", figures_table(c, "summary", "key"),
                 "<h2>Failure maps</h2>", *maps_section(c, written)]
    page = ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>"
            "<title>Firn compare</title>"
            f"<style>{STYLE}</style></head><body>\n" + "\n".join(sections) + "\n</body></html>\n")
    target = c.out / "compare.html"
    tmp = c.out / ".compare.html.tmp"
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(target)  # appears only complete
    if not quiet:
        for path in written + [target]:
            print(f"compare.py: wrote {path}", file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="the folder `firn compare` wrote its data into")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    args = parser.parse_args()
    try:
        write_page(Comparison(args.out), args.quiet)
    except (report.ReportError, KeyError, json.JSONDecodeError, np.linalg.LinAlgError) as e:
        print(f"compare.py: error: {e}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
