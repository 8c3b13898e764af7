#!/usr/bin/env python3
"""Render a described set with Mitsuba 3: the `foreign` set.

    render_set.py SET_DIR OUT_DIR [--every K] [--spp N] [render.py flags]

SET_DIR is a set rendered with `matscan simulate --recipe R --describe`
(each bundle with its `<bundle>.scene/` description beside it). Every
K-th description in name order (K = 2 by default: 32 of heldout.toml's 64
scenes, every kind and geometry family) is rendered by `render.py` into
OUT_DIR with the same relative path as its bundle. Resumable: a bundle that
already exists in OUT_DIR is kept (render.py writes atomically, so an
interrupted scene leaves nothing behind), so rerunning after a stop renders
only what is missing. Prints one line per scene with its time.
"""

import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def descriptions(root):
    """Every `<bundle>.scene` folder under `root`, in name order."""
    found = []
    for dirpath, dirnames, _ in os.walk(root):
        dirnames.sort()
        for d in dirnames:
            if d.endswith(".scene") and os.path.isfile(os.path.join(dirpath, d, "scene.json")):
                found.append(os.path.join(dirpath, d))
    return sorted(found)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("set_dir")
    ap.add_argument("out_dir")
    ap.add_argument("--every", type=int, default=2, help="render every K-th description (default 2)")
    ap.add_argument("--spp", type=int, default=128)
    args, rest = ap.parse_known_args(argv)
    if args.every < 1:
        ap.error("--every must be at least 1")
    found = descriptions(args.set_dir)
    if not found:
        print(f"{args.set_dir}: no <bundle>.scene descriptions (render the set with --describe)",
              file=sys.stderr)
        return 2
    chosen = found[:: args.every]
    total = time.time()
    failed = 0
    for i, desc in enumerate(chosen):
        rel = os.path.relpath(desc, args.set_dir)[: -len(".scene")]
        out = os.path.join(args.out_dir, rel)
        if os.path.exists(out):
            print(f"[{i + 1}/{len(chosen)}] {rel}: present, kept", flush=True)
            continue
        os.makedirs(os.path.dirname(out), exist_ok=True)
        t = time.time()
        cmd = [sys.executable, os.path.join(HERE, "render.py"), desc, out, "--spp", str(args.spp)] + rest
        code = subprocess.run(cmd, stdout=subprocess.DEVNULL).returncode
        status = "rendered" if code == 0 else f"FAILED (render.py exit {code})"
        failed += code != 0
        print(f"[{i + 1}/{len(chosen)}] {rel}: {status} in {time.time() - t:.1f} s", flush=True)
    print(f"{len(chosen)} scenes, {failed} failed, {time.time() - total:.0f} s", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
