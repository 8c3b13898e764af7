#!/usr/bin/env python3
"""White-furnace directional albedo of Mitsuba's `principled`, lobe by lobe.

    furnace.py [--samples N] [--variant V] [--json OUT] [--ours MATSCAN.json]

A plane under a uniform environment of radiance 1 (no other light) returns
its directional albedo: the mean of Mitsuba's `sample` weight (f cos / pdf).
The grid is bsdf/examples/furnace.rs's: roughness {0.05, 0.25, 0.5, 0.75, 1}
x metallic {0, 1} x transmission {0, 1} x view {0, 45, 75} degrees, base
colour white; plus base colour black for the dielectric (specular lobe
alone; glass reflection alone). Parameters as render.py sets them: `eta`
1.45 where the material transmits, else `specular` 0.5.

Mitsuba scales refracted radiance by 1 / eta^2 (radiance mode); matscan and
Cycles do not. `transmit` is Mitsuba's weight as it renders; `transmit_energy`
undoes the 1 / eta^2 so the two renderers' energy can be compared (the
factor cancels for light that enters and leaves a closed object).

With `--ours` (the JSON of `cargo run --release -p matscan-bsdf --example
furnace`) it prints both side by side as a Markdown table.
"""

import argparse
import json
import math
import sys

ROUGHNESS = (0.05, 0.25, 0.5, 0.75, 1.0)
VIEW_DEG = (0.0, 45.0, 75.0)
CASES = ((1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (1.0, 0.0, 1.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
ETA = 1.45


def principled(base, roughness, metallic, transmission):
    """The same parameter choice as mitsuba_scene.principled."""
    d = {"type": "principled", "base_color": {"type": "rgb", "value": [base] * 3},
         "roughness": roughness, "metallic": metallic}
    if transmission > 0:
        d["spec_trans"] = transmission
        d["eta"] = ETA
    else:
        d["specular"] = 0.5
    return d


def albedo(mi, dr, bsdf, view_deg, n, seed):
    """Mean reflected and transmitted sample weight from one outgoing direction."""
    import numpy as np

    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, n)
    th = math.radians(view_deg)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(math.sin(th), 0.0, math.cos(th))
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    bs, w = bsdf.sample(mi.BSDFContext(), si, sampler.next_1d(), sampler.next_2d())
    w = np.array(w, dtype=np.float64).reshape(-1, 3) if np.array(w).ndim == 1 else np.array(w, dtype=np.float64).T
    up = np.array(bs.wo.z, dtype=np.float64) > 0
    w = np.where(np.isfinite(w), w, 0.0)
    reflect = (w * up[:, None]).sum(0) / n
    transmit = (w * ~up[:, None]).sum(0) / n
    return reflect, transmit, w.std(0) / math.sqrt(n)


def run(samples, variant):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    rows = []
    seed = 1
    for base, metallic, transmission in CASES:
        for r in ROUGHNESS:
            bsdf = mi.load_dict(principled(base, r, metallic, transmission))
            for view in VIEW_DEG:
                refl, trans, err = albedo(mi, dr, bsdf, view, samples, seed)
                seed += 1
                energy = trans * ETA ** 2
                rows.append({"basecolor": base, "roughness": r, "metallic": metallic, "transmission": transmission,
                             "view_deg": view, "albedo": (refl + trans).tolist(), "reflect": refl.tolist(),
                             "transmit": trans.tolist(), "transmit_energy": energy.tolist(),
                             "albedo_energy": (refl + energy).tolist(), "stderr": err.tolist()})
    return {"renderer": f"mitsuba {mi.__version__} {variant} principled", "samples": samples, "rows": rows}


def _key(r):
    return (float(r["basecolor"]), float(r["roughness"]), float(r["metallic"]), float(r["transmission"]),
            float(r["view_deg"]))


def lobe_name(base, metallic, transmission):
    if metallic > 0:
        return "metal" if transmission == 0 else "metal (transmission 1)"
    if transmission > 0:
        return "glass, R+T" if base > 0 else "glass, R only (black)"
    return "diffuse + specular" if base > 0 else "specular only (black)"


def side_by_side(ours, theirs):
    """Markdown table: energy albedo of both, first channel (the grid is grey)."""
    mine = {_key(r): r for r in ours["rows"]}
    out = ["| lobe | roughness | view | matscan | Mitsuba | Mitsuba / matscan |", "|---|---:|---:|---:|---:|---:|"]
    for r in theirs["rows"]:
        o = mine.get(_key(r))
        if o is None:
            continue
        a, b = o["albedo"][0], r["albedo_energy"][0]
        ratio = b / a if a > 0 else float("nan")
        out.append(f"| {lobe_name(r['basecolor'], r['metallic'], r['transmission'])} | {r['roughness']} | "
                   f"{r['view_deg']:.0f} | {a:.4f} | {b:.4f} | {ratio:.3f} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=1_000_000, help="samples per direction (default 1e6)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (llvm_ad_rgb or scalar_rgb)")
    ap.add_argument("--json", default="furnace-mitsuba.json", help="where to write Mitsuba's albedos")
    ap.add_argument("--ours", help="matscan-bsdf's furnace JSON, for the side-by-side table")
    args = ap.parse_args(argv)
    if args.variant.startswith("llvm"):
        from render import find_libllvm

        find_libllvm()
    result = run(args.samples, args.variant)
    with open(args.json, "w", encoding="utf-8") as fh:
        json.dump(result, fh, indent=1)
        fh.write("\n")
    print(f"wrote {args.json}")
    if args.ours:
        with open(args.ours, encoding="utf-8") as fh:
            ours = json.load(fh)
        print(side_by_side(ours, result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
