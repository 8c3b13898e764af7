//! What light does beneath the surface, measured per material: whether it
//! scatters inside (subsurface) and how much passes through
//! (transmission).
//!
//! Two measurements, both per material of the fit (a point rarely tells,
//! a region does):
//!
//! - **Global share** of the projector's uniform light: the global light
//!   the checker separation measured ([`super::separation::global_light`])
//!   over the uniform capture's total. A surface without a subsurface lobe
//!   returns its light where it falls (share near 0: interreflections
//!   only); the Principled BSDF's subsurface lobe, as the renderer and
//!   Cycles 2.9x set it up, sends *all* diffuse light into a random walk
//!   once `subsurface` is above zero, and the share jumps (0.6 to 0.9 on
//!   the `tune` set for every subsurface from 0.05 up). So the share says
//!   whether a material has subsurface, clearly, but barely how much: a
//!   material below [`TransportOptions::max_global_share`] is measured
//!   free of subsurface (0), one above keeps the networks' value.
//! - **Backlight** ([`super::backlight`]): where the share rules out
//!   subsurface, panel light seen through the material is transmission.
//!   Per material, `t = Σq / Σ(q + a)` over its measured pixels with the
//!   fit's diffuse albedo `a = (1 - t) (1 - m) basecolor`. A straight
//!   camera ray crosses the front and a back surface, and the back may be
//!   another, opaque material (a two-material sphere): the backlight then
//!   sees less than the front passes. So the measurement is a floor: the
//!   material's transmission is raised to it where the networks said less,
//!   never lowered.
//!
//! Where a scan lacks what a measurement needs (no checker capture, no
//! backlit one, too few pixels of a material), the networks' values stand
//! and the reason is recorded.
//!
//! Boundaries: reads the reference position's photos through `inputs` and
//! the scan's mesh; writes nothing.

use super::backlight::{measure_backlight, transmission_of, BacklightOptions};
use super::separation::global_light;
use super::Fitted;
use crate::pipeline::inputs::SceneInputs;
use crate::refine::RefineError;
use matscan_calib::photos::luma;
use matscan_calib::ScanCalibration;
use matscan_scan::Bundle;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Thresholds of the per-material decisions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransportOptions {
    pub backlight: BacklightOptions,
    /// A material whose global share is below this has no subsurface lobe.
    pub max_global_share: f32,
    /// Pixels a material needs, facing the camera with a measured share
    /// (and for transmission, in the backlight measurement), to be judged.
    pub min_pixels: usize,
}

impl Default for TransportOptions {
    fn default() -> Self {
        TransportOptions {
            backlight: BacklightOptions::default(),
            max_global_share: 0.3,
            min_pixels: 50,
        }
    }
}

/// What was measured of one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialTransport {
    /// Index into the fit's materials.
    pub material: usize,
    /// Global share of the projector's light; `None` where not measured.
    pub global_share: Option<f32>,
    /// Whether the share ruled out a subsurface lobe (subsurface set to 0).
    pub subsurface_absent: bool,
    /// The backlight's floor on the effective transmission; `None` where
    /// not measured (subsurface present, no backlit photo, too few pixels).
    pub transmission_floor: Option<f32>,
}

/// The measurements of one reference image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Transport {
    pub materials: Vec<MaterialTransport>,
    /// Share of the object's pixels whose subsurface the photos set.
    pub subsurface_share: f32,
    /// Share of the object's pixels whose transmission the photos
    /// measured (raised or confirmed).
    pub transmission_share: f32,
    /// Why a measurement did not run.
    pub notes: Vec<String>,
    pub seconds: f64,
}

