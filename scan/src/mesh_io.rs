//! Reading and writing the bundle's mesh: PLY (ASCII, binary little and big
//! endian) and Wavefront OBJ.
//!
//! Reading accepts what scanners and DCC tools write (see
//! `docs/scan-format.md`): PLY vertex `x y z` of any numeric type, optional
//! normals `nx ny nz` and texture coordinates (`s t`, `u v` or
//! `texture_u texture_v`), faces as `vertex_indices`/`vertex_index` lists of
//! any integer type; unknown properties and elements are skipped. OBJ `v`,
//! `vt`, `vn` and `f` in all four corner forms with negative (relative)
//! indices; because OBJ indexes positions, texture coordinates and normals
//! separately, a position used with several combinations is split into
//! several vertices. Polygons are fan-triangulated. Texture coordinates are
//! kept as stored (origin bottom left, no flip).
//!
//! Every mesh read is checked with [`Mesh::validate`]; errors name the file
//! and the line (OBJ, ASCII PLY) or element (binary PLY) and what was
//! expected. Malformed input is an error, never a panic.
//!
//! Writing is atomic ([`crate::atomic::write_atomic`]: temporary file in
//! the same folder, then rename): PLY
//! as binary little endian with normals and `s t` coordinates when present,
//! OBJ as text with exact (shortest round-trip) decimal numbers.
//!
//! Both parsers are our own: the two crates tried in their place did not
//! fit. Measured with `examples/mesh_load_bench.rs` (the 524 172-triangle
//! cube-sphere with normals and uvs; each crate in turn behind
//! `read_ply`/`read_obj`, median on-CPU ms of 5 reads, 3 interleaved
//! rounds on a loaded 2-core machine):
//!
//! | file                 | ours    | crate                           |
//! |----------------------|---------|---------------------------------|
//! | binary PLY, 15.3 MB  | 58-62   | ply-rs-bw 4.0.1: 96-101         |
//! | ASCII PLY, 34.6 MB   | 194-251 | ply-rs-bw 4.0.1: 390-522        |
//! | OBJ, 57.4 MB         | 495-617 | tobj 4.0.5: 491-634, mesh wrong |
//!
//! - ply-rs-bw reads 1.6x (binary) to 2x (ASCII, a PEG parse per line)
//!   slower, and keeping this contract's messages took 582 lines of glue
//!   for the 596 it replaced: its errors name a line but neither the
//!   property nor the token, its header maps silently merge names declared
//!   twice, its ASCII body must hold one element per line and no `nan`
//!   token, and it needs Rust 1.87 (the workspace says 1.85).
//! - tobj cannot keep this contract: it numbers vertices by first use and
//!   drops unused ones (our own OBJ no longer reads back exactly), splits
//!   the mesh at `o`/`g`, gives a corner without `vt`/`vn` the previous
//!   corner's (or leaves the attribute arrays short), makes `l 1 2 3` a
//!   triangle, accepts NaN, fails on `\` continuations, trailing
//!   comments, one-value `vt` and non-UTF-8 comments, and its errors carry
//!   no line number. It was no faster.
//!
//! Boundaries: files only; the mesh type and its checks live in
//! [`crate::mesh`].

use crate::atomic::write_atomic;
use crate::error::ScanError;
use crate::mesh::Mesh;
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::fs;
use std::io::Read;
use std::path::Path;

/// Reads a `.ply` or `.obj` mesh (extension compared case-insensitively).
pub fn read_mesh(path: &Path) -> Result<Mesh, ScanError> {
    let kind = MeshFormat::from_path(path)?;
    let bytes = fs::read(path).map_err(|source| ScanError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    match kind {
        MeshFormat::Ply => parse_ply(&bytes, path),
        MeshFormat::Obj => parse_obj(&bytes, path),
    }
}

/// Writes `mesh` as PLY or OBJ by the extension of `path`, atomically.
pub fn write_mesh(path: &Path, mesh: &Mesh) -> Result<(), ScanError> {
    match MeshFormat::from_path(path)? {
        MeshFormat::Ply => write_ply(path, mesh),
        MeshFormat::Obj => write_obj(path, mesh),
    }
}

/// Reads a PLY mesh from `reader`; `path` only names the source in errors.
pub fn read_ply<R: Read>(mut reader: R, path: &Path) -> Result<Mesh, ScanError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|source| ScanError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    parse_ply(&bytes, path)
}

