//! The components users put on the camera: the [`Eye`], the [`Spectacles`]
//! it wears and how its defocus is drawn ([`CloneDefocus`]); and on the
//! scene: a [`CurvedMirror`] and its [`MirrorViewer`].

use bevy::prelude::*;
use optica_optics::glass::Glass;
use optica_optics::input::{Expected, InvalidInput};
use optica_optics::spectacles::CurvedMirror as MirrorOptics;
use optica_optics::spectacles::{
    self as optics, AdaptedEyes, HofstetterBound, LensDesignParams, Prescription, SpectaclesError,
};

use crate::Error;

/// The viewer's eye, on the camera that looks through it: its refractive
/// error, how far it can accommodate and its pupil. With it the camera's
/// view is blurred where the eye cannot focus (the paper's §4, by clone
/// rendering; see [`CloneDefocus`]); with [`Spectacles`] beside it, the view
/// is corrected (or not) by the lens.
///
/// Everything is in dioptres (vergence, 1/m): the far point is at vergence
/// `−R` (`R` the refractive error, negative for myopia), the near point at
/// `−R + Amp`; an object at distance `z` is `ΔD = max(0, P_far − 1/z) +
/// max(0, 1/z − P_near)` dioptres out of focus and blurred into a disc of
/// `A·ΔD` radians (`A` the pupil diameter).
///
/// ```
/// use optica_spectacles::{Accommodation, Eye, Pupil};
///
/// // A −3 D myope of 30 with a 4 mm pupil: sharp from 8 cm to 33 cm.
/// let eye = Eye {
///     refractive_error_d: -3.0,
///     accommodation: Accommodation::Age { years: 30.0 },
///     pupil: Pupil::Diameter { mm: 4.0 },
///     ..Default::default()
/// };
/// let optics = eye.optics().unwrap();
/// assert!((optics.far_point_m() - 1.0 / 3.0).abs() < 1e-6);
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Clone)]
#[require(CloneDefocus, crate::SpectaclesStatus)]
pub struct Eye {
    /// Refractive error `R` (D): negative for myopia, positive for
    /// hyperopia, 0 for an emmetrope; the sphere of an astigmatic eye.
    /// Accepted: ±30 D.
    pub refractive_error_d: f32,
    /// How far the eye can accommodate.
    pub accommodation: Accommodation,
    /// The entrance pupil.
    pub pupil: Pupil,
    /// The eye's astigmatism; none by default.
    pub astigmatism: Astigmatism,
}

/// An astigmatic eye's cylinder, written as on its prescription: an eye
/// "−1.00 / −2.00 × 90" has `refractive_error_d: -1.0` and
/// `Astigmatism { cylinder_d: -2.0, axis_deg: 90.0 }`: −1 D in the
/// vertical (axis) meridian, −3 D in the horizontal one, and [`Spectacles`]
/// of the same sphere, cylinder and axis correct it.
///
/// The eye accommodates to the circle of least confusion (the spherical
/// equivalent `R + C/2`), so where it can focus it still sees a disc
/// `A·|C|/2` radians wide, and elsewhere an ellipse drawn out across the
/// meridian with more error: a distant point is a line across the axis
/// for a myopic cylinder.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
pub struct Astigmatism {
    /// Cylinder `C` (D), either sign: the error across the axis is `R + C`.
    /// Accepted: ±10 D.
    pub cylinder_d: f32,
    /// Axis (degrees), the optometric convention of
    /// [`Spectacles::axis_deg`]: from the wearer's left, counter-clockwise
    /// as the examiner facing the wearer sees it.
    pub axis_deg: f32,
}

impl Default for Eye {
    /// An emmetrope of 25 (mean Hofstetter amplitude 11 D) with a 4 mm
    /// pupil (indoor light).
    fn default() -> Self {
        Self {
            refractive_error_d: 0.0,
            accommodation: Accommodation::Age { years: 25.0 },
            pupil: Pupil::Diameter { mm: 4.0 },
            astigmatism: Astigmatism::default(),
        }
    }
}

