//! How the calibration's design decides a camera's pose error: noisy
//! synthetic corners of the simulated rig's board (the true projection plus
//! Gaussian noise of 0.05 px per coordinate, about a 1024 px render's)
//! through the same solver as `matscan calib rig`, 64 random draws per
//! design on the rigs of `matscan calib board --seed 1..3`. Prints, per
//! rig and design, the worst position's camera error (median and 90th
//! percentile over the draws), and the focal length's and principal
//! point's median errors. The figures are in `docs/results.md`.
//!
//! ```sh
//! cargo run --release -p matscan-rigcal --example board_design [NOISE_PX [NAME]]
//! ```
//!
//! `NOISE_PX` replaces the 0.05 px (a short-focus rig's steep hand-held
//! boards render at about 0.1 px); `NAME` runs only the designs whose name
//! holds it.
//!
//! A design is the shots per position, the hand-held tilt range, the
//! hand-held distance range (times the working distance), the reference
//! board's lean (degrees about the world x axis; `None`: the placement
//! `matscan_sim::calib_target::reference_placement` chooses, every camera
//! near 45 degrees), the board's inner corners, the photos of each resting
//! placement (repeated photos of a board that does not move, each with
//! its own noise), the frames averaged into each such photo (its noise
//! over their root), the frames averaged into each held photo (a board
//! propped still on a stand) and whether the mount's second seat
//! (`matscan_sim::calib_target::seat_placement`) is photographed too.
use glam::{DMat4, DQuat, DVec2, DVec3};
use matscan_rigcal::camera::{solve_camera, Acceptance};
use matscan_rigcal::compare::pose_difference;
use matscan_rigcal::detect::Corner;
use matscan_rigcal::model::{project, Pose};
use matscan_scan::calib_bundle::{BoardPlacement, CalibManifest, CalibPosition, Shot, SEAT};
use matscan_sim::calib_target::{
    board_for, board_rig, held_pose, seat_placement, BoardBundleOptions, Hold,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::path::{Path, PathBuf};

/// Corner noise per coordinate, pixels.
const NOISE_PX: f64 = 0.05;
/// Random draws per rig and design.
const DRAWS: u64 = 64;

struct Design {
    name: &'static str,
    /// Photos per position: the reference and the hand-held poses.
    shots: usize,
    tilt_deg: (f64, f64),
    distance: (f64, f64),
    /// `None`: the simulated operator's placement.
    lean_deg: Option<f64>,
    corners: (u32, u32),
    /// Photos of each resting placement.
    photos_per_seat: usize,
    /// The mount's second seat photographed at every position too.
    seat: bool,
    /// Frames averaged into each photo of a resting placement: its corners
    /// carry the noise over the root of this.
    frames: usize,
    /// Frames averaged into each hand-held photo (a board propped on a
    /// stand holds still like a resting one).
    held_frames: usize,
}

struct Errors {
    worst_position_mm: f64,
    focal_percent: f64,
    principal_px: f64,
}

const DESIGNS: [Design; 21] = [
    design(
        "lean 25 deg about x, 9x6",
        8,
        (10.0, 40.0),
        Some(25.0),
        (9, 6),
        1,
        false,
    ),
    design(
        "every camera near 45 deg, 9x6",
        8,
        (10.0, 40.0),
        None,
        (9, 6),
        1,
        false,
    ),
    design(
        "lean 25 deg about x, 13x9",
        8,
        (10.0, 40.0),
        Some(25.0),
        (13, 9),
        1,
        false,
    ),
    design(
        "every camera near 45 deg, 13x9",
        8,
        (10.0, 40.0),
        None,
        (13, 9),
        1,
        false,
    ),
    design(
        "every camera near 45 deg, 13x9, 12 shots",
        12,
        (10.0, 40.0),
        None,
        (13, 9),
        1,
        false,
    ),
    design(
        "every camera near 45 deg, 13x9, 16 shots tilted 20 to 50 deg",
        16,
        (20.0, 50.0),
        None,
        (13, 9),
        1,
        false,
    ),
    design(
        "every camera near 45 deg, 13x9, reference photographed 4 times",
        8,
        (10.0, 40.0),
        None,
        (13, 9),
        4,
        false,
    ),
    design(
        "every camera near 45 deg, 13x9, second seat",
        8,
        (10.0, 40.0),
        None,
        (13, 9),
        1,
        true,
    ),
    design(
        "every camera near 45 deg, 13x9, second seat, each seat photographed 4 times",
        8,
        (10.0, 40.0),
        None,
        (13, 9),
        4,
        true,
    ),
    design(
        "the same (seat, 4 frames), held boards tilted 20 to 50 deg",
        8,
        (20.0, 50.0),
        None,
        (13, 9),
        4,
        true,
    ),
    design(
        "the same (seat, 4 frames), 12 shots tilted 20 to 50 deg",
        12,
        (20.0, 50.0),
        None,
        (13, 9),
        4,
        true,
    ),
    design(
        "the same (seat, 4 frames), 16 shots tilted 20 to 50 deg",
        16,
        (20.0, 50.0),
        None,
        (13, 9),
        4,
        true,
    ),
    averaged(
        "seat, one photo of 4 frames each, 8 shots",
        8,
        (10.0, 40.0),
        4,
    ),
    averaged(
        "seat, one photo of 4 frames each, 12 shots tilted 20 to 50 deg",
        12,
        (20.0, 50.0),
        4,
    ),
    averaged(
        "seat, one photo of 16 frames each, 8 shots",
        8,
        (10.0, 40.0),
        16,
    ),
    averaged(
        "seat, one photo of 16 frames each, 12 shots tilted 20 to 50 deg",
        12,
        (20.0, 50.0),
        16,
    ),
    averaged(
        "seat, one photo of 16 frames each, 16 shots tilted 20 to 50 deg",
        16,
        (20.0, 50.0),
        16,
    ),
    Design {
        distance: (0.6, 0.85),
        ..averaged(
            "seat, one photo of 16 frames each, 8 shots held at 0.6 to 0.85",
            8,
            (10.0, 40.0),
            16,
        )
    },
    Design {
        held_frames: 4,
        ..averaged(
            "seat, one photo of 16 frames each, 8 propped shots of 4 frames",
            8,
            (10.0, 40.0),
            16,
        )
    },
    Design {
        held_frames: 16,
        ..averaged(
            "seat, one photo of 16 frames each, 8 propped shots of 16 frames",
            8,
            (10.0, 40.0),
            16,
        )
    },
    Design {
        distance: (0.6, 0.85),
        held_frames: 16,
        ..averaged(
            "seat, one photo of 16 frames each, 8 propped shots of 16 frames at 0.6 to 0.85",
            8,
            (10.0, 40.0),
            16,
        )
    },
];

/// A design held at 0.8 to 1.1 times the working distance.
const fn design(
    name: &'static str,
    shots: usize,
    tilt_deg: (f64, f64),
    lean_deg: Option<f64>,
    corners: (u32, u32),
    photos_per_seat: usize,
    seat: bool,
) -> Design {
    Design {
        name,
        shots,
        tilt_deg,
        distance: (0.8, 1.1),
        lean_deg,
        corners,
        photos_per_seat,
        seat,
        frames: 1,
        held_frames: 1,
    }
}

/// The kept design (13 x 9, every camera near 45 degrees, the second
/// seat) with each resting placement photographed once as the mean of
/// `frames` frames, and `shots` photos per position.
const fn averaged(name: &'static str, shots: usize, tilt_deg: (f64, f64), frames: usize) -> Design {
    Design {
        frames,
        ..design(name, shots, tilt_deg, None, (13, 9), 1, true)
    }
}

fn gauss(rng: &mut Pcg64) -> f64 {
    let u: f64 = rng.gen_range(1e-12..1.0);
    let v: f64 = rng.gen_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// One draw of `design` on the rig of `seed`; `None` when the solver
/// refuses it.
fn trial(seed: u64, draw: u64, design: &Design, noise_px: f64) -> Option<Errors> {
    let (rig, _) = board_rig(&BoardBundleOptions {
        seed,
        ..BoardBundleOptions::default()
    });
    let board = board_for(&rig, design.corners);
    let reference = match design.lean_deg {
        None => matscan_sim::calib_target::reference_placement(&board, &rig),
        Some(lean) => {
            let facing = glam::DMat3::from_cols(DVec3::NEG_X, DVec3::NEG_Y, DVec3::Z);
            let rotation = glam::DMat3::from_rotation_x(lean.to_radians()) * facing;
            let centre = board.corner(board.cols - 1, board.rows - 1) * 0.5;
            DMat4::from_rotation_translation(DQuat::from_mat3(&rotation), -(rotation * centre))
        }
    };
    // The resting placements every position photographs, board to world.
    let mut resting: Vec<(BoardPlacement, DMat4)> =
        vec![(BoardPlacement::Reference, reference); design.photos_per_seat];
    if design.seat {
        let seat = seat_placement(&board, &rig)?;
        resting.extend(std::iter::repeat_n(
            (BoardPlacement::Seat(SEAT.into()), seat),
            design.photos_per_seat,
        ));
    }
    let mut rng = Pcg64::seed_from_u64(1000 + draw);
    let mut detections = Vec::new();
    let mut positions = Vec::new();
    for (p, at) in rig.positions.iter().enumerate() {
        let w2c = at.camera_to_world.inverse();
        let mut list = Vec::new();
        let mut placed = resting.clone();
        for _ in 1..design.shots {
            let held = held_pose(
                &mut rng,
                &board,
                &rig,
                at.camera_to_world,
                None,
                Hold {
                    tilt_deg: design.tilt_deg,
                    distance: design.distance,
                },
            )?;
            placed.push((BoardPlacement::Held, held));
        }
        for (s, (placement, b2w)) in placed.into_iter().enumerate() {
            let pose_c = Pose::from_matrix(&(w2c * b2w));
            let noise = match placement {
                BoardPlacement::Held => noise_px / (design.held_frames as f64).sqrt(),
                _ => noise_px / (design.frames as f64).sqrt(),
            };
            let corners: Vec<Corner> = (0..board.rows)
                .flat_map(|j| (0..board.cols).map(move |i| (i, j)))
                .map(|(i, j)| Corner {
                    i,
                    j,
                    pixel: project(&rig.intrinsics, &pose_c, board.corner(i, j))
                        + DVec2::new(noise * gauss(&mut rng), noise * gauss(&mut rng)),
                })
                .collect();
            detections.push(corners);
            list.push(Shot {
                file: PathBuf::from(format!("p{p}/b{s}.exr")),
                placement,
                graycode: None,
            });
        }
        positions.push(CalibPosition {
            name: at.name.clone(),
            shots: list,
        });
    }
    let m = CalibManifest {
        units: "m".into(),
        board,
        reference_to_world: reference,
        positions,
        projector: None,
    };
    let cal = solve_camera(
        Path::new("x"),
        &m,
        detections,
        (1024, 1024),
        &Acceptance {
            max_rms_px: 10.0,
            max_tilt_deg: 89.0,
            ..Acceptance::default()
        },
    )
    .ok()?;
    let mut worst: f64 = 0.0;
    for ((_, c2w), at) in cal.camera_to_world.iter().zip(&rig.positions) {
        worst = worst.max(pose_difference(c2w, &at.camera_to_world).0);
    }
    let f = (cal.camera.fx / rig.intrinsics.fx - 1.0).abs() * 100.0;
    let pp = (DVec2::new(cal.camera.cx, cal.camera.cy)
        - DVec2::new(rig.intrinsics.cx, rig.intrinsics.cy))
    .length();
    Some(Errors {
        worst_position_mm: worst * 1e3,
        focal_percent: f,
        principal_px: pp,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    // Arguments: the corner noise in pixels (default 0.05) and a piece of
    // the designs' names to run only those.
    let args: Vec<String> = std::env::args().skip(1).collect();
    let noise_px = match args.first() {
        None => NOISE_PX,
        Some(a) => match a.parse::<f64>() {
            Ok(n) if n.is_finite() && n >= 0.0 => n,
            _ => {
                eprintln!("board_design: NOISE_PX is {a:?}: expected pixels, such as 0.1");
                std::process::exit(2);
            }
        },
    };
    let only = args.get(1).cloned().unwrap_or_default();
    println!("corner noise {noise_px} px per coordinate");
    println!("rig | design | worst position, median mm | 90th percentile mm | focal, median % | principal point, median px | refused");
    for seed in [1u64, 2, 3] {
        for design in DESIGNS.iter().filter(|d| d.name.contains(only.as_str())) {
            let found: Vec<Errors> = (0..DRAWS)
                .filter_map(|d| trial(seed, d, design, noise_px))
                .collect();
            let mut positions: Vec<f64> = found.iter().map(|e| e.worst_position_mm).collect();
            positions.sort_by(f64::total_cmp);
            let p90 = positions
                .get(positions.len() * 9 / 10)
                .copied()
                .unwrap_or(f64::NAN);
            println!(
                "{seed} | {} | {:.2} | {:.2} | {:.4} | {:.3} | {}",
                design.name,
                median(positions.clone()),
                p90,
                median(found.iter().map(|e| e.focal_percent).collect()),
                median(found.iter().map(|e| e.principal_px).collect()),
                DRAWS as usize - found.len()
            );
        }
    }
}
