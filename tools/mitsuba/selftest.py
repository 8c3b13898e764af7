#!/usr/bin/env python3
"""Checks that render.py's Mitsuba scene follows docs/scene-description.md's conventions.

    selftest.py [--variant V]

Each check queries Mitsuba's own objects (sensor rays, emitter values,
texture lookups, one small render) against the description format's
formulas, computed here independently with numpy, so a flipped axis, a
half-texel shift or a missing factor of pi fails with the numbers. Needs no
matscan render. Exit 0 when every check passes, 1 otherwise.
"""

import argparse
import math
import os
import sys
import tempfile

import numpy as np

FAILURES = []


def check(name, ok, detail):
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}")
    if not ok:
        FAILURES.append(name)


def pose(yaw_deg, pitch_deg, center):
    """A camera-to-world (OpenCV frame) rotation, rows, with the given centre."""
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    m = np.eye(4)
    m[:3, :3] = ry @ rx  # the OpenCV frame is right-handed, so any rotation is a pose
    m[:3, 3] = center
    return m


def doc_dir(u, v):
    """docs/scene-description.md: the environment direction of map coordinates (u, v)."""
    phi, theta = 2 * np.pi * (u - 0.5), np.pi * v
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)


def check_environment(mi, ms, tmp):
    w, h = 32, 16
    rng = np.random.default_rng(1)
    env = rng.random((h, w, 3)).astype(np.float32) + 0.1
    path = os.path.join(tmp, "env.exr")
    mi.Bitmap(env, mi.Bitmap.PixelFormat.RGB).write(path)
    emitter = mi.load_dict(ms.environment({"environment": {"map": path}}))
    worst = 0.0
    # Texel centres, and points between texels (bilinear of our map, wrapping in u).
    for j in range(1, h - 1):
        for i in range(w):
            for du, dv in ((0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.3, 0.7)):
                d = doc_dir((i + 0.5 + du) / w, (j + 0.5 + dv) / h)
                si = dr_zeros_si(mi)
                si.wi = mi.Vector3f(*[float(x) for x in -d])
                got = np.array(emitter.eval(si)).reshape(-1)[:3]
                i1, j1 = (i + 1) % w, min(j + 1, h - 1)
                want = ((1 - du) * (1 - dv) * env[j, i] + du * (1 - dv) * env[j, i1]
                        + (1 - du) * dv * env[j1, i] + du * dv * env[j1, i1])
                worst = max(worst, float(np.max(np.abs(got - want) / want)))
    check("environment mapping", worst < 1e-4, f"largest relative error {worst:.2e} over texel centres and midpoints")


def dr_zeros_si(mi):
    import drjit as dr

    return dr.zeros(mi.SurfaceInteraction3f)


def check_camera(mi, ms):
    cam = {"width": 40, "height": 30, "fx": 35.0, "fy": 35.0, "cx": 17.25, "cy": 16.5}
    c2w = pose(30, -20, [0.3, -0.2, -1.5])
    sensor = mi.load_dict(ms.sensor(cam, c2w.tolist(), 1, 0))
    worst = 0.0
    for (i, j) in ((0, 0), (39, 0), (0, 29), (39, 29), (17, 16), (5, 22)):
        ray, _ = sensor.sample_ray(0.0, 0.5, [(i + 0.5) / cam["width"], (j + 0.5) / cam["height"]], [0.5, 0.5])
        local = np.array([(i + 0.5 - cam["cx"]) / cam["fx"], (j + 0.5 - cam["cy"]) / cam["fy"], 1.0])
        want = c2w[:3, :3] @ (local / np.linalg.norm(local))
        got = np.array(ray.d).reshape(-1)
        worst = max(worst, float(np.max(np.abs(got - want))))
    check("camera rays", worst < 1e-5, f"largest direction error {worst:.2e} (OpenCV pixel centres, off-centre principal point)")


def write_plate(path, size=1.0, z=0.0):
    """Two triangles in the z = `z` plane with s = (x + size) / 2 size, t = (y + size) / 2 size."""
    verts = [(-size, -size), (size, -size), (size, size), (-size, size)]
    with open(path, "w") as fh:
        fh.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                 "property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n"
                 "element face 2\nproperty list uchar int vertex_indices\nend_header\n")
        for x, y in verts:
            fh.write(f"{x} {y} {z} 0 0 -1 {(x + size) / (2 * size)} {(y + size) / (2 * size)}\n")
        fh.write("3 0 2 1\n3 0 3 2\n")


