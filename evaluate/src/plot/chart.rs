//! Labelled line charts as PNG: a grid of panels sharing one x axis (linear
//! or log10), each with its own y axis (linear from zero, or log10), one
//! coloured line per series with a labelled marker per point, tick labels,
//! axis titles and a legend. Used by `matscan bench` (error against run
//! time) and `matscan train` (the loss history).
//!
//! [`Axis`] chooses each axis's range and ticks (whole decades on log axes,
//! round steps from zero on linear ones), so every chart of a kind reads
//! alike; `plotters` draws (its bitmap backend, text in the embedded
//! typeface of [`super::font`]), `image` encodes. A log axis is drawn as a
//! linear axis over log10 of the values, labelled with the values.
//!
//! Crate choice: `plotters` is the well-kept Rust plotting crate; with
//! only its bitmap backend, line and point series and `ab_glyph` text it
//! adds no system library.
//!
//! Boundaries: geometry and pixels only; what the numbers mean is the
//! caller's.

use super::font;
use anyhow::{anyhow, Context, Result};
use image::{ImageFormat, RgbImage};
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::prelude::*;
use std::ops::Range;
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

    /// Where `v` lies on the drawn (linear) axis: `log10(v)` on a log axis;
    /// `None` for values the axis cannot place (non-finite, or not
    /// positive on a log axis).
    pub fn drawn(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        Some(if self.log { v.log10() } else { v })
    }

    /// The value at drawn position `d` (the inverse of [`Axis::drawn`]).
    fn value(&self, d: f64) -> f64 {
        if self.log {
            10f64.powf(d)
        } else {
            d
        }
    }

    /// The drawn range and its ticks, for plotters.
    fn drawn_range(&self) -> DrawnAxis {
        let lo = self.drawn(self.lo).unwrap_or(0.0);
        let hi = self.drawn(self.hi).filter(|h| *h > lo).unwrap_or(lo + 1.0);
        DrawnAxis {
            axis: *self,
            range: lo..hi,
            ticks: self.ticks().iter().filter_map(|&t| self.drawn(t)).collect(),
        }
    }
}

/// An [`Axis`] as plotters sees it: linear over the drawn values, with
/// exactly the axis's ticks (as the mesh's bold lines and labels; no light
/// lines), labelled with the values.
#[derive(Clone, Debug)]
struct DrawnAxis {
    axis: Axis,
    range: Range<f64>,
    ticks: Vec<f64>,
}

impl Ranged for DrawnAxis {
    type ValueType = f64;
    type FormatOption = NoDefaultFormatting;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = (value - self.range.start) / (self.range.end - self.range.start);
        limit.0 + (f * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.range.clone()
    }
}

impl ValueFormatter<f64> for DrawnAxis {
    fn format_ext(&self, value: &f64) -> String {
        tick_label(self.axis.value(*value))
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
    pub y_log: bool,
    pub panels: Vec<Panel>,
    /// Panels per row (the legend takes the next free cell).
    pub columns: usize,
}

pub const PANEL_W: u32 = 480;
pub const PANEL_H: u32 = 340;
pub const TITLE_H: u32 = 40;
/// Text sizes, pixels: chart title, panel titles and axis titles, ticks,
/// point labels.
const TITLE_PX: f64 = 22.0;
const HEADING_PX: f64 = 17.0;
const TICK_PX: f64 = 14.0;
const LABEL_PX: f64 = 11.0;
const GRID: RGBColor = RGBColor(228, 228, 228);
const AXIS_TITLE: RGBColor = RGBColor(90, 90, 90);

fn drawing(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing the chart: {e}")
}

/// Draws `chart`.
pub fn render(chart: &Chart) -> Result<RgbImage> {
    font::register();
    let columns = chart.columns.max(1);
    let cells = chart.panels.len() + 1;
    let rows = cells.div_ceil(columns);
    let (width, height) = (columns as u32 * PANEL_W, TITLE_H + rows as u32 * PANEL_H);
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    let x_axis = Axis::fit(
        chart
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| &s.points)
            .map(|p| p.x),
        chart.x_log,
    );
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        let (title, body) = root.split_vertically(TITLE_H);
        title
            .draw(&Text::new(
                chart.title.clone(),
                (12, 10),
                (font::FAMILY, TITLE_PX).into_font(),
            ))
            .map_err(drawing)?;
        let areas = body.split_evenly((rows, columns));
        for (panel, area) in chart.panels.iter().zip(&areas) {
            draw_panel(chart, panel, area, &x_axis)?;
        }
        if let Some(area) = areas.get(chart.panels.len()) {
            draw_legend(chart, area)?;
        }
        root.present().map_err(drawing)?;
    }
    RgbImage::from_raw(width, height, buf).context("chart buffer size")
}

