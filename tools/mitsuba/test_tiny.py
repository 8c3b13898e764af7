#!/usr/bin/env python3
"""Mitsuba vs matscan on a tiny described scene, within the bounds of docs/renderers.md.

    test_tiny.py DESC_DIR [--spp N] [--variant V] [--keep DIR]

DESC_DIR is a description that `matscan simulate --describe` wrote beside
its bundle (`<bundle>.scene/`). The scene is rendered with Mitsuba at low
spp into a temporary bundle and compared with our bundle capture by
capture (compare.py's numbers on `lit - ambient`, over the object mask).
The bound depends on the material class (see `BOUNDS` and
docs/renderers.md): where both renderers implement the same lobes (opaque
dielectrics) the test is tight; where Mitsuba's model differs (rough metal
and glass without multiple-scattering compensation, sqrt tint of
transmission, subsurface) only a gross convention error fails it.

Exit 0 when every capture is inside its bound, or with `skipped: mitsuba
not importable` where Mitsuba is not installed; exit 1 with the failing
captures otherwise; exit 2 on bad input.
"""

import argparse
import json
import os
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

# Per material class and capture role: (largest lit rel. MAE, allowed range
# of lit mean Mitsuba / matscan), docs/renderers.md "Bounds for a test".
# Measured on the sample scenes (matscan 32 spp, Mitsuba 64 spp) with a
# margin; `backlit` captures have a small, noisy signal on the object.
BOUNDS = {
    "opaque-dielectric": {"lit": (0.20, (0.95, 1.05)), "backlit": (0.60, (0.75, 1.33))},
    "subsurface-medium": {"lit": (0.80, (0.50, 1.50)), "backlit": (2.00, (0.50, 3.50))},
    "other": {"lit": (0.60, (0.50, 1.50)), "backlit": (0.80, (0.50, 1.50))},
}
# Mitsuba's samples per pixel per class: a medium behind a rough dielectric
# is lit only through the boundary's transmission lobe, which is noisy.
DEFAULT_SPP = {"opaque-dielectric": 64, "subsurface-medium": 256, "other": 64}


def material_class(desc, subsurface_mode="medium"):
    """Which bound applies: where the renderers' lobes agree, or which model difference dominates."""
    import mitsuba_scene as ms

    m = desc["material"]
    if ms.uses_medium(m, subsurface_mode):
        return "subsurface-medium"
    if all(ms.max_value(m[k]) == 0.0 for k in ("metallic", "transmission")) and ms.max_value(m["subsurface"]) <= ms.SUBSURFACE_ON:
        return "opaque-dielectric"
    return "other"


def role(desc, position, capture):
    for pos in desc["positions"]:
        if pos["name"] == position:
            for cap in pos["captures"]:
                if cap["name"] == capture:
                    return "backlit" if cap["backlight"] else "lit"
    return "lit"


def violations(desc, rows, bounds):
    """Lit captures outside their bound, as readable lines."""
    out = []
    for r in rows:
        if r.get("lit_rel_mae") is None:
            continue
        kind = role(desc, r["position"], r["capture"])
        max_mae, (lo, hi) = bounds[kind]
        name = f"{r['position']}/{r['capture']} ({kind})"
        if r["lit_rel_mae"] > max_mae:
            out.append(f"{name}: lit rel. MAE {r['lit_rel_mae']:.3f} > {max_mae}")
        if not lo <= r["lit_ratio"] <= hi:
            out.append(f"{name}: lit mean Mitsuba / matscan {r['lit_ratio']:.3f} outside [{lo}, {hi}]")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("desc_dir", help="a tiny matscan-scene/1 description (<bundle>.scene/)")
    ap.add_argument("--spp", type=int, default=None,
                    help="Mitsuba samples per pixel (default 64; 256 for a subsurface medium)")
    ap.add_argument("--variant", default=None, help="Mitsuba variant (default: as render.py picks)")
    ap.add_argument("--keep", help="keep Mitsuba's bundle here instead of a temporary folder")
    args = ap.parse_args(argv)
    try:
        import mitsuba  # noqa: F401
        import numpy  # noqa: F401
    except ImportError:
        print("skipped: mitsuba not importable")
        return 0
    import compare
    import description
    import render

    try:
        desc = description.load(args.desc_dir)
        cls = material_class(desc) if _variant_set(render, args.variant) else None
    except description.DescriptionError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    tmp = tempfile.mkdtemp(prefix="matscan-mitsuba-")
    out = args.keep or os.path.join(tmp, "bundle")
    try:
        spp = args.spp or DEFAULT_SPP[cls]
        rc = render.main([args.desc_dir, out, "--spp", str(spp), "--force"]
                         + (["--variant", args.variant] if args.variant else []))
        if rc != 0:
            return 2
        rows = compare.compare(desc["bundle"], out)
    except compare.CompareError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(compare.markdown(rows))
    bound = BOUNDS[cls]
    bad = violations(desc, rows, bound)
    print(json.dumps({"class": cls, "bound": bound}))
    if bad:
        print(f"FAIL: {len(bad)} capture(s) of {desc['name']} outside the {cls} bound:")
        for line in bad:
            print(f"  {line}")
        return 1
    lit = [r for r in rows if r.get("lit_rel_mae") is not None]
    print(f"ok: {len(lit)} lit captures of {desc['name']} inside the {cls} bound")
    return 0


def _variant_set(render, requested):
    """Sets the variant render.py would use (material_class reads maps through Mitsuba)."""
    render.choose_variant(requested)
    return True


if __name__ == "__main__":
    sys.exit(main())
