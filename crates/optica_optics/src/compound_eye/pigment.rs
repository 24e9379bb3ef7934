//! What a traced ray does to a fragment's colour: the pigment's absorption
//! (thesis §6.6, eq. 6.30), the lens surfaces' Fresnel loss, the escape
//! direction of a ray that leaves the eye, and the prefilter for facets
//! smaller than a pixel. The CPU twin of the material shader's last steps.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::lattice::Lattice;
use super::outcome::{Shade, ShadeFallback};
use super::prefilter_table::PrefilterTable;
use super::shading_path::{ShadeOptions, shade_fragment_with};
use crate::input::{self, InvalidInput};
use crate::ray::Ray;

/// The procedural pigment the plugin uses when no pigment texture is given:
/// each ommatidium's pigment plane is dark (absorbing) in a disc around its
/// lens's axis — the rhabdom the lens images onto — and clear outside.
///
/// The thesis maps a greyscale texture per cell and multiplies the lit
/// colour by it (§6.6: "the higher the absorption, the darker to the
/// observer"; eq. 6.30 `c = c_t(a + d) + s`). Here `c_t` is
/// `1 − darkness·(1 − smoothstep(radius − softness, radius + softness, ρ))`
/// with `ρ` the distance, in facets, from the pigment hit to the nearest
/// lens axis of the lattice (so it follows a hexagonal lattice too).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawDarkCentre")]
pub struct DarkCentre {
    radius: f64,
    softness: f64,
    darkness: f64,
}

#[derive(Deserialize)]
struct RawDarkCentre {
    radius: f64,
    softness: f64,
    darkness: f64,
}

impl TryFrom<RawDarkCentre> for DarkCentre {
    type Error = InvalidInput;
    fn try_from(r: RawDarkCentre) -> Result<Self, InvalidInput> {
        Self::new(r.radius, r.softness, r.darkness)
    }
}

impl Default for DarkCentre {
    /// A dark disc of 0.25 facets radius with an edge 0.08 facets soft,
    /// absorbing 90 %: the size of the dark pseudopupil facet in photographs
    /// of insect eyes, where the rhabdom's image fills about half the facet.
    fn default() -> Self {
        Self {
            radius: 0.25,
            softness: 0.08,
            darkness: 0.9,
        }
    }
}

impl DarkCentre {
    /// A dark disc of `radius` facets around each lens axis, its edge
    /// blurred over `±softness` facets, absorbing `darkness` (0 = none,
    /// 1 = black) of the light.
    ///
    /// Errors: a radius or softness that is not finite and `≥ 0`, a darkness
    /// outside `0..=1`.
    pub fn new(radius: f64, softness: f64, darkness: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            radius: input::non_negative("pigment dark radius (facets)", radius)?,
            softness: input::non_negative("pigment edge softness (facets)", softness)?,
            darkness: input::in_range("pigment darkness", darkness, 0.0, 1.0)?,
        })
    }

    /// Radius of the dark disc, facets.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Half-width of its soft edge, facets.
    pub fn softness(&self) -> f64 {
        self.softness
    }

    /// Fraction of the light it absorbs at the centre.
    pub fn darkness(&self) -> f64 {
        self.darkness
    }

    /// `c_t` at the pigment-plane texture coordinate `uv` (facets):
    /// `1 − darkness` on a lens axis, 1 far from every axis.
    pub fn transmission(&self, lattice: &Lattice, uv: DVec2) -> f64 {
        let rho = (uv - lattice.cell_of(uv).centre_uv).length();
        let clear = smoothstep(
            self.radius - self.softness,
            self.radius + self.softness,
            rho,
        );
        1.0 - self.darkness * (1.0 - clear)
    }
}

