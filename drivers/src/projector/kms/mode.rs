//! Display modes: the operator's request (`1280x800@60`), the timings a
//! connector lists, the choice between them, and the forced mode computed
//! with VESA CVT reduced blanking when the projector lists none.
//!
//! Boundaries: plain values; the hardware part converts drm-rs's
//! `control::Mode` to and from [`Timing`].

use crate::error::DriverError;
use std::fmt;
use std::str::FromStr;

/// Largest width or height accepted (DRM mode fields are 16-bit and CVT
/// adds blanking to them).
const MAX_SIDE: u32 = 16_384;

/// A display timing, the fields of the kernel's `drm_mode_modeinfo`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Pixel clock in kHz.
    pub clock_khz: u32,
    pub hdisplay: u16,
    pub hsync_start: u16,
    pub hsync_end: u16,
    pub htotal: u16,
    pub vdisplay: u16,
    pub vsync_start: u16,
    pub vsync_end: u16,
    pub vtotal: u16,
    pub hsync_positive: bool,
    pub vsync_positive: bool,
    pub interlaced: bool,
}

impl Timing {
    /// Frames per second (fields per second when interlaced, as DRM counts).
    pub fn refresh_hz(&self) -> f64 {
        let lines = self.htotal as f64 * self.vtotal as f64;
        if lines == 0.0 {
            return 0.0;
        }
        let r = self.clock_khz as f64 * 1000.0 / lines;
        if self.interlaced {
            r * 2.0
        } else {
            r
        }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.hdisplay as u32, self.vdisplay as u32)
    }
}

impl fmt::Display for Timing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}x{}{}@{:.2}",
            self.hdisplay,
            self.vdisplay,
            if self.interlaced { "i" } else { "" },
            self.refresh_hz()
        )
    }
}

/// A mode as a connector lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListedMode {
    pub timing: Timing,
    /// The kernel's PREFERRED flag (from the EDID's first detailed timing).
    pub preferred: bool,
}

/// The mode the operator asked for: a size and optionally a refresh rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeRequest {
    pub width: u32,
    pub height: u32,
    pub refresh_hz: Option<f64>,
}

impl ModeRequest {
    /// Refresh rate assumed when the request has none.
    pub const DEFAULT_REFRESH_HZ: f64 = 60.0;
}

impl fmt::Display for ModeRequest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)?;
        if let Some(r) = self.refresh_hz {
            write!(f, "@{r}")?;
        }
        Ok(())
    }
}

/// A mode string that is not `WIDTHxHEIGHT[@HZ]`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "display mode `{input}`: {problem}; expected WIDTHxHEIGHT or WIDTHxHEIGHT@HZ, \
     e.g. 1280x800 or 1920x1080@59.94"
)]
pub struct ModeRequestError {
    pub input: String,
    pub problem: String,
}

impl FromStr for ModeRequest {
    type Err = ModeRequestError;

    fn from_str(s: &str) -> Result<ModeRequest, ModeRequestError> {
        let err = |problem: String| ModeRequestError {
            input: s.to_string(),
            problem,
        };
        let (size, refresh) = match s.trim().split_once('@') {
            Some((size, r)) => (size, Some(r)),
            None => (s.trim(), None),
        };
        let (w, h) = size
            .split_once(['x', 'X'])
            .ok_or_else(|| err("no `x` between width and height".into()))?;
        let side = |text: &str, what: &str| -> Result<u32, ModeRequestError> {
            match text.parse::<u32>() {
                Ok(v) if (1..=MAX_SIDE).contains(&v) => Ok(v),
                Ok(v) => Err(err(format!("{what} {v} is outside 1..={MAX_SIDE}"))),
                Err(_) => Err(err(format!("{what} `{text}` is not a whole number"))),
            }
        };
        let width = side(w, "width")?;
        let height = side(h, "height")?;
        let refresh_hz = match refresh {
            None => None,
            Some(r) => match r.parse::<f64>() {
                Ok(v) if v.is_finite() && (1.0..=1000.0).contains(&v) => Some(v),
                Ok(v) => return Err(err(format!("refresh {v} Hz is outside 1..=1000"))),
                Err(_) => return Err(err(format!("refresh `{r}` is not a number"))),
            },
        };
        Ok(ModeRequest {
            width,
            height,
            refresh_hz,
        })
    }
}

