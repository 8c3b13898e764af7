//! Camera pixel formats to linear RGB: YUYV (4:2:2, BT.601 limited range,
//! what UVC webcams send), MJPG (decoded with `zune-jpeg`), GREY and RGB24,
//! each linearised through the camera's [`Response`] curve.
//!
//! Boundaries: one frame's bytes in, a raster out; no device access.

use super::response::Response;
use crate::error::DriverError;
use matscan_scan::raster::RgbRaster;

/// The pixel formats matscan decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelFormat {
    Yuyv,
    Mjpg,
    Grey,
    Rgb24,
}

/// Format names for messages.
pub const SUPPORTED: &str = "YUYV, MJPG, GREY, RGB3";

impl PixelFormat {
    /// The format of a V4L2 fourcc (`RGB3` is V4L2's RGB24).
    pub fn from_fourcc(fourcc: &[u8; 4]) -> Option<PixelFormat> {
        match fourcc {
            b"YUYV" => Some(PixelFormat::Yuyv),
            b"MJPG" => Some(PixelFormat::Mjpg),
            b"GREY" => Some(PixelFormat::Grey),
            b"RGB3" => Some(PixelFormat::Rgb24),
            _ => None,
        }
    }

    pub fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Mjpg => *b"MJPG",
            PixelFormat::Grey => *b"GREY",
            PixelFormat::Rgb24 => *b"RGB3",
        }
    }

    fn name(self) -> String {
        String::from_utf8_lossy(&self.fourcc()).into_owned()
    }

    /// Bytes per pixel of the uncompressed formats.
    fn bytes_per_pixel(self) -> Option<usize> {
        match self {
            PixelFormat::Yuyv => Some(2),
            PixelFormat::Grey => Some(1),
            PixelFormat::Rgb24 => Some(3),
            PixelFormat::Mjpg => None,
        }
    }
}

/// One frame as linear RGB. `stride` is the bytes per row (0 means tightly
/// packed); `device` names the camera in errors.
pub fn decode_frame(
    device: &str,
    format: PixelFormat,
    width: u32,
    height: u32,
    stride: usize,
    bytes: &[u8],
    response: &Response,
) -> Result<RgbRaster, DriverError> {
    let lut = response.lut();
    let lin = |code: f32| linearize(&lut, code);
    let Some(bpp) = format.bytes_per_pixel() else {
        return decode_mjpg(device, width, height, bytes, &lut);
    };
    let (w, h) = (width as usize, height as usize);
    let row = w * bpp;
    let stride = if stride == 0 { row } else { stride };
    let needed = if h == 0 { 0 } else { stride * (h - 1) + row };
    if stride < row || bytes.len() < needed || (format == PixelFormat::Yuyv && w % 2 == 1) {
        return Err(DriverError::FrameSize {
            device: device.to_string(),
            fourcc: format.name(),
            width,
            height,
            expected: needed.max(row * h),
            got: bytes.len(),
        });
    }
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let line = &bytes[y * stride..y * stride + row];
        match format {
            PixelFormat::Grey => data.extend(line.iter().map(|&g| [lut[g as usize]; 3])),
            PixelFormat::Rgb24 => data.extend(
                line.chunks_exact(3)
                    .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]]),
            ),
            PixelFormat::Yuyv => {
                for q in line.chunks_exact(4) {
                    let (y0, u, y1, v) = (q[0], q[1], q[2], q[3]);
                    for yy in [y0, y1] {
                        let [r, g, b] = bt601_to_rgb(yy, u, v);
                        data.push([lin(r), lin(g), lin(b)]);
                    }
                }
            }
            PixelFormat::Mjpg => unreachable!("compressed formats return above"),
        }
    }
    Ok(RgbRaster {
        width,
        height,
        data,
    })
}

/// BT.601 limited-range Y'CbCr to R'G'B' code values (0..=255, unrounded).
pub fn bt601_to_rgb(y: u8, u: u8, v: u8) -> [f32; 3] {
    let c = (y as f32 - 16.0) * (255.0 / 219.0);
    let d = u as f32 - 128.0;
    let e = v as f32 - 128.0;
    let scale = 255.0 / 224.0;
    let r = c + 1.402 * scale * e;
    let g = c - (0.114 * 1.772 / 0.587) * scale * d - (0.299 * 1.402 / 0.587) * scale * e;
    let b = c + 1.772 * scale * d;
    [
        r.clamp(0.0, 255.0),
        g.clamp(0.0, 255.0),
        b.clamp(0.0, 255.0),
    ]
}

/// The curve at a fractional code value (linear interpolation in the LUT).
fn linearize(lut: &[f32; 256], code: f32) -> f32 {
    let c = if code.is_finite() {
        code.clamp(0.0, 255.0)
    } else {
        0.0
    };
    let i = (c.floor() as usize).min(254);
    let t = c - i as f32;
    lut[i] + (lut[i + 1] - lut[i]) * t
}

