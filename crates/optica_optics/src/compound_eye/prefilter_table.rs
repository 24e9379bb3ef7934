//! The facet-averaged response as a function of the view direction, for
//! facets smaller than a pixel: a table precomputed from the shading path
//! (the exact tracer's, by default) that the shader reads instead of
//! tracing rays.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::error::CompoundEyeError;
use super::lattice::{Lattice, LensParams};
use super::lattice_kind::LatticeKind;
use super::pigment::{DarkCentre, FacetResponse, facet_response};
use super::shading_path::ShadeOptions;
use super::texture_axes::TextureAxes;
use crate::ray::Ray;

/// Columns of the table: view azimuths over one rotation period of the
/// lattice (90° square, 60° hexagonal), at texel centres.
pub const TABLE_AZIMUTHS: usize = 16;
/// Rows of the table: view angles from the normal, 0°–90°, at texel
/// centres.
pub const TABLE_POLARS: usize = 32;
/// Rays per axis of the stratified grid over one cell that each entry
/// averages (144 rays).
pub const TABLE_SAMPLES: usize = 12;

/// The facet average of [`facet_response`] for every view direction, on a
/// lattice of undistorted cells: per entry the mean factor on the surface
/// colour (`c_t·T`, escaping rays counting as 1, as in
/// [`facet_response_prefiltered`](super::facet_response_prefiltered)), the
/// share of rays that escape, and their mean direction.
///
/// Why a table: once a pixel covers a facet or more, what it shows is the
/// average over the facet, and that average depends only on the direction
/// the lattice is seen from (the lattice is periodic). Nine traced rays a
/// fragment estimated it with visible noise (ꟻLIP 0.14 against a
/// supersampled render at 0.5 px per facet) for 3.5× a plain material's
/// frame; 144 rays per entry, computed once per setting, cost the shader
/// one bilinear read.
///
/// Stretched or sheared UVs make cells that are not the table's: there the
/// average is that of the undistorted cell seen from the same direction.
#[derive(Debug, Clone, PartialEq)]
pub struct PrefilterTable {
    kind: LatticeKind,
    /// Row-major, `TABLE_POLARS` rows of `TABLE_AZIMUTHS`: mean factor,
    /// escape share, mean escape direction's two in-plane components (in
    /// the lattice's frame: along `U_p`, and across it towards `V_p`).
    texels: Vec<[f32; 4]>,
}

/// What the table gives for one view direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableSample {
    /// Mean factor on the surface colour.
    pub multiplier: f64,
    /// Share of the rays that leave the eye.
    pub escape: f64,
    /// Their mean direction, in world space (unit).
    pub escape_dir: DVec3,
}

impl PrefilterTable {
    /// Builds the table for touching-or-smaller lenses of `lens_radius` (a
    /// fraction of the cell inradius), `index` and pigment `depth` (lens
    /// radii), the `pigment` and Fresnel switch, traced with `options`.
    pub fn build(
        kind: LatticeKind,
        lens_radius: f64,
        index: f64,
        depth: f64,
        pigment: &DarkCentre,
        fresnel: bool,
        options: &ShadeOptions,
    ) -> Result<Self, CompoundEyeError> {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z)?;
        let r = lens_radius * kind.cell_inradius(axes.u(), axes.v());
        let lattice = Lattice::with_kind(axes, LensParams::new(r, index, depth * r)?, kind)?;
        let period = rotation_period(kind);
        let texels = (0..TABLE_POLARS * TABLE_AZIMUTHS)
            .into_par_iter()
            .map(|k| {
                let polar = (k / TABLE_AZIMUTHS) as f64 + 0.5;
                let azimuth = (k % TABLE_AZIMUTHS) as f64 + 0.5;
                let theta = polar / TABLE_POLARS as f64 * std::f64::consts::FRAC_PI_2;
                let phi = azimuth / TABLE_AZIMUTHS as f64 * period;
                let dir = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    -theta.cos(),
                );
                average(&lattice, dir, options, pigment, fresnel)
            })
            .collect();
        Ok(Self { kind, texels })
    }

    /// The entries, row-major: [`TABLE_POLARS`] rows of [`TABLE_AZIMUTHS`].
    pub fn texels(&self) -> &[[f32; 4]] {
        &self.texels
    }

    /// The table's value for a ray along `dir` into the lattice of `axes`
    /// (its normal outward), read as the shader reads it: bilinear between
    /// texel centres, repeating in azimuth, clamped in the polar angle.
    pub fn sample(&self, axes: &TextureAxes, dir: DVec3) -> TableSample {
        let (u_hat, w_hat, n) = lattice_frame(axes);
        let d = dir.normalize();
        let polar = (-d.dot(n)).clamp(-1.0, 1.0).acos();
        let azimuth = d.dot(w_hat).atan2(d.dot(u_hat));
        let x = azimuth / rotation_period(self.kind) * TABLE_AZIMUTHS as f64 - 0.5;
        let y = (polar / std::f64::consts::FRAC_PI_2 * TABLE_POLARS as f64 - 0.5)
            .clamp(0.0, (TABLE_POLARS - 1) as f64);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |i: f64, j: f64| {
            let i = (i as i64).rem_euclid(TABLE_AZIMUTHS as i64) as usize;
            let j = (j as usize).min(TABLE_POLARS - 1);
            self.texels[j * TABLE_AZIMUTHS + i].map(f64::from)
        };
        let mix =
            |a: [f64; 4], b: [f64; 4], t: f64| std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t);
        let v: [f64; 4] = mix(
            mix(texel(x0, y0), texel(x0 + 1.0, y0), fx),
            mix(texel(x0, y0 + 1.0), texel(x0 + 1.0, y0 + 1.0), fx),
            fy,
        );
        let tangent = v[2] * u_hat + v[3] * w_hat;
        let up = (1.0 - tangent.length_squared()).max(0.0).sqrt();
        TableSample {
            multiplier: v[0],
            escape: v[1],
            escape_dir: (tangent + up * n).normalize_or_zero(),
        }
    }
}

