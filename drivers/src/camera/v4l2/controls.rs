//! Locking a V4L2 camera's automatic controls.
//!
//! Control ids and menu values are the kernel's (`linux/v4l2-controls.h`),
//! written out so this file reads without the bindings. Boundaries: controls
//! only; streaming is `super`'s.

use crate::error::DriverError;
use crate::traits::CameraSettings;
use v4l::control::{Control, Value};
use v4l::Device;

const CID_AUTO_WHITE_BALANCE: u32 = 0x0098_090c;
const CID_AUTOGAIN: u32 = 0x0098_0912;
const CID_GAIN: u32 = 0x0098_0913;
const CID_WHITE_BALANCE_TEMPERATURE: u32 = 0x0098_091a;
const CID_EXPOSURE_AUTO: u32 = 0x009a_0901;
const CID_EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
const CID_EXPOSURE_AUTO_PRIORITY: u32 = 0x009a_0903;
const CID_FOCUS_AUTO: u32 = 0x009a_090c;
/// `V4L2_EXPOSURE_MANUAL` of the exposure-auto menu.
const EXPOSURE_MANUAL: i64 = 1;

/// Automatic controls off first (a manual value is refused while its
/// automatic twin is on), then the manual values.
pub(super) fn lock(
    device: &Device,
    path: &str,
    settings: &CameraSettings,
) -> Result<(), DriverError> {
    let present = device
        .query_controls()
        .map_err(|e| DriverError::io(path, "listing the camera controls", e))?;
    let find = |id: u32| present.iter().find(|d| d.id == id);
    // Exposure absolute is in units of 100 us.
    let exposure = (settings.exposure_s() as f64 * 10_000.0).round() as i64;
    let gain = find(CID_GAIN).map(|d| {
        let base = d.minimum.max(1) as f64;
        ((base * settings.gain() as f64).round() as i64).clamp(d.minimum, d.maximum)
    });
    let steps: [(u32, &'static str, Option<i64>); 8] = [
        (CID_EXPOSURE_AUTO, "exposure_auto", Some(EXPOSURE_MANUAL)),
        (
            CID_EXPOSURE_AUTO_PRIORITY,
            "exposure_auto_priority",
            Some(0),
        ),
        (CID_AUTO_WHITE_BALANCE, "white_balance_automatic", Some(0)),
        (CID_FOCUS_AUTO, "focus_automatic_continuous", Some(0)),
        (CID_AUTOGAIN, "gain_automatic", Some(0)),
        (
            CID_EXPOSURE_ABSOLUTE,
            "exposure_time_absolute",
            Some(exposure),
        ),
        (
            CID_WHITE_BALANCE_TEMPERATURE,
            "white_balance_temperature",
            Some(settings.white_balance_k() as i64),
        ),
        (CID_GAIN, "gain", gain),
    ];
    for (id, name, value) in steps {
        let (Some(desc), Some(value)) = (find(id), value) else {
            tracing::debug!("{path}: no control `{name}`; skipped");
            continue;
        };
        let clamped = value.clamp(desc.minimum, desc.maximum);
        if clamped != value {
            return Err(DriverError::Control {
                device: path.to_string(),
                control: name,
                reason: format!(
                    "{value} is outside the camera's range {}..={}",
                    desc.minimum, desc.maximum
                ),
            });
        }
        let v = match desc.typ {
            v4l::control::Type::Boolean => Value::Boolean(value != 0),
            _ => Value::Integer(value),
        };
        device
            .set_control(Control { id, value: v })
            .map_err(|e| DriverError::Control {
                device: path.to_string(),
                control: name,
                reason: e.to_string(),
            })?;
    }
    Ok(())
}
