#!/usr/bin/env python3
"""Compare two `matscan-scan/1` bundles of the same scan, photo by photo.

    compare.py BUNDLE_A BUNDLE_B [--json OUT.json] [--png DIR]

Per position and capture, over the object mask of A (`views/<pos>/mask.png`):

- `rel_rmse`: sqrt(mean((a - b)^2)) / mean(a) of radiance (photo / exposure_s),
  over masked pixels and the three channels;
- `lit_rel_rmse`: the same for `capture - ambient` (the rig light alone);
- `rel_mae`, `lit_rel_mae`: mean(|a - b|) / mean(a), which a few
  firefly pixels (a point light's highlight on a near-mirror) sway far less
  than the RMSE;
- `ratio` and `lit_ratio`: mean(b) / mean(a), which separates a bias
  (ratio away from 1) from noise (ratio near 1, rmse above 0).

Where mean(a) is 0 (the ambient photo of a scene without environment) the
relative numbers are null.

Prints a Markdown table and writes the numbers as JSON (default
`BUNDLE_B.compare.json`). `--png DIR` writes, per capture, A | B | |A - B|
side by side (sRGB, A's 99th percentile as white) for looking at the
differences.
"""

import argparse
import json
import os
import sys
import tomllib

import numpy as np


class CompareError(Exception):
    pass


def _mitsuba():
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return mi


def read_image(path):
    """(H, W, C) float32 of an EXR or PNG (PNG mapped to [0, 1])."""
    mi = _mitsuba()
    if not os.path.isfile(path):
        raise CompareError(f"{path}: missing")
    try:
        bmp = mi.Bitmap(path)
    except Exception as e:
        raise CompareError(f"{path}: not a readable image: {e}") from e
    arr = np.array(bmp, copy=True)
    scale = 1.0 / np.iinfo(arr.dtype).max if np.issubdtype(arr.dtype, np.integer) else 1.0
    arr = arr.astype(np.float32) * scale
    return arr[:, :, None] if arr.ndim == 2 else arr


def read_rgb(path):
    a = read_image(path)
    return np.repeat(a[:, :, :1], 3, axis=2) if a.shape[2] < 3 else a[:, :, :3]


def load_manifest(bundle):
    path = os.path.join(bundle, "scan.toml")
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except FileNotFoundError:
        raise CompareError(f"{path}: missing (is {bundle} a scan bundle?)") from None
    except tomllib.TOMLDecodeError as e:
        raise CompareError(f"{path}: not valid TOML: {e}") from e
    positions = {}
    for i, p in enumerate(doc.get("position", [])):
        if "name" not in p:
            raise CompareError(f"{path}: key `position[{i}].name`: missing")
        caps = {}
        for j, c in enumerate(p.get("capture", [])):
            for key in ("name", "file", "exposure_s", "lights"):
                if key not in c:
                    raise CompareError(f"{path}: key `position \"{p['name']}\".capture[{j}].{key}`: missing")
            caps[c["name"]] = c
        positions[p["name"]] = caps
    if not positions:
        raise CompareError(f"{path}: key `position`: missing; expected at least one [[position]]")
    return positions


def is_ambient(cap):
    return not cap["lights"] and "pattern" not in cap


def radiance(bundle, cap):
    return read_rgb(os.path.join(bundle, cap["file"])) / float(cap["exposure_s"])


def relative_errors(a, b, mask):
    """(rel. RMSE, rel. MAE, mean ratio) over masked pixels and channels; None where mean(a) is 0."""
    da, db = a[mask].astype(np.float64), b[mask].astype(np.float64)
    mean = float(da.mean()) if da.size else 0.0
    if not mean > 0:
        return None, None, None
    rmse = float(np.sqrt(np.mean((da - db) ** 2)))
    mae = float(np.mean(np.abs(da - db)))
    return rmse / mean, mae / mean, float(db.mean()) / mean


def _mask(bundle, pos, shape):
    path = os.path.join(bundle, "views", pos, "mask.png")
    if not os.path.isfile(path):
        print(f"warning: {path}: missing; comparing every pixel", file=sys.stderr)
        return np.ones(shape[:2], dtype=bool)
    m = read_image(path)
    if m.shape[:2] != shape[:2]:
        raise CompareError(f"{path}: {m.shape[1]}x{m.shape[0]} pixels, the photos are {shape[1]}x{shape[0]}")
    return np.any(m > 0, axis=2)


