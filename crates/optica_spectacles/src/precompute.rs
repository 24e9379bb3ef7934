//! From the user's [`Eye`], [`Spectacles`] and [`CloneDefocus`] to what the
//! clones need: the eye model, the lens design and the voxel field, redone
//! only when one of them changes (a field at the paper's setting takes
//! tens of milliseconds; nothing here runs on frames where nothing changed).

use std::time::Instant;

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::ShaderType;
use bevy::render::storage::ShaderBuffer;
use optica_optics::glam::DVec3;
use optica_optics::spectacles::{
    self as optics, DisplacementField, EyePlacement, FieldSettings, FieldStats, SpectacleLens,
};

use crate::Error;
use crate::settings::{CloneDefocus, Eye, Spectacles};

/// Where the eye sits relative to its camera: the camera is the entrance
/// pupil looking straight ahead, 3 mm behind the cornea, and the eye turns
/// about its centre of rotation 13.5 mm behind the cornea
/// (`optica_optics::spectacles::EyePlacement::default`).
pub fn eye_placement() -> EyePlacement {
    EyePlacement::default()
}

/// The camera's place in the eye's frame: z of the entrance pupil (m).
pub fn camera_z() -> f32 {
    let p = eye_placement();
    (p.centre_of_rotation().z + p.pupil_offset_m()) as f32
}

/// What the plugin made of a camera's [`Eye`], [`Spectacles`] and
/// [`CloneDefocus`]: the numbers a wearer would ask about, and why a
/// setting was refused. Added and kept up to date by the plugin.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Clone)]
pub struct SpectaclesStatus {
    /// Near point of the naked eye (m from the pupil; negative: a virtual
    /// point behind the eye; infinite when it lies at infinity).
    pub near_point_m: f32,
    /// Far point of the naked eye (m, same conventions).
    pub far_point_m: f32,
    /// The pupil diameter in use (mm).
    pub pupil_mm: f32,
    /// Through the lens, straight ahead: the corrected near and far points
    /// (m from the pupil; infinite at or beyond infinity), from the fitted
    /// vergence of the traced bundles.
    pub corrected_near_far_m: Option<Vec2>,
    /// The lens: centre thickness, thinnest edge (mm) and front power (D).
    pub lens_centre_edge_mm_front_d: Option<Vec3>,
    /// The field's counters: aims tried and failed at the rim, voxels
    /// crossed, voxels filled.
    pub field_aims_failed_crossed_filled: Option<UVec4>,
    /// Time of the last lens design and field precompute (ms).
    pub precompute_ms: f32,
    /// The last setting that was refused; the plugin then keeps the last
    /// good eye and lens (or draws the view sharp when it has none).
    #[reflect(ignore)]
    pub error: Option<Error>,
}

/// What the clone shader knows of the eye, the lens and the field
/// (`CloneParams` in `displacement.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType, Reflect)]
pub struct CloneUniform {
    /// 0: sharp, 1: the naked eye in closed form, 2: the voxel field.
    pub mode: u32,
    /// `S`.
    pub clones: u32,
    /// Tiles across the atlas.
    pub tile_cols: u32,
    /// Tiles down the atlas.
    pub tile_rows: u32,
    /// `A/2` (m).
    pub pupil_radius: f32,
    /// Near point vergence (D), of the spherical equivalent.
    pub p_near: f32,
    /// Far point vergence (D), of the spherical equivalent.
    pub p_far: f32,
    /// Centre of rotation to pupil (m).
    pub pupil_offset: f32,
    /// z of the centre of rotation (m).
    pub centre_z: f32,
    /// z of the camera (m).
    pub camera_z: f32,
    /// The field's min corner (m, eye frame; in eye coordinates
    /// `x/z'`, `y/z'`, `1/z'`).
    pub grid_origin: Vec3,
    /// The field's cell size (m, or in eye coordinates).
    pub grid_cell: Vec3,
    /// The field's cells per axis.
    pub grid_dims: UVec3,
    /// 0: clones shaded in full, 1: reprojected from the sharp view
    /// ([`CloneShading`](crate::CloneShading)).
    pub shading: u32,
    /// The eye's cylinder (D; 0 for a stigmatic eye).
    pub cylinder: f32,
    /// The cylinder's axis, a unit vector in the eye's x–y plane.
    pub axis: Vec2,
}

/// Shader modes of [`CloneUniform::mode`].
pub(crate) mod mode {
    pub const SHARP: u32 = 0;
    pub const NAKED: u32 = 1;
    pub const FIELD: u32 = 2;
    /// The voxel field in eye coordinates (`FieldGrid::Eye`).
    pub const FIELD_EYE: u32 = 3;
}

