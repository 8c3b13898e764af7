//! (in progress)
pub struct Bundle;
pub enum TruthMap {}
