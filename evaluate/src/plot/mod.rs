//! Charts as PNG: the error-against-time panels of `matscan bench` and the
//! loss history of `matscan train`, drawn with `plotters` in one embedded
//! typeface.

pub mod chart;
pub mod font;
pub mod loss;