/// The optics of one eye camera, for the clones.
#[derive(Component, Clone, Debug)]
pub struct EyeOptics {
    /// The eye model.
    pub eye: optics::Eye,
    /// The designed lens, when [`Spectacles`] are worn, where the frame
    /// holds it (`SpectacleLens::decentred` by
    /// [`Spectacles::decentration_mm`]): trace it as it is, not through
    /// `trace_lens`, which takes a centred lens and its shift.
    pub lens: Option<SpectacleLens>,
    /// The field through the lens: its vectors on the GPU, and its
    /// geometry and counters.
    pub field: Option<(Handle<ShaderBuffer>, FieldGeometry)>,
    /// The shader's numbers.
    pub uniform: CloneUniform,
}

/// A field's grid and counters, without its vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldGeometry {
    /// Min corner (m, eye frame).
    pub origin: DVec3,
    /// Cell size (m).
    pub cell: DVec3,
    /// Cells per axis.
    pub dims: [usize; 3],
    /// Whether the cells lie in eye coordinates (`origin` and `cell` then
    /// in `x/z'`, `y/z'`, `1/z'`).
    pub eye_coordinates: bool,
    /// The precompute's counters.
    pub stats: FieldStats,
}

/// What a field was built from: rebuilt only when this changes.
#[derive(Component, Clone, Debug, PartialEq)]
pub(crate) struct BuiltFrom {
    eye: optics::Eye,
    lens: Option<SpectacleLens>,
    settings: Option<FieldSettings>,
}