/// WGSL's `smoothstep`: 0 below `e0`, 1 above `e1`, Hermite in between (a
/// step at `e0` when the edges coincide).
pub(crate) fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    if e1 <= e0 {
        return if x < e0 { 0.0 } else { 1.0 };
    }
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How a traced fragment changes the surface colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FacetResponse {
    /// The factor on the surface's diffuse and ambient colour: `c_t` of
    /// eq. 6.30, times the lens surfaces' transmittance when Fresnel is on.
    /// 1 for a ray that reaches no pigment.
    pub multiplier: f64,
    /// For a ray that leaves the eye after its lenses: the unit direction it
    /// leaves in and the weight (0–1) with which the environment seen that
    /// way replaces the lit surface colour.
    pub escape: Option<(DVec3, f64)>,
}

/// The facet response of one fragment: [`shade_fragment_with`], then the
/// pigment's `c_t` ([`DarkCentre::transmission`]) and, with `fresnel`, the
/// transmittance of the lens surfaces. Fallbacks (a lens that reflects the
/// ray, an overflow) leave the colour as it is (`multiplier` 1).
pub fn facet_response(
    lattice: &Lattice,
    fragment: &Ray,
    options: &ShadeOptions,
    pigment: &DarkCentre,
    fresnel: bool,
) -> FacetResponse {
    match shade_fragment_with(lattice, fragment, options) {
        Shade::Pigment(hit) => {
            let t = if fresnel { hit.transmittance } else { 1.0 };
            FacetResponse {
                multiplier: pigment.transmission(lattice, hit.uv) * t,
                escape: None,
            }
        }
        Shade::Fallback(ShadeFallback::Escaped { dir, .. }) => FacetResponse {
            multiplier: 1.0,
            escape: Some((dir, 1.0)),
        },
        Shade::Fallback(_) => FacetResponse {
            multiplier: 1.0,
            escape: None,
        },
    }
}

/// Facets per pixel at which the prefilter starts to blend in the facet
/// average: below a quarter, a pixel sees one facet's detail sharply.
pub const PREFILTER_START: f64 = 0.25;

/// Facets per pixel at which only the facet average is left: a pixel
/// covering a whole facet cannot show where in it the view ray landed.
pub const PREFILTER_FULL: f64 = 1.0;

/// The positions (in facets, relative to the fragment's lens centre) the
/// facet average is taken over: a 3×3 stratified pattern, the centres of a
/// 3×3 split of the unit square, which holds the square cell and most of the
/// hexagonal one.
pub const PREFILTER_OFFSETS: [[f64; 2]; 9] = [
    [-1.0 / 3.0, -1.0 / 3.0],
    [0.0, -1.0 / 3.0],
    [1.0 / 3.0, -1.0 / 3.0],
    [-1.0 / 3.0, 0.0],
    [0.0, 0.0],
    [1.0 / 3.0, 0.0],
    [-1.0 / 3.0, 1.0 / 3.0],
    [0.0, 1.0 / 3.0],
    [1.0 / 3.0, 1.0 / 3.0],
];

/// How much of the facet average a fragment whose pixel spans `footprint`
/// facets shows: smoothstep from [`PREFILTER_START`] to [`PREFILTER_FULL`]
/// (0 for a footprint that is not finite).
fn prefilter_weight(footprint: f64) -> f64 {
    let footprint = if footprint.is_finite() {
        footprint
    } else {
        0.0
    };
    smoothstep(PREFILTER_START, PREFILTER_FULL, footprint)
}