fn decode_mjpg(
    device: &str,
    width: u32,
    height: u32,
    bytes: &[u8],
    lut: &[f32; 256],
) -> Result<RgbRaster, DriverError> {
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let options = DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGB);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(std::io::Cursor::new(bytes), options);
    let rgb = decoder.decode().map_err(|e| DriverError::Decode {
        device: device.to_string(),
        reason: format!("MJPG: {e:?}"),
    })?;
    let (w, h) = decoder.dimensions().unwrap_or((0, 0));
    if (w, h) != (width as usize, height as usize) || rgb.len() != w * h * 3 {
        return Err(DriverError::Decode {
            device: device.to_string(),
            reason: format!("MJPG frame is {w}x{h}, the stream was set to {width}x{height}"),
        });
    }
    let data = rgb
        .chunks_exact(3)
        .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]])
        .collect();
    Ok(RgbRaster {
        width,
        height,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn yuyv_white_black_and_primaries() {
        // Two pixel pairs: white|black, then pure red (BT.601: Y 81, U 90, V 240).
        let bytes = [235, 128, 16, 128, 81, 90, 81, 240];
        let img =
            decode_frame("cam", PixelFormat::Yuyv, 2, 2, 0, &bytes, &Response::Linear).unwrap();
        assert!(close(img.data[0], [1.0; 3], 1e-3), "{:?}", img.data[0]);
        assert!(close(img.data[1], [0.0; 3], 1e-3), "{:?}", img.data[1]);
        assert!(
            close(img.data[2], [1.0, 0.0, 0.0], 0.01),
            "{:?}",
            img.data[2]
        );
        assert_eq!(img.data[2], img.data[3]);
    }

    #[test]
    fn yuyv_mid_grey_is_linearised_by_srgb() {
        // Y' = 16 + 219 * 128/255 encodes code value 128.
        let y = (16.0f32 + 219.0 * 128.0 / 255.0).round() as u8;
        let img = decode_frame(
            "cam",
            PixelFormat::Yuyv,
            2,
            1,
            0,
            &[y, 128, y, 128],
            &Response::Srgb,
        )
        .unwrap();
        assert!((img.data[0][1] - 0.2158).abs() < 0.003, "{:?}", img.data[0]);
    }

    #[test]
    fn grey_and_rgb24_with_row_padding() {
        let grey = [255, 0, 9, 9, 128, 64, 9, 9];
        let img =
            decode_frame("cam", PixelFormat::Grey, 2, 2, 4, &grey, &Response::Linear).unwrap();
        assert_eq!(img.data[0], [1.0; 3]);
        assert_eq!(img.data[2], [128.0 / 255.0; 3]);
        let rgb = [255, 0, 0, 0, 255, 0, 7, 7, 0, 0, 255, 255, 255, 255, 7, 7];
        let img =
            decode_frame("cam", PixelFormat::Rgb24, 2, 2, 8, &rgb, &Response::Linear).unwrap();
        assert_eq!(img.data[1], [0.0, 1.0, 0.0]);
        assert_eq!(img.data[2], [0.0, 0.0, 1.0]);
        assert_eq!(img.data[3], [1.0; 3]);
    }

    #[test]
    fn short_buffers_name_the_device_and_size() {
        let err = decode_frame(
            "/dev/v4l/by-id/usb-cam",
            PixelFormat::Rgb24,
            4,
            4,
            0,
            &[0; 10],
            &Response::Srgb,
        )
        .unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("/dev/v4l/by-id/usb-cam") && msg.contains("48") && msg.contains("10"),
            "{msg}"
        );
        assert!(decode_frame("cam", PixelFormat::Yuyv, 3, 1, 0, &[0; 6], &Response::Srgb).is_err());
    }

    #[test]
    fn mjpg_decodes_to_linear_rgb() {
        let (w, h) = (16u16, 8u16);
        let pixels: Vec<u8> = (0..w as usize * h as usize)
            .flat_map(|_| [200u8, 100, 50])
            .collect();
        let mut jpeg = Vec::new();
        let mut enc = jpeg_encoder::Encoder::new(&mut jpeg, 100);
        enc.set_sampling_factor(jpeg_encoder::SamplingFactor::F_1_1);
        enc.encode(&pixels, w, h, jpeg_encoder::ColorType::Rgb)
            .unwrap();
        let img = decode_frame("cam", PixelFormat::Mjpg, 16, 8, 0, &jpeg, &Response::Srgb).unwrap();
        let lut = Response::Srgb.lut();
        let want = [lut[200], lut[100], lut[50]];
        assert!(
            close(img.data[37], want, 0.01),
            "{:?} vs {want:?}",
            img.data[37]
        );
        let wrong =
            decode_frame("cam", PixelFormat::Mjpg, 32, 8, 0, &jpeg, &Response::Srgb).unwrap_err();
        assert!(wrong.to_string().contains("16x8"), "{wrong}");
        assert!(decode_frame(
            "cam",
            PixelFormat::Mjpg,
            16,
            8,
            0,
            &jpeg[..40],
            &Response::Srgb
        )
        .is_err());
    }

    #[test]
    fn fourccs_map_both_ways() {
        for f in [
            PixelFormat::Yuyv,
            PixelFormat::Mjpg,
            PixelFormat::Grey,
            PixelFormat::Rgb24,
        ] {
            assert_eq!(PixelFormat::from_fourcc(&f.fourcc()), Some(f));
        }
        assert_eq!(PixelFormat::from_fourcc(b"NV12"), None);
    }
}
