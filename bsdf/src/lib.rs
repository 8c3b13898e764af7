//! matscan's Principled BSDF: one definition of the material model that the
//! simulated rig renders with and the estimator fits, so that the two can
//! never drift apart.
//!
//! - [`material`]: the Principled BSDF inputs at a point and the thesis's
//!   fixed constants (specular 0.5, IOR 1.45);
//! - [`Bsdf`]: the BSDF itself, below.
//!
//! Boundaries: pure functions of directions, normals and a [`Material`];
//! no ray tracing, no light transport, no images. Crate choices: `glam` for
//! vectors (the workspace's one vector type); nothing else at run time.
//!
//! The Principled BSDF as Blender 2.9x Cycles evaluates it for the thesis's
//! fixed inputs (specular 0.5, IOR 1.45, specular tint, sheen, clearcoat and
//! anisotropy 0), in world space for the path tracer: [`Bsdf::eval`] for
//! light sampling, [`Bsdf::sample`] for continuing paths, and the subsurface
//! medium and exit lobe for the integrator's random walk; inputs are a
//! [`Material`] and the normals at one point.
//!
//! # Mixing (Cycles `svm_node_closure_bsdf`, principled branch)
//!
//! With the sanitized inputs, `final_transmission = transmission (1 -
//! metallic)` (thesis eq. 3.5):
//! - **diffuse**: weight `(1 - metallic)(1 - transmission)` × mixed base
//!   colour, Burley diffuse with retro-reflection (module `diffuse`). The mixed
//!   subsurface base colour (thesis eq. 3.14) equals the base colour because
//!   the simulated rig sets subsurface colour = base colour.
//! - **subsurface**: as in Cycles 2.9x, *any* `subsurface` > 1e-5 sends the
//!   whole diffuse weight to the random-walk BSSRDF, with scattering
//!   distance `subsurface × subsurface_radius`; small `subsurface` therefore
//!   looks diffuse because the radius is small. (Blender 4.x instead splits
//!   `(1 - subsurface)` diffuse + `subsurface` BSSRDF; the thesis used 2.9x.)
//!   Effective subsurface is zero exactly when this lobe is absent (thesis
//!   eq. 3.6). Channels with distance < 1e-8 stay Burley diffuse.
//! - **specular**: weight `1 - final_transmission`, GGX reflection with
//!   alpha = roughness², Fresnel = Cycles' principled blend from
//!   `cspec0 = 0.04 (1 - metallic) + basecolor × metallic` to white, driven
//!   by the dielectric Fresnel of IOR 1.5 (= specular 0.5) (module `specular`).
//! - **transmission**: weight `final_transmission`, rough dielectric with
//!   IOR 1.45, same roughness, reflection white, refraction tinted by the
//!   base colour (module `glass`).
//!
//! The lobes are added, not layered: that is Cycles 2.9x's principled BSDF,
//! and it is not energy conserving for dielectrics. Burley diffuse alone
//! reflects 0.976..1.036 at normal incidence and up to ~1.5 at grazing view
//! for roughness 1 (retro-reflection), and the specular is added on top:
//! white dielectric albedo measured 1.02 (roughness 0) to 1.05 (roughness 1)
//! at normal incidence, 1.42 to 1.56 at 89° view.
//!
//! # Multiple scattering
//!
//! Cycles 2.9x uses its stochastic "Multiscatter GGX" above roughness 0.075.
//! We use single-scattering GGX (separable Smith G, as Cycles' GGX) plus the
//! Kulla-Conty (2017) compensation lobe
//! `F_ms (1 - E(μo))(1 - E(μi)) / (π (1 - E_avg))`, with
//! `F_ms = F_avg² E_avg / (1 - F_avg (1 - E_avg))`, where E is the
//! directional albedo table integrated in code on first use (module `energy`).
//! It is reciprocal and makes a white metal reflect 1 at every roughness
//! (measured 0.998..1.002). The glass lobe is single-scattering Walter et al.
//! divided by its white directional albedo E(μo) (tabulated per side of the
//! interface), so white glass also keeps all its energy at every roughness,
//! as Cycles' multiscatter glass does; that renormalization is not
//! reciprocal. Without it, white glass at roughness 1 would keep only 0.90
//! at normal incidence and 0.32 at grazing from outside.
//!
//! # Delta lobes
//!
//! As Cycles, alpha <= [`DELTA_ALPHA`] (roughness < ~0.0178) makes the
//! specular and glass lobes perfect mirror / smooth refraction: `eval`
//! excludes them (point lights cannot reach them) and `sample` returns them
//! with `specular_delta = true`. Above it, D and G are computed in a
//! cancellation-free form, so alpha near the threshold stays precise.
//!
//! # Sampling and MIS
//!
//! `sample` picks one lobe with probability proportional to its estimated
//! albedo seen from `wo` (Cycles' closure sample weights: mean weight for
//! diffuse and subsurface, mean Fresnel at the normal for specular, Fresnel
//! white + transmitted tint for glass), samples it (cosine for diffuse;
//! visible normals for GGX, mixed with a cosine share 1 - E(μo) for the
//! specular's multiple-scattering part; microfacet Fresnel choice between
//! reflection and refraction for glass), then
//! returns `weight = Σ f cos / Σ p_lobe pdf_lobe` over all non-delta lobes
//! (one-sample MIS, as Cycles' `shader_bsdf_sample` sums the closures). The
//! `pdf` it reports is that sum, identical to `eval(wo, wi).pdf`.
//!
//! # Subsurface entry and exit
//!
//! A `SubsurfaceEntry` sample is Cycles 2.9x's random-walk start: a cosine
//! direction around `-n` (rejected unless below the geometric surface),
//! weight = closure weight / albedo / selection probability (the walk
//! supplies the colour through the single-scattering albedo), no Fresnel.
//! [`SubsurfaceMedium`] gives σt and the single-scattering albedo by Cycles'
//! remap (formula in module `subsurface`), and [`SubsurfaceExit`] the Burley exit
//! lobe at the point where the walk leaves.
//!
//! # Geometry conventions
//!
//! `wo`, `wi` point away from the surface; both are normalized on entry.
//! - `wo` below the geometric surface: like Cycles for a back-facing hit, both
//!   normals are flipped toward `wo` and the glass uses IOR 1/1.45 (inside
//!   looking out). So a surface seen from behind shades like its front.
//! - The shading normal is bent per `wo` so that the mirror reflection stays
//!   above the geometric surface (Cycles' `ensure_valid_reflection`); a
//!   shading normal on the far side of the geometric one is replaced by it.
//! - `wi` on `wo`'s side of the geometric surface and above the shading
//!   surface: reflection lobes only. `wi` on the other side and below the
//!   shading surface: the glass transmission only. Mixed cases (the two
//!   normals disagree about `wi`) evaluate to zero.
//! - `wo` in the geometric plane, or any non-finite input: zero / None.
//! - Degenerate normals (zero, NaN) fall back to the other normal, or +Z.
//!
//! Transmission keeps Cycles' convention of not scaling radiance by 1/eta²
//! (see module `glass`). `eval` is reciprocal for the diffuse and specular lobes
//! (tested); the glass lobe is not (renormalization, eta²), nor are pairs
//! where the shading normal had to be bent, since the bend depends on `wo`.

pub mod material;

mod diffuse;
mod energy;
mod frame;
mod fresnel;
mod ggx;
mod glass;
mod lobe;
mod principled;
mod specular;
mod subsurface;

#[cfg(test)]
mod tests;

pub use fresnel::{fresnel_dielectric_cos, specular_ior};
pub use ggx::{ggx_d, ggx_g1};
pub use lobe::{BsdfEval, BsdfSample, LobeKind};
pub use material::Material;
pub use principled::{Bsdf, CLOSURE_WEIGHT_CUTOFF, DELTA_ALPHA};
pub use subsurface::{
    extinction, single_scattering_albedo, SubsurfaceExit, SubsurfaceMedium, BSSRDF_MIN_RADIUS,
};