/// The prefiltered facet response of a fragment whose pixel spans
/// `footprint` facets: [`facet_response`] where facets are large, blended
/// (smoothstep from [`PREFILTER_START`] to [`PREFILTER_FULL`]) into the
/// average response of the fragment's own facet for the same view direction
/// ([`PREFILTER_OFFSETS`]), where they shrink below a pixel.
///
/// Why the facet average: when a pixel covers many facets, neighbouring
/// facets are seen from almost the same direction, so the pixel's mean is
/// the mean over positions within one facet. That keeps the pseudopupil (a
/// pattern of many facets, set by the view direction) and removes the
/// per-facet detail that would alias into moiré. Escaping rays count as
/// unabsorbed in the average, and their environment weight fades with it.
pub fn facet_response_prefiltered(
    lattice: &Lattice,
    fragment: &Ray,
    options: &ShadeOptions,
    pigment: &DarkCentre,
    fresnel: bool,
    footprint: f64,
) -> FacetResponse {
    let point = facet_response(lattice, fragment, options, pigment, fresnel);
    let w = prefilter_weight(footprint);
    if w <= 0.0 {
        return point;
    }
    let axes = lattice.axes();
    let centre = lattice.cell_of(axes.uv_of(fragment.origin())).centre_uv;
    let mut sum = 0.0;
    for [du, dv] in PREFILTER_OFFSETS {
        let p = axes.point_of(centre + DVec2::new(du, dv));
        let r = facet_response(
            lattice,
            &Ray::from_unit(p, fragment.dir()),
            options,
            pigment,
            fresnel,
        );
        sum += r.multiplier;
    }
    let average = sum / PREFILTER_OFFSETS.len() as f64;
    FacetResponse {
        multiplier: (1.0 - w) * point.multiplier + w * average,
        escape: point.escape.map(|(dir, e)| (dir, e * (1.0 - w))),
    }
}