/// Reads an OBJ mesh from `reader`; `path` only names the source in errors.
pub fn read_obj<R: Read>(mut reader: R, path: &Path) -> Result<Mesh, ScanError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|source| ScanError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    parse_obj(&bytes, path)
}

/// Writes binary little-endian PLY: `x y z` floats, `nx ny nz` and `s t`
/// when the mesh has them, faces as `list uchar uint vertex_indices`.
pub fn write_ply(path: &Path, mesh: &Mesh) -> Result<(), ScanError> {
    check_writable(path, mesh)?;
    let mut out = Vec::with_capacity(256 + mesh.positions.len() * 32 + mesh.triangles.len() * 13);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by matscan\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n",
        mesh.positions.len()
    );
    if mesh.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.uvs.is_some() {
        header.push_str("property float s\nproperty float t\n");
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.triangles.len()
    ));
    out.extend_from_slice(header.as_bytes());
    for (i, p) in mesh.positions.iter().enumerate() {
        let mut put = |v: f32| out.extend_from_slice(&v.to_le_bytes());
        p.to_array().into_iter().for_each(&mut put);
        if let Some(n) = &mesh.normals {
            n[i].to_array().into_iter().for_each(&mut put);
        }
        if let Some(t) = &mesh.uvs {
            t[i].to_array().into_iter().for_each(&mut put);
        }
    }
    for tri in &mesh.triangles {
        out.push(3);
        for i in tri {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    write_atomic(path, &out)
}

/// Writes Wavefront OBJ with one `vt`/`vn` per vertex where present, so
/// every face corner is `i`, `i/i`, `i//i` or `i/i/i`.
pub fn write_obj(path: &Path, mesh: &Mesh) -> Result<(), ScanError> {
    use std::fmt::Write as _;
    check_writable(path, mesh)?;
    let mut s = String::with_capacity(mesh.positions.len() * 80 + mesh.triangles.len() * 30);
    s.push_str("# written by matscan\n");
    // `{}` on f32 prints the shortest decimal that reads back to the same
    // float, so a round trip is exact.
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in mesh.uvs.iter().flatten() {
        let _ = writeln!(s, "vt {} {}", t.x, t.y);
    }
    for n in mesh.normals.iter().flatten() {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    let (uv, nrm) = (mesh.uvs.is_some(), mesh.normals.is_some());
    for tri in &mesh.triangles {
        s.push('f');
        for &i in tri {
            let i = u64::from(i) + 1;
            let _ = match (uv, nrm) {
                (false, false) => write!(s, " {i}"),
                (true, false) => write!(s, " {i}/{i}"),
                (false, true) => write!(s, " {i}//{i}"),
                (true, true) => write!(s, " {i}/{i}/{i}"),
            };
        }
        s.push('\n');
    }
    write_atomic(path, s.as_bytes())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MeshFormat {
    Ply,
    Obj,
}

impl MeshFormat {
    fn from_path(path: &Path) -> Result<Self, ScanError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("ply") => Ok(Self::Ply),
            Some("obj") => Ok(Self::Obj),
            _ => Err(format_error(
                path,
                "expected a mesh file ending in .ply or .obj".to_string(),
            )),
        }
    }
}

fn format_error(path: &Path, message: String) -> ScanError {
    ScanError::Format {
        path: path.to_path_buf(),
        message,
    }
}

fn check_writable(path: &Path, mesh: &Mesh) -> Result<(), ScanError> {
    mesh.validate()
        .map_err(|d| format_error(path, format!("refusing to write an invalid mesh: {d}")))
}

// ---------------------------------------------------------------- PLY ----

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PlyEncoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

#[derive(Debug, Clone)]
enum PlyProperty {
    Scalar(Scalar, String),
    List {
        count: Scalar,
        item: Scalar,
        name: String,
    },
}

impl PlyProperty {
    fn name(&self) -> &str {
        match self {
            Self::Scalar(_, name) | Self::List { name, .. } => name,
        }
    }
}

#[derive(Debug, Clone)]
struct PlyElement {
    name: String,
    count: usize,
    properties: Vec<PlyProperty>,
}

struct PlyHeader {
    encoding: PlyEncoding,
    elements: Vec<PlyElement>,
    /// Byte offset of the body.
    body_start: usize,
    /// Number of header lines, so ASCII body lines can be numbered.
    lines: usize,
}

fn parse_ply_header(bytes: &[u8], path: &Path) -> Result<PlyHeader, ScanError> {
    let err = |line: usize, msg: String| format_error(path, format!("line {line}: {msg}"));
    let mut pos = 0;
    let mut line_no = 0;
    let mut encoding = None;
    let mut elements: Vec<PlyElement> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(format_error(
                path,
                "PLY header ends before `end_header`".to_string(),
            ));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| err(line_no, "PLY header is not text".to_string()))?
            .trim_end_matches('\r');
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if words != ["ply"] {
                return Err(format_error(
                    path,
                    "not a PLY file: expected `ply` on the first line".to_string(),
                ));
            }
            continue;
        }
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", kind, version] => {
                if !version.starts_with('1') {
                    return Err(err(line_no, format!("unsupported PLY version {version}")));
                }
                encoding = Some(match *kind {
                    "ascii" => PlyEncoding::Ascii,
                    "binary_little_endian" => PlyEncoding::BinaryLe,
                    "binary_big_endian" => PlyEncoding::BinaryBe,
                    other => {
                        return Err(err(
                            line_no,
                            format!(
                                "unknown PLY format `{other}`, expected ascii, \
                                 binary_little_endian or binary_big_endian"
                            ),
                        ))
                    }
                });
            }
            ["element", name, count] => {
                let count = count.parse::<usize>().map_err(|_| {
                    err(
                        line_no,
                        format!("element {name}: expected a count, found `{count}`"),
                    )
                })?;
                elements.push(PlyElement {
                    name: (*name).to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", rest @ ..] => {
                let Some(element) = elements.last_mut() else {
                    return Err(err(line_no, "property before any element".to_string()));
                };
                let scalar = |name: &str| {
                    Scalar::parse(name)
                        .ok_or_else(|| err(line_no, format!("unknown PLY property type `{name}`")))
                };
                let property = match rest {
                    ["list", count, item, name] => {
                        let count = scalar(count)?;
                        if !count.is_integer() {
                            return Err(err(
                                line_no,
                                format!("list {name}: the count type must be an integer type"),
                            ));
                        }
                        PlyProperty::List {
                            count,
                            item: scalar(item)?,
                            name: (*name).to_string(),
                        }
                    }
                    [ty, name] => PlyProperty::Scalar(scalar(ty)?, (*name).to_string()),
                    _ => {
                        return Err(err(
                            line_no,
                            format!(
                                "expected `property <type> <name>` or \
                                 `property list <type> <type> <name>`, found `{line}`"
                            ),
                        ))
                    }
                };
                element.properties.push(property);
            }
            ["end_header"] => break,
            _ => return Err(err(line_no, format!("unexpected PLY header line `{line}`"))),
        }
    }
    let encoding = encoding
        .ok_or_else(|| format_error(path, "PLY header has no `format` line".to_string()))?;
    Ok(PlyHeader {
        encoding,
        elements,
        body_start: pos,
        lines: line_no,
    })
}

