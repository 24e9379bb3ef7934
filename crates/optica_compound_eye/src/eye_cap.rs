//! A mesh for a compound eye with no pole in its lattice.

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, MeshBuilder, PrimitiveTopology};
use bevy::prelude::*;

/// A cap of the unit sphere around `+Z` whose UVs have no pole: the
/// stereographic projection from the far side of the sphere, so the
/// lattice's facets stay regular (the map is conformal) and shrink
/// smoothly from the cap's centre to its rim, by `cos²(θ/2)` at the angle
/// `θ` from the axis (0.41 at the default 100° rim). A UV sphere, by
/// contrast, shows its poles as rings of facets shrinking to a point.
///
/// The mesh carries tangents, so [`CompoundEye::tangent_axes`](crate::CompoundEye::tangent_axes)
/// lays a lattice on it without seams at its triangle edges.
///
/// The UVs are centred on `(0.5, 0.5)` and fill a disc of area 1, so an
/// [`EyePreset`](crate::EyePreset)'s facet count covers the cap. Turn the
/// cap so its axis points out of the head and sink its rim into the head:
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use optica_compound_eye::EyeCap;
/// # fn f(mut meshes: ResMut<Assets<Mesh>>, mut commands: Commands) {
/// let eye = meshes.add(EyeCap::default().build());
/// // The right eye: its axis along +X.
/// commands.spawn((
///     Mesh3d(eye),
///     Transform::from_rotation(Quat::from_rotation_arc(Vec3::Z, Vec3::X)),
/// ));
/// # }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct EyeCap {
    /// The rim's angle from the axis, in radians. Default 100° (a little
    /// past the equator, to sink into a head); taken within 1°–170° (the
    /// projection grows without bound towards 180°). A non-finite value
    /// gives the default.
    pub half_angle: f32,
    /// Rings of vertices from the centre to the rim (at least 1). Default
    /// 32.
    pub rings: u32,
    /// Vertices around each ring (at least 3). Default 96.
    pub sectors: u32,
}

/// The default rim angle: 100°.
const DEFAULT_HALF_ANGLE: f32 = 100.0 * std::f32::consts::PI / 180.0;

impl Default for EyeCap {
    fn default() -> Self {
        Self {
            half_angle: DEFAULT_HALF_ANGLE,
            rings: 32,
            sectors: 96,
        }
    }
}

impl EyeCap {
    /// The rim angle the mesh is built with (see [`EyeCap::half_angle`]).
    pub fn rim_angle(&self) -> f32 {
        if self.half_angle.is_finite() {
            self.half_angle
                .clamp(1f32.to_radians(), 170f32.to_radians())
        } else {
            DEFAULT_HALF_ANGLE
        }
    }

    /// The UV of the point at angle `theta` from the axis and azimuth
    /// `phi`: `0.5 + k·tan(θ/2)·(cos φ, sin φ)`, `k` making the disc's
    /// area 1.
    pub fn uv_at(&self, theta: f32, phi: f32) -> Vec2 {
        let rim = (0.5 * self.rim_angle()).tan();
        let k = 1.0 / (std::f32::consts::PI.sqrt() * rim);
        Vec2::splat(0.5) + k * (0.5 * theta).tan() * Vec2::new(phi.cos(), phi.sin())
    }
}

impl MeshBuilder for EyeCap {
    fn build(&self) -> Mesh {
        let rings = self.rings.max(1);
        let sectors = self.sectors.max(3);
        let rim = self.rim_angle();
        let mut positions = vec![[0.0, 0.0, 1.0]];
        let mut uvs = vec![self.uv_at(0.0, 0.0).to_array()];
        for i in 1..=rings {
            let theta = rim * i as f32 / rings as f32;
            for j in 0..sectors {
                let phi = std::f32::consts::TAU * j as f32 / sectors as f32;
                let (s, c) = theta.sin_cos();
                positions.push([s * phi.cos(), s * phi.sin(), c]);
                uvs.push(self.uv_at(theta, phi).to_array());
            }
        }
        // Vertex j of ring i (ring 0 is the centre).
        let at = |i: u32, j: u32| 1 + (i - 1) * sectors + j % sectors;
        let mut indices = Vec::new();
        for j in 0..sectors {
            indices.extend([0, at(1, j), at(1, j + 1)]);
        }
        for i in 1..rings {
            for j in 0..sectors {
                let (a, b) = (at(i, j), at(i + 1, j));
                let (c, d) = (at(i + 1, j + 1), at(i, j + 1));
                indices.extend([a, b, c, a, c, d]);
            }
        }
        let normals = positions.clone();
        let mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_indices(Indices::U32(indices));
        // Tangents, for `CompoundEye::tangent_axes` (and normal maps). The
        // mesh has everything mikktspace needs, so this does not fail; if
        // it ever did, the mesh would still render along its UVs' axes.
        match mesh.clone().with_generated_tangents() {
            Ok(with_tangents) => with_tangents,
            Err(_) => mesh,
        }
    }
}
