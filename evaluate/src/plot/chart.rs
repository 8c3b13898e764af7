//! Labelled line charts as PNG: a grid of panels sharing one x axis (linear
//! or log10), each with its own linear y axis from zero, one coloured line
//! per series with a labelled marker per point, tick labels, axis titles
//! and a legend. Used by `matscan bench` (error against run time).
//!
//! Drawing uses the pixel and line primitives the trainer's loss plot uses
//! (`matscan_scan::draw`) and the bitmap font of [`super::font`]; the
//! `image` crate encodes.
//!
//! Boundaries: geometry and pixels only; what the numbers mean is the
//! caller's.

use super::font;
use anyhow::{Context, Result};
use image::{ImageFormat, Rgb, RgbImage};
use matscan_scan::draw::{line, put};
use std::path::Path;

/// One axis's value range and scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Axis {
    /// An axis covering `values` (non-finite values, and non-positive ones
    /// on a log axis, are ignored). Log axes span whole decades; linear
    /// ones start at zero and end at a round number above the largest
    /// value. Without usable values: [0.1, 10] (log) or [0, 1].
    pub fn fit(values: impl IntoIterator<Item = f64>, log: bool) -> Axis {
        let usable = values
            .into_iter()
            .filter(|v| v.is_finite() && (!log || *v > 0.0));
        let (lo, hi) = usable.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if log {
            if !lo.is_finite() {
                return Axis {
                    lo: 0.1,
                    hi: 10.0,
                    log,
                };
            }
            let (a, mut b) = (lo.log10().floor(), hi.log10().ceil());
            if b <= a {
                b = a + 1.0;
            }
            Axis {
                lo: 10f64.powf(a),
                hi: 10f64.powf(b),
                log,
            }
        } else {
            let top = if hi.is_finite() && hi > 0.0 {
                let step = nice_step(hi * 1.05 / 5.0);
                (hi * 1.05 / step).ceil() * step
            } else {
                1.0
            };
            Axis {
                lo: 0.0,
                hi: top,
                log,
            }
        }
    }

    /// Where `v` lies from `lo` (0) to `hi` (1); `None` for values the axis
    /// cannot place (non-finite, or not positive on a log axis). Values
    /// outside the range map outside [0, 1].
    pub fn fraction(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let (v, lo, hi) = if self.log {
            (v.log10(), self.lo.log10(), self.hi.log10())
        } else {
            (v, self.lo, self.hi)
        };
        let span = hi - lo;
        (span.is_finite() && span > 0.0).then(|| (v - lo) / span)
    }

    /// Tick values: decades (with 2 and 5 between when the axis spans at
    /// most two decades) on a log axis; about five round steps on a linear
    /// one.
    pub fn ticks(&self) -> Vec<f64> {
        let mut ticks = Vec::new();
        if self.log {
            let (a, b) = (
                self.lo.log10().round() as i32,
                self.hi.log10().round() as i32,
            );
            let fine = b - a <= 2;
            for e in a..=b {
                let decade = 10f64.powi(e);
                for m in [1.0, 2.0, 5.0] {
                    let v = decade * m;
                    if (m == 1.0 || fine) && v <= self.hi * (1.0 + 1e-9) {
                        ticks.push(v);
                    }
                }
            }
        } else {
            let step = nice_step((self.hi - self.lo) / 5.0);
            let mut k = (self.lo / step).ceil();
            while k * step <= self.hi + step * 1e-9 {
                ticks.push(k * step);
                k += 1.0;
            }
        }
        ticks
    }
}

/// The round step (1, 2 or 5 times a power of ten) nearest above `raw`.
fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let decade = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * decade)
}

/// A tick label: as few decimals as the value needs (at most 4).
pub fn tick_label(v: f64) -> String {
    for decimals in 0..=4 {
        let text = format!("{v:.decimals$}");
        if let Ok(back) = text.parse::<f64>() {
            if (back - v).abs() <= v.abs() * 1e-6 + 1e-12 {
                return text;
            }
        }
    }
    format!("{v:.4}")
}

