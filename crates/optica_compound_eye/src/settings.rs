//! The material's user-facing settings and what the shader receives.

use bevy::prelude::*;
use bevy::render::render_resource::{AsBindGroup, ShaderType};
use optica_optics::compound_eye::{
    DarkCentre, LatticeKind, LensParams, MAX_EXACT_LENSES, MAX_LENSES, MAX_SLICES,
};
use optica_optics::input::{self, InvalidInput};

use crate::Error;

/// A compound eye on any UV-mapped mesh: a `StandardMaterial` (colour,
/// roughness, textures, lights, shadows) with Sagawa's lens lattice between
/// the surface and its colour.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin};
///
/// fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<CompoundEyeMaterial>>) {
///     commands.spawn((
///         Mesh3d(meshes.add(Sphere::new(1.0).mesh().uv(64, 32))),
///         MeshMaterial3d(materials.add(CompoundEyeMaterial {
///             base: StandardMaterial { base_color: Color::srgb(0.55, 0.12, 0.08), ..default() },
///             extension: CompoundEye { facets_per_uv: 60.0, ..default() },
///         })),
///     ));
/// }
///
/// App::new().add_plugins((DefaultPlugins, CompoundEyePlugin)).add_systems(Startup, setup).run();
/// ```
pub type CompoundEyeMaterial = bevy::pbr::ExtendedMaterial<StandardMaterial, CompoundEye>;

/// The lens arrangement on the surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum EyeLattice {
    /// One lens per square cell: the thesis's layout.
    Square,
    /// Hexagonal close packing, like real ommatidia.
    #[default]
    Hexagonal,
}

impl From<EyeLattice> for LatticeKind {
    fn from(l: EyeLattice) -> Self {
        match l {
            EyeLattice::Square => LatticeKind::Square,
            EyeLattice::Hexagonal => LatticeKind::Hexagonal,
        }
    }
}

/// What the material draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum EyeOutput {
    /// The lit surface (the default).
    #[default]
    Shaded,
    /// The optics alone, unlit, as linear values: red = the factor on the
    /// surface colour (`c_t`, times the lenses' transmittance with Fresnel
    /// on), green = the weight of the environment seen by escaping rays,
    /// blue = lenses passed / 4 by the fragment's own ray (0 where the
    /// prefilter replaces that ray by the facet average). For tests,
    /// reports and debugging; read it
    /// from an HDR target with tonemapping off.
    PigmentOnly,
}

/// The procedural pigment used when no [`CompoundEye::pigment_texture`] is
/// given: a dark disc around each lens axis on the pigment plane (see
/// `optica_optics::compound_eye::DarkCentre`).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct PigmentDisc {
    /// Radius of the dark disc, in facets.
    pub radius: f32,
    /// Half-width of its soft edge, in facets.
    pub softness: f32,
    /// Fraction of the light absorbed at its centre, `0..=1`.
    pub darkness: f32,
}

impl Default for PigmentDisc {
    fn default() -> Self {
        let d = DarkCentre::default();
        Self {
            radius: d.radius() as f32,
            softness: d.softness() as f32,
            darkness: d.darkness() as f32,
        }
    }
}

/// The largest lens index [`CompoundEye::validate`] accepts (germanium, the
/// densest optical material in use, has `n ≈ 4`).
pub const MAX_INDEX: f32 = 16.0;
/// The deepest pigment plane [`CompoundEye::validate`] accepts, in lens radii.
pub const MAX_DEPTH: f32 = 1000.0;