/// Measures `fitted`'s materials in `inputs`' reference image and applies
/// what the photos pin to `transmission` and `subsurface` (the networks'
/// maps; `None` where the plan does not estimate the parameter, which is
/// then neither measured nor changed).
pub fn measure_transport(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    fitted: &Fitted,
    mut transmission: Option<&mut [f32]>,
    mut subsurface: Option<&mut [f32]>,
    options: &TransportOptions,
) -> Result<Transport, RefineError> {
    let t0 = Instant::now();
    let n = inputs.pixels();
    let mut out = Transport::default();
    let shares = match global_shares(bundle, calibration, inputs)? {
        Ok(s) => Some(s),
        Err(why) => {
            out.notes.push(format!(
                "subsurface and transmission not measured: {why} (the global share tells \
                 scattering from transmitted light)"
            ));
            None
        }
    };
    let Some(shares) = shares else {
        out.seconds = t0.elapsed().as_secs_f64();
        return Ok(out);
    };
    let backlight = if transmission.is_some() {
        match measure_backlight(bundle, inputs, &options.backlight)? {
            Ok(m) => Some(m),
            Err(why) => {
                out.notes
                    .push(format!("transmission not measured: {why}"));
                None
            }
        }
    } else {
        None
    };
    let facing = |i: usize| {
        inputs
            .views
            .iter()
            .find(|v| v.view.position == inputs.reference)
            .is_some_and(|v| v.cos_nv()[i] >= options.backlight.min_cos_nv)
    };
    let object = inputs.mask.data.iter().filter(|&&m| m).count().max(1);
    let (mut ss_px, mut tr_px) = (0usize, 0usize);
    for (j, _) in fitted.materials.iter().enumerate() {
        let members: Vec<usize> = (0..n).filter(|&i| fitted.labels[i] == Some(j)).collect();
        let (mut g, mut tot, mut counted) = (0.0f64, 0.0f64, 0usize);
        for &i in &members {
            if let Some((gi, ti)) = shares[i] {
                if facing(i) {
                    g += f64::from(gi);
                    tot += f64::from(ti);
                    counted += 1;
                }
            }
        }
        let share = (counted >= options.min_pixels && tot > 0.0).then(|| (g / tot) as f32);
        let absent = share.is_some_and(|s| s < options.max_global_share);
        if absent {
            if let Some(ss) = subsurface.as_deref_mut() {
                for &i in &members {
                    ss[i] = 0.0;
                }
                ss_px += members.len();
            }
        }
        let mut floor = None;
        if let (true, Some(m), Some(tr)) = (absent, backlight.as_ref(), transmission.as_deref_mut())
        {
            let (mut q, mut a, mut measured) = ([0.0f64; 3], [0.0f64; 3], 0usize);
            for &i in &members {
                if !(inputs.mask.data[i] && facing(i) && m.crossings[i] > 0) {
                    continue;
                }
                let ti = tr[i].clamp(0.0, 1.0);
                let mi = fitted.metallic[i].clamp(0.0, 1.0);
                let b = fitted.basecolor[i];
                let qi = m.transmittance[i].unwrap_or([0.0; 3]);
                if !b.iter().chain(&qi).all(|v| v.is_finite()) {
                    continue;
                }
                for c in 0..3 {
                    q[c] += f64::from(qi[c]);
                    a[c] += f64::from((1.0 - ti) * (1.0 - mi) * b[c].clamp(0.0, 1.0));
                }
                measured += 1;
            }
            if measured >= options.min_pixels {
                if let Some(t) = transmission_of(q, a) {
                    for &i in &members {
                        tr[i] = tr[i].max(t);
                    }
                    tr_px += members.len();
                    floor = Some(t);
                }
            }
        }
        out.materials.push(MaterialTransport {
            material: j,
            global_share: share,
            subsurface_absent: absent,
            transmission_floor: floor,
        });
    }
    out.subsurface_share = (ss_px as f32 / object as f32).min(1.0);
    out.transmission_share = (tr_px as f32 / object as f32).min(1.0);
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Per reference pixel, the global light and the total of the projector's
/// uniform field (luma, full white, ambient exposure units), where both
/// were measured; or why not.
fn global_shares(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
) -> Result<Result<Vec<Option<(f32, f32)>>, String>, RefineError> {
    let global = match global_light(bundle, calibration, &inputs.reference)? {
        Ok(g) => g,
        Err(why) => return Ok(Err(why)),
    };
    let n = inputs.pixels();
    if global.rgb.data.len() != n {
        return Ok(Err(format!(
            "position {}: the global light's image differs from the reference's",
            inputs.reference
        )));
    }
    let Some(uniform) = inputs
        .views
        .iter()
        .find(|v| v.view.position == inputs.reference && v.view.light == global.projector)
    else {
        return Ok(Err(format!(
            "position {}: no view of the projector's uniform field",
            inputs.reference
        )));
    };
    let level = bundle
        .capture(&inputs.reference, &uniform.view.capture)?
        .uniform_level()
        .filter(|l| l.is_finite() && *l > 0.0)
        .unwrap_or(1.0) as f32;
    let floor = 1e-4;
    Ok(Ok((0..n)
        .map(|i| {
            if !inputs.mask.data[i] {
                return None;
            }
            let lit = uniform.lit()[i];
            let amb = uniform.ambient()[i];
            let total = luma([0, 1, 2].map(|c| lit[c] - amb[c])) / level;
            let g = luma(global.rgb.data[i]).max(0.0);
            (total > floor && g.is_finite()).then_some((g.min(total), total))
        })
        .collect()))
}