/// A pixel rectangle of a panel's plotting area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlotRect {
    pub left: i64,
    pub top: i64,
    pub right: i64,
    pub bottom: i64,
}

impl PlotRect {
    /// The pixel of (`x`, `y`): x grows rightwards, y upwards (rows count
    /// down from the top, hence `bottom - ...`).
    pub fn pixel_of(&self, x: &Axis, y: &Axis, (vx, vy): (f64, f64)) -> Option<(i64, i64)> {
        let (fx, fy) = (x.fraction(vx)?, y.fraction(vy)?);
        Some((
            self.left + (fx * (self.right - self.left) as f64).round() as i64,
            self.bottom - (fy * (self.bottom - self.top) as f64).round() as i64,
        ))
    }
}

/// One point: coordinates and a short label drawn beside its marker.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: String,
}

/// A line through points, in one colour.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    pub colour: [u8; 3],
    pub points: Vec<Point>,
}

/// One panel: a title and its series.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub title: String,
    pub series: Vec<Series>,
}

/// A grid of panels sharing the x axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_log: bool,
    pub panels: Vec<Panel>,
    /// Panels per row (the legend takes the next free cell).
    pub columns: usize,
}

const PANEL_W: u32 = 480;
const PANEL_H: u32 = 340;
const TITLE_H: u32 = 40;
/// Text scale of titles, axis labels and ticks (14 px tall glyphs).
const TEXT: u32 = 2;
const MARGIN_L: i64 = 84;
const MARGIN_R: i64 = 16;
const MARGIN_T: i64 = 34;
const MARGIN_B: i64 = 56;
const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
const GRID: Rgb<u8> = Rgb([228, 228, 228]);

fn text(img: &mut RgbImage, x: i64, y: i64, scale: u32, colour: Rgb<u8>, s: &str) {
    if x < 0 || y < 0 {
        return;
    }
    font::for_each_pixel(x as u32, y as u32, scale, s, |px, py| {
        put(img, (i64::from(px), i64::from(py)), colour);
    });
}

fn marker(img: &mut RgbImage, (x, y): (i64, i64), colour: Rgb<u8>) {
    for dy in -3..=3 {
        for dx in -3..=3 {
            put(img, (x + dx, y + dy), colour);
        }
    }
}

