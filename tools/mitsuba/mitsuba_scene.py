"""Mitsuba 3 scene dictionaries for a checked `matscan-scene/1` description.

Each builder maps one element of docs/scene-description.md onto Mitsuba's
plugins and states, where Mitsuba's convention differs from ours, how the
difference is undone. The caller must have called `mi.set_variant` first.
"""

import math
import sys

import mitsuba as mi
import numpy as np

from description import DescriptionError, pattern_value

# OpenCV camera frame (x right, y down, z forward) to Mitsuba's camera and
# projector frame (x left, y up, z forward): a half turn about z.
_CV_TO_MI = np.diag([-1.0, -1.0, 1.0, 1.0])

# Cycles 2.9x sends the diffuse weight to its random walk above this subsurface.
SUBSURFACE_ON = 1e-5


def _transform(rows):
    return mi.ScalarTransform4f(np.asarray(rows, dtype=np.float64).tolist())


def read_exr(path):
    """An EXR as float32 (H, W, C) numpy, whatever its stored channel type."""
    try:
        bmp = mi.Bitmap(path)
    except Exception as e:  # Mitsuba raises RuntimeError with its own text
        raise DescriptionError(f"{path}: not a readable OpenEXR image: {e}") from e
    arr = np.array(bmp, dtype=np.float32, copy=True)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if not np.all(np.isfinite(arr)):
        raise DescriptionError(f"{path}: holds NaN or infinite values")
    return arr


def sensor(camera, pose, spp, seed):
    """A perspective sensor with our pinhole intrinsics and a box pixel filter.

    Mitsuba's sensor has square pixels and takes the principal point as an
    offset in image fractions: ray through film position s = px / W + offset
    looks along x_cv / z = (px - cx) / fx when offset = 0.5 - cx / W.
    """
    w, h = camera["width"], camera["height"]
    if abs(camera["fx"] - camera["fy"]) > 1e-9 * camera["fx"]:
        raise DescriptionError(
            f"camera: fx = {camera['fx']} differs from fy = {camera['fy']}; "
            "Mitsuba's perspective sensor has square pixels only")
    return {
        "type": "perspective",
        "fov_axis": "x",
        "fov": math.degrees(2.0 * math.atan(w / (2.0 * camera["fx"]))),
        "principal_point_offset_x": 0.5 - camera["cx"] / w,
        "principal_point_offset_y": 0.5 - camera["cy"] / h,
        "near_clip": 1e-3,
        "far_clip": 1e4,
        "to_world": _transform(np.asarray(pose) @ _CV_TO_MI),
        "film": {
            "type": "hdrfilm",
            "width": w,
            "height": h,
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
            "component_format": "float32",
        },
        "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
    }


def _bitmap_texture(arr, filter_type="bilinear", wrap="repeat"):
    """A raw (linear, unconverted) bitmap texture from an (H, W, C) array."""
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if arr.shape[2] == 1:
        bmp = mi.Bitmap(arr, mi.Bitmap.PixelFormat.Y)
    else:
        bmp = mi.Bitmap(arr, mi.Bitmap.PixelFormat.RGB)
    return {"type": "bitmap", "bitmap": bmp, "raw": True, "filter_type": filter_type, "wrap_mode": wrap}


def _input(param, channels, transform=None):
    """A Principled input as a Mitsuba value or texture.

    Maps are in UV space with row 0 at v = 1; the mesh is loaded with
    `flip_tex_coords`, so Mitsuba's v' = 1 - t puts row 0 at t = 1 as ours.
    """
    if "value" in param:
        v = param["value"]
        if transform:
            v = transform(np.asarray(v)).tolist()
        if channels == 3:
            return {"type": "rgb", "value": [float(x) for x in v]}
        return float(v)
    arr = read_exr(param["map"])
    if channels == 3:
        if arr.shape[2] < 3:
            arr = np.repeat(arr[:, :, :1], 3, axis=2)
        arr = arr[:, :, :3]
    else:
        arr = arr[:, :, :1]
    arr = np.clip(arr, 0.0, 1.0)
    if transform:
        arr = transform(arr)
    return _bitmap_texture(arr)


def _uniform(param):
    return "value" in param


