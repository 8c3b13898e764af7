//! What the development probes under `examples/` share.

/// The median of `v` (the upper one of an even count); NaN when empty.
pub fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return f32::NAN;
    }
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}