/// Draws `chart`.
pub fn render(chart: &Chart) -> RgbImage {
    let columns = chart.columns.max(1);
    let cells = chart.panels.len() + 1;
    let rows = cells.div_ceil(columns) as u32;
    let (width, height) = (columns as u32 * PANEL_W, TITLE_H + rows * PANEL_H);
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    text(&mut img, 12, 12, TEXT, BLACK, &chart.title);

    let x_axis = Axis::fit(
        chart
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| &s.points)
            .map(|p| p.x),
        chart.x_log,
    );
    let glyph_h = (font::GLYPH_H * TEXT) as i64;
    for (i, panel) in chart.panels.iter().enumerate() {
        let (cx, cy) = (
            (i % columns) as i64 * PANEL_W as i64,
            TITLE_H as i64 + (i / columns) as i64 * PANEL_H as i64,
        );
        let rect = PlotRect {
            left: cx + MARGIN_L,
            top: cy + MARGIN_T,
            right: cx + PANEL_W as i64 - MARGIN_R,
            bottom: cy + PANEL_H as i64 - MARGIN_B,
        };
        let y_axis = Axis::fit(
            panel.series.iter().flat_map(|s| &s.points).map(|p| p.y),
            false,
        );
        for t in y_axis.ticks() {
            if let Some((_, py)) = rect.pixel_of(&x_axis, &y_axis, (x_axis.lo, t)) {
                line(&mut img, (rect.left, py), (rect.right, py), GRID);
                let label = tick_label(t);
                let w = font::text_width(&label, TEXT) as i64;
                text(
                    &mut img,
                    rect.left - 6 - w,
                    py - glyph_h / 2,
                    TEXT,
                    BLACK,
                    &label,
                );
            }
        }
        for t in x_axis.ticks() {
            if let Some((px, _)) = rect.pixel_of(&x_axis, &y_axis, (t, y_axis.lo)) {
                line(&mut img, (px, rect.top), (px, rect.bottom), GRID);
                let label = tick_label(t);
                let w = font::text_width(&label, TEXT) as i64;
                text(&mut img, px - w / 2, rect.bottom + 6, TEXT, BLACK, &label);
            }
        }
        line(
            &mut img,
            (rect.left, rect.bottom),
            (rect.right, rect.bottom),
            BLACK,
        );
        line(
            &mut img,
            (rect.left, rect.top),
            (rect.left, rect.bottom),
            BLACK,
        );
        text(&mut img, rect.left, cy + 10, TEXT, BLACK, &panel.title);
        let y_title_w = font::text_width(&chart.y_label, TEXT) as i64;
        text(
            &mut img,
            (rect.left - y_title_w - 6).max(cx + 4),
            cy + 10,
            TEXT,
            Rgb([90, 90, 90]),
            &chart.y_label,
        );
        let x_title_w = font::text_width(&chart.x_label, TEXT) as i64;
        text(
            &mut img,
            (rect.left + rect.right) / 2 - x_title_w / 2,
            rect.bottom + 12 + glyph_h,
            TEXT,
            Rgb([90, 90, 90]),
            &chart.x_label,
        );
        for series in &panel.series {
            let colour = Rgb(series.colour);
            let placed: Vec<((i64, i64), &str)> = series
                .points
                .iter()
                .filter_map(|p| {
                    rect.pixel_of(&x_axis, &y_axis, (p.x, p.y))
                        .map(|px| (px, p.label.as_str()))
                })
                .collect();
            for pair in placed.windows(2) {
                line(&mut img, pair[0].0, pair[1].0, colour);
                // Two pixels thick, so lines stay visible when scaled down.
                line(
                    &mut img,
                    (pair[0].0 .0, pair[0].0 .1 + 1),
                    (pair[1].0 .0, pair[1].0 .1 + 1),
                    colour,
                );
            }
            for ((x, y), label) in &placed {
                marker(&mut img, (*x, *y), colour);
                text(&mut img, x + 6, y - 12, 1, colour, label);
            }
        }
    }

    // Legend in the next free cell: one swatch and name per series.
    let i = chart.panels.len();
    let (cx, cy) = (
        (i % columns) as i64 * PANEL_W as i64,
        TITLE_H as i64 + (i / columns) as i64 * PANEL_H as i64,
    );
    let mut names: Vec<(&str, [u8; 3])> = Vec::new();
    for s in chart.panels.iter().flat_map(|p| &p.series) {
        if !names.iter().any(|(n, _)| *n == s.name) {
            names.push((&s.name, s.colour));
        }
    }
    for (k, (name, colour)) in names.iter().enumerate() {
        let y = cy + MARGIN_T + k as i64 * (glyph_h + 12);
        for dy in 0..glyph_h {
            line(
                &mut img,
                (cx + MARGIN_L, y + dy),
                (cx + MARGIN_L + 24, y + dy),
                Rgb(*colour),
            );
        }
        text(&mut img, cx + MARGIN_L + 34, y, TEXT, BLACK, name);
    }
    img
}