def doc_bilinear(tex, s, t):
    """Map lookup as the description defines it: row 0 is v = 1, texel centres at +0.5, wrap."""
    h, w = tex.shape[:2]
    x, y = s * w - 0.5, (1.0 - t) * h - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    at = lambda i, j: tex[j % h, i % w]
    return ((1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0)
            + (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1))


def check_texture(mi, ms, tmp):
    rng = np.random.default_rng(2)
    tex = rng.random((8, 12, 3)).astype(np.float32)
    tpath = os.path.join(tmp, "basecolor.exr")
    mi.Bitmap(tex, mi.Bitmap.PixelFormat.RGB).write(tpath)
    mesh = os.path.join(tmp, "plate.ply")
    write_plate(mesh)
    texture = mi.load_dict(ms._input({"map": tpath}, 3))
    scene = mi.load_dict({"type": "scene", "plate": {"type": "ply", "filename": mesh, "flip_tex_coords": True}})
    worst = 0.0
    for _ in range(200):
        x, y = rng.uniform(-0.999, 0.999, 2)
        si = scene.ray_intersect(mi.Ray3f([float(x), float(y), -1.0], [0.0, 0.0, 1.0]))
        got = np.array(texture.eval(si)).reshape(-1)[:3]
        want = doc_bilinear(tex, (x + 1) / 2, (y + 1) / 2)
        worst = max(worst, float(np.max(np.abs(got - want))))
    check("material map lookup", worst < 1e-4, f"largest error {worst:.2e} (row 0 at v = 1, bilinear, wrap)")


def project(p, c2w, k):
    local = np.linalg.inv(c2w) @ np.append(p, 1.0)
    return k["fx"] * local[0] / local[2] + k["cx"], k["fy"] * local[1] / local[2] + k["cy"], local[2]


def check_projector(mi, ms):
    from description import pattern_value

    k = {"name": "projector", "width": 120, "height": 90, "fx": 110.0, "fy": 110.0, "cx": 52.5, "cy": 47.0,
         "intensity": [3.0, 2.0, 1.0]}
    c2w = pose(-15, 10, [0.2, 0.1, -1.2])
    k["to_world"] = c2w.tolist()
    pattern = {"kind": "checker", "period_px": 12.0, "phase_px": [3.0, 5.0], "low": 0.1, "high": 0.9}
    emitter = mi.load_dict(ms.projector(k, pattern))
    rng = np.random.default_rng(3)
    worst, n, outside = 0.0, 0, 0
    while n < 400:
        q = rng.uniform([-0.2, -0.2, 0.5], [0.2, 0.2, 1.5])
        p = c2w[:3, :3] @ (q * np.array([2.5, 2.5, 1])) + c2w[:3, 3]
        px, py, z = project(p, c2w, k)
        it = dr_zeros_si(mi)
        it.p = mi.Point3f(*[float(x) for x in p])
        ds, spec = emitter.sample_direction(it, [0.5, 0.5])
        got = np.array(spec).reshape(-1)[:3]
        u, v = math.floor(px), math.floor(py)
        inside = 0 <= u < k["width"] and 0 <= v < k["height"] and z > 0
        d2 = float(np.sum((p - c2w[:3, 3]) ** 2))
        want = (np.array(k["intensity"]) * float(pattern_value(pattern, u, v)) / d2) if inside else np.zeros(3)
        if not inside:
            outside += 1
        rel = np.abs(got - want) / np.maximum(want, 1e-3)
        worst = max(worst, float(rel.max()))
        n += 1
    check("projector intensity / d^2 per pixel", worst < 2e-3,
          f"largest relative error {worst:.2e} over {n} points ({outside} outside the image)")


