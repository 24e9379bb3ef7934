//! The user-facing components: [`LensFlare`] on a camera, [`FlareSource`]
//! on the lights that flare.

use bevy::prelude::*;

use optica_optics::input::{self, Expected, InvalidInput};
use optica_optics::lens_flare::band_wavelengths;

use crate::{Error, FlareGhosts, LensAsset};

/// Most rays per side of a ghost's grid.
pub const MAX_GRID: u32 = 512;
/// Most wavelengths a flare is traced at.
pub const MAX_WAVELENGTHS: u32 = 16;
/// [`LensFlare::coarse_ghost_px`]'s default.
pub const DEFAULT_COARSE_GHOST_PX: f32 = 64.0;
/// [`LensFlare::merge_cells`]'s default.
pub const DEFAULT_MERGE_CELLS: f32 = 0.5;
/// [`LensFlare::merge_wavelengths_px`]'s default.
pub const DEFAULT_MERGE_WAVELENGTHS_PX: f32 = 2.0;

/// Physically based lens flare on a camera: ghosts (light reflected twice
/// inside the lens) traced through a real lens prescription.
///
/// The ghosts are light: they are added to the camera's HDR target (the
/// component requires [`Hdr`](bevy::camera::Hdr)) before bloom, which
/// spreads them, and tonemapping.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_lens_flare::{FlareSource, LensFlare};
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>) {
///     commands.spawn((
///         Camera3d::default(),
///         LensFlare::new(assets.load(optica_lens_flare::lenses::DOUBLE_GAUSS)),
///     ));
///     commands.spawn((DirectionalLight::default(), FlareSource::default()));
/// }
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component)]
#[require(bevy::camera::Hdr, FlareGhosts)]
pub struct LensFlare {
    /// The lens the light passes through.
    pub lens: Handle<LensAsset>,
    /// Rays per side of each ghost's grid, `2..=512`: the quality knob
    /// (the report sweeps it against a 512² reference). With
    /// [`LensFlare::adaptive_grid`] (the default) it is the mean: the
    /// ghosts trace the rays of `grid²` each in all, shared by power.
    pub grid: u32,
    /// Shares the rays among the ghosts by the power each carries (the
    /// blog's adaptive resolution, with power as the measure): a ghost's
    /// grid follows the cube root of its estimated power, from 8 to 512
    /// rays per side, which least misplaces the flare's light for the
    /// rays (`optica_optics::lens_flare::grid_sizes_by_power`); `false`
    /// traces every ghost at `grid²`. On by default: on the double Gauss
    /// (83 ghosts at 512², one of which carries half the light) a mean of
    /// 16² follows the reference more closely than a fixed 32² (relative
    /// L1 0.08 against 0.12, both at half resolution; the `lens_flare`
    /// report's `rendered` and `fixed grid` series, at 1e45d9f,
    /// 2026-12-03) with a quarter of the triangles. (Sizing by how much a
    /// ghost deforms, the blog's measure, gave its smooth bright ghosts too
    /// few rays: 0.29 against 0.15, at aa5f021, 2026-12-01; no current
    /// series measures it.)
    pub adaptive_grid: bool,
    /// Uses the lens's axial symmetry (the blog's *Symmetry*): each grid is
    /// traced for the light turned into one meridional plane, where the
    /// ghost is mirror symmetric, so only half its rows are traced; the
    /// result is turned back to the light's azimuth.
    pub symmetry: bool,
    /// Wavelengths traced, `1..=16`, spread over 420–680 nm (dispersion:
    /// ghosts move and change colour with the wavelength). Each ghost's
    /// light and colour are those of the whole band at any count: the
    /// traced wavelengths are scaled per ghost by its throughput over the
    /// band (`optica_optics::lens_flare::GhostSpectrum`), so fewer only
    /// loses the colour fringes of dispersion.
    pub wavelengths: u32,
    /// A ghost whose image moves by less than this many pixels across the
    /// band (where the ghosts are added up: see
    /// [`LensFlare::ghost_resolution`], and half that resolution for the
    /// large ghosts of [`LensFlare::coarse_ghost_px`]) is drawn once, at
    /// the middle wavelength, in the colour of the whole band, instead of
    /// once per wavelength: a third of its cells and pixels at three
    /// wavelengths. Below a pixel its wavelengths would draw the same
    /// image; above, the price is its colour fringes, at most this wide.
    /// `0` draws every wavelength of every ghost. Measured per ghost and
    /// degree of field angle
    /// (`optica_optics::lens_flare::GhostSpectrum::spread_mm`).
    ///
    /// On the double Gauss at 512² on lavapipe (report series `merged
    /// wavelengths (defaults)`), the default 2 takes the flare's passes
    /// from 12.6 ms to 10.5 ms and the frame from 1.50× [1.48, 1.52] to
    /// 1.43× [1.42, 1.46] the frame without the flare, against 1, at a
    /// relative L1 against the reference of 0.1433 instead of 0.1385
    /// (0.1263 at 0, every wavelength drawn).
    pub merge_wavelengths_px: f32,
    /// The iris.
    pub aperture: ApertureSettings,
    /// A single-layer anti-reflection coating put on every glass–air
    /// interface, or `None` for the coatings the lens file gives.
    pub coating: Option<CoatingSettings>,
    /// Overall brightness of the flare, multiplying the physical result.
    pub intensity: f32,
    /// Most ghosts drawn: the brightest by the estimate are kept.
    pub ghost_budget: u32,
    /// Ghosts dimmer than this fraction of the brightest are left out.
    pub min_relative: f32,
    /// Occlusion by the scene's depth (a light behind a wall does not
    /// flare), or `None` to let every light flare whatever is in front.
    pub occlusion: Option<FlareOcclusion>,
    /// The starburst round each light (the aperture's diffraction), or
    /// `None`.
    pub starburst: Option<StarburstSettings>,
    /// Ripples at the edge of each ghost (the aperture's Fresnel
    /// diffraction), or `None` for sharp-edged ghosts.
    pub ringing: Option<RingingSettings>,
    /// The resolution the ghosts are added up at before they are scaled up
    /// onto the view (the starburst is always drawn at full resolution).
    pub ghost_resolution: GhostResolution,
    /// A ghost whose image is wider than this many pixels where the ghosts
    /// are added up (see [`LensFlare::ghost_resolution`]) is added up at
    /// half that resolution, a quarter of its pixels, and scaled up with
    /// the rest (its grid stays as fine). Large ghosts are the defocused
    /// ones, smooth inside, and their softened iris edge is a small part of
    /// their light; they are also most of the flare's pixels: on the zoom
    /// (311 ghosts, 1280×720) the default cuts the fragments shaded from
    /// 9.4 M to 2.1 M and the flare's passes from 52–55 ms to 23–25 ms on
    /// lavapipe in two full runs (series `zoom 1280x720, no coarse ghosts` against
    /// `zoom 1280x720`). The price is softer edges on the bright large
    /// ghosts: on the double Gauss at 512² the relative L1 against the
    /// reference goes from 0.11 to 0.14 (128 px: 0.14; series
    /// `no coarse ghosts (defaults)` against `coarse ghosts (defaults)`).
    /// `None` adds every ghost up at `ghost_resolution`; `Some(0.0)` every
    /// ghost at half of it.
    pub coarse_ghost_px: Option<f32>,
    /// A large ghost's cells (those added up at half resolution, see
    /// [`LensFlare::coarse_ghost_px`]) are smaller than its pixels there,
    /// and its draw costs by the cell. Where a 2 × 2 block of them is
    /// smooth — every ray inside every rim, no cell folded or at the gain
    /// bound, the largest irradiance within this share of the smallest,
    /// and the block's outline off the four cells' area by at most a
    /// tenth of this — it is drawn as one cell carrying their power. `0`
    /// draws every cell. On the double Gauss at 512² on lavapipe, at the
    /// other defaults, 0.5 shades 20,402 rays in the coarse pass instead
    /// of 29,281 and takes the flare from 1.49× [1.47, 1.54] to 1.36×
    /// [1.36, 1.42] the frame without it in one full run (1.46× to 1.41×
    /// in another), at the same relative L1 against the reference (0.1433
    /// against 0.1432); 1.0 gains nothing more (1.42× [1.40, 1.46]) and
    /// adds error (0.1474).
    /// Series `merged cells (defaults)`.
    pub merge_cells: f32,
}

