//! The OpenCV pinhole camera model of the contract, used for the camera and
//! (without distortion) for the projector.
//!
//! Pixel centres lie at integer + 0.5, so pixel (column i, row j) covers
//! `[i, i+1) x [j, j+1)` and a ray "through pixel (i, j)" goes through
//! `(i + 0.5, j + 0.5)`. Distortion is OpenCV's `k1 k2 p1 p2 k3`.

use crate::bvh::Ray;
use glam::{DMat4, DVec2, DVec3};

/// Intrinsics of a camera or projector, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Intrinsics {
    pub width: u32,
    pub height: u32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// OpenCV `k1 k2 p1 p2 k3`; all zero means none.
    pub distortion: [f64; 5],
}

/// Intrinsics plus a pose: enough to project world points and to cast rays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    pub intrinsics: Intrinsics,
    pub camera_to_world: DMat4,
    world_to_camera: DMat4,
}

/// One line, as calibration reports print it.
impl std::fmt::Display for Intrinsics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = self.distortion;
        write!(
            f,
            "{}x{}: fx {:.2} fy {:.2} cx {:.2} cy {:.2}, distortion {:.4} {:.4} {:.5} {:.5} {:.4}",
            self.width,
            self.height,
            self.fx,
            self.fy,
            self.cx,
            self.cy,
            d[0],
            d[1],
            d[2],
            d[3],
            d[4]
        )
    }
}

impl Intrinsics {
    /// The same camera at another image size: focal lengths and principal
    /// point scaled by `sx` horizontally and `sy` vertically, the image
    /// `width` x `height`; distortion, in normalized coordinates, is kept.
    pub fn scaled(&self, sx: f64, sy: f64, width: u32, height: u32) -> Intrinsics {
        Intrinsics {
            width,
            height,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: self.cx * sx,
            cy: self.cy * sy,
            distortion: self.distortion,
        }
    }

    /// The same camera photographing `width` x `height` pixels (each axis
    /// scaled by its own ratio); unchanged when either size is zero.
    pub fn scaled_to(&self, width: u32, height: u32) -> Intrinsics {
        if width == 0 || height == 0 || self.width == 0 || self.height == 0 {
            return *self;
        }
        self.scaled(
            f64::from(width) / f64::from(self.width),
            f64::from(height) / f64::from(self.height),
            width,
            height,
        )
    }

    pub fn has_distortion(&self) -> bool {
        self.distortion.iter().any(|&d| d != 0.0)
    }

    /// Applies distortion to normalized image coordinates (x/z, y/z).
    pub fn distort(&self, p: DVec2) -> DVec2 {
        if !self.has_distortion() {
            return p;
        }
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        DVec2::new(
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// Inverts [`Intrinsics::distort`] by fixed-point iteration (as OpenCV's
    /// `undistortPoints` does); exact for zero distortion.
    pub fn undistort(&self, d: DVec2) -> DVec2 {
        if !self.has_distortion() {
            return d;
        }
        let mut p = d;
        for _ in 0..20 {
            let err = self.distort(p) - d;
            p -= err;
            if err.length_squared() < 1e-24 {
                break;
            }
        }
        p
    }

    /// Pixel coordinates of a camera-frame point, or `None` behind the camera.
    pub fn project_camera_point(&self, pc: DVec3) -> Option<DVec2> {
        if pc.z <= 0.0 || !pc.is_finite() {
            return None;
        }
        let n = self.distort(DVec2::new(pc.x / pc.z, pc.y / pc.z));
        Some(DVec2::new(self.fx * n.x + self.cx, self.fy * n.y + self.cy))
    }

    /// Unit direction in the camera frame of the ray through pixel
    /// coordinates `px` (continuous; pixel centres at +0.5).
    pub fn ray_direction(&self, px: DVec2) -> DVec3 {
        let d = DVec2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        let n = self.undistort(d);
        DVec3::new(n.x, n.y, 1.0).normalize()
    }
}

impl PinholeCamera {
    pub fn new(intrinsics: Intrinsics, camera_to_world: DMat4) -> Self {
        Self {
            intrinsics,
            camera_to_world,
            world_to_camera: camera_to_world.inverse(),
        }
    }

    pub fn world_to_camera(&self) -> DMat4 {
        self.world_to_camera
    }

    /// Centre of projection in world space.
    pub fn center(&self) -> DVec3 {
        self.camera_to_world.transform_point3(DVec3::ZERO)
    }

    /// Pixel coordinates of a world point, or `None` behind the camera.
    pub fn project(&self, world: DVec3) -> Option<DVec2> {
        self.intrinsics
            .project_camera_point(self.world_to_camera.transform_point3(world))
    }

    /// Depth (camera-frame z) of a world point.
    pub fn depth(&self, world: DVec3) -> f64 {
        self.world_to_camera.transform_point3(world).z
    }

    /// World-space ray through continuous pixel coordinates `px`.
    pub fn ray(&self, px: DVec2) -> Ray {
        let d = self
            .camera_to_world
            .transform_vector3(self.intrinsics.ray_direction(px))
            .normalize();
        Ray::new(self.center().as_vec3(), d.as_vec3())
    }

    /// World-space ray through the centre of pixel (column `i`, row `j`).
    pub fn pixel_ray(&self, i: u32, j: u32) -> Ray {
        self.ray(DVec2::new(i as f64 + 0.5, j as f64 + 0.5))
    }
}

/// Builds a camera-to-world matrix (OpenCV frame) looking from `eye` at
/// `target`, with `up` roughly the world's up; image y points away from `up`.
pub fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> DMat4 {
    let z = (target - eye).normalize();
    let x = z.cross(up).normalize();
    let y = z.cross(x);
    DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0))
}

/// Row-major 16 numbers (the manifest's layout) to a matrix.
pub fn mat4_from_row_major(m: &[f64; 16]) -> DMat4 {
    DMat4::from_cols_array(m).transpose()
}

/// A matrix to row-major 16 numbers (the manifest's layout).
pub fn mat4_to_row_major(m: &DMat4) -> [f64; 16] {
    m.transpose().to_cols_array()
}