def _png(path, a, b, white):
    """A | B | |A - B| in sRGB for the eye."""
    mi = _mitsuba()
    row = np.concatenate([a, b, np.abs(a - b)], axis=1) / max(white, 1e-12)
    row = np.clip(row, 0, 1)
    srgb = np.where(row <= 0.0031308, 12.92 * row, 1.055 * row ** (1 / 2.4) - 0.055)
    img = (srgb * 255 + 0.5).astype(np.uint8)
    mi.Bitmap(np.ascontiguousarray(img), mi.Bitmap.PixelFormat.RGB).write(path)


def compare_position(bundle_a, bundle_b, pos, caps_a, caps_b, png_dir):
    rows = []
    amb_name = next((n for n, c in caps_a.items() if is_ambient(c)), None)
    if amb_name is None:
        raise CompareError(f"{bundle_a}/scan.toml: position {pos} has no ambient capture")
    if amb_name not in caps_b:
        raise CompareError(f"{bundle_b}/scan.toml: position {pos} has no capture `{amb_name}`")
    amb_a, amb_b = radiance(bundle_a, caps_a[amb_name]), radiance(bundle_b, caps_b[amb_name])
    mask = _mask(bundle_a, pos, amb_a.shape)
    for name, cap in caps_a.items():
        if name not in caps_b:
            raise CompareError(f"{bundle_b}/scan.toml: position {pos} has no capture `{name}`")
        a, b = radiance(bundle_a, cap), radiance(bundle_b, caps_b[name])
        if a.shape != b.shape:
            raise CompareError(f"{pos}/{name}: image sizes differ ({a.shape[1]}x{a.shape[0]} vs {b.shape[1]}x{b.shape[0]})")
        err, mae, ratio = relative_errors(a, b, mask)
        row = {"position": pos, "capture": name, "rel_rmse": err, "rel_mae": mae, "ratio": ratio,
               "mean_a": float(a[mask].mean()), "pixels": int(mask.sum())}
        if name != amb_name:
            row["lit_rel_rmse"], row["lit_rel_mae"], row["lit_ratio"] = relative_errors(a - amb_a, b - amb_b, mask)
        rows.append(row)
        if png_dir:
            os.makedirs(png_dir, exist_ok=True)
            _png(os.path.join(png_dir, f"{pos}-{name}.png"), a, b, float(np.percentile(a, 99)))
    return rows


def compare(bundle_a, bundle_b, png_dir=None):
    ma, mb = load_manifest(bundle_a), load_manifest(bundle_b)
    rows = []
    for pos, caps in ma.items():
        if pos not in mb:
            raise CompareError(f"{bundle_b}/scan.toml: no position `{pos}`")
        rows += compare_position(bundle_a, bundle_b, pos, caps, mb[pos], png_dir)
    return rows


def _fmt(row, key):
    if key not in row:
        return ""
    return "n/a" if row[key] is None else f"{row[key]:.3f}"


COLUMNS = (("rel. RMSE", "rel_rmse"), ("rel. MAE", "rel_mae"), ("mean B/A", "ratio"),
           ("lit rel. RMSE", "lit_rel_rmse"), ("lit rel. MAE", "lit_rel_mae"), ("lit mean B/A", "lit_ratio"))


def markdown(rows):
    out = ["| position | capture | " + " | ".join(c for c, _ in COLUMNS) + " |",
           "|---|---|" + "---:|" * len(COLUMNS)]
    for r in rows:
        out.append(f"| {r['position']} | {r['capture']} | " + " | ".join(_fmt(r, k) for _, k in COLUMNS) + " |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bundle_a", help="reference bundle (its masks are used)")
    ap.add_argument("bundle_b", help="the bundle to compare with it")
    ap.add_argument("--json", help="where to write the numbers (default BUNDLE_B.compare.json)")
    ap.add_argument("--png", help="folder for A | B | |A - B| images")
    args = ap.parse_args(argv)
    try:
        rows = compare(args.bundle_a, args.bundle_b, args.png)
    except CompareError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        print(markdown(rows))
    except BrokenPipeError:  # piped into head: the JSON still gets written
        sys.stdout = None
    out = args.json or os.path.normpath(args.bundle_b) + ".compare.json"
    with open(out, "w", encoding="utf-8") as fh:
        json.dump({"a": os.path.abspath(args.bundle_a), "b": os.path.abspath(args.bundle_b), "rows": rows}, fh, indent=2)
        fh.write("\n")
    if sys.stdout:
        print(f"\nwrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