/// The resolution a [`LensFlare`] adds its ghosts up at: the cost of the
/// flare is mostly the ghosts' pixels (a wide lens's ghosts overlap a
/// hundred deep), and most ghosts are smooth.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Default)]
pub enum GhostResolution {
    /// Every pixel: the sharpest iris edges.
    Full,
    /// Half the view's width and height (a quarter of the pixels), scaled
    /// up bilinearly; the light each ghost adds is kept. On the double
    /// Gauss at 512² (83 ghosts, 3 wavelengths, fixed 32²) it follows the
    /// reference as closely as `Full` (relative L1 0.116 against 0.117:
    /// the bilinear filter smooths the cells' steps as much as it blurs
    /// the iris's edges) at about a third of the draw's cost (series
    /// `ghost resolution (defaults)`, at 1e45d9f, 2026-12-03).
    Half,
    /// A quarter of the view's width and height (a sixteenth of the
    /// pixels), scaled up bilinearly. The default: with the default grids
    /// on the double Gauss at 512², relative L1 0.098 (0.080 at half
    /// resolution) at under half the cost of `Half` (series
    /// `ghost resolution (defaults)`, at 1e45d9f, 2026-12-03); the ghosts
    /// are smooth and overlap a hundred deep, so their pixels are the
    /// flare's cost.
    #[default]
    Quarter,
}