/// The shader's prefilter with a [`PrefilterTable`] (its default where the
/// pigment is the procedural one): [`facet_response`] where facets are
/// large, blended (smoothstep from [`PREFILTER_START`] to
/// [`PREFILTER_FULL`]) into the table's facet average for the fragment's
/// view direction where they shrink below a pixel. The escape weight is
/// blended the same way; its direction is the fragment's own ray's where
/// that escapes, the table's mean otherwise. Where the table alone counts
/// (`w = 1`), the fragment's own ray is not traced.
pub fn facet_response_tabled(
    lattice: &Lattice,
    fragment: &Ray,
    options: &ShadeOptions,
    pigment: &DarkCentre,
    fresnel: bool,
    footprint: f64,
    table: &PrefilterTable,
) -> FacetResponse {
    let w = prefilter_weight(footprint);
    let point = if w < 1.0 {
        facet_response(lattice, fragment, options, pigment, fresnel)
    } else {
        FacetResponse {
            multiplier: 1.0,
            escape: None,
        }
    };
    if w <= 0.0 {
        return point;
    }
    let t = table.sample(lattice.axes(), fragment.dir());
    let own = point.escape.map_or(0.0, |(_, e)| e);
    let escape = (1.0 - w) * own + w * t.escape;
    let dir = point.escape.map_or(t.escape_dir, |(d, _)| d);
    FacetResponse {
        multiplier: (1.0 - w) * point.multiplier + w * t.multiplier,
        escape: (escape > 0.0).then_some((dir, escape)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compound_eye::lattice::LensParams;
    use crate::compound_eye::lattice_kind::LatticeKind;
    use crate::compound_eye::texture_axes::TextureAxes;
    use crate::input::Expected;

    fn lattice(kind: LatticeKind) -> Lattice {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        Lattice::with_kind(axes, LensParams::thesis(0.5, 1.5).unwrap(), kind).unwrap()
    }

    fn fragment(x: f64, y: f64, polar_deg: f64, azimuth_deg: f64) -> Ray {
        let (t, p) = (polar_deg.to_radians(), azimuth_deg.to_radians());
        Ray::new(
            DVec3::new(x, y, 0.0),
            DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), -t.cos()),
        )
        .unwrap()
    }

    #[test]
    fn dark_centre_absorbs_on_the_axis_and_not_between() {
        let p = DarkCentre::default();
        for kind in [LatticeKind::Square, LatticeKind::Hexagonal] {
            let l = lattice(kind);
            let axis = kind.centre_of_index([2, 1]);
            assert!(
                (p.transmission(&l, axis) - (1.0 - p.darkness())).abs() < 1e-12,
                "{kind:?}"
            );
            // Half a facet from every axis (between two lenses): clear.
            let between = 0.5 * (kind.centre_of_index([2, 1]) + kind.centre_of_index([3, 1]));
            assert!(
                (p.transmission(&l, between) - 1.0).abs() < 1e-12,
                "{kind:?}"
            );
        }
        assert_eq!(smoothstep(0.2, 0.2, 0.1), 0.0);
        assert_eq!(smoothstep(0.2, 0.2, 0.2), 1.0);
        let e = DarkCentre::new(0.2, 0.05, 1.5).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            ("pigment darkness", Expected::Range { min: 0.0, max: 1.0 })
        );
        assert_eq!(
            DarkCentre::new(f64::NAN, 0.05, 0.5).unwrap_err().what,
            "pigment dark radius (facets)"
        );
        let json = r#"{"radius": -1.0, "softness": 0.1, "darkness": 0.5}"#;
        assert!(serde_json::from_str::<DarkCentre>(json).is_err());
    }

    #[test]
    fn the_pseudopupil_facet_is_dark_and_fresnel_darkens_more() {
        let l = lattice(LatticeKind::Square);
        let p = DarkCentre::default();
        let on_axis = fragment(0.5, 0.5, 0.0, 0.0);
        let plain = facet_response(&l, &on_axis, &ShadeOptions::thesis(8), &p, false);
        assert!(
            (plain.multiplier - 0.1).abs() < 1e-12 && plain.escape.is_none(),
            "{plain:?}"
        );
        let lossy = facet_response(&l, &on_axis, &ShadeOptions::thesis(8), &p, true);
        assert!((lossy.multiplier - 0.1 * 0.9216).abs() < 1e-12, "{lossy:?}");
    }

    #[test]
    fn prefilter_blends_from_the_point_to_the_facet_average() {
        let l = lattice(LatticeKind::Hexagonal);
        let p = DarkCentre::default();
        let o = ShadeOptions::neighbours(8);
        let frag = fragment(0.31, 0.2, 25.0, 40.0);
        let point = facet_response(&l, &frag, &o, &p, true);
        assert_eq!(
            facet_response_prefiltered(&l, &frag, &o, &p, true, 0.1),
            point
        );
        assert_eq!(
            facet_response_prefiltered(&l, &frag, &o, &p, true, f64::NAN),
            point
        );
        // Beyond one facet per pixel, every fragment of a facet shows the same average.
        let a = facet_response_prefiltered(&l, &frag, &o, &p, true, 2.0);
        let b = facet_response_prefiltered(&l, &fragment(0.05, 0.1, 25.0, 40.0), &o, &p, true, 2.0);
        assert!(
            (a.multiplier - b.multiplier).abs() < 1e-12,
            "{a:?} vs {b:?}"
        );
        let half = facet_response_prefiltered(&l, &frag, &o, &p, true, 0.625);
        assert!((half.multiplier - 0.5 * (point.multiplier + a.multiplier)).abs() < 1e-12);
        // The average still follows the view direction: the pseudopupil stays.
        let head_on =
            facet_response_prefiltered(&l, &fragment(0.3, 0.2, 0.0, 0.0), &o, &p, true, 2.0);
        let oblique =
            facet_response_prefiltered(&l, &fragment(0.3, 0.2, 45.0, 0.0), &o, &p, true, 2.0);
        assert!(
            head_on.multiplier < oblique.multiplier,
            "{head_on:?} vs {oblique:?}"
        );
    }

    #[test]
    fn a_ray_leaving_the_eye_reports_its_direction() {
        // n < 1 bends the ray away from the axis; at the lens's side a steep
        // ray leaves upward after the exit refraction.
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        let l = Lattice::new(axes, LensParams::thesis(0.5, 0.8).unwrap()).unwrap();
        let p = DarkCentre::default();
        let mut escaped = 0;
        for k in 0..400 {
            let (x, y) = (
                (k % 20) as f64 / 20.0 + 0.025,
                (k / 20) as f64 / 20.0 + 0.025,
            );
            let r = facet_response(
                &l,
                &fragment(x, y, 60.0, 10.0),
                &ShadeOptions::thesis(16),
                &p,
                false,
            );
            if let Some((dir, w)) = r.escape {
                escaped += 1;
                assert!(
                    dir.z > 0.0
                        && (dir.length() - 1.0).abs() < 1e-12
                        && w == 1.0
                        && r.multiplier == 1.0
                );
            }
        }
        assert!(escaped > 0, "no ray escaped");
    }
}
