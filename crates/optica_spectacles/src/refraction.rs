//! The lens's refraction of the view (the paper's §3): rays traced on the
//! CPU from the eye through every vertex of the lens's back surface and
//! both surfaces, redone only when the lens or its place before the eye
//! changes; on the GPU each vertex's exit ray finds the scene in the eye
//! camera's depth, and the lens, drawn over the view, shows the view where
//! those rays land (see `render::refraction`).

use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::render_resource::ShaderType;
use optica_optics::glam::DVec3;
use optica_optics::glass::{LAMBDA_C_NM, LAMBDA_F_NM};
use optica_optics::spectacles::{
    DEFAULT_VIEWPOINT_REGULARISATION, LensTrace, SpectacleLens, refract_vertices,
    virtual_viewpoint_of_traces,
};

use crate::Error;
use crate::precompute::camera_z;
use crate::settings::Spectacles;

/// One lens vertex as the GPU reads it (`LensVertex` in
/// `lens_refraction.wgsl`), in the eye camera's view space (metres, −z
/// ahead).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct LensVertex {
    /// The back-surface vertex (where the eye looks into the lens).
    pub back: Vec3,
    /// 1 when the ray through it leaves the front surface; 0 when it is
    /// totally reflected or leaves through the rim (masked: drawn as the
    /// lens's dark edge, not as a wrong view).
    pub exits: u32,
    /// Where the ray leaves the front surface.
    pub origin: Vec3,
    /// Padding.
    pub _pad0: f32,
    /// Its direction after the lens (unit), at the d line (green).
    pub dir: Vec3,
    /// Padding.
    pub _pad1: f32,
    /// The direction at the C line (red): `dir` without chromatic
    /// aberration. The exit point is taken as the d line's for all three
    /// (they differ by micrometres).
    pub dir_red: Vec3,
    /// Padding.
    pub _pad2: f32,
    /// The direction at the F line (blue).
    pub dir_blue: Vec3,
    /// Padding.
    pub _pad3: f32,
}

/// The traced lens of an eye camera, made from its [`Spectacles`] whenever
/// they change (the lens, or where it sits: `decentration_mm`), and drawn
/// over the camera's view. Read it for the virtual viewpoint.
#[derive(Component, Clone, Debug, ExtractComponent)]
pub struct LensRefraction {
    /// Every back-surface vertex, ring by ring from the axis.
    pub vertices: Vec<LensVertex>,
    /// Triangles over them.
    pub indices: Vec<u32>,
    /// The virtual viewpoint (the paper's §3.1 step 2: the point nearest
    /// the refracted rays' backward extensions), view space (m).
    pub viewpoint: Vec3,
    /// How far the refracted rays pass from it, root mean square (m): how
    /// well a single viewpoint stands for the lens.
    pub viewpoint_rms_m: f32,
    /// Vertices whose ray does not leave through the front surface.
    pub masked: u32,
    /// Time of the trace (ms).
    pub trace_ms: f32,
    /// Whether red and blue were traced apart from green (the lens's
    /// chromatic aberration is drawn); otherwise green's rays stand for all.
    pub chromatic: bool,
}

/// An eye-frame point (cornea at z = 0, +z ahead, +x to the wearer's
/// left) in the camera's view space.
pub fn view_of_eye(p: DVec3) -> Vec3 {
    Vec3::new(-p.x as f32, p.y as f32, camera_z() - p.z as f32)
}

/// An eye-frame direction in the camera's view space.
fn view_dir_of_eye(d: DVec3) -> Vec3 {
    Vec3::new(-d.x as f32, d.y as f32, -d.z as f32)
}