/// Where a body read failed, for the error message.
enum BodyFault {
    Eof,
    /// An ASCII token that does not parse as the property's type.
    BadToken(String),
}

/// One value source for the body; ASCII and binary bodies read the same
/// element loop through it.
trait PlyBody {
    fn scalar(&mut self, ty: Scalar) -> Result<f64, BodyFault>;
    /// Where the reader stands, for error messages.
    fn locate(&self) -> String;
}

struct BinaryBody<'a> {
    bytes: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl PlyBody for BinaryBody<'_> {
    fn scalar(&mut self, ty: Scalar) -> Result<f64, BodyFault> {
        let n = ty.size();
        let raw = self
            .bytes
            .get(self.pos..self.pos + n)
            .ok_or(BodyFault::Eof)?;
        self.pos += n;
        let mut buf = [0u8; 8];
        buf[..n].copy_from_slice(raw);
        if self.big_endian {
            buf[..n].reverse();
        }
        let b2 = [buf[0], buf[1]];
        let b4 = [buf[0], buf[1], buf[2], buf[3]];
        Ok(match ty {
            Scalar::I8 => f64::from(buf[0] as i8),
            Scalar::U8 => f64::from(buf[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes(b2)),
            Scalar::U16 => f64::from(u16::from_le_bytes(b2)),
            Scalar::I32 => f64::from(i32::from_le_bytes(b4)),
            Scalar::U32 => f64::from(u32::from_le_bytes(b4)),
            Scalar::F32 => f64::from(f32::from_le_bytes(b4)),
            Scalar::F64 => f64::from_le_bytes(buf),
        })
    }

    fn locate(&self) -> String {
        format!("byte {}", self.pos)
    }
}

