//! The Principled BSDF at one point: mixes the lobes with Cycles 2.9x's
//! closure weights, picks a lobe by its estimated albedo when sampling, and
//! combines the lobes' densities into one MIS pdf. The lobes themselves live
//! in the sibling modules.

use super::diffuse::{burley_cos, cosine_pdf, sample_cosine};
use super::frame::{ShadingFrame, SurfaceNormals};
use super::glass::Glass;
use super::lobe::{BsdfEval, BsdfSample, LobeKind};
use super::specular::Specular;
use super::subsurface::{clamp_unit, SubsurfaceMedium, BSSRDF_MIN_RADIUS};
use crate::material::{Material, IOR, SPECULAR};
use glam::Vec3;

/// Cycles' `CLOSURE_WEIGHT_CUTOFF`: lobes weighted below it are dropped.
pub const CLOSURE_WEIGHT_CUTOFF: f32 = 1e-5;
/// GGX alpha at or below which Cycles treats a microfacet lobe as a perfect
/// mirror / smooth glass (its test is alpha_x alpha_y <= 1e-7): roughness
/// below about 0.0178.
pub const DELTA_ALPHA: f32 = 3.162_277_7e-4;
/// Largest subsurface radius honoured (scene units); keeps σt above zero.
const MAX_SUBSURFACE_RADIUS: f32 = 1e6;

/// Lobe order used for selection.
const DIFFUSE: usize = 0;
const SPECULAR_LOBE: usize = 1;
const GLASS: usize = 2;
const SUBSURFACE: usize = 3;

/// Prepared lobes of one [`Material`] at one surface point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bsdf {
    normals: SurfaceNormals,
    roughness: f32,
    /// Burley diffuse weight (RGB); zero when absent.
    diffuse: Vec3,
    /// Mixing weight (1 - final transmission) and lobe.
    specular: Option<(f32, Specular)>,
    /// Mixing weight (final transmission) and lobe.
    glass: Option<(f32, Glass)>,
    subsurface: Option<SubsurfaceLobe>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct SubsurfaceLobe {
    /// Closure weight: diffuse weight × mixed base colour.
    weight: Vec3,
    /// Walk start throughput: the closure weight without the albedo.
    entry_weight: Vec3,
    medium: SubsurfaceMedium,
}

/// Everything that depends on `wo` but not on `wi`.
struct Prepared {
    frame: ShadingFrame,
    wo: Vec3,
    eta: f32,
    probability: [f32; 4],
}

impl Bsdf {
    /// Prepares the lobes for `mat` (sanitized first) at a point with shading
    /// normal `n` and geometric normal `ng` (any length; repaired if
    /// degenerate, see [`super`]).
    pub fn new(mat: &Material, n: Vec3, ng: Vec3) -> Bsdf {
        let m = mat.sanitized();
        let base = m.basecolor;
        let metallic = m.metallic;
        let final_transmission = m.effective_transmission();
        let diffuse_weight = (1.0 - metallic) * (1.0 - m.transmission);
        let specular_weight = 1.0 - final_transmission;
        // Thesis eq. 3.14 with subsurface colour = base colour: the mixed
        // subsurface base colour equals the base colour.
        let mixed = base;

        let mut diffuse = Vec3::ZERO;
        let mut subsurface = None;
        if mean(mixed) > CLOSURE_WEIGHT_CUTOFF && diffuse_weight > CLOSURE_WEIGHT_CUTOFF {
            let weight = mixed * diffuse_weight;
            if m.subsurface > CLOSURE_WEIGHT_CUTOFF {
                // Cycles 2.9x: any subsurface sends the whole diffuse weight
                // to the BSSRDF, with the radius scaled by `subsurface`.
                let radius =
                    (m.subsurface_radius * m.subsurface).min(Vec3::splat(MAX_SUBSURFACE_RADIUS));
                let walks = radius.cmpge(Vec3::splat(BSSRDF_MIN_RADIUS));
                diffuse = Vec3::select(walks, Vec3::ZERO, weight);
                let sss_weight = Vec3::select(walks, weight, Vec3::ZERO);
                if sss_weight.max_element() > 0.0 {
                    subsurface = Some(SubsurfaceLobe {
                        weight: sss_weight,
                        // Cycles' safe_divide(weight, albedo): zero where the
                        // albedo is zero.
                        entry_weight: Vec3::select(
                            walks & mixed.cmpgt(Vec3::ZERO),
                            Vec3::splat(diffuse_weight),
                            Vec3::ZERO,
                        ),
                        medium: SubsurfaceMedium::from_albedo_and_radius(
                            mixed,
                            radius,
                            m.roughness,
                        ),
                    });
                }
            } else {
                diffuse = weight;
            }
        }

        let alpha = m.roughness * m.roughness;
        let delta = alpha <= DELTA_ALPHA;
        let specular = (specular_weight > CLOSURE_WEIGHT_CUTOFF).then(|| {
            // Specular tint 0: the dielectric F0 is 0.08 * specular, white.
            let cspec0 = Vec3::splat(0.08 * SPECULAR) * (1.0 - metallic) + base * metallic;
            (
                specular_weight,
                Specular::new(m.roughness, alpha, delta, cspec0),
            )
        });
        let glass = (final_transmission > CLOSURE_WEIGHT_CUTOFF).then(|| {
            (
                final_transmission,
                Glass::new(m.roughness, alpha, delta, base),
            )
        });

        Bsdf {
            normals: SurfaceNormals::new(n, ng),
            roughness: m.roughness,
            diffuse,
            specular,
            glass,
            subsurface,
        }
    }

