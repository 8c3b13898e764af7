//! Hole filling by push-pull (Gortler et al. 1996): a pyramid of weighted
//! 2x2 means down to one texel, then each level's holes filled from the
//! bilinearly upsampled coarser level on the way up.
//!
//! Only texels of weight 0 change; every filled value is a convex
//! combination of measured ones, so it stays within their range. Filling
//! runs over the whole texture, in UV space: a hole takes the values of
//! nearby texels in the image, which may belong to another chart. Outside
//! every chart that is what mip-mapping needs (no black pulled in); inside
//! a chart it is a plausible guess, and the coverage map says it is one.

/// Fills the texels of `values` (`channels` interleaved per texel,
/// `width` x `height`) whose `weights` are not positive. With no positive
/// weight anywhere, every texel becomes `fallback`.
pub fn push_pull(
    values: &mut [f32],
    weights: &[f32],
    width: usize,
    height: usize,
    channels: usize,
    fallback: &[f32],
) {
    let known: Vec<f32> = weights
        .iter()
        .map(|&w| if w > 0.0 && w.is_finite() { 1.0 } else { 0.0 })
        .collect();
    if !known.iter().any(|&w| w > 0.0) {
        for texel in values.chunks_mut(channels) {
            for (v, f) in texel.iter_mut().zip(fallback.iter().cycle()) {
                *v = *f;
            }
        }
        return;
    }
    fill(values, &known, width, height, channels);
}

/// One level: fills `values` where `weights` (in `[0, 1]`) fall short of
/// 1, from the next coarser level.
fn fill(values: &mut [f32], weights: &[f32], w: usize, h: usize, c: usize) {
    if weights.iter().all(|&wt| wt >= 1.0) || (w == 1 && h == 1) {
        return;
    }
    let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
    let mut coarse = vec![0.0f32; cw * ch * c];
    let mut coarse_w = vec![0.0f32; cw * ch];
    for y in 0..ch {
        for x in 0..cw {
            let i = y * cw + x;
            let mut wsum = 0.0;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (fx, fy) = (2 * x + dx, 2 * y + dy);
                if fx >= w || fy >= h {
                    continue;
                }
                let j = fy * w + fx;
                let wt = weights[j];
                if wt <= 0.0 {
                    continue;
                }
                wsum += wt;
                for k in 0..c {
                    coarse[i * c + k] += wt * values[j * c + k];
                }
            }
            if wsum > 0.0 {
                for k in 0..c {
                    coarse[i * c + k] /= wsum;
                }
            }
            coarse_w[i] = wsum.min(1.0);
        }
    }
    fill(&mut coarse, &coarse_w, cw, ch, c);
    let mut up = [0.0f32; 4];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let wt = weights[i];
            if wt >= 1.0 {
                continue;
            }
            // Fine texel centre in coarse texel coordinates.
            let (sx, sy) = ((x as f32 + 0.5) / 2.0 - 0.5, (y as f32 + 0.5) / 2.0 - 0.5);
            let (x0, y0) = (sx.floor(), sy.floor());
            let (tx, ty) = (sx - x0, sy - y0);
            let cx = |v: f32| v.clamp(0.0, cw as f32 - 1.0) as usize;
            let cy = |v: f32| v.clamp(0.0, ch as f32 - 1.0) as usize;
            let (xa, xb, ya, yb) = (cx(x0), cx(x0 + 1.0), cy(y0), cy(y0 + 1.0));
            for k in 0..c.min(4) {
                let at = |xx: usize, yy: usize| coarse[(yy * cw + xx) * c + k];
                let top = at(xa, ya) * (1.0 - tx) + at(xb, ya) * tx;
                let bottom = at(xa, yb) * (1.0 - tx) + at(xb, yb) * tx;
                up[k] = top * (1.0 - ty) + bottom * ty;
            }
            for k in 0..c.min(4) {
                values[i * c + k] = wt * values[i * c + k] + (1.0 - wt) * up[k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_measured_texel_fills_everything_with_its_value() {
        let (w, h) = (7, 5);
        let mut values = vec![0.0; w * h];
        let mut weights = vec![0.0; w * h];
        values[2 * w + 3] = 0.6;
        weights[2 * w + 3] = 1.0;
        push_pull(&mut values, &weights, w, h, 1, &[0.0]);
        assert!(values.iter().all(|&v| (v - 0.6).abs() < 1e-6), "{values:?}");
    }

    #[test]
    fn nothing_measured_gives_the_fallback() {
        let mut values = vec![0.3; 3 * 4];
        push_pull(&mut values, &[0.0; 4], 2, 2, 3, &[0.1, 0.2, 0.3]);
        assert_eq!(&values[9..12], &[0.1, 0.2, 0.3]);
    }
}