def max_value(param):
    """Largest value of a Principled input, constant or map."""
    if "value" in param:
        return float(np.max(param["value"]))
    return float(read_exr(param["map"]).max())


def uses_medium(material, mode):
    """Whether the object becomes a dielectric boundary around a medium.

    Only where subsurface scattering is uniform and everything that would mix
    other lobes into Cycles' closure is absent: Mitsuba's homogeneous medium
    cannot vary over the surface, and Mitsuba's principled has no subsurface.
    """
    if mode not in ("medium", "walk"):
        return False
    m = material
    if not all(_uniform(m[k]) for k in ("subsurface", "metallic", "transmission", "basecolor")):
        return False
    return (m["subsurface"]["value"] > SUBSURFACE_ON and m["metallic"]["value"] == 0.0
            and m["transmission"]["value"] == 0.0)


def cycles_medium(basecolor, radius):
    """Cycles 2.9x's random-walk remap (matscan-bsdf `subsurface`), per channel.

    single-scattering albedo from the multiple-scattering albedo A, and
    extinction 1 / (d s) with s = 1.9 - A + 3.5 (A - 0.8)^2.
    """
    a = np.clip(np.asarray(basecolor, dtype=np.float64), 0.0, 1.0)
    d = np.asarray(radius, dtype=np.float64)
    alpha = np.clip(1.0 - np.exp(a * (-5.09406 + a * (2.61188 - 4.31805 * a))), 0.0, 1.0)
    s = 1.9 - a + 3.5 * (a - 0.8) ** 2
    sigma_t = 1.0 / np.maximum(d * s, 1e-16)
    return alpha, sigma_t


def _register_diffuse_transmitter():
    """A white Lambertian transmitter (Mitsuba 3.9 has no `difftrans` plugin).

    Light crossing it leaves cosine-distributed on the other side with no
    loss: the boundary of Cycles 2.9x's random walk (cosine entry, diffuse
    exit, no Fresnel weight). Written in Python, so practical with the
    llvm variant only.
    """
    import drjit as dr

    if getattr(_register_diffuse_transmitter, "done", False):
        return

    class DiffuseTransmitter(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            flags = mi.BSDFFlags.DiffuseTransmission | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            self.m_components = [flags]
            self.m_flags = flags

        def sample(self, ctx, si, sample1, sample2, active):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            wo = mi.Vector3f(wo.x, wo.y, dr.select(cos_i > 0, -wo.z, wo.z))
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = dr.abs(wo.z) * dr.inv_pi
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseTransmission)
            bs.sampled_component = mi.UInt32(0)
            ok = active & (cos_i != 0) & (bs.pdf > 0)
            return bs, dr.select(ok, mi.Color3f(1.0), mi.Color3f(0.0))

        def _value(self, si, wo):
            through = mi.Frame3f.cos_theta(si.wi) * mi.Frame3f.cos_theta(wo) < 0
            return dr.select(through, dr.abs(mi.Frame3f.cos_theta(wo)) * dr.inv_pi, 0.0)

        def eval(self, ctx, si, wo, active):
            return mi.Color3f(self._value(si, wo))

        def pdf(self, ctx, si, wo, active):
            return self._value(si, wo)

        def eval_pdf(self, ctx, si, wo, active):
            v = self._value(si, wo)
            return mi.Color3f(v), v

        def to_string(self):
            return "DiffuseTransmitter[]"

    mi.register_bsdf("matscan_difftrans", lambda props: DiffuseTransmitter(props))
    _register_diffuse_transmitter.done = True


