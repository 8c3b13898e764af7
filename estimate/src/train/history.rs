//! The loss history: `loss.csv`, one row per logging interval, appended,
//! and cut back to the restored step when a run resumes from a checkpoint.
//!
//! Out of scope: computing the losses (see `loss`) and drawing them: the
//! `matscan train` command redraws `loss.png` from this file after every
//! row (`matscan_evaluate::plot::loss`), so the library links no plotting.

use super::checkpoint::write_atomic;
use super::error::TrainError;
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
