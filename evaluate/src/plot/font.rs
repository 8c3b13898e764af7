//! The one typeface of matscan's images (bench charts, loss plots, contact
//! sheets): DejaVu Sans, embedded, so a scanner PC without fonts draws the
//! same labels. `assets/DejaVuSans-subset.ttf` holds the printable ASCII
//! range and a few symbols (degree, plus-minus, micro, times, dashes,
//! minus, less- and greater-or-equal), cut from DejaVu Sans 2.37 with
//! fonttools' `pyftsubset` (26 KB instead of 760 KB); its licence is
//! `assets/DejaVuSans-LICENSE.txt`. Characters outside the subset draw as
//! the font's missing-glyph box.
//!
//! Charts draw it through `plotters` (which rasterizes with `ab_glyph`;
//! [`register`] hands it the font); [`draw_text`] rasterizes with
//! `ab_glyph` directly into the contact sheet's float buffer, which is no
//! plotters backend.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans-subset.ttf");

/// The family name charts ask plotters for.
pub const FAMILY: &str = "sans-serif";

fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| {
        // The file is part of the binary; the tests below parse it.
        FontRef::try_from_slice(FONT_BYTES).expect("the embedded font is valid TrueType")
    })
}

/// Makes the font plotters' [`FAMILY`] (once per process).
pub fn register() {
    static REGISTERED: OnceLock<()> = OnceLock::new();
    REGISTERED.get_or_init(|| {
        // Only fails on bytes that are no font, which the tests rule out.
        let _ =
            plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, FONT_BYTES);
    });
}

/// Height of one line of text at `px` pixels (ascent plus descent).
pub fn line_height(px: f32) -> u32 {
    let scaled = font().as_scaled(PxScale::from(px));
    (scaled.ascent() - scaled.descent()).ceil() as u32
}

/// Each glyph of `text` at `px` pixels with its pen position from the
/// start of the line (kerning included), and the line's full advance.
fn layout(text: &str, px: f32) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
    let scaled = font().as_scaled(PxScale::from(px));
    let mut caret = 0.0f32;
    let mut previous = None;
    let glyphs = text
        .chars()
        .map(|c| {
            let id = scaled.glyph_id(c);
            if let Some(p) = previous {
                caret += scaled.kern(p, id);
            }
            let at = caret;
            caret += scaled.h_advance(id);
            previous = Some(id);
            (id, at)
        })
        .collect();
    (glyphs, caret)
}

/// Width in pixels of `text` at `px` pixels, kerning included.
pub fn text_width(text: &str, px: f32) -> u32 {
    layout(text, px).1.ceil() as u32
}

/// Draws `text` at `px` pixels with the top of its line at (`x`, `y`) into
/// an RGB float buffer of `width` x `height`, blending `color` by the
/// glyphs' coverage and clipping at the edges.
#[allow(clippy::too_many_arguments)]
pub fn draw_text(
    buf: &mut [f32],
    width: u32,
    height: u32,
    x: u32,
    y: u32,
    px: f32,
    color: [f32; 3],
    text: &str,
) {
    let font = font();
    let scale = PxScale::from(px);
    let baseline = y as f32 + font.as_scaled(scale).ascent();
    for (id, at) in layout(text, px).0 {
        let glyph = id.with_scale_and_position(scale, point(x as f32 + at, baseline));
        let Some(outline) = font.outline_glyph(glyph) else {
            continue;
        };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (
                bounds.min.x as i64 + i64::from(gx),
                bounds.min.y as i64 + i64::from(gy),
            );
            if px < 0 || py < 0 || px >= i64::from(width) || py >= i64::from(height) {
                return;
            }
            let i = (py as usize * width as usize + px as usize) * 3;
            let a = coverage.clamp(0.0, 1.0);
            for (channel, c) in buf[i..i + 3].iter_mut().zip(color) {
                *channel = *channel * (1.0 - a) + c * a;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_parses_and_has_the_ascii_glyphs() {
        let font = FontRef::try_from_slice(FONT_BYTES).expect("valid font");
        for c in ' '..='~' {
            assert_ne!(font.glyph_id(c).0, 0, "no glyph for {c:?}");
        }
        assert!(plotters::style::register_font(
            FAMILY,
            plotters::style::FontStyle::Normal,
            FONT_BYTES
        )
        .is_ok());
    }

    #[test]
    fn text_is_drawn_inside_its_line_and_grows_with_its_length() {
        let (w, h) = (80, 24);
        let mut buf = vec![0f32; (w * h * 3) as usize];
        draw_text(&mut buf, w, h, 2, 2, 14.0, [1.0, 0.0, 0.0], "Ag");
        let red = |x: u32, y: u32| buf[((y * w + x) * 3) as usize] > 0.5;
        let lit: Vec<(u32, u32)> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| red(x, y))
            .collect();
        assert!(!lit.is_empty());
        let line = line_height(14.0);
        assert!(lit.iter().all(|&(x, y)| y >= 2 && y < 2 + line && x >= 2));
        let right = lit.iter().map(|p| p.0).max().unwrap_or(0);
        assert!(right <= 2 + text_width("Ag", 14.0), "{right}");
        assert!(text_width("Ag Ag", 14.0) > text_width("Ag", 14.0) + 10);
        // Nothing but red drawn: green and blue untouched.
        assert!(buf.chunks(3).all(|c| c[1] == 0.0 && c[2] == 0.0));
    }

    #[test]
    fn text_running_past_the_edge_is_clipped() {
        let (w, h) = (8u32, 20u32);
        let mut buf = vec![0f32; (w * h * 3) as usize];
        draw_text(&mut buf, w, h, 3, 2, 14.0, [0.5, 0.5, 0.5], "WWW");
        assert!(buf.iter().any(|&v| v > 0.0));
        // The last column is reached: the text runs on past it.
        assert!((0..h).any(|y| buf[((y * w + w - 1) * 3) as usize] > 0.0));
    }
}