/// The field's maps as the GPU reads them: `cells × 2 × 3` little-endian
/// `f32`s, voxel-major (x fastest), then `m_x`, `m_y`, then component.
pub fn field_bytes(field: &DisplacementField) -> Vec<u8> {
    let mut out = Vec::with_capacity(field.maps().len() * 12);
    for v in field.maps() {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// Redoes the optics of every eye camera whose settings changed.
#[allow(clippy::type_complexity)]
pub(crate) fn update_optics(
    mut commands: Commands,
    changed: Query<
        (
            Entity,
            &Eye,
            &CloneDefocus,
            Option<&Spectacles>,
            Option<&EyeOptics>,
            Option<&BuiltFrom>,
            Option<&SpectaclesStatus>,
        ),
        Or<(Changed<Eye>, Changed<Spectacles>, Changed<CloneDefocus>)>,
    >,
    mut removed_spectacles: RemovedComponents<Spectacles>,
    all: Query<
        (
            Entity,
            &Eye,
            &CloneDefocus,
            Option<&Spectacles>,
            Option<&EyeOptics>,
            Option<&BuiltFrom>,
            Option<&SpectaclesStatus>,
        ),
        Without<Spectacles>,
    >,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
) {
    let mut todo: Vec<_> = changed.iter().collect();
    for entity in removed_spectacles.read() {
        if let Ok(item) = all.get(entity)
            && !todo.iter().any(|t| t.0 == entity)
        {
            todo.push(item);
        }
    }
    for (entity, eye, defocus, spectacles, old, built, status) in todo {
        let started = Instant::now();
        let mut status = status.cloned().unwrap_or_default();
        status.error = None;
        let mut refuse = |why: Error| {
            warn!("optica_spectacles: camera {entity}: {why}");
            status.error = Some(why);
        };
        // The eye: refused numbers keep the last good eye.
        let eye_model = match eye.optics() {
            Ok(e) => Some(e),
            Err(e) => {
                refuse(Error::Eye(e.into()));
                old.map(|o| o.eye)
            }
        };
        let Some(eye_model) = eye_model else {
            commands.entity(entity).insert(status);
            continue;
        };
        // The lens, where the frame holds it (the field blurs through the
        // decentred lens): an impossible prescription keeps the last good
        // lens.
        let lens = match spectacles.map(|s| {
            let d = s.decentration_mm.as_dvec2() * 1e-3;
            s.design()
                .and_then(|l| l.decentred(d).map_err(optics::SpectaclesError::from))
        }) {
            None => None,
            Some(Ok(l)) => Some(l),
            Some(Err(e)) => {
                refuse(Error::Spectacles(e));
                old.and_then(|o| o.lens)
            }
        };
        let settings = match lens {
            None => None,
            Some(_) => match defocus.field.settings() {
                Ok(s) => Some(s),
                Err(e) => {
                    refuse(Error::Field(e.into()));
                    built.and_then(|b| b.settings)
                }
            },
        };
        let from = BuiltFrom {
            eye: eye_model,
            lens,
            settings,
        };
        let mut field = old.and_then(|o| o.field.clone());
        if built != Some(&from) {
            field = None;
            if let (Some(lens), Some(settings)) = (&lens, &settings) {
                match optics::precompute_field(&eye_model, &eye_placement(), Some(lens), settings) {
                    Ok(f) => {
                        let geometry = FieldGeometry {
                            origin: f.counts().origin(),
                            cell: f.counts().cell_size(),
                            dims: f.counts().dims(),
                            eye_coordinates: matches!(f.layout(), optics::FieldLayout::Eye { .. }),
                            stats: *f.stats(),
                        };
                        let buffer = buffers.add(ShaderBuffer {
                            data: Some(field_bytes(&f)),
                            asset_usage: RenderAssetUsages::RENDER_WORLD,
                            ..default()
                        });
                        field = Some((buffer, geometry));
                    }
                    Err(e) => refuse(Error::Field(e)),
                }
            }
            status.precompute_ms = started.elapsed().as_secs_f32() * 1e3;
        }
        fill_status(&mut status, &eye_model, lens.as_ref(), field.as_ref());
        let uniform = clone_uniform(&eye_model, lens.is_some(), field.as_ref(), defocus);
        commands.entity(entity).insert((
            EyeOptics {
                eye: eye_model,
                lens,
                field,
                uniform,
            },
            from,
            status,
        ));
    }
}

/// The shader's numbers for an eye (tiles are filled in by the clone rig).
fn clone_uniform(
    eye: &optics::Eye,
    wears_lens: bool,
    field: Option<&(Handle<ShaderBuffer>, FieldGeometry)>,
    defocus: &CloneDefocus,
) -> CloneUniform {
    let p = eye_placement();
    let mut u = CloneUniform {
        mode: mode::NAKED,
        clones: defocus.clones.clamp(1, crate::settings::MAX_CLONES),
        tile_cols: 1,
        tile_rows: 1,
        pupil_radius: (0.5 * eye.pupil_diameter_m()) as f32,
        p_near: eye.near_point_vergence_d() as f32,
        p_far: eye.far_point_vergence_d() as f32,
        pupil_offset: p.pupil_offset_m() as f32,
        centre_z: p.centre_of_rotation().z as f32,
        camera_z: camera_z(),
        grid_origin: Vec3::ZERO,
        grid_cell: Vec3::ONE,
        grid_dims: UVec3::ONE,
        shading: match defocus.shading {
            crate::settings::CloneShading::Full => 0,
            crate::settings::CloneShading::Reprojected => 1,
        },
        cylinder: eye.cylinder_d() as f32,
        axis: eye.axis_direction().truncate().as_vec2(),
    };
    match field {
        Some((_, g)) => {
            u.mode = if g.eye_coordinates {
                mode::FIELD_EYE
            } else {
                mode::FIELD
            };
            u.grid_origin = g.origin.as_vec3();
            u.grid_cell = g.cell.as_vec3();
            u.grid_dims = UVec3::new(g.dims[0] as u32, g.dims[1] as u32, g.dims[2] as u32);
        }
        // Spectacles whose field could not be built: drawn sharp rather
        // than as the naked eye, which would pretend the lens is not there.
        None if wears_lens => u.mode = mode::SHARP,
        None => {}
    }
    u
}

/// Fills the wearer's numbers.
fn fill_status(
    status: &mut SpectaclesStatus,
    eye: &optics::Eye,
    lens: Option<&SpectacleLens>,
    field: Option<&(Handle<ShaderBuffer>, FieldGeometry)>,
) {
    status.near_point_m = eye.near_point_m() as f32;
    status.far_point_m = eye.far_point_m() as f32;
    status.pupil_mm = (eye.pupil_diameter_m() * 1e3) as f32;
    status.corrected_near_far_m = lens.and_then(|l| corrected_points(eye, l));
    status.lens_centre_edge_mm_front_d = lens.map(|l| {
        let edge = (0..72)
            .filter_map(|k| {
                l.edge_thickness_m(f64::from(k) * std::f64::consts::TAU / 72.0)
                    .ok()
            })
            .fold(f64::INFINITY, f64::min);
        Vec3::new(
            (l.centre_thickness_m() * 1e3) as f32,
            (edge * 1e3) as f32,
            l.front_power_d() as f32,
        )
    });
    status.field_aims_failed_crossed_filled = field.map(|(_, g)| {
        UVec4::new(
            g.stats.aims as u32,
            g.stats.aims_failed as u32,
            g.stats.voxels_crossed as u32,
            g.stats.voxels_filled as u32,
        )
    });
}

/// The corrected near and far points straight ahead (m from the lens's
/// exit; infinite at or beyond infinity): the fitted vergence of the near
/// and far bundles along the axis, traced through the lens.
pub fn corrected_points(eye: &optics::Eye, lens: &SpectacleLens) -> Option<Vec2> {
    let samples = optics::pupil_samples(64);
    let rho = 0.5 * eye.pupil_diameter_m().max(1e-3);
    let point = |v: f64| {
        optics::trace_bundle(Some(lens), &eye_placement(), DVec3::Z, rho, v, &samples)
            .ok()
            .map(|b| {
                let w = b.vergence_d();
                if w > 0.0 {
                    (1.0 / w) as f32
                } else {
                    f32::INFINITY
                }
            })
    };
    Some(Vec2::new(
        point(eye.near_point_vergence_d())?,
        point(eye.far_point_vergence_d())?,
    ))
}
