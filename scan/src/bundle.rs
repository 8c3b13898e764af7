//! A scan bundle on disk: opening one (manifest validated, every referenced
//! file present), reading its photos, masks, truth maps and mesh with size
//! checks, and writing one atomically ([`BundleWriter`]).
//!
//! Boundaries: file layout and consistency between files; pixel and mesh
//! codecs live in [`crate::image_io`] and [`crate::mesh_io`], manifest rules
//! in [`crate::manifest`].

use crate::atomic::{write_atomic, PendingDir};
use crate::camera::PinholeCamera;
use crate::error::ScanError;
use crate::estimate_maps::MapValues;
use crate::image_io::{self, Precision};
use crate::manifest::{Capture, Manifest, Position};
use crate::mesh::Mesh;
use crate::param::Param;
use crate::raster::{MaskRaster, Raster, RgbRaster, ScalarRaster};
use std::fmt;
use std::path::{Component, Path, PathBuf};

/// The manifest's file name inside a bundle.
pub const MANIFEST_FILE: &str = "scan.toml";
/// The mesh file names a bundle may use, in order of preference.
pub const MESH_FILES: [&str; 2] = ["geometry.ply", "geometry.obj"];

/// An opened bundle: its manifest is valid and every file it names exists.
#[derive(Debug, Clone)]
pub struct Bundle {
    pub root: PathBuf,
    pub manifest: Manifest,
    /// One line per unknown manifest key or other tolerated oddity.
    pub warnings: Vec<String>,
}

/// A ground-truth map of a simulated scan, `truth/<position>/<map>.exr`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum TruthMap {
    /// The effective parameter as rendered (RGB for basecolor, else one
    /// channel).
    Param(Param),
    /// `illum_<capture>`: the lit capture rendered with white diffuse
    /// materials and the environment off (RGB).
    Illum(String),
    /// Valid pixels (one channel, 1 where valid).
    Mask,
}

/// The pixels of a truth map, typed by what the map holds.
#[derive(Debug, Clone, PartialEq)]
pub enum TruthImage {
    Rgb(RgbRaster),
    Scalar(ScalarRaster),
    Mask(MaskRaster),
}

/// How a truth map is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TruthKind {
    Rgb,
    Scalar,
    Mask,
}

impl TruthMap {
    /// The file stem: `basecolor`, `illum_flash0`, `mask`.
    pub fn stem(&self) -> String {
        match self {
            TruthMap::Param(p) => p.name().to_string(),
            TruthMap::Illum(capture) => format!("illum_{capture}"),
            TruthMap::Mask => "mask".to_string(),
        }
    }

    /// `truth/<position>/<stem>.exr`, relative to the bundle folder.
    pub fn relative_path(&self, position: &str) -> PathBuf {
        Path::new("truth")
            .join(position)
            .join(format!("{}.exr", self.stem()))
    }

    pub fn kind(&self) -> TruthKind {
        match self {
            TruthMap::Param(Param::Basecolor) | TruthMap::Illum(_) => TruthKind::Rgb,
            TruthMap::Param(_) => TruthKind::Scalar,
            TruthMap::Mask => TruthKind::Mask,
        }
    }
}

impl fmt::Display for TruthMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.stem())
    }
}

impl TruthImage {
    pub fn kind(&self) -> TruthKind {
        match self {
            TruthImage::Rgb(_) => TruthKind::Rgb,
            TruthImage::Scalar(_) => TruthKind::Scalar,
            TruthImage::Mask(_) => TruthKind::Mask,
        }
    }

    pub fn into_rgb(self) -> Option<RgbRaster> {
        match self {
            TruthImage::Rgb(r) => Some(r),
            _ => None,
        }
    }

    pub fn into_scalar(self) -> Option<ScalarRaster> {
        match self {
            TruthImage::Scalar(r) => Some(r),
            _ => None,
        }
    }