/// How far the eye can accommodate (its amplitude `Amp`, D).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub enum Accommodation {
    /// The amplitude in dioptres, `0..=30`.
    Dioptres(f32),
    /// The mean amplitude at this age by Hofstetter (1950):
    /// `18.5 − 0.3·age`, 0 past about 62.
    Age {
        /// Age in years.
        years: f32,
    },
}

/// The eye's entrance pupil.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub enum Pupil {
    /// A fixed diameter in millimetres, `0..=50` (real pupils are 2–8 mm;
    /// the paper renders with 12 mm to exaggerate the blur).
    Diameter {
        /// Diameter, mm.
        mm: f32,
    },
    /// The light-adapted diameter by Watson & Yellott's unified formula
    /// (2012), for both eyes adapted to a 60° field.
    Light {
        /// Adapting luminance, cd/m² (an office ~100, overcast day ~3,000).
        luminance_cd_m2: f32,
        /// Age in years (clamped to the formula's 20–83).
        age_years: f32,
    },
}

impl Eye {
    /// The paper's eye from its near and far points (m; `f32::INFINITY` for
    /// an emmetrope's far point) and pupil (mm): Fig. 8(a) is
    /// `from_near_far(0.2, 10.0, 12.0)`, Fig. 8(b) `from_near_far(0.5, 1.3, 12.0)`.
    /// Invalid numbers give an eye that [`Eye::optics`] refuses.
    pub fn from_near_far(near_m: f32, far_m: f32, pupil_mm: f32) -> Self {
        let p_far = if far_m.is_infinite() {
            0.0
        } else {
            1.0 / far_m
        };
        Self {
            refractive_error_d: -p_far,
            accommodation: Accommodation::Dioptres(1.0 / near_m - p_far),
            pupil: Pupil::Diameter { mm: pupil_mm },
            astigmatism: Astigmatism::default(),
        }
    }

    /// The accommodation amplitude (D) these settings give.
    pub fn amplitude_d(&self) -> Result<f64, InvalidInput> {
        match self.accommodation {
            Accommodation::Dioptres(d) => Ok(f64::from(d)),
            Accommodation::Age { years } => {
                optics::hofstetter_amplitude_d(f64::from(years), HofstetterBound::Mean)
            }
        }
    }

    /// The pupil diameter (mm) these settings give.
    pub fn pupil_mm(&self) -> Result<f64, InvalidInput> {
        match self.pupil {
            Pupil::Diameter { mm } => Ok(f64::from(mm)),
            Pupil::Light {
                luminance_cd_m2,
                age_years,
            } => optics::pupil_diameter_watson_yellott_mm(
                f64::from(luminance_cd_m2),
                60.0,
                f64::from(age_years),
                AdaptedEyes::Both,
            ),
        }
    }

    /// The eye model of `optica_optics` these settings describe.
    ///
    /// Errors: a number that is not finite or out of range, named.
    pub fn optics(&self) -> Result<optics::Eye, InvalidInput> {
        optics::Eye::new(
            f64::from(self.refractive_error_d),
            self.amplitude_d()?,
            self.pupil_mm()? * 1e-3,
        )?
        .with_astigmatism(
            f64::from(self.astigmatism.cylinder_d),
            f64::from(self.astigmatism.axis_deg),
        )
    }
}

/// How the eye's defocus is drawn: the paper's clones (§4.2). Required by
/// [`Eye`]; its defaults are the paper's `S = 10` and voxel field.
///
/// The scene is drawn `clones` times, every vertex of clone `i` moved by
/// the `i`-th vector of its displacement set (a disc across the line of
/// sight as wide as the blur there), and the drawings averaged. Without
/// [`Spectacles`] the sets come in closed form per vertex; with them, from
/// the voxel field precomputed through the lens.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Clone)]
pub struct CloneDefocus {
    /// `S`, the number of clones (pupil samples), `1..=`[`MAX_CLONES`]. More
    /// clones make smoother blur and cost one more drawing of the scene each.
    pub clones: u32,
    /// The voxel field's box in front of the eye, and its resolution (used
    /// with [`Spectacles`] only).
    pub field: FieldBox,
    /// How each clone is shaded.
    pub shading: CloneShading,
    /// Draws the view sharp (no clones) while `false`: the cost and look
    /// of the scene without the eye.
    pub enabled: bool,
}