def _medium_object(material, mode):
    """Cycles' medium inside a boundary.

    `medium`: a rough dielectric (IOR 1.45, GGX alpha = roughness^2), the
    physical construction. `walk`: a white diffuse transmitter, which enters
    and leaves the medium cosine-distributed without Fresnel or refraction,
    as Cycles 2.9x's random walk does (but without its specular lobe).
    """
    m = material
    dist = m["subsurface"]["value"] * np.asarray(m["subsurface_radius"])
    albedo, sigma_t = cycles_medium(m["basecolor"]["value"], np.maximum(dist, 1e-8))
    if mode == "walk":
        _register_diffuse_transmitter()
        bsdf = {"type": "matscan_difftrans"}
    else:
        alpha = _input(m["roughness"], 1, transform=lambda r: np.clip(r, 0, 1) ** 2)
        bsdf = {"type": "roughdielectric", "distribution": "ggx", "int_ior": m["ior"], "ext_ior": 1.0,
                "alpha": alpha if not isinstance(alpha, float) else max(alpha, 1e-4)}
    # Mitsuba parses an "rgb" sigma_t as a reflectance (each channel at
    # most 1), so its magnitude travels in `scale`.
    scale = float(max(np.max(sigma_t), 1e-16))
    medium = {
        "type": "homogeneous",
        "albedo": {"type": "rgb", "value": albedo.tolist()},
        "sigma_t": {"type": "rgb", "value": (sigma_t / scale).tolist()},
        "scale": scale,
        "phase": {"type": "isotropic"},
    }
    return bsdf, medium


def principled(material):
    """Mitsuba's principled for our inputs (no sheen, clearcoat, anisotropy, tint).

    Mitsuba takes either `specular` or `eta`, and one value drives both the
    dielectric reflection and the refraction. Cycles uses F0 = 0.04 (IOR 1.5,
    specular 0.5) for reflection and IOR 1.45 for the glass lobe; we keep the
    reflection exact for opaque objects and the refraction exact where the
    object transmits anywhere.
    """
    m = material
    bsdf = {
        "type": "principled",
        "base_color": _input(m["basecolor"], 3),
        "roughness": _input(m["roughness"], 1),
        "metallic": _input(m["metallic"], 1),
    }
    if max_value(m["transmission"]) > 0.0:
        bsdf["spec_trans"] = _input(m["transmission"], 1)
        bsdf["eta"] = m["ior"]
    else:
        bsdf["specular"] = m["specular"]
    return bsdf


def object_shape(desc, subsurface_mode):
    """The mesh with its material; returns (shape dict, needs volpath)."""
    shape = {"type": "ply", "filename": desc["mesh"], "flip_tex_coords": True, "face_normals": False}
    if uses_medium(desc["material"], subsurface_mode):
        bsdf, medium = _medium_object(desc["material"], subsurface_mode)
        shape["bsdf"] = bsdf
        shape["interior"] = medium
        return shape, True
    shape["bsdf"] = principled(desc["material"])
    return shape, False


def environment(desc):
    """The envmap emitter for the description's equirectangular map.

    Mitsuba's envmap reads column u at phi = 2 pi u (ours: 2 pi (u - 1/2)), so
    a half turn about +Y aligns the columns; its rows are spaced
    `align-corners` (row k at theta = pi k / (H - 1); ours: pi (j + 1/2) / H),
    so the map is resampled to 2H + 1 rows at our row centres and the
    midpoints between them, on which Mitsuba's linear interpolation gives
    exactly our bilinear lookup.
    """
    if desc["environment"] is None:
        return None
    env = read_exr(desc["environment"]["map"])[:, :, :3]
    h = env.shape[0]
    rows = np.empty((2 * h + 1,) + env.shape[1:], dtype=np.float32)
    rows[1::2] = env
    rows[2:-1:2] = 0.5 * (env[:-1] + env[1:])
    rows[0] = env[0]
    rows[-1] = env[-1]
    return {
        "type": "envmap",
        "bitmap": mi.Bitmap(np.ascontiguousarray(rows), mi.Bitmap.PixelFormat.RGB),
        "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], 180),
    }


def flash(f):
    return {"type": "point", "position": f["position"], "intensity": {"type": "rgb", "value": f["intensity"]}}


# Texels per projector pixel are chosen so that fx * s >= this: the cos^3
# factor below is exact at texel centres only, and varies by about
# 1.5 tan(theta) / (fx s) across a texel (under 0.2 % at this size).
_MIN_TEXELS_PER_RADIAN = 500.0


