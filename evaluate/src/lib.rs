//! The estimator measured, as a user of a scanner rig or a reviewer of the
//! method asks for it: how wrong, how fast, and how it looks re-rendered.
//!
//! - [`scans`]: which scan folders a set holds, and their views;
//! - [`eval`]: error against run time over simulated scans with truth
//!   (`matscan eval`): the thesis's tables, chained or each network fed the
//!   truth of its dependencies, and in texture space under novel light;
//! - [`bench`]: the knobs that trade error for run time (`matscan bench`);
//! - [`render`] and [`rerender`]: the scanned object with its estimated and
//!   its true material under novel lights and views (`matscan render`);
//! - [`image_metrics`]: PSNR and SSIM of two renders;
//! - [`plot`]: the charts of `bench`; [`sheet`]: a scan's contact sheet.
//!
//! Boundaries: reads scans and writes only into folders it is given
//! (scratch estimates, rendered sets, reports); estimates through
//! `matscan-estimate`, bakes through `matscan-bake`, renders through
//! `matscan-sim`. Printing and argument parsing are the binary's.
//!
//! Crate choices: `anyhow` for errors, because every failure here is
//! reported to a person running an evaluation with the file it concerns,
//! and no caller matches on them; `image` for the PNG charts and sheets.

pub mod bench;
pub mod eval;
pub mod image_metrics;
pub mod plot;
pub mod render;
pub mod rerender;
pub mod scans;
pub mod sheet;