/// How the clones are shaded.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CloneShading {
    /// The eye camera draws the scene once, sharp, with all its shading;
    /// each clone is drawn with a cheap shader that only records where its
    /// (undisplaced) surface point lies in that sharp view, and takes the
    /// colour there (bilinearly, from the pixels that show the same
    /// surface) when the point is visible in it. What this gives up:
    /// surface points the sharp view hides behind a nearer object (the
    /// inner edge of a blurred object in front of a sharp one) are left
    /// out of the mean at that pixel; points just past the view's edge
    /// take the edge pixel's colour; and resampling the sharp view adds
    /// about a sixth of a pixel² to the blur's variance, which shows where
    /// the blur is itself about a pixel wide. The default: a clone costs a
    /// fraction of a shaded drawing of the scene (see the `spectacles`
    /// report).
    #[default]
    Reprojected,
    /// The paper's: every clone is shaded in full by its material (Bevy's
    /// lights, shadows, textures), and the view is their mean. Exact at
    /// every edge; each clone costs a shaded drawing of the scene.
    Full,
}

/// The most clones [`CloneDefocus::clones`] may ask for.
pub const MAX_CLONES: u32 = 64;

impl Default for CloneDefocus {
    fn default() -> Self {
        Self {
            clones: 10,
            field: FieldBox::default(),
            shading: CloneShading::default(),
            enabled: true,
        }
    }
}

/// The voxel field's box, in the eye's frame: `x` across (to the
/// wearer's left), `y` up, `z` the distance in front of the cornea, metres.
/// The box must hold the scene the lens shows: a vertex beyond it takes the
/// set of the box's last voxel along its line of sight, scaled by distance
/// (documented fallback).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct FieldBox {
    /// Half the box's width (m).
    pub half_width_m: f32,
    /// Half the box's height (m).
    pub half_height_m: f32,
    /// Nearest distance (m).
    pub near_m: f32,
    /// Farthest distance (m).
    pub far_m: f32,
    /// Voxels per axis.
    pub voxels: UVec3,
    /// Bundles traced through the lens: rings × segments of the lens's
    /// polar layout (the paper: the lens's ~1,500 vertices).
    pub aims: UVec2,
    /// Pupil rays per bundle (the paper: 10). Each voxel keeps its set as
    /// a linear map of the pupil, so this is not the number of clones drawn.
    pub bundle_rays: u32,
    /// Lay the voxels out in eye coordinates (not in the paper; the
    /// journal version's future work): uniform in the sight line's
    /// direction from the eye's centre of rotation and in dioptric
    /// distance, small near the eye and reaching infinity. The box then
    /// gives the extent: the angles of its far face as the eye sees them,
    /// every distance from its near face on. On by default: at the
    /// paper's voxel count its sets are 4× closer to the direct reference
    /// beyond the paper's box (0.27 against 1.04 mrad at 2.5–10 m, where
    /// the box falls back to its far face) and 6× closer within it (0.068
    /// against 0.42 mrad at 0.1–2 m); off gives the paper's box. See the
    /// crate docs.
    pub eye_coordinates: bool,
}

impl Default for FieldBox {
    /// The paper's voxel count and extent: 110×77×42 voxels over its box
    /// (5.5 × 3.85 × 2.1 m from 3 cm in front of the cornea: the angles of
    /// its far face, every distance from 3 cm to infinity), laid out in
    /// eye coordinates, and 1,537 bundles.
    fn default() -> Self {
        let paper = optics::FieldSettings::paper();
        let (min, max) = (paper.min(), paper.max());
        let d = paper.dims();
        Self {
            half_width_m: max.x as f32,
            half_height_m: max.y as f32,
            near_m: min.z as f32,
            far_m: max.z as f32,
            voxels: UVec3::new(d[0] as u32, d[1] as u32, d[2] as u32),
            aims: UVec2::new(paper.aim_rings() as u32, paper.aim_segments() as u32),
            bundle_rays: paper.clones() as u32,
            eye_coordinates: true,
        }
    }
}