/// The compound-eye extension of `StandardMaterial`: the lens lattice, its
/// optics, the pigment and the quality knobs. Use it as
/// [`CompoundEyeMaterial`]`{ base, extension }`.
///
/// Lengths are relative to the lattice, so one setting fits any mesh scale:
/// the lens radius is a fraction of the cell's inradius (half a facet on
/// undistorted UVs), the pigment depth a multiple of the lens radius.
///
/// Invalid values (NaN, a radius outside `(0, 1]`, a depth outside
/// `[2, MAX_DEPTH]` radii, an index outside `(0, MAX_INDEX]`, a non-positive
/// `facets_per_uv`) switch the lattice off: the mesh
/// renders as its plain `StandardMaterial`, and the plugin logs a warning
/// naming the value (once per change of the material).
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone, PartialEq)]
#[uniform(100, CompoundEyeUniform)]
pub struct CompoundEye {
    /// Facets per UV unit, `R_t` of the thesis's eq. 6.1: the texture
    /// coordinate times this is the lattice coordinate, one facet per unit.
    pub facets_per_uv: f32,
    /// The lens arrangement.
    pub lattice: EyeLattice,
    /// Lay the lattice along the mesh's tangents (`Mesh::ATTRIBUTE_TANGENT`,
    /// e.g. from `Mesh::with_generated_tangents`) instead of its UVs' axes:
    /// facets keep one shape (square, or regular hexagons) and the area the
    /// UVs give them, and since tangents are interpolated across triangle
    /// edges, a coarse mesh shows no seams (the UVs' own axes change at
    /// every edge where UVs are piecewise linear). The UVs' stretch and
    /// shear are not followed: use it on meshes whose UVs are (nearly)
    /// conformal, such as [`EyeCap`](crate::EyeCap). Without tangents on
    /// the mesh the UVs' axes are used.
    pub tangent_axes: bool,
    /// Lay the lattice along the smooth axis field that
    /// [`insert_axis_field`](crate::insert_axis_field) writes into the mesh
    /// (its tangents and second UV channel): each vertex carries its
    /// triangles' texture axes averaged, interpolated across every
    /// triangle, so a coarse mesh shows no seams **and** the UVs' stretch
    /// and shear are kept (which [`Self::tangent_axes`] gives up). Without
    /// the field on the mesh (no tangents or no second UV channel) the
    /// other axes are used.
    pub axis_field: bool,
    /// Lens (sphere) radius as a fraction of the cell's inradius, `(0, 1]`;
    /// 1 = neighbouring lenses touch.
    pub lens_radius: f32,
    /// Refractive index of the lenses relative to the outside, in
    /// `(0, MAX_INDEX]`.
    pub lens_index: f32,
    /// Depth of the pigment plane below the surface in lens radii, in
    /// `[2, MAX_DEPTH]`.
    /// The default 2 is the thesis's `d = 2r` (eq. 6.29): the plane touches
    /// the bottom of the sphere. It is independent of the index; the
    /// paraxial focus of a ball lens lies at `1 + n/(2(n−1))` radii, 2.5 for
    /// `n = 1.5`, which the presets use.
    pub pigment_depth: f32,
    /// Follow the exact path (the default): the view ray is walked cell by
    /// cell across the whole lens layer, so it finds the lens it really
    /// meets at any angle (entered below the sphere's equator too), and
    /// each exit ray is walked the same way, through up to 16 lenses with
    /// `follow_neighbours`. Off: the thesis's slice search with `slices`,
    /// exact near the axis and falling away at oblique incidence.
    pub exact: bool,
    /// Slice planes of the thesis's lens search (`K`, §6.4), clamped to 64,
    /// when `exact` is off. 0 looks only at the surface; 8 finds the right
    /// lens for all but grazing rays; 32 reaches the method's floor at
    /// every angle.
    pub slices: u32,
    /// Follow a ray that leaves one lens into its neighbours (up to 16
    /// lenses on the exact path, 4 with the slice search); off is the
    /// thesis's model (one lens).
    pub follow_neighbours: bool,
    /// Count the light the lens surfaces reflect (unpolarised Fresnel at
    /// entry and exit): the pigment's contribution is scaled by what is
    /// transmitted.
    pub fresnel: bool,
    /// Blend into the facet average where facets shrink below a pixel, so
    /// that distant eyes show their pseudopupil without moiré.
    pub prefilter: bool,
    /// The procedural pigment, used when `pigment_texture` is `None`.
    pub pigment: PigmentDisc,
    /// A greyscale pigment texture (red channel; 1 = transparent, 0 =
    /// absorbing), tiled over the pigment plane: its own UV space, set by
    /// `pigment_uv_scale` and `pigment_uv_offset`, independent of the lens
    /// lattice (thesis §6.2). Sampled with mipmaps when it has them, with
    /// the image's own sampler: give it `ImageAddressMode::Repeat` to tile
    /// it (Bevy's default sampler clamps at the edge).
    #[texture(101)]
    #[sampler(102)]
    pub pigment_texture: Option<Handle<Image>>,
    /// The prefilter's table of facet averages ([`PrefilterTable`]), made
    /// by the plugin from the other settings whenever they change (shared
    /// between materials with the same optics): leave it `None`. Until it
    /// is made, and with a pigment texture, the prefilter traces nine rays
    /// a fragment instead.
    ///
    /// [`PrefilterTable`]: optica_optics::compound_eye::PrefilterTable
    #[texture(103, sample_type = "float", filterable = false)]
    pub prefilter_table: Option<Handle<Image>>,
    /// Pigment texture coordinate per facet: `tex = facet · scale + offset`.
    pub pigment_uv_scale: Vec2,
    /// See `pigment_uv_scale`.
    pub pigment_uv_offset: Vec2,
    /// What the material draws.
    pub output: EyeOutput,
}