impl GhostResolution {
    /// The view's size over the ghosts' target's, per side.
    pub fn divisor(self) -> u32 {
        match self {
            Self::Full => 1,
            Self::Half => 2,
            Self::Quarter => 4,
        }
    }
}

impl LensFlare {
    /// A flare through `lens` with the default settings.
    pub fn new(lens: Handle<LensAsset>) -> Self {
        Self {
            lens,
            grid: 16,
            adaptive_grid: true,
            symmetry: true,
            wavelengths: 3,
            merge_wavelengths_px: DEFAULT_MERGE_WAVELENGTHS_PX,
            aperture: ApertureSettings::default(),
            coating: Some(CoatingSettings::default()),
            intensity: 1.0,
            ghost_budget: 64,
            min_relative: 0.001,
            occlusion: Some(FlareOcclusion::default()),
            starburst: Some(StarburstSettings::default()),
            ringing: Some(RingingSettings::default()),
            ghost_resolution: GhostResolution::Quarter,
            coarse_ghost_px: Some(DEFAULT_COARSE_GHOST_PX),
            merge_cells: DEFAULT_MERGE_CELLS,
        }
    }

    /// Checks every number; the first one that is wrong, as an
    /// [`Error`] naming it.
    pub fn validate(&self) -> Result<(), Error> {
        count("flare grid", self.grid, 2, MAX_GRID)?;
        count("flare wavelengths", self.wavelengths, 1, MAX_WAVELENGTHS)?;
        input::non_negative("flare intensity", f64::from(self.intensity))?;
        input::non_negative(
            "flare merge_wavelengths_px",
            f64::from(self.merge_wavelengths_px),
        )?;
        if let Some(px) = self.coarse_ghost_px {
            input::non_negative("flare coarse_ghost_px", f64::from(px))?;
        }
        input::non_negative("flare merge_cells", f64::from(self.merge_cells))?;
        input::in_range("flare min_relative", f64::from(self.min_relative), 0.0, 1.0)?;
        self.aperture.validate()?;
        if let Some(c) = &self.coating {
            c.validate()?;
        }
        if let Some(o) = &self.occlusion {
            o.validate()?;
        }
        if let Some(s) = &self.starburst {
            s.validate()?;
        }
        if let Some(r) = &self.ringing {
            r.validate()?;
        }
        Ok(())
    }

    /// The wavelengths traced, nm: evenly over 420–680 nm (550 nm for one).
    pub fn wavelengths_nm(&self) -> Vec<f64> {
        band_wavelengths(self.wavelengths.clamp(1, MAX_WAVELENGTHS) as usize)
    }
}

/// The iris of a [`LensFlare`]'s lens.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct ApertureSettings {
    /// Number of blades, `3..=32`; 0 for a round iris.
    pub blades: u32,
    /// Rotation of the blades, degrees.
    pub rotation_deg: f32,
    /// 0 for straight blades, 1 for a round opening.
    pub roundness: f32,
    /// Stopped down to this paraxial f-number, or `None` for the lens wide
    /// open. Values faster than the lens are refused.
    pub f_number: Option<f32>,
}

