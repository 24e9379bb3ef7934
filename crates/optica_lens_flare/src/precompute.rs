//! Choosing the ghosts a [`LensFlare`] camera draws (the blog's *Intensity
//! LOD* and *Aperture culling*), redone only when the lens, the coating or
//! the aperture changes: every two-reflection path of the lens is
//! estimated with a small grid, ranked, and kept or left out with a reason;
//! the diffraction textures are made then too.

use bevy::prelude::*;
use optica_optics::lens::{Coating, LensPrescription};
use optica_optics::lens_flare::{
    Aperture, EstimateOptions, FlareError, coat_air_interfaces, estimate_ghosts,
    grid_sizes_by_power, light_from_field, stopped_to_f_number,
};

use crate::diffraction::{ringing_image, starburst_image};
use crate::fit::MIN_SCREEN_GRID;
use crate::{Error, LensAsset, LensFlare, MAX_GRID};

/// Field angle of the light the ghosts are ranked for, degrees. The ranking
/// is done once per lens and aperture, not per light; the order of the
/// brightest ghosts changes little with the angle, and each kept ghost is
/// traced at every light's real direction.
pub const RANKING_FIELD_DEG: f64 = 10.0;

/// What became of one ghost path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Reflect)]
pub enum GhostFate {
    /// Drawn.
    Drawn,
    /// Dimmer than [`LensFlare::min_relative`] of the brightest.
    TooDim,
    /// Bright enough, but past [`LensFlare::ghost_budget`].
    OverBudget,
    /// No ray of the estimate gets through the lens and the aperture.
    Blocked,
}

/// One two-reflection path of the lens and its fate.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct GhostChoice {
    /// Reflects at surface `.0`, then at `.1` (in front of it).
    pub path: (usize, usize),
    /// Estimated mean irradiance relative to the brightest ghost.
    pub relative: f64,
    /// Drawn, or why not.
    pub fate: GhostFate,
    /// Rays per side of its grid when drawn (0 when not).
    pub grid: u32,
    /// Estimated power reaching the sensor relative to the most powerful
    /// ghost's (what its grid size follows with
    /// [`LensFlare::adaptive_grid`]).
    pub power: f64,
}

/// On a [`LensFlare`] camera: the lens as traced and every ghost path with
/// its fate, brightest first. Rebuilt when the lens asset, the coating or
/// the aperture changes.
#[derive(Component, Clone, Debug, Default)]
pub struct FlareGhosts {
    /// The prescription as traced (coated, stopped down), once loaded.
    pub lens: Option<LensPrescription>,
    /// The iris, in the stop plane of that prescription.
    pub aperture: Option<Aperture>,
    /// Every ghost path (n(n−1)/2 for n interfaces), brightest first.
    pub ghosts: Vec<GhostChoice>,
    /// The starburst texture (RGB per texel, each channel summing to about
    /// 1), when [`LensFlare::starburst`] is on.
    pub starburst: Option<Handle<Image>>,
    /// The ringing texture (the iris's propagated intensity at 650, 550
    /// and 450 nm in R, G, B; 1 on average over the opening), when
    /// [`LensFlare::ringing`] is on.
    pub ringing: Option<Handle<Image>>,
    /// Why no ghost could be chosen (the lens is not loaded, a setting is
    /// invalid, the estimate failed); the last good choice is kept.
    pub problem: Option<Error>,
    built_for: Option<Key>,
}

impl FlareGhosts {
    /// The paths drawn, brightest first.
    pub fn drawn(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.drawn_grids().map(|(path, _)| path)
    }

    /// The paths drawn with their grid sizes, brightest first.
    pub fn drawn_grids(&self) -> impl Iterator<Item = ((usize, usize), u32)> + '_ {
        self.ghosts
            .iter()
            .filter(|g| g.fate == GhostFate::Drawn)
            .map(|g| (g.path, g.grid))
    }

    /// Rays traced per light and wavelength each frame.
    pub fn rays_per_light(&self) -> u64 {
        self.drawn_grids()
            .map(|(_, n)| u64::from(n) * u64::from(n))
            .sum()
    }
}

/// What a choice depends on.
#[derive(Clone, Debug, PartialEq)]
struct Key {
    lens: AssetId<LensAsset>,
    aperture: crate::ApertureSettings,
    coating: Option<crate::CoatingSettings>,
    budget: u32,
    min_relative: f32,
    grid: u32,
    adaptive_grid: bool,
    wavelengths: u32,
    starburst: Option<crate::StarburstSettings>,
    ringing: Option<crate::RingingSettings>,
}

impl Key {
    fn of(flare: &LensFlare) -> Self {
        Self {
            lens: flare.lens.id(),
            aperture: flare.aperture,
            coating: flare.coating,
            budget: flare.ghost_budget,
            min_relative: flare.min_relative,
            grid: flare.grid,
            adaptive_grid: flare.adaptive_grid,
            wavelengths: flare.wavelengths,
            starburst: flare.starburst,
            ringing: flare.ringing,
        }
    }
}