impl Default for CompoundEye {
    /// Hexagonal touching lenses of index 1.5 with the pigment at the
    /// thesis's `d = 2r`, the exact path, neighbours, Fresnel and the
    /// prefilter on, 40 facets per UV unit.
    fn default() -> Self {
        Self {
            facets_per_uv: 40.0,
            lattice: EyeLattice::Hexagonal,
            tangent_axes: false,
            axis_field: false,
            lens_radius: 1.0,
            lens_index: 1.5,
            pigment_depth: 2.0,
            exact: true,
            slices: 8,
            follow_neighbours: true,
            fresnel: true,
            prefilter: true,
            pigment: PigmentDisc::default(),
            pigment_texture: None,
            prefilter_table: None,
            pigment_uv_scale: Vec2::ONE,
            pigment_uv_offset: Vec2::ZERO,
            output: EyeOutput::Shaded,
        }
    }
}

impl CompoundEye {
    /// The thesis's model: square lattice, touching lenses, `d = 2r`, one
    /// lens per ray found by `slices` slice planes, no Fresnel, no
    /// prefilter.
    pub fn thesis(facets_per_uv: f32, lens_index: f32, slices: u32) -> Self {
        Self {
            facets_per_uv,
            lattice: EyeLattice::Square,
            lens_index,
            exact: false,
            slices,
            follow_neighbours: false,
            fresnel: false,
            prefilter: false,
            ..default()
        }
    }

    /// Checks every number: the first one the shader cannot use, named.
    pub fn validate(&self) -> Result<(), InvalidInput> {
        input::positive("facets per UV unit", self.facets_per_uv as f64)?;
        input::in_range(
            "lens radius (fraction of the cell inradius)",
            self.lens_radius as f64,
            f64::MIN_POSITIVE,
            1.0,
        )?;
        // Beyond these bounds f32 overflows inside the refraction; no real
        // lens comes near them (germanium, n ≈ 4, is the densest optics).
        input::in_range(
            "lens refractive index",
            self.lens_index as f64,
            f64::MIN_POSITIVE,
            MAX_INDEX as f64,
        )?;
        input::in_range(
            "pigment depth (lens radii)",
            self.pigment_depth as f64,
            0.0,
            MAX_DEPTH as f64,
        )?;
        // A unit lens checks index and depth ≥ 2r as the CPU twin does.
        LensParams::new(1.0, self.lens_index as f64, self.pigment_depth as f64).map_err(
            |e| match e {
                optica_optics::compound_eye::CompoundEyeError::Input(i) => i,
                _ => InvalidInput::new(
                    "pigment depth (lens radii)",
                    self.pigment_depth as f64,
                    optica_optics::input::Expected::AtLeast(2.0),
                ),
            },
        )?;
        DarkCentre::new(
            self.pigment.radius as f64,
            self.pigment.softness as f64,
            self.pigment.darkness as f64,
        )?;
        input::finite_vec2("pigment UV scale", self.pigment_uv_scale.as_dvec2())?;
        input::finite_vec2("pigment UV offset", self.pigment_uv_offset.as_dvec2())?;
        Ok(())
    }

