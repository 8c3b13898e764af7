//! Pixel and line primitives for the plots drawn straight into an image:
//! the trainer's loss plot and the evaluation's charts share them, so both
//! clip and rasterize alike.

use image::{Rgb, RgbImage};

/// Sets pixel (`x`, `y`) when it lies inside the image (the clipping every
/// primitive shares).
pub fn put(img: &mut RgbImage, (x, y): (i64, i64), colour: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, colour);
    }
}

/// Draws a one-pixel line from (`x0`, `y0`) to (`x1`, `y1`) (Bresenham),
/// clipped to the image.
pub fn line(img: &mut RgbImage, (x0, y0): (i64, i64), (x1, y1): (i64, i64), colour: Rgb<u8>) {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let (mut x, mut y, mut err) = (x0, y0, dx + dy);
    loop {
        put(img, (x, y), colour);
        if x == x1 && y == y1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}