struct AsciiBody<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    tokens: std::str::SplitWhitespace<'a>,
    line_no: usize,
    first_line: usize,
}

impl<'a> AsciiBody<'a> {
    fn new(text: &'a str, first_line: usize) -> Self {
        Self {
            lines: text.lines().enumerate(),
            tokens: "".split_whitespace(),
            line_no: first_line,
            first_line,
        }
    }

    fn token(&mut self) -> Option<&'a str> {
        loop {
            if let Some(t) = self.tokens.next() {
                return Some(t);
            }
            let (i, line) = self.lines.next()?;
            self.line_no = self.first_line + i;
            self.tokens = line.split_whitespace();
        }
    }
}

impl PlyBody for AsciiBody<'_> {
    fn scalar(&mut self, ty: Scalar) -> Result<f64, BodyFault> {
        let token = self.token().ok_or(BodyFault::Eof)?;
        let value = if ty.is_integer() {
            // Some writers print integers as `3.0`; accept integral values.
            token
                .parse::<i64>()
                .ok()
                .map(|v| v as f64)
                .or_else(|| token.parse::<f64>().ok().filter(|v| v.fract() == 0.0))
        } else {
            token.parse::<f64>().ok()
        };
        value.ok_or_else(|| BodyFault::BadToken(token.to_string()))
    }

    fn locate(&self) -> String {
        format!("line {}", self.line_no)
    }
}

/// What the reader keeps of the vertex element: property positions.
struct VertexLayout {
    position: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
}

impl VertexLayout {
    fn find(element: &PlyElement, path: &Path) -> Result<Self, ScanError> {
        let scalar_index = |name: &str| -> Result<Option<usize>, ScanError> {
            match element.properties.iter().position(|p| p.name() == name) {
                Some(i) => match &element.properties[i] {
                    PlyProperty::Scalar(..) => Ok(Some(i)),
                    PlyProperty::List { .. } => Err(format_error(
                        path,
                        format!("element vertex: property {name} must be a scalar, not a list"),
                    )),
                },
                None => Ok(None),
            }
        };
        let all = |names: &[&str]| -> Result<Option<Vec<usize>>, ScanError> {
            let found = names
                .iter()
                .map(|n| scalar_index(n))
                .collect::<Result<Vec<_>, _>>()?;
            if found.iter().all(Option::is_some) {
                Ok(Some(found.into_iter().flatten().collect()))
            } else {
                Ok(None)
            }
        };
        let position = all(&["x", "y", "z"])?.ok_or_else(|| {
            format_error(
                path,
                "element vertex: expected scalar properties x, y and z".to_string(),
            )
        })?;
        let normal = all(&["nx", "ny", "nz"])?;
        let mut uv = None;
        for names in [["s", "t"], ["u", "v"], ["texture_u", "texture_v"]] {
            if let Some(found) = all(&names)? {
                uv = Some([found[0], found[1]]);
                break;
            }
        }
        Ok(Self {
            position: [position[0], position[1], position[2]],
            normal: normal.map(|n| [n[0], n[1], n[2]]),
            uv,
        })
    }
}

