"""Reading and checking a `matscan-scene/1` description (docs/scene-description.md).

Everything the renderer needs is validated here, up front, so that a bad
description fails with one message naming the file and the key
(`scene.json: key `positions[1].flashes[0].intensity`: expected 3 numbers`)
instead of a Mitsuba error half-way through a render.
Standard library only: the checks must run even where Mitsuba is missing.
"""

import json
import math
import os

FORMAT = "matscan-scene/1"
MATERIAL_PARAMS = ("basecolor", "roughness", "metallic", "transmission", "subsurface")


class DescriptionError(Exception):
    """A description that cannot be rendered; the message names file and key."""


class _Checker:
    """Typed access to a JSON tree that reports `file: key `path`: problem`."""

    def __init__(self, file):
        self.file = file

    def fail(self, path, what):
        raise DescriptionError(f"{self.file}: key `{path}`: {what}")

    def get(self, obj, key, path):
        if not isinstance(obj, dict) or key not in obj:
            self.fail(f"{path}.{key}" if path else key, "missing")
        return obj[key]

    def number(self, obj, key, path, positive=False):
        v = self.get(obj, key, path)
        full = f"{path}.{key}" if path else key
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.fail(full, f"expected a finite number, found {json.dumps(v)}")
        if positive and v <= 0:
            self.fail(full, f"expected a positive number, found {v}")
        return float(v)

    def integer(self, obj, key, path):
        v = self.get(obj, key, path)
        full = f"{path}.{key}" if path else key
        if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
            self.fail(full, f"expected a positive integer, found {json.dumps(v)}")
        return v

    def vector(self, obj, key, path, n, nonnegative=False):
        v = self.get(obj, key, path)
        full = f"{path}.{key}" if path else key
        ok = isinstance(v, list) and len(v) == n and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v
        )
        if not ok:
            self.fail(full, f"expected {n} finite numbers, found {json.dumps(v)}")
        if nonnegative and any(x < 0 for x in v):
            self.fail(full, f"expected {n} non-negative numbers, found {json.dumps(v)}")
        return [float(x) for x in v]

    def string(self, obj, key, path):
        v = self.get(obj, key, path)
        if not isinstance(v, str) or not v:
            self.fail(f"{path}.{key}" if path else key, f"expected a non-empty string, found {json.dumps(v)}")
        return v

    def matrix(self, obj, key, path):
        """A row-major 4x4 affine pose, as nested row lists."""
        m = self.vector(obj, key, path, 16)
        rows = [m[0:4], m[4:8], m[8:12], m[12:16]]
        if rows[3] != [0.0, 0.0, 0.0, 1.0]:
            self.fail(f"{path}.{key}", f"expected an affine transform whose last row is 0 0 0 1, found {rows[3]}")
        a = [r[:3] for r in rows[:3]]
        det = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
               - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
               + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
        if abs(det) < 1e-12:
            self.fail(f"{path}.{key}", "expected an invertible transform; its 3x3 part is singular")
        return rows


def _relative_file(c, desc_dir, value, path):
    """A file inside the description folder (no absolute paths, no `..`)."""
    if not isinstance(value, str) or not value or os.path.isabs(value) or ".." in value.replace("\\", "/").split("/"):
        c.fail(path, f"expected a file name relative to the description folder, found {json.dumps(value)}")
    full = os.path.join(desc_dir, value)
    if not os.path.isfile(full):
        raise DescriptionError(f"{full}: missing (named by {c.file} key `{path}`)")
    return full


def _param(c, desc_dir, material, name, channels):
    """One Principled input: {'value': v} or {'map': path}."""
    entry = c.get(material, name, "material")
    path = f"material.{name}"
    if not isinstance(entry, dict) or (("value" in entry) == ("map" in entry)):
        c.fail(path, 'expected { "value": v } or { "map": "<file>.exr" }')
    if "map" in entry:
        return {"map": _relative_file(c, desc_dir, entry["map"], path + ".map")}
    if channels == 3:
        v = c.vector(entry, "value", path, 3, nonnegative=True)
    else:
        v = c.number(entry, "value", path)
    return {"value": v}


def _material(c, desc_dir, doc):
    m = c.get(doc, "material", "")
    out = {}
    for name in MATERIAL_PARAMS:
        out[name] = _param(c, desc_dir, m, name, 3 if name == "basecolor" else 1)
    out["subsurface_radius"] = c.vector(m, "subsurface_radius", "material", 3, nonnegative=True)
    out["specular"] = c.number(m, "specular", "material")
    out["ior"] = c.number(m, "ior", "material", positive=True)
    out["model"] = m.get("model", "")
    return out


def _pattern(c, value, path):
    if value is None:
        return None
    kind = c.string(value, "kind", path)
    if kind == "uniform":
        return {"kind": "uniform", "level": c.number(value, "level", path)}
    if kind == "checker":
        phase = value.get("phase_px", [0.0, 0.0])
        return {
            "kind": "checker",
            "period_px": c.number(value, "period_px", path, positive=True),
            "phase_px": c.vector({"phase_px": phase}, "phase_px", path, 2),
            "low": float(value.get("low", 0.0)),
            "high": float(value.get("high", 1.0)),
        }
    c.fail(f"{path}.kind", f'expected "uniform" or "checker", found {json.dumps(kind)}')


