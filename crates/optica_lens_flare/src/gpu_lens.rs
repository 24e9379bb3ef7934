//! The lens as the trace shader reads it (`shaders/lens_trace.wgsl`): one
//! record of eight `f32` per surface, the layout of its `LensSurface`.

use bevy::render::render_resource::ShaderType;
use optica_optics::lens::PreparedLens;
use optica_optics::lens_flare::{Aperture, ApertureShape};

/// The trace shader library (`shaders/lens_trace.wgsl`), the WGSL twin of
/// `optica_optics::lens::PreparedLens::trace_to`, the shader library
/// `optica_lens_flare::lens_trace`. It reads the lens through the virtual
/// `surface_count()` and `surface_at(k)`, which the including shader
/// overrides; pasted into plain WGSL (a readback test), its
/// `#define_import_path` line and those two defaults are left out and the
/// two defined instead.
pub const LENS_TRACE_WGSL: &str = include_str!("shaders/lens_trace.wgsl");

/// The aperture test (`shaders/aperture.wgsl`), the WGSL twin of
/// `optica_optics::lens_flare::Aperture::contains`:
/// `aperture_contains(p, blades, rotation, radius, arc_w)` with
/// [`aperture_params`] (blades 0 = round); the shader library
/// `optica_lens_flare::aperture`.
pub const APERTURE_WGSL: &str = include_str!("shaders/aperture.wgsl");

/// The aperture as `aperture_contains` takes it: blades (0 = round),
/// rotation (rad), circumradius (mm) and the edge arcs' `1/q`.
pub fn aperture_params(aperture: &Aperture) -> (u32, f32, f32, f32) {
    let r = aperture.radius_mm();
    match aperture.shape() {
        ApertureShape::Circle => (0, 0.0, r as f32, 0.0),
        ApertureShape::Blades {
            blades,
            rotation_rad,
            roundness,
        } => {
            let half = std::f64::consts::PI / f64::from(blades);
            // As `Aperture::blades` computes it.
            let w = if r > 0.0 {
                roundness / r / (1.0 - (roundness * half.sin()).powi(2)).sqrt()
            } else {
                0.0
            };
            (blades, rotation_rad as f32, r as f32, w as f32)
        }
    }
}

/// Floats per surface record.
pub const SURFACE_FLOATS: usize = 8;

/// One surface as the shaders read it (`LensSurface`): z, curvature,
/// semi-aperture, n before, n after, stop flag, coating index (0 = bare),
/// coating thickness (nm).
#[derive(ShaderType, Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct GpuSurface {
    z: f32,
    c: f32,
    semi: f32,
    n_before: f32,
    n_after: f32,
    is_stop: f32,
    coat_n: f32,
    coat_d_nm: f32,
}

impl GpuSurface {
    /// Its floats in the order of the record.
    fn floats(self) -> [f32; SURFACE_FLOATS] {
        [
            self.z,
            self.c,
            self.semi,
            self.n_before,
            self.n_after,
            self.is_stop,
            self.coat_n,
            self.coat_d_nm,
        ]
    }
}

/// The surfaces of `lens` (at its wavelength) as the trace pass reads them.
pub(crate) fn gpu_surfaces(lens: &PreparedLens) -> Vec<GpuSurface> {
    lens.surface_data()
        .iter()
        .map(|s| {
            let (coat_n, coat_d) = s
                .coating
                .map_or((0.0, 0.0), |c| (c.index(), c.thickness_nm()));
            GpuSurface {
                z: s.vertex_z as f32,
                c: s.curvature as f32,
                semi: s.semi_aperture_mm as f32,
                n_before: s.n_before as f32,
                n_after: s.n_after as f32,
                is_stop: if s.is_stop { 1.0 } else { 0.0 },
                coat_n: coat_n as f32,
                coat_d_nm: coat_d as f32,
            }
        })
        .collect()
}

/// The surfaces of `lens` (at its wavelength) as the shader's
/// `LensSurface` records, the floats of the records the trace pass reads:
/// z, curvature, semi-aperture, n before, n after, stop flag, coating
/// index (0 = bare), coating thickness (nm).
pub fn pack_surfaces(lens: &PreparedLens) -> Vec<[f32; SURFACE_FLOATS]> {
    gpu_surfaces(lens)
        .into_iter()
        .map(GpuSurface::floats)
        .collect()
}