fn parse_ply(bytes: &[u8], path: &Path) -> Result<Mesh, ScanError> {
    let header = parse_ply_header(bytes, path)?;
    let body_bytes = &bytes[header.body_start..];
    match header.encoding {
        PlyEncoding::Ascii => {
            let text = std::str::from_utf8(body_bytes).map_err(|e| {
                format_error(
                    path,
                    format!(
                        "ASCII PLY body is not text (invalid byte at body offset {})",
                        e.valid_up_to()
                    ),
                )
            })?;
            let mut body = AsciiBody::new(text, header.lines + 1);
            read_ply_elements(&header, &mut body, body_bytes.len() / 2, path)
        }
        PlyEncoding::BinaryLe | PlyEncoding::BinaryBe => {
            let mut body = BinaryBody {
                bytes: body_bytes,
                pos: 0,
                big_endian: header.encoding == PlyEncoding::BinaryBe,
            };
            read_ply_elements(&header, &mut body, body_bytes.len(), path)
        }
    }
}

/// Reads every element in header order. `max_items` bounds any allocation
/// driven by a count in the file (each item takes at least that many bytes).
fn read_ply_elements(
    header: &PlyHeader,
    body: &mut impl PlyBody,
    max_items: usize,
    path: &Path,
) -> Result<Mesh, ScanError> {
    let vertex_element = header.elements.iter().find(|e| e.name == "vertex");
    let Some(vertex_element) = vertex_element else {
        return Err(format_error(
            path,
            "PLY has no `vertex` element".to_string(),
        ));
    };
    let layout = VertexLayout::find(vertex_element, path)?;
    let vertex_count = vertex_element.count;
    if u32::try_from(vertex_count).is_err() {
        return Err(format_error(
            path,
            format!(
                "element vertex: {vertex_count} vertices, expected at most {}",
                u32::MAX
            ),
        ));
    }
    let cap = vertex_count.min(max_items);
    let mut positions = Vec::with_capacity(cap);
    let mut normals = layout.normal.map(|_| Vec::with_capacity(cap));
    let mut uvs = layout.uv.map(|_| Vec::with_capacity(cap));
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut seen_vertex = false;
    let mut seen_face = false;
    let mut values: Vec<f64> = Vec::new();
    let mut polygon: Vec<u32> = Vec::new();

    for element in &header.elements {
        let role = match element.name.as_str() {
            "vertex" if !seen_vertex => {
                seen_vertex = true;
                Role::Vertex
            }
            "face" if !seen_face => {
                seen_face = true;
                Role::Face(face_list_index(element, path)?)
            }
            _ => Role::Skip,
        };
        if element.properties.is_empty() {
            // Nothing to read, however large the count.
            continue;
        }
        for index in 0..element.count {
            let fail = |body: &dyn PlyBody, property: &str, fault: BodyFault| {
                let what = match fault {
                    BodyFault::Eof => "unexpected end of file".to_string(),
                    BodyFault::BadToken(t) => format!("expected a number, found `{t}`"),
                };
                format_error(
                    path,
                    format!(
                        "{}: element {} {index}, property {property}: {what}",
                        body.locate(),
                        element.name
                    ),
                )
            };
            values.clear();
            for (pi, property) in element.properties.iter().enumerate() {
                match property {
                    PlyProperty::Scalar(ty, name) => {
                        let v = body.scalar(*ty).map_err(|f| fail(body, name, f))?;
                        values.push(v);
                    }
                    PlyProperty::List { count, item, name } => {
                        let n = body.scalar(*count).map_err(|f| fail(body, name, f))?;
                        if n < 0.0 {
                            return Err(format_error(
                                path,
                                format!(
                                    "{}: element {} {index}, property {name}: \
                                     negative list length {n}",
                                    body.locate(),
                                    element.name
                                ),
                            ));
                        }
                        let keep = matches!(role, Role::Face(i) if i == pi);
                        polygon.clear();
                        for _ in 0..n as u64 {
                            let v = body.scalar(*item).map_err(|f| fail(body, name, f))?;
                            if keep {
                                if !(0.0..vertex_count as f64).contains(&v) {
                                    return Err(format_error(
                                        path,
                                        format!(
                                            "{}: element face {index}: vertex index {v} out of \
                                             range, expected 0 to {}",
                                            body.locate(),
                                            vertex_count as i64 - 1
                                        ),
                                    ));
                                }
                                polygon.push(v as u32);
                            }
                        }
                        values.push(n);
                        if keep {
                            if polygon.len() < 3 {
                                return Err(format_error(
                                    path,
                                    format!(
                                        "{}: element face {index}: expected at least 3 \
                                         vertices, found {}",
                                        body.locate(),
                                        polygon.len()
                                    ),
                                ));
                            }
                            fan_triangulate(&polygon, &mut triangles);
                        }
                    }
                }
            }
            if let Role::Vertex = role {
                let get = |i: usize| values[i] as f32;
                let p = Vec3::new(
                    get(layout.position[0]),
                    get(layout.position[1]),
                    get(layout.position[2]),
                );
                let bad = |what: &str| {
                    format_error(
                        path,
                        format!("{}: element vertex {index}: {what}", body.locate()),
                    )
                };
                if !p.is_finite() {
                    return Err(bad("expected finite coordinates x y z"));
                }
                positions.push(p);
                if let (Some(out), Some([a, b, c])) = (normals.as_mut(), layout.normal) {
                    let n = Vec3::new(get(a), get(b), get(c));
                    if !n.is_finite() {
                        return Err(bad("expected a finite normal nx ny nz"));
                    }
                    out.push(n);
                }
                if let (Some(out), Some([a, b])) = (uvs.as_mut(), layout.uv) {
                    let t = Vec2::new(get(a), get(b));
                    if !t.is_finite() {
                        return Err(bad("expected finite texture coordinates"));
                    }
                    out.push(t);
                }
            }
        }
        if let Role::Skip = role {
            tracing::debug!(
                "{}: skipped PLY element `{}` ({} items)",
                path.display(),
                element.name,
                element.count
            );
        }
    }
    if !seen_face {
        return Err(format_error(
            path,
            "PLY has no `face` element: expected a triangle mesh, not a point cloud".to_string(),
        ));
    }
    let mesh = Mesh {
        positions,
        normals,
        uvs,
        triangles,
    };
    mesh.validate()
        .map_err(|d| format_error(path, d.to_string()))?;
    Ok(mesh)
}