/// Draws `chart` into a PNG at `path` (atomically).
pub fn write_png(chart: &Chart, path: &Path) -> Result<()> {
    let img = render(chart);
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, ImageFormat::Png)
        .with_context(|| format!("encoding {}", path.display()))?;
    matscan_scan::atomic::write_atomic(path, bytes.get_ref())
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_spans_whole_decades_and_places_values_by_their_logarithm() {
        let axis = Axis::fit([0.3, 45.0, f64::NAN, -1.0], true);
        assert_eq!((axis.lo, axis.hi), (0.1, 100.0));
        assert!((axis.fraction(1.0).unwrap() - 1.0 / 3.0).abs() < 1e-12);
        assert!((axis.fraction(10.0).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        assert!((axis.fraction(0.1).unwrap()).abs() < 1e-12);
        assert_eq!(axis.fraction(0.0), None);
        assert_eq!(axis.fraction(f64::INFINITY), None);
        let ticks = axis.ticks();
        assert_eq!(ticks.first(), Some(&0.1));
        assert_eq!(ticks.last(), Some(&100.0));
        // Three decades: decades only.
        assert_eq!(ticks.len(), 4);
    }

    #[test]
    fn linear_axis_starts_at_zero_and_ends_on_a_round_number() {
        let axis = Axis::fit([0.12, 0.34], false);
        assert_eq!(axis.lo, 0.0);
        assert!((axis.hi - 0.4).abs() < 1e-12, "{}", axis.hi);
        assert!((axis.fraction(0.1).unwrap() - 0.25).abs() < 1e-12);
        let ticks = axis.ticks();
        assert_eq!(ticks.len(), 5);
        assert!((ticks[1] - 0.1).abs() < 1e-12 && (ticks[4] - 0.4).abs() < 1e-12);
        assert_eq!(Axis::fit([], false).hi, 1.0);
        assert_eq!(
            Axis::fit([f64::NAN], true),
            Axis {
                lo: 0.1,
                hi: 10.0,
                log: true
            }
        );
    }

    #[test]
    fn plot_rect_maps_the_axis_corners_to_its_pixel_corners_with_y_up() {
        let rect = PlotRect {
            left: 100,
            top: 20,
            right: 400,
            bottom: 220,
        };
        let x = Axis {
            lo: 1.0,
            hi: 1000.0,
            log: true,
        };
        let y = Axis {
            lo: 0.0,
            hi: 0.5,
            log: false,
        };
        assert_eq!(rect.pixel_of(&x, &y, (1.0, 0.0)), Some((100, 220)));
        assert_eq!(rect.pixel_of(&x, &y, (1000.0, 0.5)), Some((400, 20)));
        // 10 s is a third of the way along three decades; 0.25 halfway up.
        assert_eq!(rect.pixel_of(&x, &y, (10.0, 0.25)), Some((200, 120)));
        assert_eq!(rect.pixel_of(&x, &y, (-1.0, 0.25)), None);
    }

    #[test]
    fn tick_labels_use_only_the_decimals_they_need() {
        assert_eq!(tick_label(100.0), "100");
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(0.05), "0.05");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
    }

    #[test]
    fn render_draws_series_in_their_colour_inside_the_panel() {
        let chart = Chart {
            title: "t".into(),
            x_label: "seconds".into(),
            y_label: "MAD".into(),
            x_log: true,
            panels: vec![Panel {
                title: "roughness".into(),
                series: vec![Series {
                    name: "views".into(),
                    colour: [200, 0, 0],
                    points: vec![
                        Point {
                            x: 1.0,
                            y: 0.1,
                            label: "1".into(),
                        },
                        Point {
                            x: 9.0,
                            y: 0.2,
                            label: "9".into(),
                        },
                    ],
                }],
            }],
            columns: 2,
        };
        let img = render(&chart);
        assert_eq!(
            (img.width(), img.height()),
            (2 * PANEL_W, TITLE_H + PANEL_H)
        );
        let red = |x: u32, y: u32| *img.get_pixel(x, y) == Rgb([200, 0, 0]);
        // Both markers lie where the axis mapping puts them.
        let rect = PlotRect {
            left: MARGIN_L,
            top: TITLE_H as i64 + MARGIN_T,
            right: PANEL_W as i64 - MARGIN_R,
            bottom: TITLE_H as i64 + PANEL_H as i64 - MARGIN_B,
        };
        let x = Axis::fit([1.0, 9.0], true);
        let y = Axis::fit([0.1, 0.2], false);
        let (px, py) = rect.pixel_of(&x, &y, (1.0, 0.1)).unwrap();
        assert!(red(px as u32, py as u32));
        let (qx, qy) = rect.pixel_of(&x, &y, (9.0, 0.2)).unwrap();
        assert!(red(qx as u32, qy as u32));
        // Nothing red far from the line, e.g. the panel's top-right corner.
        assert!(!red((rect.right - 2) as u32, (rect.top + 2) as u32));
    }
}