impl FieldBox {
    /// The settings of `optica_optics` for this box.
    ///
    /// Errors: a box, resolution or ray count the field refuses, named.
    pub fn settings(&self) -> Result<optics::FieldSettings, InvalidInput> {
        let v = |x: f32| f64::from(x);
        optics::FieldSettings::paper()
            .with_box(
                optica_optics::glam::DVec3::new(
                    -v(self.half_width_m),
                    -v(self.half_height_m),
                    v(self.near_m),
                ),
                optica_optics::glam::DVec3::new(
                    v(self.half_width_m),
                    v(self.half_height_m),
                    v(self.far_m),
                ),
            )?
            .with_dims([
                self.voxels.x as usize,
                self.voxels.y as usize,
                self.voxels.z as usize,
            ])?
            .with_aims(self.aims.x as usize, self.aims.y as usize)?
            .with_clones(self.bundle_rays as usize)
            .map(|st| {
                st.with_grid(if self.eye_coordinates {
                    optics::FieldGrid::Eye
                } else {
                    optics::FieldGrid::Box
                })
            })
    }
}

/// Spectacle lens materials (index at the d line / Abbe number).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub enum LensMaterial {
    /// CR-39 plastic, 1.498 / 58: the common plastic lens.
    Cr39,
    /// Crown glass, 1.523 / 59.
    Crown,
    /// Trivex, 1.53 / 44.
    Trivex,
    /// Polycarbonate, 1.586 / 30.
    Polycarbonate,
    /// Mid-index plastic, 1.60 / 41.
    Index160,
    /// High-index plastic, 1.67 / 32.
    Index167,
    /// High-index plastic, 1.74 / 33.
    Index174,
    /// The paper's glass: n = 1.66, no dispersion given.
    Paper,
    /// Any material by its index and Abbe number.
    Custom {
        /// Index at the d line (587.6 nm), 1.3–3.
        n_d: f32,
        /// Abbe number.
        v_d: f32,
    },
}

impl LensMaterial {
    /// The materials with names, for menus.
    pub const PRESETS: [LensMaterial; 8] = [
        LensMaterial::Cr39,
        LensMaterial::Crown,
        LensMaterial::Trivex,
        LensMaterial::Polycarbonate,
        LensMaterial::Index160,
        LensMaterial::Index167,
        LensMaterial::Index174,
        LensMaterial::Paper,
    ];

    /// The material's name.
    pub fn name(&self) -> &'static str {
        match self {
            LensMaterial::Cr39 => "CR-39",
            LensMaterial::Crown => "crown",
            LensMaterial::Trivex => "Trivex",
            LensMaterial::Polycarbonate => "polycarbonate",
            LensMaterial::Index160 => "1.60",
            LensMaterial::Index167 => "1.67",
            LensMaterial::Index174 => "1.74",
            LensMaterial::Paper => "paper (n 1.66)",
            LensMaterial::Custom { .. } => "custom",
        }
    }

    /// The glass model of `optica_optics`.
    pub fn glass(&self) -> Glass {
        let abbe = |nd: f64, vd: f64| Glass::Abbe { nd, vd };
        match *self {
            LensMaterial::Cr39 => abbe(1.498, 58.0),
            LensMaterial::Crown => abbe(1.523, 59.0),
            LensMaterial::Trivex => abbe(1.53, 44.0),
            LensMaterial::Polycarbonate => abbe(1.586, 30.0),
            LensMaterial::Index160 => abbe(1.60, 41.0),
            LensMaterial::Index167 => abbe(1.67, 32.0),
            LensMaterial::Index174 => abbe(1.74, 33.0),
            LensMaterial::Paper => Glass::Constant(1.66),
            LensMaterial::Custom { n_d, v_d } => abbe(f64::from(n_d), f64::from(v_d)),
        }
    }
}