enum Role {
    Vertex,
    /// The face element, with the index of its vertex index list.
    Face(usize),
    Skip,
}

fn face_list_index(element: &PlyElement, path: &Path) -> Result<usize, ScanError> {
    element
        .properties
        .iter()
        .position(|p| {
            matches!(p, PlyProperty::List { item, name, .. }
                if (name == "vertex_indices" || name == "vertex_index") && item.is_integer())
        })
        .ok_or_else(|| {
            format_error(
                path,
                "element face: expected an integer list property `vertex_indices` \
                 (or `vertex_index`)"
                    .to_string(),
            )
        })
}

fn fan_triangulate(polygon: &[u32], triangles: &mut Vec<[u32; 3]>) {
    for k in 1..polygon.len().saturating_sub(1) {
        triangles.push([polygon[0], polygon[k], polygon[k + 1]]);
    }
}

// ---------------------------------------------------------------- OBJ ----

/// One face corner: indices into the file's `v`, `vt` and `vn` lists
/// (0-based, already resolved from negative indices, not yet range-checked
/// for positive ones).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Corner {
    p: u32,
    t: Option<u32>,
    n: Option<u32>,
}

fn parse_obj(bytes: &[u8], path: &Path) -> Result<Mesh, ScanError> {
    // Lossy: comments and names in legacy encodings must not fail a read.
    let text = String::from_utf8_lossy(bytes);
    let mut positions: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut corners: Vec<Corner> = Vec::new();
    // (first corner, corner count, line) per face.
    let mut faces: Vec<(usize, usize, usize)> = Vec::new();

    let mut logical = String::new();
    let mut start_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        if logical.is_empty() {
            start_line = line_no;
        }
        // A trailing backslash continues the statement on the next line.
        if let Some(cont) = raw.strip_suffix('\\') {
            logical.push_str(cont);
            logical.push(' ');
            continue;
        }
        logical.push_str(raw);
        let statement = std::mem::take(&mut logical);
        let body = statement.split('#').next().unwrap_or("");
        let mut words = body.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let err = |msg: String| format_error(path, format!("line {start_line}: {msg}"));
        let numbers = |words: std::str::SplitWhitespace, min: usize, max: usize, what: &str| {
            let vals: Vec<f32> = words
                .take(max)
                .map(|w| {
                    w.parse::<f32>()
                        .map_err(|_| err(format!("{what}: expected a number, found `{w}`")))
                })
                .collect::<Result<_, _>>()?;
            if vals.len() < min {
                return Err(err(format!(
                    "{what}: expected {min} numbers, found {}",
                    vals.len()
                )));
            }
            if vals.iter().any(|v| !v.is_finite()) {
                return Err(err(format!("{what}: expected finite numbers")));
            }
            Ok(vals)
        };
        match keyword {
            "v" => {
                // Extra values (w, or vertex colours) are ignored.
                let v = numbers(words, 3, 3, "vertex `v`")?;
                positions.push(Vec3::new(v[0], v[1], v[2]));
            }
            "vt" => {
                let v = numbers(words, 1, 2, "texture coordinate `vt`")?;
                uvs.push(Vec2::new(v[0], v.get(1).copied().unwrap_or(0.0)));
            }
            "vn" => {
                let v = numbers(words, 3, 3, "normal `vn`")?;
                normals.push(Vec3::new(v[0], v[1], v[2]));
            }
            "f" => {
                let first = corners.len();
                for word in words {
                    let corner = parse_corner(word, [positions.len(), uvs.len(), normals.len()])
                        .map_err(|msg| err(format!("face corner `{word}`: {msg}")))?;
                    corners.push(corner);
                }
                let n = corners.len() - first;
                if n < 3 {
                    return Err(err(format!("face: expected at least 3 corners, found {n}")));
                }
                faces.push((first, n, start_line));
            }
            _ => {}
        }
    }
    if !logical.is_empty() {
        tracing::debug!("{}: ignored a trailing line continuation", path.display());
    }
    if faces.is_empty() {
        return Err(format_error(
            path,
            "OBJ has no faces: expected a triangle mesh".to_string(),
        ));
    }
    for &(first, n, line) in &faces {
        for c in &corners[first..first + n] {
            let out_of_range = |what: &str, i: u32, len: usize| {
                format_error(
                    path,
                    format!(
                        "line {line}: face refers to {what} {} but the file has {len}",
                        i as u64 + 1
                    ),
                )
            };
            if c.p as usize >= positions.len() {
                return Err(out_of_range("vertex", c.p, positions.len()));
            }
            if let Some(t) = c.t.filter(|&t| t as usize >= uvs.len()) {
                return Err(out_of_range("texture coordinate", t, uvs.len()));
            }
            if let Some(n) = c.n.filter(|&n| n as usize >= normals.len()) {
                return Err(out_of_range("normal", n, normals.len()));
            }
        }
    }
    let mesh = split_obj_vertices(&positions, &uvs, &normals, &corners, &faces, path)?;
    mesh.validate()
        .map_err(|d| format_error(path, d.to_string()))?;
    Ok(mesh)
}

