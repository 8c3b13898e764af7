//! The loss history: `loss.csv` (one row per logging interval, appended)
//! and `loss.png`, a line plot drawn with the `image` crate alone.
//!
//! The plot has a log10 loss axis (losses fall over decades), the training
//! loss in blue and the test loss in red, faint horizontal lines at every
//! decade and no text (no font is linked into the library; the CSV carries
//! the numbers). It is redrawn from the CSV, so a resumed run plots its
//! whole history.
//!
//! Out of scope: computing the losses (see `loss`).

use super::checkpoint::write_atomic;
use super::error::TrainError;
use image::{ImageFormat, Rgb, RgbImage};
use matscan_scan::draw::line;
use std::io::Write;
use std::path::Path;

/// Header of `loss.csv`.
pub const CSV_HEADER: &str = "step,phase,views,train_loss,test_loss,seconds";

/// One logged interval.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Steps done.
    pub step: usize,
    /// Schedule phase of the last step.
    pub phase: String,
    /// Views of the last step.
    pub views: usize,
    /// Mean training loss over the interval.
    pub train: f64,
    /// Test loss, when evaluated.
    pub test: Option<f64>,
    /// Training seconds so far.
    pub seconds: f64,
}

impl Row {
    fn line(&self) -> String {
        let test = self.test.map(|t| format!("{t:.6}")).unwrap_or_default();
        format!(
            "{},{},{},{:.6},{},{:.1}",
            self.step, self.phase, self.views, self.train, test, self.seconds
        )
    }

    fn parse(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            return None;
        }
        Some(Row {
            step: f[0].parse().ok()?,
            phase: f[1].to_string(),
            views: f[2].parse().ok()?,
            train: f[3].parse().ok()?,
            test: f[4].parse().ok(),
            seconds: f[5].parse().ok()?,
        })
    }
}

/// Reads `loss.csv`; a missing file is an empty history, unreadable rows
/// are skipped.
pub fn read_rows(path: &Path) -> Result<Vec<Row>, TrainError> {
    match std::fs::read_to_string(path) {
        Ok(text) => Ok(text.lines().skip(1).filter_map(Row::parse).collect()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
        Err(source) => Err(TrainError::Io {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// Keeps only rows up to `step` (after resuming from a checkpoint, rows a
/// killed run logged past it are dropped).
pub fn truncate(path: &Path, step: usize) -> Result<(), TrainError> {
    let rows: Vec<Row> = read_rows(path)?
        .into_iter()
        .filter(|r| r.step <= step)
        .collect();
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    for r in &rows {
        text.push_str(&r.line());
        text.push('\n');
    }
    write_atomic(path, text.as_bytes())
}

/// Appends one row, writing the header first into a new file.
pub fn append(path: &Path, row: &Row) -> Result<(), TrainError> {
    let io = |source| TrainError::Io {
        path: path.to_path_buf(),
        source,
    };
    let new = !path.exists();
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(io)?;
    if new {
        writeln!(file, "{CSV_HEADER}").map_err(io)?;
    }
    writeln!(file, "{}", row.line()).map_err(io)
}

const W: u32 = 800;
const H: u32 = 450;
const MARGIN: i64 = 20;

/// Draws `rows` into a PNG at `path` (atomically).
pub fn draw(rows: &[Row], path: &Path) -> Result<(), TrainError> {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let values = rows
        .iter()
        .flat_map(|r| std::iter::once(r.train).chain(r.test))
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v.log10()), hi.max(v.log10()))
    });
    let max_step = rows.iter().map(|r| r.step).max().unwrap_or(1).max(1) as f64;
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo.floor(), hi.ceil())
    } else {
        (-3.0, 0.0)
    };
    let (pw, ph) = (
        (W as i64 - 2 * MARGIN) as f64,
        (H as i64 - 2 * MARGIN) as f64,
    );
    let to_xy = |step: usize, v: f64| -> (i64, i64) {
        let x = MARGIN + (step as f64 / max_step * pw).round() as i64;
        let y = MARGIN + ((hi - v.max(1e-12).log10()) / (hi - lo) * ph).round() as i64;
        (x, y)
    };
    // Decade lines and axes.
    let mut decade = lo;
    while decade <= hi {
        let y = MARGIN + ((hi - decade) / (hi - lo) * ph).round() as i64;
        line(
            &mut img,
            (MARGIN, y),
            (W as i64 - MARGIN, y),
            Rgb([225, 225, 225]),
        );
        decade += 1.0;
    }
    let (x_axis, y_axis) = (H as i64 - MARGIN, MARGIN);
    line(
        &mut img,
        (MARGIN, x_axis),
        (W as i64 - MARGIN, x_axis),
        Rgb([0, 0, 0]),
    );
    line(&mut img, (y_axis, MARGIN), (y_axis, x_axis), Rgb([0, 0, 0]));
    let mut draw_series = |points: Vec<(i64, i64)>, colour: Rgb<u8>| {
        for pair in points.windows(2) {
            line(&mut img, pair[0], pair[1], colour);
        }
    };
    draw_series(
        rows.iter()
            .filter(|r| r.train.is_finite() && r.train > 0.0)
            .map(|r| to_xy(r.step, r.train))
            .collect(),
        Rgb([40, 90, 220]),
    );
    draw_series(
        rows.iter()
            .filter_map(|r| {
                r.test
                    .filter(|t| t.is_finite() && *t > 0.0)
                    .map(|t| (r.step, t))
            })
            .map(|(s, t)| to_xy(s, t))
            .collect(),
        Rgb([220, 40, 40]),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, ImageFormat::Png)
        .map_err(|e| TrainError::Plot(e.to_string()))?;
    write_atomic(path, bytes.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_through_csv_lines() {
        let row = Row {
            step: 40,
            phase: "pair".into(),
            views: 2,
            train: 0.125,
            test: Some(0.25),
            seconds: 3.5,
        };
        assert_eq!(Row::parse(&row.line()), Some(row.clone()));
        let no_test = Row { test: None, ..row };
        assert_eq!(Row::parse(&no_test.line()), Some(no_test));
    }
}