/// Which mode to set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModeChoice {
    /// The connector's mode at this index.
    Listed(usize),
    /// A mode the connector does not list, computed by CVT-RB.
    Forced(Timing),
}

/// Picks the mode for `device` (named in errors):
/// - a request whose size the connector lists: that size, nearest refresh
///   (ties: the preferred mode, then the first listed, which the kernel
///   sorts best first); progressive modes before interlaced ones;
/// - no request: the preferred mode (the first listed if none is flagged);
/// - a request the connector does not list, or a connector that lists
///   nothing (a projector without EDID, or an unreadable one): a forced
///   CVT-RB mode of the requested size, as the kernel's `video=` option does;
///   the explicit request wins over a different preferred size because the
///   calibration is tied to the projector's resolution;
/// - no request and no modes: an error saying to set a mode.
pub fn select_mode(
    modes: &[ListedMode],
    request: Option<&ModeRequest>,
    device: &str,
) -> Result<ModeChoice, DriverError> {
    let Some(req) = request else {
        if modes.is_empty() {
            return Err(DriverError::InvalidSetting {
                device: device.to_string(),
                reason: "the output lists no modes (no or unreadable EDID) and no mode is \
                         configured; set the projector's native mode, e.g. `1280x800@60`"
                    .into(),
            });
        }
        let i = modes.iter().position(|m| m.preferred).unwrap_or(0);
        return Ok(ModeChoice::Listed(i));
    };
    let wanted = req.refresh_hz.unwrap_or(ModeRequest::DEFAULT_REFRESH_HZ);
    let best = modes
        .iter()
        .enumerate()
        .filter(|(_, m)| m.timing.size() == (req.width, req.height))
        .min_by(|(i, a), (j, b)| {
            let key = |m: &ListedMode| {
                (
                    m.timing.interlaced,
                    // Without an asked refresh a preferred mode of that size
                    // wins outright.
                    req.refresh_hz.is_none() && !m.preferred,
                    (m.timing.refresh_hz() - wanted).abs(),
                )
            };
            let (ka, kb) = (key(a), key(b));
            ka.0.cmp(&kb.0)
                .then(ka.1.cmp(&kb.1))
                .then(ka.2.total_cmp(&kb.2))
                .then(b.preferred.cmp(&a.preferred))
                .then(i.cmp(j))
        });
    if let Some((i, _)) = best {
        return Ok(ModeChoice::Listed(i));
    }
    if !modes.is_empty() {
        tracing::warn!(
            device,
            requested = %req,
            listed = %modes.iter().map(|m| m.timing.to_string()).collect::<Vec<_>>().join(", "),
            "the output does not list the requested size; forcing it with CVT reduced blanking"
        );
    }
    cvt_reduced_blanking(req.width, req.height, wanted)
        .map(ModeChoice::Forced)
        .map_err(|reason| DriverError::InvalidSetting {
            device: device.to_string(),
            reason: format!("cannot force mode {req}: {reason}"),
        })
}