/// Parses `p`, `p/t`, `p//n` or `p/t/n` (1-based, negative = relative to
/// the `counts` of positions, uvs and normals read so far).
fn parse_corner(word: &str, counts: [usize; 3]) -> Result<Corner, String> {
    let mut parts = word.split('/');
    let mut index = |slot: usize, required: bool| -> Result<Option<u32>, String> {
        match parts.next() {
            None | Some("") if !required => Ok(None),
            None | Some("") => Err("expected a vertex index".to_string()),
            Some(s) => {
                let i: i64 = s
                    .parse()
                    .map_err(|_| format!("expected an integer index, found `{s}`"))?;
                let resolved = match i {
                    0 => return Err("index 0 is invalid (OBJ indices start at 1)".to_string()),
                    i if i > 0 => i - 1,
                    i => counts[slot] as i64 + i,
                };
                if resolved < 0 {
                    return Err(format!(
                        "relative index {i} points before the first element"
                    ));
                }
                u32::try_from(resolved)
                    .map(Some)
                    .map_err(|_| format!("index {i} is too large"))
            }
        }
    };
    let p = index(0, true)?.ok_or_else(|| "expected a vertex index".to_string())?;
    let t = index(1, false)?;
    let n = index(2, false)?;
    if parts.next().is_some() {
        return Err("expected at most three `/`-separated indices".to_string());
    }
    Ok(Corner { p, t, n })
}