def _projector_grid(p):
    """Texel grid of a centred texture whose texel edges fall on projector pixel edges.

    Mitsuba's projector puts its optical axis at the texture centre, so an
    off-centre principal point is handled by padding; `s` texels per pixel
    make the padding integral (exact when 2 s cx and 2 s cy are integers).
    """
    for s in (1, 2, 4, 8):
        if abs(2 * s * p["cx"] - round(2 * s * p["cx"])) < 1e-6 and abs(2 * s * p["cy"] - round(2 * s * p["cy"])) < 1e-6:
            break
    else:
        print(f"warning: projector `{p['name']}`: principal point ({p['cx']}, {p['cy']}) is not on a "
              "1/16-pixel grid; pattern edges are placed to within 1/16 projector pixel", file=sys.stderr)
    while p["fx"] * s < _MIN_TEXELS_PER_RADIAN:
        s *= 2
    n = int(round(2 * s * max(p["cx"], p["width"] - p["cx"])))
    m = int(round(2 * s * max(p["cy"], p["height"] - p["cy"])))
    if (n - round(2 * s * p["cx"])) % 2:
        n += 1
    if (m - round(2 * s * p["cy"])) % 2:
        m += 1
    return s, n, m


def projector(p, pattern):
    """The projector emitter showing `pattern`.

    Mitsuba's projector delivers pi * texel / (d^2 cos^3 theta) (irradiance
    fixed on its z = 1 plane); ours delivers intensity * pattern / d^2 with no
    falloff. So each texel holds intensity * pattern * cos^3(theta) / pi at its
    centre, looked up nearest-neighbour so checker edges stay sharp.
    """
    if abs(p["fx"] - p["fy"]) > 1e-9 * p["fx"]:
        raise DescriptionError(
            f"projector `{p['name']}`: fx = {p['fx']} differs from fy = {p['fy']}; "
            "Mitsuba's projector has square pixels only")
    s, n, m = _projector_grid(p)
    # Projector pixel coordinates of texel centres.
    x = p["cx"] + (np.arange(n) + 0.5 - n / 2.0) / s
    y = p["cy"] + (np.arange(m) + 0.5 - m / 2.0) / s
    u, v = np.floor(x), np.floor(y)
    inside = (u[None, :] >= 0) & (u[None, :] < p["width"]) & (v[:, None] >= 0) & (v[:, None] < p["height"])
    level = pattern_value(pattern, u[None, :], v[:, None]) * inside
    tx, ty = (x - p["cx"]) / p["fx"], (y - p["cy"]) / p["fy"]
    cos3 = (1.0 + tx[None, :] ** 2 + ty[:, None] ** 2) ** -1.5
    tex = (level * cos3 / math.pi)[:, :, None] * np.asarray(p["intensity"])[None, None, :]
    return {
        "type": "projector",
        "irradiance": _bitmap_texture(tex, filter_type="nearest", wrap="clamp"),
        "fov_axis": "x",
        "fov": math.degrees(2.0 * math.atan(n / (2.0 * s * p["fx"]))),
        "scale": 1.0,
        "to_world": _transform(np.asarray(p["to_world"]) @ _CV_TO_MI),
    }


def backlight(b, camera_center, on):
    """The panel: a two-sided grey Lambertian parallelogram, emitting from the camera side when on.

    Mitsuba's rectangle spans [-1, 1]^2 with normal +z and its area emitter
    emits toward +z only; the half edges are swapped when needed so that
    +z = half_u x half_v faces the camera, which keeps the frame right-handed.
    """
    c, hu, hv = (np.asarray(b[k]) for k in ("center", "half_u", "half_v"))
    n = np.cross(hu, hv)
    if np.linalg.norm(n) <= 0.0:
        return None
    if np.dot(n, np.asarray(camera_center) - c) < 0.0:
        hu, hv, n = hv, hu, -n
    n = n / np.linalg.norm(n)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = hu, hv, n, c
    albedo = min(max(b["albedo"], 0.0), 1.0)
    shape = {
        "type": "rectangle",
        "to_world": _transform(m),
        "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [albedo] * 3}}},
    }
    if on:
        shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": b["radiance"]}}
    return shape


# Medium scattering events count as depth in volpath; Cycles' random walk has
# its own budget (256 steps), so a walk must not be cut at the surface depth.
VOLUME_MAX_DEPTH = 256


def integrator(max_depth, volumetric):
    """Our `max_depth` counts scattering vertices; Mitsuba counts path segments."""
    if volumetric:
        return {"type": "volpath", "max_depth": VOLUME_MAX_DEPTH, "hide_emitters": False}
    return {"type": "path", "max_depth": max_depth + 1, "hide_emitters": False}