/// Chooses the ghosts of every [`LensFlare`] camera whose lens or settings
/// changed, or whose lens asset was (re)loaded.
pub(crate) fn choose_ghosts(
    mut commands: Commands,
    mut cameras: Query<(Entity, &LensFlare, Option<&mut FlareGhosts>)>,
    lenses: Res<Assets<LensAsset>>,
    mut images: ResMut<Assets<Image>>,
    mut events: MessageReader<AssetEvent<LensAsset>>,
) {
    let changed: Vec<AssetId<LensAsset>> = events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for (entity, flare, ghosts) in &mut cameras {
        let key = Key::of(flare);
        let fresh = ghosts
            .as_ref()
            .is_some_and(|g| g.built_for.as_ref() == Some(&key) && !changed.contains(&key.lens));
        if fresh {
            continue;
        }
        let result = match lenses.get(&flare.lens) {
            None => Err(Error::LensNotLoaded),
            Some(asset) => flare.validate().and_then(|()| {
                let (lens, aperture, choices) = choose(flare, &asset.0)?;
                let burst = starburst_image(flare, &aperture)?;
                let ring = ringing_image(flare, &aperture)?;
                Ok((lens, aperture, choices, burst, ring))
            }),
        };
        let mut next = ghosts.as_deref().cloned().unwrap_or_default();
        match result {
            Ok((lens, aperture, choices, burst, ring)) => {
                next.lens = Some(lens);
                next.aperture = Some(aperture);
                next.ghosts = choices;
                next.starburst = burst.map(|i| images.add(i));
                next.ringing = ring.map(|i| images.add(i));
                next.problem = None;
                next.built_for = Some(key);
            }
            Err(why) => {
                if next.problem.as_ref() != Some(&why) {
                    warn!("optica_lens_flare: {why}; the flare keeps its last ghosts");
                }
                next.problem = Some(why);
                // Not marked as built: tried again when something changes
                // (a lens still loading arrives as an asset event).
                next.built_for = None;
            }
        }
        match ghosts {
            Some(mut g) => *g = next,
            None => {
                commands.entity(entity).insert(next);
            }
        }
    }
}

/// Gives each drawn ghost its grid size: `flare.grid`, or with
/// [`LensFlare::adaptive_grid`] one that follows the cube root of its
/// power (`optica_optics::lens_flare::grid_sizes_by_power`), from
/// [`MIN_SCREEN_GRID`] to [`MAX_GRID`] rays per side, the rays of `grid²`
/// per ghost in all.
fn size_grids(flare: &LensFlare, mut choices: Vec<GhostChoice>) -> Vec<GhostChoice> {
    let drawn: Vec<usize> = (0..choices.len())
        .filter(|&k| choices[k].fate == GhostFate::Drawn)
        .collect();
    let sizes = if flare.adaptive_grid {
        let powers: Vec<f64> = drawn.iter().map(|&k| choices[k].power).collect();
        grid_sizes_by_power(
            &powers,
            flare.grid,
            MIN_SCREEN_GRID.min(flare.grid),
            MAX_GRID,
        )
    } else {
        vec![flare.grid; drawn.len()]
    };
    for (&k, size) in drawn.iter().zip(sizes) {
        choices[k].grid = size;
    }
    choices
}

/// The prescription as `flare` traces it, its iris and its ghosts, ranked
/// and culled.
pub fn choose(
    flare: &LensFlare,
    prescription: &LensPrescription,
) -> Result<(LensPrescription, Aperture, Vec<GhostChoice>), Error> {
    let mut lens = prescription.clone();
    if let Some(c) = flare.coating {
        let coating = Coating::quarter_wave(f64::from(c.index), f64::from(c.design_wavelength_nm))?;
        lens = coat_air_interfaces(&lens, coating).map_err(FlareError::from)?;
    }
    if let Some(f) = flare.aperture.f_number {
        lens = stopped_to_f_number(&lens, f64::from(f))?;
    }
    let radius = lens.stop_semi_aperture_mm();
    let a = &flare.aperture;
    let aperture = if a.blades == 0 {
        Aperture::circle(radius)
    } else {
        Aperture::blades(
            a.blades,
            f64::from(a.rotation_deg).to_radians(),
            f64::from(a.roundness),
            radius,
        )
    }?;
    let ranked = estimate_ghosts(
        &lens,
        light_from_field(RANKING_FIELD_DEG, 0.0),
        550.0,
        &aperture,
        &EstimateOptions::default(),
    )?;
    let brightest = ranked.iter().map(|g| g.intensity).fold(0.0, f64::max);
    let most_power = ranked.iter().map(|g| g.power).fold(0.0, f64::max);
    let mut drawn = 0u32;
    let choices = ranked
        .iter()
        .map(|g| {
            let relative = if brightest > 0.0 {
                g.intensity / brightest
            } else {
                0.0
            };
            // (A NaN estimate counts as blocked, as zero does.)
            let fate = if g.intensity.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                GhostFate::Blocked
            } else if relative < f64::from(flare.min_relative) {
                GhostFate::TooDim
            } else if drawn >= flare.ghost_budget {
                GhostFate::OverBudget
            } else {
                drawn += 1;
                GhostFate::Drawn
            };
            let path = match g.path {
                optica_optics::lens::TracePath::Ghost { first, second } => (first, second),
                optica_optics::lens::TracePath::Primary => (0, 0),
            };
            GhostChoice {
                path,
                relative,
                fate,
                grid: 0,
                power: if most_power > 0.0 {
                    g.power / most_power
                } else {
                    0.0
                },
            }
        })
        .collect();
    let choices = size_grids(flare, choices);
    Ok((lens, aperture, choices))
}