fn draw_panel(
    chart: &Chart,
    panel: &Panel,
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    x_axis: &Axis,
) -> Result<()> {
    let y_axis = Axis::fit(
        panel.series.iter().flat_map(|s| &s.points).map(|p| p.y),
        chart.y_log,
    );
    let mut plot = ChartBuilder::on(area)
        .caption(&panel.title, (font::FAMILY, HEADING_PX))
        .margin(10)
        .x_label_area_size(46)
        .y_label_area_size(64)
        .build_cartesian_2d(x_axis.drawn_range(), y_axis.drawn_range())
        .map_err(drawing)?;
    plot.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .label_style((font::FAMILY, TICK_PX))
        .axis_desc_style((font::FAMILY, HEADING_PX).into_font().color(&AXIS_TITLE))
        .draw()
        .map_err(drawing)?;
    for series in &panel.series {
        let [r, g, b] = series.colour;
        let colour = RGBColor(r, g, b);
        let placed: Vec<(f64, f64, &str)> = series
            .points
            .iter()
            .filter_map(|p| Some((x_axis.drawn(p.x)?, y_axis.drawn(p.y)?, p.label.as_str())))
            .collect();
        plot.draw_series(LineSeries::new(
            placed.iter().map(|&(x, y, _)| (x, y)),
            colour.stroke_width(2),
        ))
        .map_err(drawing)?;
        let label_font = (font::FAMILY, LABEL_PX).into_font().color(&colour);
        plot.draw_series(placed.iter().map(|&(x, y, label)| {
            EmptyElement::at((x, y))
                + Rectangle::new([(-3, -3), (3, 3)], colour.filled())
                + Text::new(label.to_string(), (6, -14), label_font.clone())
        }))
        .map_err(drawing)?;
    }
    Ok(())
}

/// One swatch and name per series, in the cell after the last panel.
fn draw_legend(
    chart: &Chart,
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
) -> Result<()> {
    let mut names: Vec<(&str, [u8; 3])> = Vec::new();
    for s in chart.panels.iter().flat_map(|p| &p.series) {
        if !names.iter().any(|(n, _)| *n == s.name) {
            names.push((&s.name, s.colour));
        }
    }
    let row = font::line_height(TICK_PX as f32) as i32 + 12;
    for (k, (name, [r, g, b])) in names.iter().enumerate() {
        let y = 44 + k as i32 * row;
        area.draw(&Rectangle::new(
            [(84, y), (108, y + row - 12)],
            RGBColor(*r, *g, *b).filled(),
        ))
        .map_err(drawing)?;
        area.draw(&Text::new(
            name.to_string(),
            (118, y),
            (font::FAMILY, TICK_PX).into_font(),
        ))
        .map_err(drawing)?;
    }
    Ok(())
}

/// Draws `chart` into a PNG at `path` (atomically).
pub fn write_png(chart: &Chart, path: &Path) -> Result<()> {
    let img = render(chart).with_context(|| format!("drawing {}", path.display()))?;
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
        assert!((axis.drawn(10.0).unwrap() - 1.0).abs() < 1e-12);
        assert!((axis.value(axis.drawn(0.3).unwrap()) - 0.3).abs() < 1e-12);
        assert_eq!(axis.drawn(0.0), None);
        assert_eq!(axis.drawn(f64::INFINITY), None);
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
        assert_eq!(axis.drawn(0.1), Some(0.1));
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
    fn tick_labels_use_only_the_decimals_they_need() {
        assert_eq!(tick_label(100.0), "100");
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(0.05), "0.05");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
    }

    #[test]
    fn render_draws_series_in_their_colour_rising_inside_the_panel() {
        let chart = Chart {
            title: "t".into(),
            x_label: "seconds".into(),
            y_label: "MAD".into(),
            x_log: true,
            y_log: false,
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
        let img = render(&chart).expect("drawn");
        assert_eq!(
            (img.width(), img.height()),
            (2 * PANEL_W, TITLE_H + PANEL_H)
        );
        let red: Vec<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0 == [200, 0, 0])
            .map(|(x, y, _)| (x, y))
            .collect();
        let in_panel: Vec<_> = red.iter().filter(|p| p.0 < PANEL_W).collect();
        let in_legend = red.len() - in_panel.len();
        assert!(
            in_panel.len() > 50,
            "{} red pixels in the panel",
            in_panel.len()
        );
        assert!(in_legend > 50, "{in_legend} red pixels in the legend");
        assert!(in_panel
            .iter()
            .all(|p| p.1 > TITLE_H && p.1 < TITLE_H + PANEL_H));
        // The line rises: its leftmost pixels lie lower than its rightmost.
        let left = in_panel.iter().min_by_key(|p| p.0).expect("red");
        let right = in_panel.iter().max_by_key(|p| p.0).expect("red");
        assert!(right.0 > left.0 + 100, "{left:?} {right:?}");
        assert!(left.1 > right.1 + 40, "{left:?} {right:?}");
        // Nothing red in the panel's top-right corner.
        assert!(!in_panel
            .iter()
            .any(|p| p.0 > PANEL_W - 20 && p.1 < TITLE_H + 30));
    }

    #[test]
    fn a_log_y_axis_with_nothing_positive_still_draws() {
        let chart = Chart {
            title: "loss".into(),
            x_label: "step".into(),
            y_label: "loss".into(),
            x_log: false,
            y_log: true,
            panels: vec![Panel {
                title: "basecolor".into(),
                series: vec![Series {
                    name: "train".into(),
                    colour: [40, 90, 220],
                    points: vec![Point {
                        x: 0.0,
                        y: 0.0,
                        label: String::new(),
                    }],
                }],
            }],
            columns: 2,
        };
        assert!(render(&chart).is_ok());
    }
}