/// CVT reduced blanking, version 1 (VESA CVT 1.1, the kernel's
/// `drm_cvt_mode(.., reduced = true)`): 160 pixels of horizontal blanking
/// (front porch 48, sync 32), vertical front porch 3, vertical sync by aspect
/// ratio, at least 460 µs of vertical blanking and a pixel clock rounded
/// down to 0.25 MHz. Sync is +h −v, which tells the sink it is CVT-RB.
///
/// The width is used as given, not rounded down to CVT's 8-pixel cells: the
/// projector's native width is what the scan's calibration needs, and sinks
/// take any width.
pub fn cvt_reduced_blanking(width: u32, height: u32, refresh_hz: f64) -> Result<Timing, String> {
    const H_BLANK: u32 = 160;
    const H_SYNC: u32 = 32;
    const H_FRONT_PORCH: u32 = 48;
    const V_FRONT_PORCH: u32 = 3;
    const MIN_V_BACK_PORCH: u32 = 6;
    const MIN_V_BLANK_US: f64 = 460.0;
    const CLOCK_STEP_KHZ: f64 = 250.0;

    if !(1..=MAX_SIDE).contains(&width) || !(1..=MAX_SIDE).contains(&height) {
        return Err(format!("size {width}x{height} is outside 1..={MAX_SIDE}"));
    }
    let frame_us = 1e6 / refresh_hz;
    if !refresh_hz.is_finite() || refresh_hz <= 0.0 || frame_us <= MIN_V_BLANK_US {
        return Err(format!(
            "refresh {refresh_hz} Hz leaves no time for the 460 µs vertical blank"
        ));
    }
    // Vertical sync length encodes the aspect ratio (CVT table 3-2),
    // judged on the width rounded to 8-pixel cells as the standard does.
    let (w8, v) = (width / 8 * 8, height);
    let v_sync = if v % 3 == 0 && v * 4 / 3 == w8 {
        4
    } else if v % 9 == 0 && v * 16 / 9 == w8 {
        5
    } else if v % 10 == 0 && v * 16 / 10 == w8 {
        6
    } else if (v % 4 == 0 && v * 5 / 4 == w8) || (v % 9 == 0 && v * 15 / 9 == w8) {
        7
    } else {
        10
    };
    let h_period_us = (frame_us - MIN_V_BLANK_US) / v as f64;
    let vbi_lines = (MIN_V_BLANK_US / h_period_us).floor() as u32 + 1;
    let vbi_lines = vbi_lines.max(V_FRONT_PORCH + v_sync + MIN_V_BACK_PORCH);
    let vtotal = v + vbi_lines;
    let htotal = width + H_BLANK;
    let clock_khz = CLOCK_STEP_KHZ
        * (refresh_hz * vtotal as f64 * htotal as f64 / 1000.0 / CLOCK_STEP_KHZ).floor();
    let u16_of = |x: u32| u16::try_from(x).map_err(|_| format!("total {x} exceeds 65535"));
    Ok(Timing {
        clock_khz: clock_khz as u32,
        hdisplay: u16_of(width)?,
        hsync_start: u16_of(width + H_FRONT_PORCH)?,
        hsync_end: u16_of(width + H_FRONT_PORCH + H_SYNC)?,
        htotal: u16_of(htotal)?,
        vdisplay: u16_of(v)?,
        vsync_start: u16_of(v + V_FRONT_PORCH)?,
        vsync_end: u16_of(v + V_FRONT_PORCH + v_sync)?,
        vtotal: u16_of(vtotal)?,
        hsync_positive: true,
        vsync_positive: false,
        interlaced: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(s: &str) -> ModeRequest {
        s.parse().expect("valid mode")
    }

    fn listed(w: u16, h: u16, refresh: f64, preferred: bool) -> ListedMode {
        // A CVT-RB-like timing with the clock picked for `refresh`.
        let (htotal, vtotal) = (w + 160, h + 30);
        ListedMode {
            timing: Timing {
                clock_khz: (refresh * htotal as f64 * vtotal as f64 / 1000.0).round() as u32,
                hdisplay: w,
                hsync_start: w + 48,
                hsync_end: w + 80,
                htotal,
                vdisplay: h,
                vsync_start: h + 3,
                vsync_end: h + 9,
                vtotal,
                hsync_positive: true,
                vsync_positive: false,
                interlaced: false,
            },
            preferred,
        }
    }

    #[test]
    fn mode_strings_parse_with_and_without_refresh() {
        assert_eq!(
            req("1280x800"),
            ModeRequest {
                width: 1280,
                height: 800,
                refresh_hz: None
            }
        );
        assert_eq!(req("1280x800@60").refresh_hz, Some(60.0));
        let r = req("1920x1080@59.94");
        assert_eq!((r.width, r.height, r.refresh_hz), (1920, 1080, Some(59.94)));
        assert_eq!(req("912X1140").width, 912);
        assert_eq!(req("1920x1080@59.94").to_string(), "1920x1080@59.94");
    }

    #[test]
    fn bad_mode_strings_name_the_input_and_the_expected_form() {
        for (input, problem) in [
            ("1280", "no `x`"),
            ("1280x", "height `` is not a whole number"),
            ("x800", "width `` is not a whole number"),
            ("0x800", "width 0 is outside"),
            ("1280x800@", "refresh `` is not a number"),
            ("1280x800@abc", "refresh `abc`"),
            ("1280x800@0", "refresh 0 Hz is outside"),
            ("1280x800@inf", "refresh inf Hz is outside"),
            ("-1x800", "width `-1`"),
            ("99999x800", "width 99999 is outside"),
        ] {
            let err = input.parse::<ModeRequest>().unwrap_err().to_string();
            assert!(err.contains(&format!("`{input}`")), "{err}");
            assert!(err.contains(problem), "{input}: {err}");
            assert!(err.contains("WIDTHxHEIGHT@HZ"), "{err}");
        }
    }

    #[test]
    fn cvt_rb_1280x800_at_60_matches_the_published_timing() {
        let t = cvt_reduced_blanking(1280, 800, 60.0).unwrap();
        assert_eq!(t.clock_khz, 71_000);
        assert_eq!((t.hsync_start, t.hsync_end, t.htotal), (1328, 1360, 1440));
        // 16:10: vsync 6.
        assert_eq!((t.vsync_start, t.vsync_end, t.vtotal), (803, 809, 823));
        assert!(t.hsync_positive && !t.vsync_positive && !t.interlaced);
        assert!((t.refresh_hz() - 59.91).abs() < 0.01, "{}", t.refresh_hz());
    }

    #[test]
    fn cvt_rb_1920x1080_at_60_matches_the_published_timing() {
        let t = cvt_reduced_blanking(1920, 1080, 60.0).unwrap();
        assert_eq!(t.clock_khz, 138_500);
        assert_eq!((t.hsync_start, t.hsync_end, t.htotal), (1968, 2000, 2080));
        // 16:9: vsync 5.
        assert_eq!((t.vsync_start, t.vsync_end, t.vtotal), (1083, 1088, 1111));
    }

    #[test]
    fn cvt_rb_other_published_modes() {
        // 1024x768@60 RB (4:3, vsync 4): 56.00 MHz, 1184 x 790.
        let t = cvt_reduced_blanking(1024, 768, 60.0).unwrap();
        assert_eq!((t.clock_khz, t.htotal, t.vtotal), (56_000, 1184, 790));
        assert_eq!(t.vsync_end - t.vsync_start, 4);
        // 1920x1200@60 RB (16:10): 154.00 MHz, 2080 x 1235.
        let t = cvt_reduced_blanking(1920, 1200, 60.0).unwrap();
        assert_eq!((t.clock_khz, t.htotal, t.vtotal), (154_000, 2080, 1235));
        // 1280x1024@60 RB (5:4, vsync 7), by the formula: 30 blank lines
        // (460 µs / 15.83 µs, rounded up), 60 * 1054 * 1440 = 91.07 MHz,
        // rounded down to 91.00.
        let t = cvt_reduced_blanking(1280, 1024, 60.0).unwrap();
        assert_eq!((t.clock_khz, t.htotal, t.vtotal), (91_000, 1440, 1054));
        assert_eq!(t.vsync_end - t.vsync_start, 7);
    }

    #[test]
    fn cvt_rb_odd_aspect_uses_vsync_10_and_keeps_the_width() {
        // LightCrafter 4500: 912x1140, no standard aspect.
        let t = cvt_reduced_blanking(912, 1140, 60.0).unwrap();
        assert_eq!(t.hdisplay, 912);
        assert_eq!(t.htotal, 1072);
        assert_eq!(t.vsync_end - t.vsync_start, 10);
        assert!(t.vtotal - t.vsync_end >= 6);
        // Rounding the clock down to 0.25 MHz lands just under 60 Hz.
        let r = t.refresh_hz();
        assert!(r <= 60.0 && r > 59.75, "{r}");
    }

    #[test]
    fn cvt_rb_refuses_a_refresh_with_no_room_for_blanking() {
        assert!(cvt_reduced_blanking(1280, 800, 3000.0).is_err());
        assert!(cvt_reduced_blanking(0, 800, 60.0).is_err());
    }

    #[test]
    fn request_picks_the_listed_size_with_the_nearest_refresh() {
        let modes = [
            listed(1920, 1080, 60.0, true),
            listed(1280, 800, 75.0, false),
            listed(1280, 800, 60.0, false),
            listed(1280, 800, 50.0, false),
        ];
        let pick = |s: &str| select_mode(&modes, Some(&req(s)), "card0").unwrap();
        assert_eq!(pick("1280x800@59.94"), ModeChoice::Listed(2));
        assert_eq!(pick("1280x800@49"), ModeChoice::Listed(3));
        assert_eq!(pick("1280x800@120"), ModeChoice::Listed(1));
        // No refresh asked: nearest to 60.
        assert_eq!(pick("1280x800"), ModeChoice::Listed(2));
        assert_eq!(pick("1920x1080"), ModeChoice::Listed(0));
    }

    #[test]
    fn request_without_refresh_takes_the_preferred_mode_of_that_size() {
        let modes = [
            listed(1280, 800, 60.0, false),
            listed(1280, 800, 120.0, true),
        ];
        assert_eq!(
            select_mode(&modes, Some(&req("1280x800")), "card0").unwrap(),
            ModeChoice::Listed(1)
        );
        assert_eq!(
            select_mode(&modes, Some(&req("1280x800@60")), "card0").unwrap(),
            ModeChoice::Listed(0)
        );
    }

    #[test]
    fn progressive_wins_over_interlaced_of_the_same_size() {
        let mut i = listed(1920, 1080, 60.0, false);
        i.timing.interlaced = true;
        let modes = [i, listed(1920, 1080, 50.0, false)];
        assert_eq!(
            select_mode(&modes, Some(&req("1920x1080@60")), "card0").unwrap(),
            ModeChoice::Listed(1)
        );
    }

    #[test]
    fn no_request_takes_the_preferred_mode_else_the_first() {
        let modes = [
            listed(1024, 768, 60.0, false),
            listed(1280, 800, 60.0, true),
        ];
        assert_eq!(
            select_mode(&modes, None, "card0").unwrap(),
            ModeChoice::Listed(1)
        );
        let modes = [
            listed(1024, 768, 60.0, false),
            listed(1280, 800, 60.0, false),
        ];
        assert_eq!(
            select_mode(&modes, None, "card0").unwrap(),
            ModeChoice::Listed(0)
        );
    }

    #[test]
    fn no_modes_forces_the_request_with_cvt_rb() {
        let got = select_mode(&[], Some(&req("1280x800")), "card0").unwrap();
        assert_eq!(
            got,
            ModeChoice::Forced(cvt_reduced_blanking(1280, 800, 60.0).unwrap())
        );
        let ModeChoice::Forced(t) = got else {
            unreachable!()
        };
        assert_eq!((t.clock_khz, t.htotal, t.vtotal), (71_000, 1440, 823));
    }

    #[test]
    fn unlisted_request_is_forced_rather_than_swapped_for_another_size() {
        // The kernel's no-EDID fallback lists only VESA modes up to 1024x768.
        let modes = [listed(1024, 768, 60.0, true), listed(800, 600, 60.0, false)];
        let got = select_mode(&modes, Some(&req("1280x800@60")), "card0").unwrap();
        assert_eq!(
            got,
            ModeChoice::Forced(cvt_reduced_blanking(1280, 800, 60.0).unwrap())
        );
    }

    #[test]
    fn no_request_and_no_modes_says_to_set_a_mode() {
        let err = select_mode(&[], None, "/dev/dri/card0:HDMI-A-1")
            .unwrap_err()
            .to_string();
        assert!(err.contains("/dev/dri/card0:HDMI-A-1"), "{err}");
        assert!(err.contains("lists no modes"), "{err}");
        assert!(err.contains("1280x800@60"), "{err}");
    }

    #[test]
    fn timing_displays_size_and_refresh() {
        let t = cvt_reduced_blanking(1920, 1080, 60.0).unwrap();
        assert_eq!(t.to_string(), "1920x1080@59.93");
    }
}