/// Builds one mesh vertex per distinct (position, uv, normal) combination.
/// The first combination seen for file position `p` keeps index `p`, so a
/// file without seams keeps its vertex order; other combinations are
/// appended.
fn split_obj_vertices(
    file_positions: &[Vec3],
    file_uvs: &[Vec2],
    file_normals: &[Vec3],
    corners: &[Corner],
    faces: &[(usize, usize, usize)],
    path: &Path,
) -> Result<Mesh, ScanError> {
    let has_uv = corners.iter().any(|c| c.t.is_some());
    let has_normal = corners.iter().any(|c| c.n.is_some());
    let mut positions = file_positions.to_vec();
    let mut uvs = has_uv.then(|| vec![Vec2::ZERO; positions.len()]);
    let mut normals = has_normal.then(|| vec![Vec3::ZERO; positions.len()]);
    let mut first_use: Vec<Option<Corner>> = vec![None; positions.len()];
    let mut extra: HashMap<Corner, u32> = HashMap::new();
    let mut missing_uv = 0usize;
    let mut missing_normal = 0usize;

    let mut vertex_of = |c: Corner| -> Result<u32, ScanError> {
        let slot = c.p as usize;
        let index = match first_use[slot] {
            None => {
                first_use[slot] = Some(c);
                c.p
            }
            Some(first) if first == c => c.p,
            Some(_) => {
                if let Some(&i) = extra.get(&c) {
                    return Ok(i);
                }
                let i = u32::try_from(positions.len()).map_err(|_| {
                    format_error(path, "too many vertices after splitting".to_string())
                })?;
                extra.insert(c, i);
                positions.push(file_positions[slot]);
                if let Some(u) = uvs.as_mut() {
                    u.push(Vec2::ZERO);
                }
                if let Some(n) = normals.as_mut() {
                    n.push(Vec3::ZERO);
                }
                i
            }
        };
        if let Some(u) = uvs.as_mut() {
            match c.t {
                Some(t) => u[index as usize] = file_uvs[t as usize],
                None => missing_uv += 1,
            }
        }
        if let Some(n) = normals.as_mut() {
            match c.n {
                Some(k) => n[index as usize] = file_normals[k as usize],
                None => missing_normal += 1,
            }
        }
        Ok(index)
    };

    let mut triangles = Vec::with_capacity(corners.len());
    let mut polygon = Vec::new();
    for &(first, n, _) in faces {
        polygon.clear();
        for &c in &corners[first..first + n] {
            polygon.push(vertex_of(c)?);
        }
        fan_triangulate(&polygon, &mut triangles);
    }
    if missing_uv > 0 {
        tracing::warn!(
            "{}: {missing_uv} face corners have no texture coordinate; they get (0, 0)",
            path.display()
        );
    }
    if missing_normal > 0 {
        tracing::warn!(
            "{}: {missing_normal} face corners have no normal; they get a zero normal \
             (shading falls back to the geometric normal)",
            path.display()
        );
    }
    Ok(Mesh {
        positions,
        normals,
        uvs,
        triangles,
    })
}