/// The spectacle lens the [`Eye`] looks through, on the same camera.
///
/// The lens is designed from the prescription as an optician would
/// (Vogel's base curve unless given, the thick-lens back surface, toric
/// for a cylinder, the thinnest centre that keeps a 1 mm edge) and drawn
/// in front of the eye; the eye's defocus is then taken through it.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Clone)]
pub struct Spectacles {
    /// Sphere `S` (D): −3 corrects a −3 D myope. Accepted: ±20 D.
    pub sphere_d: f32,
    /// Cylinder `C` (D), either sign; 0 for a spherical lens.
    pub cylinder_d: f32,
    /// Cylinder axis (degrees), the optometric convention: from the
    /// wearer's left (the examiner's right, facing the wearer)
    /// counter-clockwise as the examiner sees the lens, `0..180`.
    pub axis_deg: f32,
    /// Near addition (D) of a progressive-addition lens, `0..=4`; 0 (the
    /// default) for a single-vision lens. The lens's power grows by it
    /// from the fitting point (its centre, where the eye looks straight
    /// ahead) down a corridor of [`Spectacles::corridor_mm`] into the near
    /// zone below, with the blurred zones either side of the corridor that
    /// every progressive lens has (`optica_optics::spectacles::ProgressiveAddition`).
    pub addition_d: f32,
    /// The progressive corridor's length (mm): from the fitting point to
    /// the full addition, 14 by default (short corridors are ~11 mm).
    pub corridor_mm: f32,
    /// Lens material.
    pub material: LensMaterial,
    /// Cornea to the lens's back vertex (mm): 12–14 is usual.
    pub vertex_distance_mm: f32,
    /// Diameter of the round blank (mm).
    pub blank_diameter_mm: f32,
    /// The thinnest centre (mm); plus lenses are thicker, to keep a 1 mm edge.
    pub min_centre_thickness_mm: f32,
    /// Front surface power (D); `None` for Vogel's rule.
    pub base_curve_d: Option<f32>,
    /// Draws the lens's refraction of the view (the paper's §3): the
    /// magnification, the distortion towards the rim, the dark rim of a
    /// strong minus lens.
    pub refraction: bool,
    /// The lens's tessellation, rings × segments of its back surface (the
    /// paper: ~1,500 vertices, 24 × 64): the refraction is traced at each
    /// vertex and interpolated between them. At most [`MAX_LENS_VERTICES`]
    /// vertices.
    pub tessellation: UVec2,
    /// The lens's optical centre off the line of sight (mm, to the
    /// wearer's left and up): glasses that sit off centre, or slide. The
    /// lens is retraced whenever it changes (~0.2 ms at the default
    /// tessellation; the `spectacles` report's series
    /// `refraction, −4 D (knob rings)`), and the defocus field with it (the
    /// blur moves with the lens). An offset of the blank's radius or more
    /// is refused (the lens would not be before the eye).
    pub decentration_mm: Vec2,
    /// Draws the lens's chromatic aberration from the material's Abbe
    /// number: the view's red, green and blue are refracted as the C, d and
    /// F lines (656, 588, 486 nm), so that towards the rim, where the lens
    /// acts as a prism of `c·F` prism dioptres, colours part by `c·F/V`
    /// (a −6 D polycarbonate lens, V = 30, at 1 cm: 0.2 prism dioptres,
    /// 7 arcminutes, the coloured fringes its wearers notice; CR-39,
    /// V = 58, half that). Costs two more traces when the lens changes and
    /// two more texture reads per lens pixel. No effect for the paper's
    /// constant-index material.
    pub chromatic_aberration: bool,
}