/// Traces `lens`, shifted `decentration` (m, eye frame x and y: the lens's
/// optical centre off the line of sight), at `rings × segments`: the rays
/// from the camera (the entrance pupil) through every back-surface vertex;
/// with `chromatic`, also at the C and F lines (red and blue).
pub fn trace_lens(
    lens: &SpectacleLens,
    decentration: DVec3,
    rings: usize,
    segments: usize,
    chromatic: bool,
) -> Result<LensRefraction, Error> {
    let started = std::time::Instant::now();
    let mesh = lens.mesh(rings, segments).map_err(Error::Refraction)?;
    // In the lens's frame the eye sits off its axis by −decentration.
    let eye = DVec3::new(0.0, 0.0, f64::from(camera_z())) - decentration;
    let back = mesh.back_positions();
    let traces = refract_vertices(lens, eye, back).map_err(|e| Error::Refraction(e.into()))?;
    // The directions at the C and F lines; a ray that gets through at the
    // d line but not at another (total reflection within a hair of the
    // rim) keeps the d line's.
    let chromatic = chromatic && lens.params().material().is_dispersive();
    let exit_dirs = |nm: f64| -> Result<Vec<Option<DVec3>>, Error> {
        if !chromatic {
            return Ok(vec![None; back.len()]);
        }
        let t = refract_vertices(&lens.at_wavelength(nm), eye, back)
            .map_err(|e| Error::Refraction(e.into()))?;
        Ok(t.iter()
            .map(|t| match *t {
                LensTrace::Exit { dir, .. } => Some(dir),
                _ => None,
            })
            .collect())
    };
    let (red, blue) = (exit_dirs(LAMBDA_C_NM)?, exit_dirs(LAMBDA_F_NM)?);
    let fit = virtual_viewpoint_of_traces(&traces, eye, DEFAULT_VIEWPOINT_REGULARISATION)
        .map_err(Error::Refraction)?;
    let mut masked = 0;
    let vertices = back
        .iter()
        .zip(&traces)
        .enumerate()
        .map(|(i, (b, t))| {
            let (origin, dir, exits) = match *t {
                LensTrace::Exit { front, dir, .. } => (front, dir, 1),
                _ => {
                    masked += 1;
                    (*b, (*b - eye).normalize_or_zero(), 0)
                }
            };
            LensVertex {
                back: view_of_eye(*b + decentration),
                exits,
                origin: view_of_eye(origin + decentration),
                dir: view_dir_of_eye(dir),
                dir_red: view_dir_of_eye(red[i].unwrap_or(dir)),
                dir_blue: view_dir_of_eye(blue[i].unwrap_or(dir)),
                ..default()
            }
        })
        .collect();
    let n = back.len() as u32;
    let indices = mesh
        .triangles()
        .iter()
        .filter(|t| t.iter().all(|&i| i < n))
        .flatten()
        .copied()
        .collect();
    Ok(LensRefraction {
        vertices,
        indices,
        viewpoint: view_of_eye(fit.point + decentration),
        viewpoint_rms_m: fit.rms_distance_m as f32,
        masked,
        trace_ms: started.elapsed().as_secs_f32() * 1e3,
        chromatic,
    })
}

/// Retraces the lens of every camera whose [`Spectacles`] changed, and
/// removes the trace where they were removed or the lens is not drawn.
pub(crate) fn update_refraction(
    mut commands: Commands,
    changed: Query<(Entity, &Spectacles), Changed<Spectacles>>,
    mut removed: RemovedComponents<Spectacles>,
) {
    for entity in removed.read() {
        if let Ok(mut e) = commands.get_entity(entity) {
            e.remove::<LensRefraction>();
        }
    }
    for (entity, spectacles) in &changed {
        if !spectacles.refraction {
            commands.entity(entity).remove::<LensRefraction>();
            continue;
        }
        // A refused lens is named by `update_optics` in SpectaclesStatus;
        // here it only leaves the view unrefracted.
        let Ok(lens) = spectacles.design() else {
            commands.entity(entity).remove::<LensRefraction>();
            continue;
        };
        let d = spectacles.decentration_mm.as_dvec2() * 1e-3;
        match trace_lens(
            &lens,
            DVec3::new(d.x, d.y, 0.0),
            spectacles.tessellation.x as usize,
            spectacles.tessellation.y as usize,
            spectacles.chromatic_aberration,
        ) {
            Ok(trace) => {
                commands.entity(entity).insert(trace);
            }
            Err(e) => {
                warn!("optica_spectacles: camera {entity}: lens refraction: {e}");
                commands.entity(entity).remove::<LensRefraction>();
            }
        }
    }
}

/// Makes the depth of cameras that draw a lens bindable (the exit rays
/// find the scene in it) and their view HDR (the lens resamples the view
/// in linear light, before tonemapping).
pub(crate) fn make_depth_readable(
    mut commands: Commands,
    mut cameras: Query<(Entity, &mut Camera3d, Has<bevy::camera::Hdr>), With<LensRefraction>>,
) {
    use bevy::render::render_resource::TextureUsages;
    for (entity, mut camera, hdr) in &mut cameras {
        let usages = TextureUsages::from(camera.depth_texture_usages);
        if !usages.contains(TextureUsages::TEXTURE_BINDING) {
            camera.depth_texture_usages = (usages | TextureUsages::TEXTURE_BINDING).into();
        }
        if !hdr {
            commands.entity(entity).insert(bevy::camera::Hdr);
        }
    }
}

/// The lens's refraction: its shader, and the trace when the lens changes.
pub(crate) struct LensRefractionPlugin;

impl Plugin for LensRefractionPlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "shaders/lens_refraction.wgsl");
        app.add_systems(
            PostUpdate,
            (update_refraction, make_depth_readable)
                .chain()
                .in_set(crate::SpectaclesSystems::Refraction),
        );
    }
}
