//! glTF 2.0 export of the scanned mesh with its baked material:
//! `material.gltf` + `material.bin` + PNG textures, or one `material.glb`.
//!
//! Material mapping (Principled BSDF to glTF's metallic-roughness model):
//! - basecolor: `baseColorTexture` (`texture/basecolor.png`, sRGB);
//! - roughness and metallic: `metallicRoughnessTexture`
//!   (`texture/metallic_roughness.png`, roughness in G, metallic in B, R
//!   unused at 1), packed from the two scalar textures;
//! - transmission: `KHR_materials_transmission`, its R channel read from
//!   the grey `texture/transmission.png`;
//! - subsurface: `KHR_materials_diffuse_transmission` (factor 1, its
//!   texture's alpha channel from `texture/diffuse_transmission.png`, grey
//!   plus alpha, both the subsurface weight; colour from basecolor). It is
//!   the closest Khronos extension: Lambertian light passing through a thin
//!   surface. What it loses: the Principled subsurface radius (mean free
//!   path per channel) and with it the distance light travels under the
//!   surface; light leaves on the far side of the surface instead of
//!   around the entry point, so thick objects look more translucent than
//!   they are. `KHR_materials_volume` was not used: it only attenuates
//!   refractive transmission and says nothing about diffuse scattering.
//!   Viewers that do not know the extension ignore it (it is in
//!   `extensionsUsed`, not `extensionsRequired`).
//!
//! Parameters the bake lacks use glTF's neutral values (basecolor white,
//! roughness 0.5, metallic 0, no transmission or subsurface).
//!
//! Geometry: positions, unit normals (computed from the triangles where
//! the mesh has none), UVs with v flipped (glTF's origin is top left), u32
//! indices; the node scales the mesh to metres from the manifest's units.
//!
//! Crate choice: `gltf-json` (the document types of the `gltf` crate,
//! maintained with it) builds the JSON, so field names and enums cannot be
//! misspelt; the diffuse transmission extension, which it does not model,
//! goes into its `extensions.others` map. The GLB container (a 12-byte
//! header and two chunks) is written here: the `gltf` crate's writer would
//! pull in the whole reader for a few lines.

use crate::error::BakeError;
use crate::textures::{clip, texture_dir, write_textures, BakedTextures, TEXTURE_DIR};
use gltf_json as json;
use gltf_json::validation::Checked::Valid;
use gltf_json::validation::USize64;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use matscan_scan::atomic::write_atomic;
use matscan_scan::{Mesh, Param};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const GLTF_FILE: &str = "material.gltf";
pub const BIN_FILE: &str = "material.bin";
pub const GLB_FILE: &str = "material.glb";
pub const METALLIC_ROUGHNESS_FILE: &str = "metallic_roughness.png";
pub const DIFFUSE_TRANSMISSION_FILE: &str = "diffuse_transmission.png";
pub const PRINCIPLED_FILE: &str = "principled.md";
pub const TRANSMISSION_EXT: &str = "KHR_materials_transmission";
pub const DIFFUSE_TRANSMISSION_EXT: &str = "KHR_materials_diffuse_transmission";

/// `.gltf` with its `.bin` and PNG files, or one self-contained `.glb`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GltfFormat {
    Separate,
    Binary,
}

/// Metres per unit of the manifest's `units` (glTF is in metres); an
/// unknown unit is taken as metres, with a warning.
pub fn metres_per_unit(units: &str) -> f32 {
    match units {
        "mm" => 0.001,
        "cm" => 0.01,
        "dm" => 0.1,
        "m" => 1.0,
        other => {
            tracing::warn!("unknown units `{other}` in scan.toml; exporting as metres");
            1.0
        }
    }
}