/// The lattice's frame: `U_p`'s direction, the in-plane direction across
/// it towards `V_p`, and the outward normal.
fn lattice_frame(axes: &TextureAxes) -> (DVec3, DVec3, DVec3) {
    let n = axes.normal();
    let u_hat = axes.u().normalize();
    let w = axes.v() - axes.v().dot(u_hat) * u_hat;
    (u_hat, w.normalize(), n)
}

/// The angle the lattice repeats under when turned about its normal.
fn rotation_period(kind: LatticeKind) -> f64 {
    match kind {
        LatticeKind::Square => std::f64::consts::FRAC_PI_2,
        LatticeKind::Hexagonal => std::f64::consts::FRAC_PI_3,
    }
}

/// One entry: the response averaged over a stratified grid of one cell.
fn average(
    lattice: &Lattice,
    dir: DVec3,
    options: &ShadeOptions,
    pigment: &DarkCentre,
    fresnel: bool,
) -> [f32; 4] {
    let kind = lattice.kind();
    let (mut factor, mut escaped, mut escape_dir) = (0.0, 0.0, DVec3::ZERO);
    for i in 0..TABLE_SAMPLES {
        for j in 0..TABLE_SAMPLES {
            let w = DVec2::new(i as f64 + 0.5, j as f64 + 0.5) / TABLE_SAMPLES as f64;
            let p = lattice.axes().point_of(kind.from_lattice(w));
            let Ok(ray) = Ray::new(p, dir) else { continue };
            let FacetResponse { multiplier, escape } =
                facet_response(lattice, &ray, options, pigment, fresnel);
            factor += multiplier;
            if let Some((d, weight)) = escape {
                escaped += weight;
                escape_dir += weight * d;
            }
        }
    }
    let n = (TABLE_SAMPLES * TABLE_SAMPLES) as f64;
    let mean_dir = escape_dir.normalize_or_zero();
    [
        (factor / n) as f32,
        (escaped / n) as f32,
        mean_dir.x as f32,
        mean_dir.y as f32,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(kind: LatticeKind, index: f64) -> PrefilterTable {
        PrefilterTable::build(
            kind,
            1.0,
            index,
            2.0,
            &DarkCentre::default(),
            true,
            &ShadeOptions::exact(16),
        )
        .unwrap()
    }

    #[test]
    fn the_table_is_the_average_of_many_traced_rays() {
        for kind in [LatticeKind::Square, LatticeKind::Hexagonal] {
            let t = table(kind, 1.5);
            assert_eq!(t.texels().len(), TABLE_POLARS * TABLE_AZIMUTHS);
            assert!(t.texels().iter().flatten().all(|v| v.is_finite()));
            // Straight down the axis, a dark-centre pigment darkens the
            // average (the pseudopupil); nothing escapes.
            let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
            let down = t.sample(&axes, -DVec3::Z);
            assert!(down.multiplier < 0.9 && down.escape == 0.0, "{down:?}");
            // The table at a direction between texels agrees with a fresh
            // average there to within its interpolation.
            let r = 1.0 * kind.cell_inradius(DVec3::X, DVec3::Y);
            let lattice =
                Lattice::with_kind(axes, LensParams::new(r, 1.5, 2.0 * r).unwrap(), kind).unwrap();
            let dir = DVec3::new(0.31, 0.12, -0.6).normalize();
            let direct = average(
                &lattice,
                dir,
                &ShadeOptions::exact(16),
                &DarkCentre::default(),
                true,
            );
            let read = t.sample(&axes, dir);
            assert!(
                (read.multiplier - f64::from(direct[0])).abs() < 0.05,
                "{kind:?}: table {read:?}, direct {direct:?}"
            );
        }
    }

    #[test]
    fn the_table_turns_and_mirrors_with_the_lattice() {
        let t = table(LatticeKind::Hexagonal, 1.4);
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        let dir = DVec3::new(0.5, 0.2, -0.7).normalize();
        let here = t.sample(&axes, dir);
        // The same lattice turned by 40° about its normal, seen from the
        // direction turned with it, reads the same entry.
        let turn = glam::DQuat::from_rotation_z(0.7);
        let turned =
            TextureAxes::from_axes(DVec3::ZERO, turn * DVec3::X, turn * DVec3::Y, DVec3::Z)
                .unwrap();
        let there = t.sample(&turned, turn * dir);
        assert!((here.multiplier - there.multiplier).abs() < 1e-9);
        // Lenses of index 1.0 bend nothing: at 0.1 rad the average is the
        // pigment's own over the cell, and no ray escapes.
        let flat = table(LatticeKind::Square, 1.0);
        let s = flat.sample(&axes, DVec3::new(0.1, 0.0, -1.0).normalize());
        assert!(
            s.escape == 0.0 && s.multiplier > 0.0 && s.multiplier < 1.0,
            "{s:?}"
        );
    }
}