def check_plate_render(mi, ms):
    """A white-ish Lambertian plate under the projector: radiance = albedo I cos / (pi d^2)."""
    k = {"name": "projector", "width": 64, "height": 64, "fx": 60.0, "fy": 60.0, "cx": 32.0, "cy": 32.0,
         "intensity": [2.0, 2.0, 2.0], "to_world": pose(0, 0, [0.3, 0.0, -1.0]).tolist()}
    cam = {"width": 16, "height": 16, "fx": 40.0, "fy": 40.0, "cx": 8.0, "cy": 8.0}
    c2w = pose(0, 0, [0.0, 0.0, -1.0])
    tilt = math.radians(25)
    n = np.array([math.sin(tilt), 0.0, -math.cos(tilt)])
    albedo = 0.8
    scene = mi.load_dict({
        "type": "scene",
        "integrator": ms.integrator(1, False),
        "sensor": ms.sensor(cam, c2w.tolist(), 512, 0),
        "plate": {"type": "rectangle", "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], -25).scale(3.0),
                  "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse",
                                                        "reflectance": {"type": "rgb", "value": [albedo] * 3}}}},
        "projector": ms.projector(k, {"kind": "uniform", "level": 1.0}),
    })
    img = np.array(mi.render(scene, spp=512))
    # Centre pixels: the plate point seen through the pixel centre.
    worst = 0.0
    for (i, j) in ((7, 7), (8, 8), (5, 10), (10, 6)):
        d = c2w[:3, :3] @ np.array([(i + 0.5 - 8) / 40.0, (j + 0.5 - 8) / 40.0, 1.0])
        o = c2w[:3, 3]
        t = -np.dot(o, n) / np.dot(d, n)
        p = o + t * d
        l = np.array(k["to_world"])[:3, 3] - p
        d2 = float(l @ l)
        cos = abs(float(np.dot(l / math.sqrt(d2), n)))
        want = albedo * 2.0 * cos / (math.pi * d2)
        worst = max(worst, abs(float(img[j, i, 0]) - want) / want)
    check("projector on a diffuse plate", worst < 0.01, f"largest relative error {worst:.2e} vs albedo I cos / (pi d^2)")


def check_flash(mi, ms):
    e = mi.load_dict(ms.flash({"name": "f", "position": [0.1, 0.2, -1.0], "intensity": [5.0, 4.0, 3.0]}))
    it = dr_zeros_si(mi)
    it.p = mi.Point3f(0.4, -0.3, 0.5)
    _, spec = e.sample_direction(it, [0.5, 0.5])
    d2 = 0.3 ** 2 + 0.5 ** 2 + 1.5 ** 2
    err = float(np.max(np.abs(np.array(spec).reshape(-1)[:3] - np.array([5.0, 4.0, 3.0]) / d2)))
    check("flash intensity / d^2", err < 1e-6, f"error {err:.2e}")


def check_backlight(mi, ms):
    b = {"name": "backlight", "center": [0.1, 0.0, 1.0], "half_u": [0.0, 0.5, 0.0], "half_v": [0.6, 0.0, 0.05],
         "radiance": [2.0, 1.5, 1.0], "albedo": 0.85}
    cam = [0.0, 0.0, -1.5]
    scene = mi.load_dict({"type": "scene", "panel": ms.backlight(b, cam, True)})
    c, hu, hv = (np.array(b[k]) for k in ("center", "half_u", "half_v"))
    ok_geom = True
    for a, bb, hit in ((0.95, 0.95, True), (-0.95, 0.9, True), (1.05, 0.0, False), (0.0, -1.05, False)):
        target = c + a * hu + bb * hv
        d = target - np.array(cam)
        si = scene.ray_intersect(mi.Ray3f(cam, (d / np.linalg.norm(d)).tolist()))
        ok_geom &= bool(si.is_valid()) == hit
    front = [0.0, 0.0, -1.5]
    back = [0.0, 0.0, 3.0]
    values = []
    for o in (front, back):
        d = c - np.array(o)
        si = scene.ray_intersect(mi.Ray3f(o, (d / np.linalg.norm(d)).tolist()))
        values.append(np.array(si.emitter(scene).eval(si)).reshape(-1)[:3])
        bsdf = si.bsdf()
        wo = si.to_local(mi.Vector3f(*[float(x) for x in -d / np.linalg.norm(d)]))
        f = np.array(bsdf.eval(mi.BSDFContext(), si, wo)).reshape(-1)[0] / abs(float(np.array(wo.z).reshape(-1)[0]))
        values.append(f * math.pi)
    ok = (ok_geom and np.allclose(values[0], b["radiance"]) and np.allclose(values[2], 0.0)
          and abs(values[1] - 0.85) < 1e-5 and abs(values[3] - 0.85) < 1e-5)
    check("backlight panel", ok, f"edges {'ok' if ok_geom else 'wrong'}, front emits {values[0]}, back emits "
          f"{values[2]}, albedo front {values[1]:.4f} back {values[3]:.4f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", default="scalar_rgb")
    args = ap.parse_args(argv)
    if args.variant.startswith("llvm"):
        from render import find_libllvm

        find_libllvm()
    import mitsuba as mi

    mi.set_variant(args.variant)
    import mitsuba_scene as ms

    with tempfile.TemporaryDirectory() as tmp:
        check_environment(mi, ms, tmp)
        check_camera(mi, ms)
        check_texture(mi, ms, tmp)
        check_projector(mi, ms)
        check_plate_render(mi, ms)
        check_flash(mi, ms)
        check_backlight(mi, ms)
    print(f"{7 - len(FAILURES)} passed, {len(FAILURES)} failed")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