impl Default for Spectacles {
    /// A plano CR-39 lens, 12 mm from the cornea, 50 mm blank, 2 mm centre,
    /// refraction drawn at the paper's tessellation, centred.
    fn default() -> Self {
        Self {
            sphere_d: 0.0,
            cylinder_d: 0.0,
            axis_deg: 0.0,
            addition_d: 0.0,
            corridor_mm: 14.0,
            material: LensMaterial::Cr39,
            vertex_distance_mm: 12.0,
            blank_diameter_mm: 50.0,
            min_centre_thickness_mm: 2.0,
            base_curve_d: None,
            refraction: true,
            tessellation: UVec2::new(24, 64),
            decentration_mm: Vec2::ZERO,
            chromatic_aberration: true,
        }
    }
}

impl Spectacles {
    /// A spherical lens of `sphere_d` dioptres, otherwise the defaults.
    pub fn sphere(sphere_d: f32) -> Self {
        Self {
            sphere_d,
            ..default()
        }
    }

    /// The prescription.
    ///
    /// Errors: numbers that are not finite, powers beyond ±20 D, an
    /// addition outside `0..=4` D.
    pub fn prescription(&self) -> Result<Prescription, InvalidInput> {
        Prescription::new(
            f64::from(self.sphere_d),
            f64::from(self.cylinder_d),
            f64::from(self.axis_deg),
        )?
        .with_addition(f64::from(self.addition_d))
    }

    /// The lens maker's choices.
    ///
    /// Errors: a number out of range, named.
    pub fn design_params(&self) -> Result<LensDesignParams, InvalidInput> {
        LensDesignParams::default()
            .with_glass(self.material.glass())?
            .with_vertex_distance_m(f64::from(self.vertex_distance_mm) * 1e-3)?
            .with_blank_diameter_m(f64::from(self.blank_diameter_mm) * 1e-3)?
            .with_min_centre_thickness_m(f64::from(self.min_centre_thickness_mm) * 1e-3)?
            .with_base_curve_d(self.base_curve_d.map(f64::from))?
            .with_corridor_m(f64::from(self.corridor_mm) * 1e-3)
    }

    /// The designed lens, in the eye's frame, centred (the refraction and
    /// the defocus field each place it by [`Self::decentration_mm`]).
    ///
    /// Errors: bad numbers, a tessellation of more than
    /// [`MAX_LENS_VERTICES`] vertices, a prescription no lens of this
    /// blank can carry (e.g. +20 D in CR-39 on a 50 mm blank: its front
    /// surface would close before the rim), or a decentration that puts
    /// the eye's axis off the blank, as [`SpectaclesError`]: a refused
    /// lens is neither drawn nor blurred through.
    pub fn design(&self) -> Result<optics::SpectacleLens, SpectaclesError> {
        if self.refraction {
            let vertices = u64::from(self.tessellation.x) * u64::from(self.tessellation.y);
            if vertices > MAX_LENS_VERTICES {
                return Err(InvalidInput::new(
                    "lens tessellation rings × segments",
                    vertices as f64,
                    Expected::Range {
                        min: 3.0,
                        max: MAX_LENS_VERTICES as f64,
                    },
                )
                .into());
            }
        }
        let lens = optics::design_lens(&self.prescription()?, &self.design_params()?)?;
        let (off_mm, rim_mm) = (self.decentration_mm.length(), lens.rim_radius_m() * 1e3);
        if !(f64::from(off_mm) < rim_mm) {
            return Err(InvalidInput::new(
                "lens decentration (mm)",
                f64::from(off_mm),
                Expected::Range {
                    min: 0.0,
                    max: rim_mm,
                },
            )
            .into());
        }
        Ok(lens)
    }
}

/// The most vertices a lens's tessellation ([`Spectacles::tessellation`],
/// rings × segments) may have: 2¹⁸, 170 times the paper's ~1,500. Each
/// takes 48 bytes of a GPU buffer the refraction pass binds whole; 3.3
/// million of them (160 MB) passed the other checks and overran the 128
/// MiB a storage binding may hold, stopping rendering with a wgpu error
/// (found by drawing random accepted settings).
pub const MAX_LENS_VERTICES: u64 = 1 << 18;