    pub fn into_mask(self) -> Option<MaskRaster> {
        match self {
            TruthImage::Mask(r) => Some(r),
            _ => None,
        }
    }
}

/// The scan bundles (folders holding [`MANIFEST_FILE`]) of a set: `dir`
/// itself when it is one, else those directly under it and one level
/// further down (a set grouped by kind, as `matscan simulate --recipe`
/// writes it), sorted by path. Empty when there are none.
pub fn find_bundles(dir: &Path) -> Result<Vec<PathBuf>, ScanError> {
    fn walk(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), ScanError> {
        if dir.join(MANIFEST_FILE).is_file() {
            out.push(dir.to_path_buf());
            return Ok(());
        }
        if depth == 0 {
            return Ok(());
        }
        let io = |source| ScanError::Io {
            path: dir.to_path_buf(),
            source,
        };
        for entry in std::fs::read_dir(dir).map_err(io)? {
            let path = entry.map_err(io)?.path();
            if path.is_dir() {
                walk(&path, depth - 1, out)?;
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, 2, &mut out)?;
    out.sort();
    Ok(out)
}

/// `views/<position>/<capture>.exr`: where [`BundleWriter::write_photo`]
/// puts a photo.
pub fn photo_path(position: &str, capture: &str) -> PathBuf {
    Path::new("views")
        .join(position)
        .join(format!("{capture}.exr"))
}

/// `views/<position>/mask.png`: the optional object mask.
pub fn mask_path(position: &str) -> PathBuf {
    Path::new("views").join(position).join("mask.png")
}

impl Bundle {
    /// Opens the bundle in `root`: reads and validates `scan.toml` and
    /// checks that the mesh and every file the manifest names exist.
    pub fn open(root: impl Into<PathBuf>) -> Result<Bundle, ScanError> {
        let root = root.into();
        let manifest_path = root.join(MANIFEST_FILE);
        require_file(&manifest_path, || {
            "the manifest every scan bundle has; is this a scan folder?".to_string()
        })?;
        let (manifest, mut warnings) = Manifest::read(&manifest_path)?;

        let meshes: Vec<&str> = MESH_FILES
            .iter()
            .copied()
            .filter(|m| root.join(m).exists())
            .collect();
        match meshes.as_slice() {
            [] => {
                return Err(ScanError::Missing {
                    path: root.join(MESH_FILES[0]),
                    needed_by: "the object mesh: geometry.ply or geometry.obj".to_string(),
                })
            }
            [_] => {}
            [use_, ..] => {
                let w = format!(
                    "{}: both {} exist; using {use_}",
                    root.display(),
                    meshes.join(" and ")
                );
                tracing::warn!("{w}");
                warnings.push(w);
            }
        }
        require_file(&root.join(meshes[0]), || "the object mesh".to_string())?;

        for p in &manifest.positions {
            for c in &p.captures {
                require_file(&root.join(&c.file), || {
                    format!(
                        "the photo of position {:?} capture {:?} in {MANIFEST_FILE}",
                        p.name, c.name
                    )
                })?;
            }
            if let Some(mask) = &p.white_reference_mask {
                require_file(&root.join(mask), || {
                    format!(
                        "the white reference mask of position {:?} in {MANIFEST_FILE}",
                        p.name
                    )
                })?;
            }
        }
        Ok(Bundle {
            root,
            manifest,
            warnings,
        })
    }

    pub fn manifest_path(&self) -> PathBuf {
        self.root.join(MANIFEST_FILE)
    }

    /// The mesh file: `geometry.ply` where present, else `geometry.obj`.
    pub fn mesh_path(&self) -> PathBuf {
        let ply = self.root.join(MESH_FILES[0]);
        if ply.exists() {
            ply
        } else {
            self.root.join(MESH_FILES[1])
        }
    }

    pub fn read_mesh(&self) -> Result<Mesh, ScanError> {
        crate::mesh_io::read_mesh(&self.mesh_path())
    }

    /// The position called `name`, or an error listing those there are.
    pub fn position(&self, name: &str) -> Result<&Position, ScanError> {
        self.manifest.position(name).ok_or_else(|| {
            let have: Vec<&str> = self
                .manifest
                .positions
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            ScanError::NotInManifest {
                path: self.manifest_path(),
                message: format!("no position `{name}` (it has {})", have.join(", ")),
            }
        })
    }

    /// The capture `capture` of position `position`.
    pub fn capture(&self, position: &str, capture: &str) -> Result<&Capture, ScanError> {
        let p = self.position(position)?;
        p.capture(capture).ok_or_else(|| {
            let have: Vec<&str> = p.captures.iter().map(|c| c.name.as_str()).collect();
            ScanError::NotInManifest {
                path: self.manifest_path(),
                message: format!(
                    "position `{position}` has no capture `{capture}` (it has {})",
                    have.join(", ")
                ),
            }
        })
    }

    /// The camera (intrinsics and pose) of a position.
    pub fn camera(&self, position: &str) -> Result<PinholeCamera, ScanError> {
        Ok(self.position(position)?.pinhole(self.manifest.camera))
    }

    /// The linear RGB photo of a capture (PNG decoded per its declared
    /// encoding), checked to be the camera's size.
    pub fn read_photo(&self, position: &str, capture: &str) -> Result<RgbRaster, ScanError> {
        let c = self.capture(position, capture)?;
        let path = self.root.join(&c.file);
        let image = image_io::read_rgb(&path, c.encoding)?;
        self.check_size(&path, &image)?;
        Ok(image)
    }

    /// The object mask `views/<position>/mask.png`, if the bundle has one.
    pub fn read_mask(&self, position: &str) -> Result<Option<MaskRaster>, ScanError> {
        self.position(position)?;
        self.read_optional_mask(&self.root.join(mask_path(position)))
    }

    /// The white reference mask the manifest declares for a position, if
    /// any.
    pub fn read_white_reference_mask(
        &self,
        position: &str,
    ) -> Result<Option<MaskRaster>, ScanError> {
        match &self.position(position)?.white_reference_mask {
            None => Ok(None),
            Some(rel) => {
                let path = self.root.join(rel);
                let mask = image_io::read_mask_png(&path)?;
                self.check_size(&path, &mask)?;
                Ok(Some(mask))
            }
        }
    }

    /// A truth map of a simulated scan; `None` where the bundle has none.
    /// The truth object mask of `position` (simulated scans); `None`
    /// without one.
    pub fn truth_mask(&self, position: &str) -> Result<Option<MaskRaster>, ScanError> {
        Ok(self
            .read_truth(position, &TruthMap::Mask)?
            .and_then(TruthImage::into_mask))
    }

    /// `param`'s truth map at `position` (simulated scans; RGB for
    /// basecolor); `None` without one.
    pub fn truth_param(
        &self,
        position: &str,
        param: Param,
    ) -> Result<Option<MapValues>, ScanError> {
        Ok(match self.read_truth(position, &TruthMap::Param(param))? {
            Some(TruthImage::Rgb(r)) => Some(MapValues::Rgb(r)),
            Some(TruthImage::Scalar(r)) => Some(MapValues::Scalar(r)),
            _ => None,
        })
    }

    pub fn read_truth(
        &self,
        position: &str,
        map: &TruthMap,
    ) -> Result<Option<TruthImage>, ScanError> {
        self.position(position)?;
        if let TruthMap::Illum(capture) = map {
            self.capture(position, capture)?;
        }
        let path = self.root.join(map.relative_path(position));
        if !path.exists() {
            return Ok(None);
        }
        let image = match map.kind() {
            TruthKind::Rgb => {
                let r = image_io::read_rgb_exr(&path)?;
                self.check_size(&path, &r)?;
                TruthImage::Rgb(r)
            }
            TruthKind::Scalar => {
                let r = image_io::read_scalar_exr(&path)?;
                self.check_size(&path, &r)?;
                TruthImage::Scalar(r)
            }
            TruthKind::Mask => {
                let r = image_io::read_scalar_exr(&path)?;
                self.check_size(&path, &r)?;
                TruthImage::Mask(r.map(|&v| v > 0.5))
            }
        };
        Ok(Some(image))
    }

    /// Reads every photo and mask once, checking that each decodes, is
    /// finite and has the camera's size: a full check of the bundle beyond
    /// what [`Bundle::open`] does.
    pub fn verify_images(&self) -> Result<(), ScanError> {
        for p in &self.manifest.positions {
            for c in &p.captures {
                self.read_photo(&p.name, &c.name)?;
            }
            self.read_mask(&p.name)?;
            self.read_white_reference_mask(&p.name)?;
        }
        Ok(())
    }

    fn read_optional_mask(&self, path: &Path) -> Result<Option<MaskRaster>, ScanError> {
        if !path.exists() {
            return Ok(None);
        }
        let mask = image_io::read_mask_png(path)?;
        self.check_size(path, &mask)?;
        Ok(Some(mask))
    }

    fn check_size<T>(&self, path: &Path, image: &Raster<T>) -> Result<(), ScanError> {
        let cam = &self.manifest.camera;
        if image.width != cam.width || image.height != cam.height {
            return Err(ScanError::SizeMismatch {
                path: path.to_path_buf(),
                expected_width: cam.width,
                expected_height: cam.height,
                found_width: image.width,
                found_height: image.height,
            });
        }
        Ok(())
    }
}

fn require_file(path: &Path, needed_by: impl FnOnce() -> String) -> Result<(), ScanError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(_) => Err(ScanError::format(
            path,
            format!("expected a file ({})", needed_by()),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(ScanError::Missing {
            path: path.to_path_buf(),
            needed_by: needed_by(),
        }),
        Err(e) => Err(ScanError::io(path, e)),
    }
}

/// Builds a bundle in a hidden temporary folder and publishes it in one
/// rename: a reader never sees a half-written bundle, and a writer that
/// fails or is dropped leaves nothing behind.
#[derive(Debug)]
pub struct BundleWriter {
    dir: PendingDir,
}

impl BundleWriter {
    /// Starts a bundle that [`BundleWriter::finish`] will publish at
    /// `final_dir`. Fails at once if `final_dir` exists.
    pub fn create(final_dir: impl Into<PathBuf>) -> Result<Self, ScanError> {
        Ok(Self {
            dir: PendingDir::create(final_dir)?,
        })
    }

    /// The temporary folder being filled, for writers outside this crate
    /// (prefer [`BundleWriter::path_for`], which also makes folders).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Where the bundle will be published.
    pub fn target(&self) -> &Path {
        self.dir.target()
    }

    /// The absolute path of bundle-relative `rel` inside the temporary
    /// folder, with its parent folders created. `rel` must be relative and
    /// free of `..`.
    pub fn path_for(&self, rel: impl AsRef<Path>) -> Result<PathBuf, ScanError> {
        let rel = rel.as_ref();
        let inside = !rel.as_os_str().is_empty()
            && rel.components().all(|c| matches!(c, Component::Normal(_)));
        if !inside {
            return Err(ScanError::format(
                rel,
                "expected a path relative to the bundle folder, without . or ..",
            ));
        }
        let path = self.dir.path().join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| ScanError::io(parent, e))?;
        }
        Ok(path)
    }

    /// Writes raw bytes (a mesh, a side file) at bundle-relative `rel`.
    pub fn write_file(&self, rel: impl AsRef<Path>, bytes: &[u8]) -> Result<(), ScanError> {
        write_atomic(&self.path_for(rel)?, bytes)
    }

    /// Writes the mesh as `geometry.ply` (binary little-endian PLY).
    pub fn write_mesh(&self, mesh: &Mesh) -> Result<(), ScanError> {
        crate::mesh_io::write_mesh(&self.path_for(MESH_FILES[0])?, mesh)
    }

    /// Writes a photo at its conventional place, `views/<position>/<capture>.exr`,
    /// and returns that relative path for the capture's `file`.
    pub fn write_photo(
        &self,
        position: &str,
        capture: &str,
        image: &RgbRaster,
        precision: Precision,
    ) -> Result<PathBuf, ScanError> {
        let rel = photo_path(position, capture);
        self.write_rgb_exr(&rel, image, precision)?;
        Ok(rel)
    }

    /// Writes an RGB EXR at any bundle-relative path.
    pub fn write_rgb_exr(
        &self,
        rel: impl AsRef<Path>,
        image: &RgbRaster,
        precision: Precision,
    ) -> Result<(), ScanError> {
        image_io::write_rgb_exr(&self.path_for(rel)?, image, precision)
    }

    /// Writes the object mask `views/<position>/mask.png`.
    pub fn write_mask(&self, position: &str, mask: &MaskRaster) -> Result<(), ScanError> {
        image_io::write_mask_png(&self.path_for(mask_path(position))?, mask)
    }

    /// Writes a mask PNG at any bundle-relative path (a white reference
    /// mask, say) and returns that path.
    pub fn write_mask_at(
        &self,
        rel: impl AsRef<Path>,
        mask: &MaskRaster,
    ) -> Result<PathBuf, ScanError> {
        let rel = rel.as_ref().to_path_buf();
        image_io::write_mask_png(&self.path_for(&rel)?, mask)?;
        Ok(rel)
    }

    /// Writes an RGB truth map (basecolor, `illum_<capture>`) as float EXR.
    pub fn write_truth_rgb(
        &self,
        position: &str,
        map: &TruthMap,
        image: &RgbRaster,
    ) -> Result<(), ScanError> {
        let path = self.truth_path(position, map, TruthKind::Rgb)?;
        image_io::write_rgb_exr(&path, image, Precision::Float)
    }

    /// Writes a single-channel truth map as float EXR (channel `R`).
    pub fn write_truth_scalar(
        &self,
        position: &str,
        map: &TruthMap,
        image: &ScalarRaster,
    ) -> Result<(), ScanError> {
        let path = self.truth_path(position, map, TruthKind::Scalar)?;
        image_io::write_scalar_exr(&path, image, Precision::Float)
    }

    /// Writes the truth validity mask `truth/<position>/mask.exr` (1 where
    /// valid, 0 elsewhere).
    pub fn write_truth_mask(&self, position: &str, mask: &MaskRaster) -> Result<(), ScanError> {
        let path = self.truth_path(position, &TruthMap::Mask, TruthKind::Mask)?;
        let values = mask.map(|&m| if m { 1.0 } else { 0.0 });
        image_io::write_scalar_exr(&path, &values, Precision::Float)
    }

    fn truth_path(
        &self,
        position: &str,
        map: &TruthMap,
        kind: TruthKind,
    ) -> Result<PathBuf, ScanError> {
        let rel = map.relative_path(position);
        if map.kind() != kind {
            return Err(ScanError::format(
                rel,
                format!(
                    "truth map {map} is stored as {:?}, not {kind:?}",
                    map.kind()
                ),
            ));
        }
        self.path_for(rel)
    }

    /// Writes `scan.toml` last, checks the whole bundle as
    /// [`Bundle::open`] would (manifest valid, mesh and every named file
    /// present), then publishes it at its final path. On error nothing is
    /// published and the temporary folder is removed.
    pub fn finish(self, manifest: &Manifest) -> Result<Bundle, ScanError> {
        write_atomic(
            &self.path_for(MANIFEST_FILE)?,
            manifest.to_toml().as_bytes(),
        )?;
        let check = Bundle::open(self.dir.path())?;
        let root = self.dir.publish()?;
        Ok(Bundle {
            root,
            manifest: check.manifest,
            warnings: check.warnings,
        })
    }
}