impl Default for ApertureSettings {
    /// Six straight-ish blades, wide open.
    fn default() -> Self {
        Self {
            blades: 6,
            rotation_deg: 0.0,
            roundness: 0.2,
            f_number: None,
        }
    }
}

impl ApertureSettings {
    fn validate(&self) -> Result<(), Error> {
        if self.blades != 0 && !(3..=32).contains(&self.blades) {
            return Err(Error::Blades(self.blades));
        }
        input::finite("aperture rotation (deg)", f64::from(self.rotation_deg))?;
        input::in_range("aperture roundness", f64::from(self.roundness), 0.0, 1.0)?;
        if let Some(f) = self.f_number {
            input::positive("f-number", f64::from(f))?;
        }
        Ok(())
    }
}

/// How a [`LensFlare`] camera's depth hides its lights.
///
/// Each frame, the depth buffer is read at a fixed pattern of 256 points
/// on a small disk round the light's image; the fraction of them that lie
/// behind the light is the light's visibility, which scales all its
/// ghosts. The disk makes the visibility soft (a light sliding behind an
/// edge fades over the disk's width instead of popping), and the
/// visibility is blended with the last frame's so that sub-pixel motion
/// (a swaying branch) does not make the flare flicker.
///
/// Under Bevy's temporal anti-aliasing (`TemporalAntiAliasing`), the depth
/// buffer is drawn with a projection jittered by a subpixel each frame:
/// the disk follows the jitter, and the raw visibilities of the last eight
/// frames (one for each offset of Bevy's jitter sequence) are averaged
/// before the blend, so a static light half behind an edge keeps the same
/// visibility every frame (tested on lavapipe, a sun half behind a wall:
/// from one frame to the next its flare changed by 2.8 % with the default
/// blend and by 21 % without one before; now by under 10⁻⁴, and not at
/// all without the blend; the render test
/// `a_static_flare_does_not_flicker_under_taa`, at c96fb24, 2026-12-02).
///
/// Lights whose image is off the screen have no depth to read: the part
/// of the disk outside the view counts as visible, so a light outside the
/// view flares fully. The camera's depth texture is made readable
/// (`Camera3d::depth_texture_usages` gains `TEXTURE_BINDING`) for this.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct FlareOcclusion {
    /// Radius of the disk read round the light, as a fraction of the
    /// view's height, `0..=0.25`.
    pub radius: f32,
    /// Weight of the last frame's visibility in this frame's, `0..1`
    /// (0: no smoothing; 0.7 reaches 97 % of a change in 10 frames).
    pub history: f32,
    /// Geometry less than this far (world units) in front of a point or
    /// spot light does not hide it, so a bulb's own mesh round the light
    /// leaves it visible.
    pub light_radius: f32,
}

impl Default for FlareOcclusion {
    /// A disk of 1 % of the view's height, history 0.7, 0.1 world units
    /// round a point light.
    fn default() -> Self {
        Self {
            radius: 0.01,
            history: 0.7,
            light_radius: 0.1,
        }
    }
}

impl FlareOcclusion {
    fn validate(&self) -> Result<(), Error> {
        input::in_range("occlusion radius", f64::from(self.radius), 0.0, 0.25)?;
        // History 1 would never let the visibility change.
        if !(0.0..1.0).contains(&self.history) {
            return Err(Error::Setting(InvalidInput::new(
                "occlusion history (below 1)",
                f64::from(self.history),
                Expected::Range { min: 0.0, max: 1.0 },
            )));
        }
        input::non_negative("occlusion light radius", f64::from(self.light_radius))?;
        Ok(())
    }
}

/// Texture sides of the diffraction textures.
const DIFFRACTION_SIDES: std::ops::RangeInclusive<u32> = 32..=1024;

fn check_side(what: &'static str, side: u32) -> Result<(), Error> {
    if !DIFFRACTION_SIDES.contains(&side) || !side.is_multiple_of(2) {
        return Err(Error::Resolution { what, side });
    }
    Ok(())
}

/// `n` if it is in `min..=max`.
fn count(what: &'static str, n: u32, min: u32, max: u32) -> Result<(), InvalidInput> {
    input::in_range(what, f64::from(n), f64::from(min), f64::from(max)).map(|_| ())
}

