//! The lens as the trace shader reads it (`shaders/lens_trace.wgsl`): one
//! record of eight `f32` per surface, the layout of its `LensSurface`.

use optica_optics::lens::PreparedLens;

/// The trace shader library (`shaders/lens_trace.wgsl`), the WGSL twin of
/// `optica_optics::lens::PreparedLens::trace_to`. It reads the lens through
/// `surface_count()` and `surface_at(k)`, which the including shader
/// defines.
pub const LENS_TRACE_WGSL: &str = include_str!("shaders/lens_trace.wgsl");

/// Floats per surface record.
pub const SURFACE_FLOATS: usize = 8;

/// The surfaces of `lens` (at its wavelength) as the shader's
/// `LensSurface` records: z, curvature, semi-aperture, n before, n after,
/// stop flag, coating index (0 = bare), coating thickness (nm).
pub fn pack_surfaces(lens: &PreparedLens) -> Vec<[f32; SURFACE_FLOATS]> {
    lens.surface_data()
        .iter()
        .map(|s| {
            let (coat_n, coat_d) = s
                .coating
                .map_or((0.0, 0.0), |c| (c.index(), c.thickness_nm()));
            [
                s.vertex_z as f32,
                s.curvature as f32,
                s.semi_aperture_mm as f32,
                s.n_before as f32,
                s.n_after as f32,
                if s.is_stop { 1.0 } else { 0.0 },
                coat_n as f32,
                coat_d as f32,
            ]
        })
        .collect()
}