    /// The optics' `LatticeKind`.
    pub fn lattice_kind(&self) -> LatticeKind {
        self.lattice.into()
    }
}

/// Switches of the shader, packed into one `u32` (the `FLAG_*` constants at
/// the top of `compound_eye.wgsl`).
mod flags {
    pub const ENABLED: u32 = 1;
    pub const HEXAGONAL: u32 = 2;
    pub const FRESNEL: u32 = 4;
    pub const PREFILTER: u32 = 8;
    pub const TEXTURE: u32 = 16;
    pub const PIGMENT_ONLY: u32 = 32;
    pub const EXACT: u32 = 64;
    pub const TABLE: u32 = 128;
    pub const TANGENT_AXES: u32 = 256;
    pub const AXIS_FIELD: u32 = 512;
}

/// The uniform the shader reads (`CompoundEyeUniform` in `compound_eye.wgsl`).
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct CompoundEyeUniform {
    facets_per_uv: f32,
    lens_radius: f32,
    lens_index: f32,
    pigment_depth: f32,
    dark_radius: f32,
    dark_softness: f32,
    darkness: f32,
    slices: u32,
    pigment_scale: Vec2,
    pigment_offset: Vec2,
    max_lenses: u32,
    flags: u32,
}

impl From<&CompoundEye> for CompoundEyeUniform {
    fn from(e: &CompoundEye) -> Self {
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        let flags = flag(e.validate().is_ok(), flags::ENABLED)
            | flag(e.lattice == EyeLattice::Hexagonal, flags::HEXAGONAL)
            | flag(e.fresnel, flags::FRESNEL)
            | flag(e.prefilter, flags::PREFILTER)
            | flag(e.pigment_texture.is_some(), flags::TEXTURE)
            | flag(e.output == EyeOutput::PigmentOnly, flags::PIGMENT_ONLY)
            | flag(e.exact, flags::EXACT)
            | flag(e.prefilter_table.is_some(), flags::TABLE)
            | flag(e.tangent_axes, flags::TANGENT_AXES)
            | flag(e.axis_field, flags::AXIS_FIELD);
        Self {
            facets_per_uv: e.facets_per_uv,
            lens_radius: e.lens_radius,
            lens_index: e.lens_index,
            pigment_depth: e.pigment_depth,
            dark_radius: e.pigment.radius,
            dark_softness: e.pigment.softness,
            darkness: e.pigment.darkness,
            slices: e.slices.min(MAX_SLICES),
            pigment_scale: e.pigment_uv_scale,
            pigment_offset: e.pigment_uv_offset,
            max_lenses: match (e.follow_neighbours, e.exact) {
                (false, _) => 1,
                (true, true) => MAX_EXACT_LENSES,
                (true, false) => MAX_LENSES,
            },
            flags,
        }
    }
}

/// What the plugin made of the [`CompoundEyeMaterial`] of a mesh: whether
/// the lattice is drawn, whether the prefilter's table is in use, and why
/// not. Added to every entity with a `MeshMaterial3d<CompoundEyeMaterial>`
/// and kept up to date when its material changes.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default)]
pub struct CompoundEyeStatus {
    /// The settings are valid: the shader draws the lattice (otherwise the
    /// mesh renders as its base material).
    pub lattice: bool,
    /// The prefilter's table is bound: facets below a pixel show their
    /// average response instead of moiré ([`CompoundEye::prefilter`] on,
    /// no pigment texture).
    pub prefiltered: bool,
    /// Why the eye is not drawn as set; `None` while the material is still
    /// loading.
    #[reflect(ignore)]
    pub error: Option<Error>,
}
