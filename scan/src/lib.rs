//! The scan bundle, format `matscan-scan/1`: the one data layer every other
//! matscan crate stands on.
//!
//! A bundle is a folder: `scan.toml` (the [`Manifest`]), the object mesh, the
//! photos of every capture at every position, an optional mask per position
//! and, for simulated scans, truth maps. This crate reads, validates and
//! writes such folders (see `docs/scan-format.md`), and owns the geometry
//! layer shared by the renderer (`matscan-sim`) and calibration
//! (`matscan-calib`): the [`Mesh`], its BVH ray caster ([`Bvh`]) and the
//! OpenCV pinhole [`camera`] model.
//!
//! Boundaries: no rendering, no estimation, no device I/O. Everything here is
//! plain data plus file formats, so that a bundle written by another tool is
//! read exactly like one written by us.
//!
//! Crate choices: `toml` + `serde` for the manifest (the contract's format);
//! `exr` (pure Rust, maintained, reads half and float) for photos; `image`
//! with only its PNG codec for 16-bit PNG photos and 8-bit masks; `glam` for
//! vectors (f64 for calibration matrices, f32 on the ray-casting hot path).

pub mod atomic;
pub mod bundle;
pub mod bvh;
pub mod calib_bundle;
pub mod camera;
pub mod capture_list;
pub mod error;
pub mod estimate_maps;
pub mod image_io;
pub mod lights_bundle;
pub mod manifest;
pub mod mesh;
pub mod mesh_io;
pub mod param;
pub mod raster;
pub mod time;
pub mod white_bundle;

pub use bundle::{Bundle, BundleWriter, TruthImage, TruthKind, TruthMap};
pub use bvh::{offset_origin, offset_origin_scaled, Bvh, Hit, Ray, RayCaster};
pub use camera::{Intrinsics, PinholeCamera};
pub use error::ScanError;
pub use image_io::Precision;
pub use manifest::{
    gray_code, gray_decode, Capture, CaptureRole, Encoding, GrayAxis, Light, LightKind, Manifest,
    Pattern, Position, FORMAT,
};
pub use mesh::{Mesh, MeshDefect, SurfacePoint};
pub use param::Param;
pub use raster::Raster;