/// Writes the textures (`texture/`, the baker's layout plus the two packed
/// glTF textures), the glTF file(s) and `principled.md` into `out_dir`;
/// returns the main file (`material.gltf` or `material.glb`).
/// `metres_per_unit` scales the mesh to glTF's metres.
pub fn export_gltf(
    mesh: &Mesh,
    textures: &BakedTextures,
    out_dir: &Path,
    format: GltfFormat,
    metres_per_unit: f32,
) -> Result<PathBuf, BakeError> {
    let Some(uvs) = mesh.uvs.as_ref() else {
        return Err(BakeError::InvalidOption {
            what: "mesh",
            message: "the mesh has no UVs; glTF export needs the UVs the textures were baked in"
                .into(),
        });
    };
    mesh.validate().map_err(|e| BakeError::InvalidOption {
        what: "mesh",
        message: e.to_string(),
    })?;
    let tex_dir = texture_dir(out_dir);
    write_textures(&tex_dir, textures)?;
    let images = packed_images(textures)?;
    for image in &images {
        if let Some(bytes) = &image.packed {
            write_atomic(&tex_dir.join(image.file), bytes)?;
        }
    }
    let geometry = Geometry::of(mesh, uvs);
    let embed = format == GltfFormat::Binary;
    let mut bin = geometry.bytes.clone();
    let mut image_views = Vec::new();
    if embed {
        for image in &images {
            let bytes = match &image.packed {
                Some(b) => b.clone(),
                None => std::fs::read(tex_dir.join(image.file))
                    .map_err(|e| BakeError::io(tex_dir.join(image.file), e))?,
            };
            image_views.push((bin.len(), bytes.len()));
            bin.extend_from_slice(&bytes);
            pad(&mut bin, 0);
        }
    }
    let root = document(
        &geometry,
        &images,
        &image_views,
        bin.len(),
        embed,
        metres_per_unit,
    );
    write_atomic(
        &out_dir.join(PRINCIPLED_FILE),
        principled_text(textures).as_bytes(),
    )?;
    match format {
        GltfFormat::Separate => {
            let text = root
                .to_vec_pretty()
                .map_err(|e| BakeError::format(out_dir.join(GLTF_FILE), e.to_string()))?;
            write_atomic(&out_dir.join(BIN_FILE), &bin)?;
            let path = out_dir.join(GLTF_FILE);
            write_atomic(&path, &text)?;
            Ok(path)
        }
        GltfFormat::Binary => {
            let path = out_dir.join(GLB_FILE);
            let json = root
                .to_vec()
                .map_err(|e| BakeError::format(&path, e.to_string()))?;
            write_atomic(&path, &glb(json, bin))?;
            Ok(path)
        }
    }
}

/// One image of the material: a file of the texture folder, and for the
/// packed ones their PNG bytes.
struct MaterialImage {
    role: Role,
    file: &'static str,
    packed: Option<Vec<u8>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    BaseColor,
    MetallicRoughness,
    Transmission,
    DiffuseTransmission,
}

fn packed_images(t: &BakedTextures) -> Result<Vec<MaterialImage>, BakeError> {
    let (w, h) = (t.width(), t.height());
    let n = w as usize * h as usize;
    let mut out = Vec::new();
    if t.basecolor().is_some() {
        out.push(MaterialImage {
            role: Role::BaseColor,
            file: "basecolor.png",
            packed: None,
        });
    }
    let rough = t.scalar(Param::Roughness);
    let metal = t.scalar(Param::Metallic);
    if rough.is_some() || metal.is_some() {
        let mut bytes = Vec::with_capacity(n * 6);
        for i in 0..n {
            let r = rough.map_or(0.5, |m| m.data[i]);
            let m = metal.map_or(0.0, |m| m.data[i]);
            for v in [1.0, r, m] {
                bytes.extend_from_slice(&u16_of(v).to_ne_bytes());
            }
        }
        out.push(MaterialImage {
            role: Role::MetallicRoughness,
            file: METALLIC_ROUGHNESS_FILE,
            packed: Some(png(&bytes, w, h, ExtendedColorType::Rgb16)?),
        });
    }
    if t.scalar(Param::Transmission).is_some() {
        out.push(MaterialImage {
            role: Role::Transmission,
            file: "transmission.png",
            packed: None,
        });
    }
    if let Some(s) = t.scalar(Param::Subsurface) {
        let bytes: Vec<u8> = s
            .data
            .iter()
            .flat_map(|&v| {
                let q = u16_of(v).to_ne_bytes();
                [q[0], q[1], q[0], q[1]]
            })
            .collect();
        out.push(MaterialImage {
            role: Role::DiffuseTransmission,
            file: DIFFUSE_TRANSMISSION_FILE,
            packed: Some(png(&bytes, w, h, ExtendedColorType::La16)?),
        });
    }
    Ok(out)
}

fn u16_of(v: f32) -> u16 {
    (clip(v) * 65535.0).round() as u16
}

fn png(bytes: &[u8], w: u32, h: u32, color: ExtendedColorType) -> Result<Vec<u8>, BakeError> {
    let mut out = Vec::new();
    PngEncoder::new(&mut out)
        .write_image(bytes, w, h, color)
        .map_err(|e| {
            BakeError::format(PathBuf::from("<png>"), format!("could not encode PNG: {e}"))
        })?;
    Ok(out)
}

/// The mesh as glTF buffer data: positions, normals, UVs, indices, each
/// 4-byte aligned, in this order.
struct Geometry {
    bytes: Vec<u8>,
    vertex_count: usize,
    index_count: usize,
    min: [f32; 3],
    max: [f32; 3],
}

