#!/usr/bin/python3
"""Rewrites the generated tables of the manual from `firn keys --markdown`.

The scene reference (docs/reference/scene.md) and the outputs reference
(docs/reference/outputs.md) hold tables between `<!-- firn keys --markdown: [NAME] -->` and
`<!-- end of firn keys -->`; firn_tests "[docs]" fails when they differ from the code's. After
changing src/scene/key_docs.cc or src/io/output_keys.cc, run from the repository's root:
    /usr/bin/python3 tests/docs/update_key_tables.py --firn build/firn
"""
import argparse
import re
import subprocess

PAGES = ["docs/reference/scene.md", "docs/reference/outputs.md"]
BLOCK = re.compile(r"(<!-- firn keys --markdown: \[([^\]]+)\] -->\n)(.*?)(\n<!-- end of firn keys -->)",
                   re.S)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--firn", default="build/firn")
    a = ap.parse_args()
    text = subprocess.run([a.firn, "keys", "--markdown"], check=True, capture_output=True,
                          text=True).stdout
    tables = {m.group(2): m.group(3) for m in BLOCK.finditer(text)}
    for page in PAGES:
        old = open(page, encoding="utf-8").read()
        new = BLOCK.sub(lambda m: m.group(1) + tables[m.group(2)] + m.group(4), old)
        if new != old:
            open(page, "w", encoding="utf-8").write(new)
            print(f"{page}: updated")


if __name__ == "__main__":
    main()