    /// f(wo, wi) |cos(n, wi)| and the density of sampling `wi` with
    /// [`Self::sample`], excluding delta lobes. Zero for directions on the
    /// wrong side (see [`super`]).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> BsdfEval {
        match self.prepare(wo) {
            Some(p) => self.eval_prepared(&p, wi),
            None => BsdfEval::ZERO,
        }
    }

    /// Samples a direction from `u` in [0, 1)³ (`u[0]` picks the lobe,
    /// `u[1]` and `u[2]` the direction); None when the sample is invalid.
    pub fn sample(&self, wo: Vec3, u: [f32; 3]) -> Option<BsdfSample> {
        let p = self.prepare(wo)?;
        let (lobe, u_reuse) = pick(&p.probability, clamp_unit(u[0]))?;
        let (u1, u2) = (clamp_unit(u[1]), clamp_unit(u[2]));
        let selected = p.probability[lobe];
        let local = match lobe {
            DIFFUSE => sample_cosine(u1, u2),
            SPECULAR_LOBE => {
                let (weight, lobe) = self.specular?;
                if lobe.is_delta() {
                    let wi = Vec3::new(-p.wo.x, -p.wo.y, p.wo.z);
                    let value = lobe.delta_weight(p.wo) * weight;
                    return delta_sample(&p, wi, value / selected, selected);
                }
                lobe.sample(p.wo, u_reuse, u1, u2)?
            }
            GLASS => {
                let (weight, lobe) = self.glass?;
                if lobe.is_delta() {
                    let s = lobe.sample_delta(p.wo, p.eta, u_reuse)?;
                    let value = s.weight * (weight / selected);
                    return delta_sample(&p, s.wi, value, selected * s.probability);
                }
                lobe.sample(p.wo, p.eta, u_reuse, u1, u2)?
            }
            _ => {
                let sss = self.subsurface?;
                let down = sample_cosine(u1, u2) * Vec3::new(1.0, 1.0, -1.0);
                let wi = p.frame.to_world(down).normalize_or_zero();
                let cos_g = p.frame.geometric_cos(wi);
                if cos_g.is_nan() || cos_g >= 0.0 {
                    return None;
                }
                return Some(BsdfSample {
                    wi,
                    weight: sss.entry_weight / selected,
                    pdf: selected * cosine_pdf(-down),
                    kind: LobeKind::SubsurfaceEntry,
                    specular_delta: false,
                });
            }
        };
        let wi = p.frame.to_world(local).normalize_or_zero();
        let e = self.eval_prepared(&p, wi);
        if e.pdf.is_nan() || e.pdf <= 0.0 {
            return None;
        }
        let weight = e.value / e.pdf;
        if !weight.is_finite() {
            return None;
        }
        let kind = if p.frame.geometric_cos(wi) > 0.0 {
            LobeKind::Reflection
        } else {
            LobeKind::Transmission
        };
        Some(BsdfSample {
            wi,
            weight,
            pdf: e.pdf,
            kind,
            specular_delta: false,
        })
    }

    /// Weight of the subsurface lobe (RGB): diffuse weight × mixed base
    /// colour; zero when effective subsurface is 0.
    pub fn subsurface_weight(&self) -> Vec3 {
        self.subsurface.map_or(Vec3::ZERO, |s| s.weight)
    }

    /// The random-walk medium, when the material has subsurface scattering.
    pub fn subsurface_medium(&self) -> Option<SubsurfaceMedium> {
        self.subsurface.map(|s| s.medium)
    }

    fn prepare(&self, wo: Vec3) -> Option<Prepared> {
        let wo = wo.normalize_or_zero();
        let frame = self.normals.frame(wo)?;
        let wo = frame.to_local(wo);
        let eta = if frame.backfacing() { 1.0 / IOR } else { IOR };
        let mut weights = [0.0_f32; 4];
        weights[DIFFUSE] = mean(self.diffuse);
        if let Some((w, lobe)) = &self.specular {
            weights[SPECULAR_LOBE] = w * lobe.selection_weight(wo);
        }
        if let Some((w, lobe)) = &self.glass {
            weights[GLASS] = w * lobe.selection_weight(wo, eta);
        }
        if let Some(s) = &self.subsurface {
            weights[SUBSURFACE] = mean(s.weight);
        }
        let total: f32 = weights.iter().sum();
        let probability = if total > 0.0 {
            weights.map(|w| w / total)
        } else {
            [0.0; 4]
        };
        Some(Prepared {
            frame,
            wo,
            eta,
            probability,
        })
    }

    fn eval_prepared(&self, p: &Prepared, wi: Vec3) -> BsdfEval {
        let wi = wi.normalize_or_zero();
        let cos_g = p.frame.geometric_cos(wi);
        let local = p.frame.to_local(wi);
        let wo = p.wo;
        let mut value = Vec3::ZERO;
        let mut pdf = 0.0;
        if cos_g > 0.0 && local.z > 0.0 {
            if self.diffuse != Vec3::ZERO {
                value += self.diffuse * burley_cos(wo, local, self.roughness);
                pdf += p.probability[DIFFUSE] * cosine_pdf(local);
            }
            if let Some((w, lobe)) = &self.specular {
                value += lobe.value(wo, local) * *w;
                pdf += p.probability[SPECULAR_LOBE] * lobe.pdf(wo, local);
            }
            if let Some((w, lobe)) = &self.glass {
                let (v, d) = lobe.reflection(wo, local, p.eta);
                value += v * *w;
                pdf += p.probability[GLASS] * d;
            }
        } else if cos_g < 0.0 && local.z < 0.0 {
            if let Some((w, lobe)) = &self.glass {
                let (v, d) = lobe.transmission(wo, local, p.eta);
                value += v * *w;
                pdf += p.probability[GLASS] * d;
            }
        }
        if value.is_finite() && pdf.is_finite() {
            BsdfEval { value, pdf }
        } else {
            BsdfEval::ZERO
        }
    }
}

/// A delta-lobe sample, valid only on the side its kind implies.
fn delta_sample(p: &Prepared, local: Vec3, weight: Vec3, pdf: f32) -> Option<BsdfSample> {
    let wi = p.frame.to_world(local).normalize_or_zero();
    let cos_g = p.frame.geometric_cos(wi);
    let kind = if local.z > 0.0 && cos_g > 0.0 {
        LobeKind::Reflection
    } else if local.z < 0.0 && cos_g < 0.0 {
        LobeKind::Transmission
    } else {
        return None;
    };
    (weight.is_finite() && pdf > 0.0).then_some(BsdfSample {
        wi,
        weight,
        pdf,
        kind,
        specular_delta: true,
    })
}

/// Picks a lobe by `u` and returns it with `u` rescaled to [0, 1) within the
/// lobe's interval, for reuse.
fn pick(probability: &[f32; 4], u: f32) -> Option<(usize, f32)> {
    let last = probability.iter().rposition(|&q| q > 0.0)?;
    let mut start = 0.0;
    for (i, &q) in probability.iter().enumerate() {
        if q <= 0.0 {
            continue;
        }
        if u < start + q || i == last {
            return Some((i, clamp_unit((u - start) / q)));
        }
        start += q;
    }
    None
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}
