//! The training loss plot (`matscan train`'s `loss.png`): training loss in
//! blue and test loss in red against the step, on a log10 loss axis
//! (losses fall over decades), drawn as a [`Chart`] like every other chart.
//! The numbers are the trainer's `loss.csv`; the plot is redrawn from it
//! whole, so a resumed run shows its whole history.

use super::chart::{self, Chart, Panel, Point, Series};
use anyhow::Result;
use std::path::Path;

/// One logged interval of the history.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LossPoint {
    pub step: usize,
    pub train: f64,
    pub test: Option<f64>,
}

pub const TRAIN_COLOUR: [u8; 3] = [40, 90, 220];
pub const TEST_COLOUR: [u8; 3] = [220, 40, 40];

/// The chart of `history` for the network `network`.
pub fn loss_chart(network: &str, history: &[LossPoint]) -> Chart {
    let series = |name: &str, colour, value: &dyn Fn(&LossPoint) -> Option<f64>| Series {
        name: name.to_string(),
        colour,
        points: history
            .iter()
            .filter_map(|p| {
                value(p).map(|y| Point {
                    x: p.step as f64,
                    y,
                    label: String::new(),
                })
            })
            .collect(),
    };
    Chart {
        title: format!("{network} network: training history"),
        x_label: "step".to_string(),
        y_label: "loss (log)".to_string(),
        x_log: false,
        y_log: true,
        panels: vec![Panel {
            title: network.to_string(),
            series: vec![
                series("training loss", TRAIN_COLOUR, &|p| Some(p.train)),
                series("test loss", TEST_COLOUR, &|p| p.test),
            ],
        }],
        columns: 2,
    }
}

/// Draws [`loss_chart`] into a PNG at `path` (atomically).
pub fn write_loss_png(network: &str, history: &[LossPoint], path: &Path) -> Result<()> {
    chart::write_png(&loss_chart(network, history), path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_history_becomes_a_log_loss_chart_with_test_points_where_measured() {
        let history = [
            LossPoint {
                step: 10,
                train: 0.5,
                test: None,
            },
            LossPoint {
                step: 20,
                train: 0.05,
                test: Some(0.08),
            },
        ];
        let c = loss_chart("roughness", &history);
        assert!(c.y_log && !c.x_log);
        let [train, test] = &c.panels[0].series[..] else {
            panic!("two series expected");
        };
        assert_eq!(train.points.len(), 2);
        assert_eq!((train.points[1].x, train.points[1].y), (20.0, 0.05));
        assert_eq!(test.points.len(), 1);
        assert_eq!(test.colour, TEST_COLOUR);
        let img = chart::render(&c).expect("drawn");
        let blue = img.pixels().filter(|p| p.0 == TRAIN_COLOUR).count();
        assert!(blue > 50, "{blue} blue pixels");
    }
}
