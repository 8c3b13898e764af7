//! Charts drawn into an `image` buffer: the error-against-time panels of
//! `matscan bench`, with a small bitmap font for their labels.

pub mod chart;
pub mod font;