impl Geometry {
    fn of(mesh: &Mesh, uvs: &[glam::Vec2]) -> Geometry {
        let normals: Vec<glam::Vec3> = match &mesh.normals {
            Some(n) => n
                .iter()
                .map(|v| v.try_normalize().unwrap_or(glam::Vec3::Z))
                .collect(),
            None => {
                let mut m = mesh.clone();
                m.compute_vertex_normals();
                m.normals.unwrap_or_default()
            }
        };
        let mut bytes = Vec::new();
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &mesh.positions {
            for (k, v) in p.to_array().into_iter().enumerate() {
                min[k] = min[k].min(v);
                max[k] = max[k].max(v);
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        for n in &normals {
            for v in n.to_array() {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        for uv in uvs {
            // glTF's UV origin is the top left.
            for v in [uv.x, 1.0 - uv.y] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        for t in &mesh.triangles {
            for i in t {
                bytes.extend_from_slice(&i.to_le_bytes());
            }
        }
        Geometry {
            bytes,
            vertex_count: mesh.positions.len(),
            index_count: mesh.triangles.len() * 3,
            min,
            max,
        }
    }
}

fn pad(bytes: &mut Vec<u8>, fill: u8) {
    while !bytes.len().is_multiple_of(4) {
        bytes.push(fill);
    }
}

fn document(
    g: &Geometry,
    images: &[MaterialImage],
    image_views: &[(usize, usize)],
    bin_len: usize,
    embed: bool,
    metres_per_unit: f32,
) -> json::Root {
    let mut root = json::Root::default();
    root.asset.generator = Some(format!("matscan {}", env!("CARGO_PKG_VERSION")));
    let buffer = root.push(json::Buffer {
        byte_length: USize64::from(bin_len),
        extensions: None,
        extras: Default::default(),
        name: None,
        uri: (!embed).then(|| BIN_FILE.to_string()),
    });
    let n = g.vertex_count;
    let mut offset = 0usize;
    let mut view = |root: &mut json::Root, len: usize, target: Option<json::buffer::Target>| {
        let v = root.push(json::buffer::View {
            buffer,
            byte_length: USize64::from(len),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: None,
            extras: Default::default(),
            name: None,
            target: target.map(Valid),
        });
        offset += len;
        v
    };
    let array = Some(json::buffer::Target::ArrayBuffer);
    let positions_view = view(&mut root, n * 12, array);
    let normals_view = view(&mut root, n * 12, array);
    let uvs_view = view(&mut root, n * 8, array);
    let indices_view = view(
        &mut root,
        g.index_count * 4,
        Some(json::buffer::Target::ElementArrayBuffer),
    );
    let accessor = |root: &mut json::Root,
                    view: json::Index<json::buffer::View>,
                    count: usize,
                    component: json::accessor::ComponentType,
                    type_: json::accessor::Type,
                    bounds: Option<([f32; 3], [f32; 3])>| {
        root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min: bounds.map(|(lo, _)| json::Value::from(lo.to_vec())),
            max: bounds.map(|(_, hi)| json::Value::from(hi.to_vec())),
            name: None,
            normalized: false,
            sparse: None,
        })
    };
    use json::accessor::{ComponentType as C, Type as T};
    let positions = accessor(
        &mut root,
        positions_view,
        n,
        C::F32,
        T::Vec3,
        Some((g.min, g.max)),
    );
    let normals = accessor(&mut root, normals_view, n, C::F32, T::Vec3, None);
    let uvs = accessor(&mut root, uvs_view, n, C::F32, T::Vec2, None);
    let indices = accessor(
        &mut root,
        indices_view,
        g.index_count,
        C::U32,
        T::Scalar,
        None,
    );

    let sampler = root.push(json::texture::Sampler {
        mag_filter: Some(Valid(json::texture::MagFilter::Linear)),
        min_filter: Some(Valid(json::texture::MinFilter::LinearMipmapLinear)),
        ..Default::default()
    });
    let mut textures: BTreeMap<u8, json::Index<json::Texture>> = BTreeMap::new();
    for (k, image) in images.iter().enumerate() {
        let source = root.push(json::Image {
            buffer_view: None,
            mime_type: None,
            name: Some(image.file.trim_end_matches(".png").to_string()),
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        if embed {
            let (start, len) = image_views[k];
            let v = root.push(json::buffer::View {
                buffer,
                byte_length: USize64::from(len),
                byte_offset: Some(USize64::from(start)),
                byte_stride: None,
                extensions: None,
                extras: Default::default(),
                name: None,
                target: None,
            });
            let img = &mut root.images[source.value()];
            img.buffer_view = Some(v);
            img.mime_type = Some(json::image::MimeType("image/png".to_string()));
        } else {
            root.images[source.value()].uri = Some(format!("{TEXTURE_DIR}/{}", image.file));
        }
        let texture = root.push(json::Texture {
            name: None,
            sampler: Some(sampler),
            source,
            extensions: None,
            extras: Default::default(),
        });
        textures.insert(image.role as u8, texture);
    }
    let info = |role: Role| {
        textures
            .get(&(role as u8))
            .map(|&index| json::texture::Info {
                index,
                tex_coord: 0,
                extensions: None,
                extras: Default::default(),
            })
    };
    let mut pbr = json::material::PbrMetallicRoughness {
        base_color_texture: info(Role::BaseColor),
        metallic_roughness_texture: info(Role::MetallicRoughness),
        ..Default::default()
    };
    if pbr.metallic_roughness_texture.is_none() {
        pbr.metallic_factor = json::material::StrengthFactor(0.0);
        pbr.roughness_factor = json::material::StrengthFactor(0.5);
    }
    let mut ext = json::extensions::material::Material::default();
    if let Some(t) = info(Role::Transmission) {
        ext.transmission = Some(json::extensions::material::Transmission {
            transmission_factor: json::extensions::material::TransmissionFactor(1.0),
            transmission_texture: Some(t),
            extras: Default::default(),
        });
        root.extensions_used.push(TRANSMISSION_EXT.to_string());
    }
    if let Some(t) = info(Role::DiffuseTransmission) {
        let mut value = serde_json::json!({
            "diffuseTransmissionFactor": 1.0,
            "diffuseTransmissionTexture": { "index": t.index.value() },
        });
        if let Some(base) = info(Role::BaseColor) {
            value["diffuseTransmissionColorTexture"] =
                serde_json::json!({ "index": base.index.value() });
        }
        ext.others
            .insert(DIFFUSE_TRANSMISSION_EXT.to_string(), value);
        root.extensions_used
            .push(DIFFUSE_TRANSMISSION_EXT.to_string());
    }
    let has_ext = ext.transmission.is_some() || !ext.others.is_empty();
    let material = root.push(json::Material {
        name: Some("matscan".to_string()),
        pbr_metallic_roughness: pbr,
        extensions: has_ext.then_some(ext),
        ..Default::default()
    });
    let mut attributes = BTreeMap::new();
    attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
    attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
    attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uvs);
    let mesh = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("scan".to_string()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    });
    let scale = if metres_per_unit.is_finite() && metres_per_unit > 0.0 {
        metres_per_unit
    } else {
        1.0
    };
    let node = root.push(json::Node {
        mesh: Some(mesh),
        name: Some("scan".to_string()),
        scale: (scale != 1.0).then_some([scale; 3]),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);
    root
}

/// The binary container: header, JSON chunk (space padded), BIN chunk
/// (zero padded), all lengths little-endian.
fn glb(mut json: Vec<u8>, mut bin: Vec<u8>) -> Vec<u8> {
    pad(&mut json, b' ');
    pad(&mut bin, 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// `principled.md`: which texture feeds which Principled BSDF input.
fn principled_text(t: &BakedTextures) -> String {
    let mut s = String::from(
        "# Principled BSDF textures\n\n\
         Baked by matscan in the mesh's UV map (`texture/`, 16-bit PNG, one texel per\n\
         UV cell, row 0 at v = 1). In Blender, add an Image Texture node per file\n\
         (UV coordinates of the mesh) and connect its Color output as below.\n\n\
         | file | Principled BSDF input | image colour space |\n\
         | --- | --- | --- |\n",
    );
    for param in t.params() {
        let (input, space) = match param {
            Param::Basecolor => ("Base Color", "sRGB"),
            Param::Roughness => ("Roughness", "Non-Color"),
            Param::Metallic => ("Metallic", "Non-Color"),
            Param::Transmission => (
                "Transmission (Transmission Weight in Blender 4)",
                "Non-Color",
            ),
            Param::Subsurface => ("Subsurface (Subsurface Weight in Blender 4)", "Non-Color"),
        };
        s.push_str(&format!(
            "| `texture/{}.png` | {input} | {space} |\n",
            param.name()
        ));
    }
    s.push_str(
        "\n`texture/coverage.png` is no BSDF input: 255 where a camera measured the texel,\n\
         0 where hole filling guessed it.\n\
         `material.gltf` carries the same material for glTF viewers (roughness and\n\
         metallic packed into `texture/metallic_roughness.png`, subsurface approximated\n\
         by KHR_materials_diffuse_transmission, which has no subsurface radius).\n",
    );
    s
}