/// The starburst: the Fraunhofer diffraction pattern of the iris (with the
/// lens's dust and scratches), summed over the flare's wavelengths, drawn
/// round each flaring light. Recomputed (an FFT on the CPU) only when the
/// iris or these settings change.
///
/// Its light is a share of the light's own image spread by diffraction:
/// per light it adds `intensity` × the light's irradiance × the entrance
/// pupil's area (the energy the lens focuses from that light) to the
/// frame, most of it in the pattern's core. A real iris diffracts into a
/// fraction of a degree; `size` stretches the pattern to a visible size
/// (as Hullin et al. do), keeping its energy, and it fades out towards the
/// edge of its square. No pixel gets more than 4096 from it, so the HDR
/// target cannot overflow.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct StarburstSettings {
    /// Half the width of the pattern, as a fraction of the view's height,
    /// `(0, 2]`.
    pub size: f32,
    /// The share of the light's focused energy the pattern carries (1:
    /// all of it, blinding; the default 0.001 gives a bright core and
    /// visible spikes).
    pub intensity: f32,
    /// Texels per side of the FFT, an even number in `32..=1024`.
    pub resolution: u32,
    /// Dust specks on the lens.
    pub specks: u32,
    /// Scratches on the lens.
    pub scratches: u32,
    /// Where the dust and scratches fall.
    pub seed: u64,
}

impl Default for StarburstSettings {
    /// A quarter of the view's height, 0.001 of the light's focused
    /// energy, 256², 40 specks and 6 scratches.
    fn default() -> Self {
        Self {
            size: 0.25,
            intensity: 0.001,
            resolution: 256,
            specks: 40,
            scratches: 6,
            seed: 1,
        }
    }
}

impl StarburstSettings {
    fn validate(&self) -> Result<(), Error> {
        input::positive("starburst size", f64::from(self.size))?;
        input::in_range("starburst size", f64::from(self.size), 0.0, 2.0)?;
        input::non_negative("starburst intensity", f64::from(self.intensity))?;
        if self.specks > 10_000 || self.scratches > 1_000 {
            return Err(Error::Dirt {
                specks: self.specks,
                scratches: self.scratches,
            });
        }
        check_side("starburst", self.resolution)
    }
}

/// Ringing: the ripples that diffraction at the iris's edge puts inside
/// each ghost, from the iris's field carried by the angular spectrum
/// method (one texture per red, green and blue, recomputed only when the
/// iris or these settings change), looked up where each ray crossed the
/// stop.
///
/// Every ghost shares one propagation distance, given as a Fresnel number
/// `r² / (λ z)` at 550 nm: large numbers give a few fine ripples at the
/// edge, small ones broad rings across the ghost.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct RingingSettings {
    /// The Fresnel number at 550 nm, `0.5..=10000`.
    pub fresnel_number: f32,
    /// Texels per side, an even number in `32..=1024`.
    pub resolution: u32,
}

impl Default for RingingSettings {
    /// Fresnel number 60, 256².
    fn default() -> Self {
        Self {
            fresnel_number: 60.0,
            resolution: 256,
        }
    }
}

impl RingingSettings {
    fn validate(&self) -> Result<(), Error> {
        input::in_range(
            "ringing Fresnel number",
            f64::from(self.fresnel_number),
            0.5,
            10_000.0,
        )?;
        check_side("ringing", self.resolution)
    }
}

/// A quarter-wave single-layer anti-reflection coating.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default)]
pub struct CoatingSettings {
    /// Index of the layer (MgF₂: 1.38).
    pub index: f32,
    /// Wavelength at which the layer is a quarter wave thick, nm.
    pub design_wavelength_nm: f32,
}

impl Default for CoatingSettings {
    /// MgF₂ at 550 nm.
    fn default() -> Self {
        Self {
            index: 1.38,
            design_wavelength_nm: 550.0,
        }
    }
}

impl CoatingSettings {
    fn validate(&self) -> Result<(), Error> {
        input::in_range("coating index", f64::from(self.index), 1.0, 3.0)?;
        input::positive(
            "coating design wavelength (nm)",
            f64::from(self.design_wavelength_nm),
        )?;
        Ok(())
    }
}

/// Marks a light (directional, point or spot) whose light flares in every
/// [`LensFlare`] camera, also when it is outside the view.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct FlareSource {
    /// Scales this light's flare.
    pub strength: f32,
}

impl Default for FlareSource {
    fn default() -> Self {
        Self { strength: 1.0 }
    }
}
