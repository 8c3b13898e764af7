#!/usr/bin/env python3
"""Render a `matscan-scene/1` description with Mitsuba 3 into a `matscan-scan/1` bundle.

    render.py DESC_DIR OUT_BUNDLE [--spp N] [--variant V] [--subsurface medium|principled]

OUT_BUNDLE is a copy of the description's `bundle` (manifest, mesh, masks,
truth) with every photo replaced by Mitsuba's render times `exposure_s`, as
half-float RGB EXR like ours. Every capture is the ambient scene plus its
rig lights (the scan contract), and light transport is linear, so each
position renders the ambient scene once and each capture's rig lights alone
on top of it: the same construction as our renderer, and lit - ambient is
free of ambient noise. The bundle is built in `OUT_BUNDLE.tmp-<pid>` and
renamed into place when complete.
"""

import argparse
import os
import shutil
import sys
import time

import description
from description import DescriptionError

HALF_MAX = 65504.0


def _parse_args(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("desc_dir", help="the description folder (<bundle>.scene/)")
    ap.add_argument("out_bundle", help="the bundle to write (must not exist unless --force)")
    ap.add_argument("--spp", type=int, default=128, help="samples per pixel per render (default 128)")
    ap.add_argument("--variant", default=None,
                    help="Mitsuba variant: llvm_ad_rgb (default where available) or scalar_rgb")
    ap.add_argument("--subsurface", choices=("medium", "walk", "principled"), default="medium",
                    help="uniform subsurface: a dielectric around a medium (default), a diffuse "
                         "transmitter around it (walk), or principled without subsurface")
    ap.add_argument("--seed", type=int, default=0, help="base seed of the renders")
    ap.add_argument("--threads", type=int, default=0, help="render threads (default: all cores)")
    ap.add_argument("--force", action="store_true", help="replace OUT_BUNDLE if it exists")
    args = ap.parse_args(argv)
    if args.spp < 1:
        ap.error("--spp must be at least 1")
    return args


def find_libllvm():
    """A libLLVM >= 16 for Dr.Jit, unless DRJIT_LIBLLVM_PATH already names one.

    Dr.Jit 1.5 emits `llvm.minimum`, which LLVM 15 (Debian 12's default
    libLLVM) cannot compile for x86: the process aborts ("LLVM ERROR: Cannot
    select ... fminimum"). So we point Dr.Jit at the newest installed one.
    """
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    import glob
    import re

    found = []
    for pattern in ("/usr/lib/*/libLLVM-*.so*", "/usr/lib/llvm-*/lib/libLLVM*.so*", "/usr/lib64/libLLVM*.so*"):
        for path in glob.glob(pattern):
            m = re.search(r"(?:LLVM-|llvm-|LLVM\.so\.)(\d+)", path)
            if m and int(m.group(1)) >= 16:
                found.append((int(m.group(1)), path))
    if not found:
        return None
    path = max(found)[1]
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path


def _llvm_works():
    """Whether llvm_ad_rgb renders here; tried in a child, since a bad LLVM aborts the process."""
    import subprocess

    probe = ("import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); "
             "s = mi.load_dict({'type': 'scene', 'integrator': {'type': 'path'}, "
             "'sensor': {'type': 'perspective', 'film': {'type': 'hdrfilm', 'width': 4, 'height': 4}}, "
             "'e': {'type': 'constant'}, "
             "'o': {'type': 'sphere', 'center': [0, 0, 3], 'bsdf': {'type': 'principled', 'spec_trans': 0.5, 'metallic': 0.5}}}); "
             "mi.render(s, spp=4)")
    try:
        r = subprocess.run([sys.executable, "-c", probe], capture_output=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0


def choose_variant(requested):
    """The requested variant, else llvm_ad_rgb where it works (3x faster at 256 px), else scalar_rgb."""
    find_libllvm()
    import mitsuba as mi

    available = mi.variants()
    if not requested and mi.variant() is not None:
        return mi.variant()  # already chosen in this process (test_tiny, furnace)
    if requested:
        if requested not in available:
            raise DescriptionError(f"--variant {requested}: not in this Mitsuba build ({', '.join(available)})")
        mi.set_variant(requested)
        return requested
    if "llvm_ad_rgb" in available and _llvm_works():
        mi.set_variant("llvm_ad_rgb")
        return "llvm_ad_rgb"
    if "scalar_rgb" in available:
        print("note: llvm_ad_rgb does not run here (needs libLLVM >= 16, see docs/renderers.md); "
              "using scalar_rgb", file=sys.stderr)
        mi.set_variant("scalar_rgb")
        return "scalar_rgb"
    raise DescriptionError("no usable RGB variant (llvm_ad_rgb or scalar_rgb) in this Mitsuba build")


def check_bundle(desc):
    """The source bundle must hold the manifest and every photo the description names."""
    bundle = desc["bundle"]
    if not os.path.isfile(os.path.join(bundle, "scan.toml")):
        raise DescriptionError(
            f"{os.path.join(bundle, 'scan.toml')}: missing (the bundle named by {desc['file']} key `bundle`)")
    for pos in desc["positions"]:
        for cap in pos["captures"]:
            path = os.path.join(bundle, cap["file"])
            if not os.path.isfile(path):
                raise DescriptionError(
                    f"{path}: missing (the photo of position {pos['name']} capture {cap['name']} in {desc['file']})")


def copy_bundle(desc, tmp):
    """Everything but the photos (replaced) and estimate/ (derived from our photos)."""
    bundle = desc["bundle"]
    photos = {os.path.normpath(os.path.join(bundle, c["file"])) for p in desc["positions"] for c in p["captures"]}

    def ignore(folder, names):
        skip = [n for n in names if os.path.normpath(os.path.join(folder, n)) in photos]
        if os.path.normpath(folder) == os.path.normpath(bundle) and "estimate" in names:
            skip.append("estimate")
        return skip

    shutil.copytree(bundle, tmp, ignore=ignore)


class PositionRenderer:
    """Builds and renders the Mitsuba scenes of one position."""

    def __init__(self, desc, pos, args, env):
        import mitsuba_scene as ms

        self.desc, self.pos, self.args, self.env = desc, pos, args, env
        pose = pos["camera_to_world"]
        self.camera_center = [pose[0][3], pose[1][3], pose[2][3]]
        self.ms = ms

    def _scene(self, with_env, flashes, pattern, backlit, seed):
        ms, desc, pos = self.ms, self.desc, self.pos
        shape, volumetric = ms.object_shape(desc, self.args.subsurface)
        scene = {
            "type": "scene",
            "integrator": ms.integrator(desc["render"]["max_depth"], volumetric),
            "sensor": ms.sensor(desc["camera"], pos["camera_to_world"], self.args.spp, seed),
            "object": shape,
        }
        panel = ms.backlight(pos["backlight"], self.camera_center, backlit)
        if panel is not None:
            scene["backlight"] = panel
        if with_env and self.env is not None:
            scene["environment"] = self.env
        by_name = {f["name"]: f for f in pos["flashes"]}
        for name in flashes:
            scene[f"flash_{name}"] = ms.flash(by_name[name])
        if pattern is not None:
            scene["projector"] = ms.projector(pos["projector"], pattern)
        # A scene without any emitter renders black; skipping it saves a JIT
        # compile and Mitsuba's warning (ambient of a scene without environment).
        emits = (with_env and self.env is not None) or bool(flashes) or pattern is not None
        return scene, emits or (backlit and panel is not None)

    def render(self, with_env, flashes, pattern, backlit, seed):
        """Radiance (H, W, 3) of the scene with just these emitters."""
        import mitsuba as mi
        import numpy as np

        scene, lit = self._scene(with_env, flashes, pattern, backlit, seed)
        cam = self.desc["camera"]
        if not lit:
            return np.zeros((cam["height"], cam["width"], 3), dtype=np.float32)
        img = mi.render(mi.load_dict(scene), spp=self.args.spp, seed=seed)
        return np.array(img, dtype=np.float32)[:, :, :3]


def write_photo(path, radiance, exposure):
    """Half-float R G B EXR of exposure x radiance, finite and within half range."""
    import mitsuba as mi
    import numpy as np

    photo = radiance * np.float32(exposure)
    bad = ~np.isfinite(photo)
    if bad.any():
        print(f"warning: {path}: {int(bad.sum())} non-finite values set to 0", file=sys.stderr)
        photo[bad] = 0.0
    over = photo > HALF_MAX
    if over.any():
        print(f"warning: {path}: {int(over.sum())} values above the half-float range clipped", file=sys.stderr)
        photo = np.minimum(photo, HALF_MAX)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    bmp = mi.Bitmap(np.ascontiguousarray(photo.astype(np.float16)), mi.Bitmap.PixelFormat.RGB)
    bmp.write(path)


def render_position(desc, index, args, env, tmp):
    """Every capture of one position; returns per-capture timing lines."""
    pos = desc["positions"][index]
    r = PositionRenderer(desc, pos, args, env)
    base = args.seed * 100003 + index * 1009
    t0 = time.time()
    ambient = r.render(True, [], None, False, base)
    lines = [(pos["name"], "(ambient scene)", time.time() - t0)]
    for ci, cap in enumerate(pos["captures"]):
        t0 = time.time()
        photo = ambient
        if cap["flashes"] or cap["projector"] is not None or cap["backlight"]:
            photo = ambient + r.render(False, cap["flashes"], cap["projector"], cap["backlight"], base + 1 + ci)
        write_photo(os.path.join(tmp, cap["file"]), photo, pos["exposure_s"])
        lines.append((pos["name"], cap["name"], time.time() - t0))
    return lines


def run(args):
    desc = description.load(args.desc_dir)
    check_bundle(desc)
    out = os.path.abspath(args.out_bundle)
    if os.path.exists(out) and not args.force:
        raise DescriptionError(f"{out} already exists; refusing to replace it (use --force)")
    variant = choose_variant(args.variant)
    if args.threads > 0:
        import drjit as dr

        dr.set_thread_count(args.threads)
    import mitsuba_scene as ms

    env = ms.environment(desc)
    tmp = f"{out}.tmp-{os.getpid()}"
    if os.path.exists(tmp):
        shutil.rmtree(tmp)
    try:
        copy_bundle(desc, tmp)
        start = time.time()
        timings = []
        for i in range(len(desc["positions"])):
            timings += render_position(desc, i, args, env, tmp)
        if os.path.exists(out):
            shutil.rmtree(out)
        os.rename(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    for pos, cap, t in timings:
        print(f"  {pos} {cap}: {t:.2f} s")
    total = time.time() - start
    print(f"{out}: {len(timings) - len(desc['positions'])} photos, variant {variant}, "
          f"{args.spp} spp, subsurface {args.subsurface}, {total:.1f} s")
    return 0


def main(argv=None):
    args = _parse_args(sys.argv[1:] if argv is None else argv)
    try:
        return run(args)
    except DescriptionError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