/// A curved mirror in the scene, seen by the camera with [`MirrorViewer`].
///
/// Its reflecting face looks along the entity's forward (−Z), so
/// `Transform::looking_at(viewer, Vec3::Y)` turns it to a viewer; the
/// rectangle spans `size_m` across X and Y. Keep its scale 1 (a scaled
/// mirror is named in the log: its reflection is traced unscaled). The
/// plugin gives it its mesh and material.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_spectacles::{CurvedMirror, MirrorViewer};
///
/// fn setup(mut commands: Commands) {
///     commands.spawn((Camera3d::default(), MirrorViewer));
///     // A door mirror 1 m ahead, turned to the camera.
///     commands.spawn((
///         CurvedMirror::default(),
///         Transform::from_xyz(0.3, 0.0, -1.0).looking_at(Vec3::ZERO, Vec3::Y),
///     ));
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default, Clone)]
#[require(Transform, Visibility)]
pub struct CurvedMirror {
    /// Radius of curvature (m): positive convex (a passenger-side door
    /// mirror: 1.2–1.5 m; European rules ask at least 1.2 m), negative
    /// concave, `f32::INFINITY` flat. A zero or NaN radius, or one smaller
    /// than the half-diagonal, is refused (named in the log; nothing drawn).
    pub radius_m: f32,
    /// Width and height (m).
    pub size_m: Vec2,
    /// Cells of the mirror's grid across and down (the per-vertex method's
    /// knob: its error against an exact trace falls with it).
    pub tessellation: UVec2,
    /// Reflectance (0–1): about 0.9 for a silvered glass mirror, 0.5–0.6
    /// for a car's chromed or blue-tinted one.
    pub reflectance: f32,
    /// Side (px) of the environment image (per vertex) or of each cube
    /// face (cube maps).
    pub resolution: u32,
    /// How the reflection is drawn.
    pub method: MirrorMethod,
}

impl Default for CurvedMirror {
    fn default() -> Self {
        Self {
            radius_m: 1.4,
            size_m: Vec2::new(0.24, 0.16),
            tessellation: UVec2::new(32, 24),
            reflectance: 0.9,
            resolution: 512,
            method: MirrorMethod::PerVertex,
        }
    }
}

impl CurvedMirror {
    /// The mirror's optics (its CPU twin), or why it is refused.
    pub fn optics(&self) -> Result<MirrorOptics, Error> {
        MirrorOptics::new(
            f64::from(self.radius_m),
            f64::from(self.size_m.x),
            f64::from(self.size_m.y),
        )
        .map_err(Error::Mirror)
    }
}

/// How a [`CurvedMirror`] reflects.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub enum MirrorMethod {
    /// The paper's per-vertex ray tracing: each vertex shows where its
    /// reflected ray meets the scene.
    #[default]
    PerVertex,
    /// Bevy's reflection probe with a cube map captured at the mirror every
    /// frame, treated as infinitely far (no parallax correction).
    CubeMap,
    /// Bevy's parallax-corrected reflection probe: the cube map captured at
    /// the centre of the room's box every frame, the reflection corrected
    /// against the box's walls (exact on them: 0.11 px in the report's
    /// scene on Mesa 25's lavapipe). The probe is a cube round the room
    /// (side: the box's largest size), the box its parallax bound: Bevy
    /// corrects in the probe's own space, which keeps directions only
    /// under a uniform scale. A device without reflection probes draws the
    /// plain cube map instead (see [`MirrorState`](crate::MirrorState)).
    ParallaxCorrectedCubeMap {
        /// The room box's centre (world, m).
        room_centre: Vec3,
        /// Half its size along the world axes (m).
        room_half_size: Vec3,
    },
}

/// Marks the camera mirrors are traced for (one per app: the per-vertex
/// method reflects one viewpoint). It is given [`MIRROR_LAYER`](crate::MIRROR_LAYER) so it sees
/// the mirrors.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component, Default)]
pub struct MirrorViewer;