def _position(c, doc_pos, i):
    path = f"positions[{i}]"
    name = c.string(doc_pos, "name", path)
    if "/" in name or "\\" in name or name in (".", ".."):
        c.fail(f"{path}.name", f"expected a name usable as a folder name, found {json.dumps(name)}")
    path = f"positions[{i}]"
    flashes = []
    for j, f in enumerate(c.get(doc_pos, "flashes", path)):
        fp = f"{path}.flashes[{j}]"
        flashes.append({
            "name": c.string(f, "name", fp),
            "position": c.vector(f, "position", fp, 3),
            "intensity": c.vector(f, "intensity", fp, 3, nonnegative=True),
        })
    pj = c.get(doc_pos, "projector", path)
    pp = f"{path}.projector"
    projector = {
        "name": c.string(pj, "name", pp),
        "to_world": c.matrix(pj, "projector_to_world", pp),
        "width": c.integer(pj, "width", pp),
        "height": c.integer(pj, "height", pp),
        "fx": c.number(pj, "fx", pp, positive=True),
        "fy": c.number(pj, "fy", pp, positive=True),
        "cx": c.number(pj, "cx", pp),
        "cy": c.number(pj, "cy", pp),
        "intensity": c.vector(pj, "intensity", pp, 3, nonnegative=True),
    }
    bl = c.get(doc_pos, "backlight", path)
    bp = f"{path}.backlight"
    backlight = {
        "name": c.string(bl, "name", bp),
        "center": c.vector(bl, "center", bp, 3),
        "half_u": c.vector(bl, "half_u", bp, 3),
        "half_v": c.vector(bl, "half_v", bp, 3),
        "radiance": c.vector(bl, "radiance", bp, 3, nonnegative=True),
        "albedo": c.number(bl, "albedo", bp),
    }
    names = {f["name"] for f in flashes}
    captures = []
    for j, cap in enumerate(c.get(doc_pos, "captures", path)):
        cp = f"{path}.captures[{j}]"
        cap_flashes = c.get(cap, "flashes", cp)
        if not isinstance(cap_flashes, list):
            c.fail(f"{cp}.flashes", "expected a list of flash names")
        for k, fname in enumerate(cap_flashes):
            if fname not in names:
                c.fail(f"{cp}.flashes[{k}]", f"names flash {json.dumps(fname)}, which {path} does not have")
        backlit = c.get(cap, "backlight", cp)
        if not isinstance(backlit, bool):
            c.fail(f"{cp}.backlight", f"expected true or false, found {json.dumps(backlit)}")
        file = c.string(cap, "file", cp)
        if os.path.isabs(file) or ".." in file.split("/"):
            c.fail(f"{cp}.file", f"expected a path relative to the bundle, found {json.dumps(file)}")
        captures.append({
            "name": c.string(cap, "name", cp),
            "file": file,
            "flashes": list(cap_flashes),
            "projector": _pattern(c, c.get(cap, "projector", cp), f"{cp}.projector"),
            "backlight": backlit,
        })
    if not captures:
        c.fail(f"{path}.captures", "expected at least one capture")
    return {
        "name": name,
        "camera_to_world": c.matrix(doc_pos, "camera_to_world", path),
        "exposure_s": c.number(doc_pos, "exposure_s", path, positive=True),
        "flashes": flashes,
        "projector": projector,
        "backlight": backlight,
        "captures": captures,
    }


def load(desc_dir):
    """The checked description in `desc_dir` as plain dicts, paths made absolute."""
    file = os.path.join(desc_dir, "scene.json")
    if not os.path.isfile(file):
        raise DescriptionError(f"{file}: missing (is {desc_dir} a matscan-scene/1 description folder?)")
    try:
        with open(file, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as e:
        raise DescriptionError(f"{file}: not valid JSON: {e}") from e
    c = _Checker(file)
    fmt = c.get(doc, "format", "")
    if fmt != FORMAT:
        c.fail("format", f"expected {json.dumps(FORMAT)}, found {json.dumps(fmt)}")
    cam = c.get(doc, "camera", "")
    camera = {k: c.integer(cam, k, "camera") for k in ("width", "height")}
    camera.update({k: c.number(cam, k, "camera", positive=True) for k in ("fx", "fy")})
    camera.update({k: c.number(cam, k, "camera") for k in ("cx", "cy")})
    env = c.get(doc, "environment", "")
    environment = None
    if env is not None:
        environment = {"map": _relative_file(c, desc_dir, c.get(env, "map", "environment"), "environment.map")}
    bundle_rel = c.string(doc, "bundle", "")
    positions = [_position(c, p, i) for i, p in enumerate(c.get(doc, "positions", ""))]
    if not positions:
        c.fail("positions", "expected at least one position")
    render = doc.get("render") or {}
    return {
        "file": file,
        "dir": os.path.abspath(desc_dir),
        "name": doc.get("name", ""),
        "bundle": os.path.normpath(os.path.join(os.path.abspath(desc_dir), bundle_rel)),
        "mesh": _relative_file(c, desc_dir, c.get(doc, "mesh", ""), "mesh"),
        "material": _material(c, desc_dir, doc),
        "environment": environment,
        "camera": camera,
        "render": {"max_depth": int(render.get("max_depth", 8)), "samples": int(render.get("samples", 32))},
        "positions": positions,
    }


def pattern_value(pattern, u, v):
    """The pattern at integer projector pixel (u, v), clamped to [0, 1] as ours does.

    Works on numpy arrays as well as numbers (only floor/arith is used).
    """
    if pattern["kind"] == "uniform":
        return min(max(pattern["level"], 0.0), 1.0) + 0.0 * u
    half = pattern["period_px"] / 2.0
    pu, pv = pattern["phase_px"]
    import numpy as np  # only checker patterns need it, and only render.py asks

    i = np.floor((u - pu) / half)
    j = np.floor((v - pv) / half)
    even = (i + j) % 2 == 0
    lo = min(max(pattern["low"], 0.0), 1.0)
    hi = min(max(pattern["high"], 0.0), 1.0)
    return np.where(even, hi, lo)
