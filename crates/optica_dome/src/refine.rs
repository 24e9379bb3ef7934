//! The paper's refinement on the CPU: each mesh a dome camera sees gets a
//! *twin*, its triangles clipped behind the viewer and split until every
//! edge's projected chord lies within the camera's pixel tolerance of the
//! true curved image (`optica_optics::dome::refine_triangle`, §3.3 with
//! neighbours sharing their split edges, so no crack opens).
//!
//! Why the CPU: WGSL has no geometry shader, and the split depends on the
//! camera only through the mesh's placement in view space, which for most
//! scenes changes rarely; so a twin is rebuilt only when its mesh, its
//! placement relative to the camera or the camera's settings change.
//!
//! Twins live on the render layer [`DOME_LAYER`], which only dome cameras
//! see (and which every light is given), so other cameras keep drawing the
//! originals. A twin carries its original's material when that material's
//! type has a [`crate::DomeMaterialPlugin`] (`StandardMaterial` has one by
//! default); it casts no shadow (its original does). A twin is seen by the
//! dome whatever the original's own `RenderLayers`; float vertex attributes
//! (`Float32x2/3/4`) are carried, others (joints, integer data) are not.

use std::marker::PhantomData;

use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::RenderLayers;
use bevy::light::NotShadowCaster;
use bevy::math::{Affine3A, DAffine3, DVec3};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use optica_optics::dome::{DomeProjection, SplitRule, refine_triangle};

use crate::DomeCamera;

/// The render layer of the refined twins and of dome cameras.
pub const DOME_LAYER: usize = 29;

/// On an original mesh entity: its twin and what the twin was built for.
#[derive(Component, Debug)]
pub struct DomeTwin {
    /// The twin entity (a child of the original).
    pub twin: Entity,
    /// The twin's mesh, rewritten in place when it is refined again: a new
    /// handle every frame would make Bevy re-specialise the twin each frame
    /// and never draw it while the camera moves.
    twin_mesh: Handle<Mesh>,
    view_from_local: Affine3A,
    mesh: AssetId<Mesh>,
    camera: DomeCamera,
    size_px: u32,
}

/// On a twin: the original it refines.
#[derive(Component, Debug, Clone, Copy)]
pub struct DomeTwinOf(pub Entity);

/// Copies the material of type `M` from originals to their twins, so meshes
/// with that material appear on dome cameras. `DomePlugin` adds it for
/// `StandardMaterial`; add it for your own materials.
pub struct DomeMaterialPlugin<M: Material>(PhantomData<M>);

impl<M: Material> Default for DomeMaterialPlugin<M> {
    fn default() -> Self {
        Self(PhantomData)
    }
}

impl<M: Material> Plugin for DomeMaterialPlugin<M> {
    fn build(&self, app: &mut App) {
        app.add_systems(
            PostUpdate,
            copy_material::<M>
                .after(refine_twins)
                .run_if(any_with_component::<DomeCamera>),
        );
    }
}

fn copy_material<M: Material>(
    mut commands: Commands,
    twins: Query<(Entity, &DomeTwinOf, Option<&MeshMaterial3d<M>>)>,
    originals: Query<&MeshMaterial3d<M>, Without<DomeTwinOf>>,
) {
    for (twin, of, has) in &twins {
        if let Ok(material) = originals.get(of.0)
            && has.is_none_or(|m| m.0 != material.0)
        {
            commands.entity(twin).insert(material.clone());
        }
    }
}

/// Any of Bevy's lights.
type AnyLight = Or<(With<DirectionalLight>, With<PointLight>, With<SpotLight>)>;

/// Gives every light the dome layer too, so that dome cameras are lit.
pub(crate) fn light_the_dome_layer(
    mut commands: Commands,
    lights: Query<(Entity, Option<&RenderLayers>), AnyLight>,
) {
    for (entity, layers) in &lights {
        let layers = layers.cloned().unwrap_or_default();
        if !layers.intersects(&RenderLayers::layer(DOME_LAYER)) {
            commands.entity(entity).insert(layers.with(DOME_LAYER));
        }
    }
}

/// Builds or rebuilds the twin of every mesh the (first) dome camera may
/// see, when its mesh, its placement relative to the camera or the camera's
/// settings changed.
#[allow(clippy::type_complexity)]
pub(crate) fn refine_twins(
    mut commands: Commands,
    cameras: Query<(&DomeCamera, &Camera, &GlobalTransform)>,
    mut originals: Query<
        (Entity, &Mesh3d, &GlobalTransform, Option<&mut DomeTwin>),
        Without<DomeTwinOf>,
    >,
    mut meshes: ResMut<Assets<Mesh>>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
) {
    // Meshes edited in place keep their id: their twins are stale too.
    let edited: Vec<AssetId<Mesh>> = mesh_events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    let Some((camera, render, camera_transform)) = cameras
        .iter()
        .find(|(camera, ..)| camera.mode == crate::DomeMode::Vertex)
    else {
        // No vertex-mode camera: twins are not needed.
        for (entity, _, _, twin) in &originals {
            if let Some(twin) = twin {
                commands.entity(twin.twin).despawn();
                commands.entity(entity).remove::<DomeTwin>();
            }
        }
        return;
    };
    if camera.validate().is_err() {
        return;
    }
    let size_px = render
        .physical_target_size()
        .map_or(DEFAULT_SIZE_PX, |s| s.x.max(s.y).max(1));
    let Ok(projection) = camera.projection(size_px) else {
        return;
    };
    let Ok(rule) = SplitRule::chord_gap(f64::from(camera.tolerance_px)) else {
        return;
    };
    let view_from_world = camera_transform.affine().inverse();
    for (entity, mesh3d, transform, twin) in &mut originals {
        let view_from_local = view_from_world * transform.affine();
        let fresh = twin.as_ref().is_some_and(|t| {
            t.mesh == mesh3d.id()
                && !edited.contains(&t.mesh)
                && t.camera == *camera
                && t.size_px == size_px
                && t.view_from_local == view_from_local
        });
        if fresh {
            continue;
        }
        let Some(source) = meshes.get(&mesh3d.0) else {
            continue;
        };
        let Some(refined) = refine_mesh_asset(source, view_from_local, &projection, rule) else {
            continue;
        };
        match twin {
            Some(mut twin) => {
                if let Some(mut mesh) = meshes.get_mut(&twin.twin_mesh) {
                    *mesh = refined;
                } else {
                    twin.twin_mesh = meshes.add(refined);
                    commands
                        .entity(twin.twin)
                        .insert(Mesh3d(twin.twin_mesh.clone()));
                }
                twin.view_from_local = view_from_local;
                twin.mesh = mesh3d.id();
                twin.camera = *camera;
                twin.size_px = size_px;
            }
            None => {
                let handle = meshes.add(refined);
                let twin = commands
                    .spawn((
                        Mesh3d(handle.clone()),
                        Transform::IDENTITY,
                        // Right from the first frame (propagation has run).
                        *transform,
                        ChildOf(entity),
                        RenderLayers::layer(DOME_LAYER),
                        NotShadowCaster,
                        DomeTwinOf(entity),
                    ))
                    .id();
                commands.entity(entity).insert(DomeTwin {
                    twin,
                    twin_mesh: handle,
                    view_from_local,
                    mesh: mesh3d.id(),
                    camera: *camera,
                    size_px,
                });
            }
        }
    }
}

/// The domemaster size assumed before the camera's target is known.
const DEFAULT_SIZE_PX: u32 = 2048;

/// `source` (a triangle list in its local space) refined for a dome camera
/// that sees it through `view_from_local`: clipped behind the viewer and
/// split by `rule`, in the same local space, with every `Float32x2/3/4`
/// vertex attribute interpolated (normals and tangents renormalised).
/// `None` for other topologies or a mesh without positions.
pub fn refine_mesh_asset(
    source: &Mesh,
    view_from_local: Affine3A,
    projection: &DomeProjection,
    rule: SplitRule,
) -> Option<Mesh> {
    if source.primitive_topology() != PrimitiveTopology::TriangleList {
        return None;
    }
    let Some(VertexAttributeValues::Float32x3(positions)) =
        source.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return None;
    };
    let indices: Vec<u32> = match source.indices() {
        Some(Indices::U16(i)) => i.iter().map(|&v| u32::from(v)).collect(),
        Some(Indices::U32(i)) => i.clone(),
        None => (0..positions.len() as u32).collect(),
    };
    let view_from_local = DAffine3::from_mat4(Mat4::from(view_from_local).as_dmat4());
    let local_from_view = view_from_local.inverse();
    let view: Vec<DVec3> = positions
        .iter()
        .map(|p| view_from_local.transform_point3(DVec3::from(p.map(f64::from))))
        .collect();
    // Attributes to carry, besides the position.
    // (An attribute of another length than the positions is malformed;
    // it is left out rather than read out of bounds.)
    let carried: Vec<_> = source
        .attributes()
        .filter(|(a, v)| a.id != Mesh::ATTRIBUTE_POSITION.id && v.len() == positions.len())
        .filter_map(|(a, values)| Interpolated::of(values).map(|v| (*a, v)))
        .collect();
    let mut out_positions: Vec<[f32; 3]> = Vec::new();
    let mut out_carried: Vec<Interpolated> = carried.iter().map(|(_, v)| v.empty()).collect();
    let mut out_indices: Vec<u32> = Vec::new();
    for t in indices.chunks_exact(3) {
        let ids = [t[0] as usize, t[1] as usize, t[2] as usize];
        if ids.iter().any(|&i| i >= view.len()) {
            continue;
        }
        let corners = ids.map(|i| view[i]);
        let Ok(refined) = refine_triangle(projection, corners, rule) else {
            continue;
        };
        let (points, triangles) = refined.mesh.into_parts();
        let base = out_positions.len() as u32;
        for p in &points {
            let local = local_from_view.transform_point3(*p);
            out_positions.push(local.as_vec3().to_array());
            let weights = barycentric(corners, *p);
            for (out, (_, values)) in out_carried.iter_mut().zip(&carried) {
                out.push_mix(values, ids, weights);
            }
        }
        out_indices.extend(triangles.iter().flatten().map(|i| base + i));
    }
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    );
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, out_positions);
    for ((attribute, _), values) in carried.iter().zip(out_carried) {
        let normalise =
            attribute.id == Mesh::ATTRIBUTE_NORMAL.id || attribute.id == Mesh::ATTRIBUTE_TANGENT.id;
        mesh.insert_attribute(*attribute, values.finish(normalise));
    }
    mesh.insert_indices(Indices::U32(out_indices));
    Some(mesh)
}

/// Barycentric weights of `p` (on the triangle's plane) in `t`, by areas
/// projected on the triangle's normal; the centroid's for a degenerate
/// triangle.
fn barycentric(t: [DVec3; 3], p: DVec3) -> [f64; 3] {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let area = n.length_squared();
    // Also catches a NaN area.
    if area.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return [1.0 / 3.0; 3];
    }
    let w0 = (t[1] - p).cross(t[2] - p).dot(n) / area;
    let w1 = (t[2] - p).cross(t[0] - p).dot(n) / area;
    [w0, w1, 1.0 - w0 - w1]
}

/// A float vertex attribute being interpolated.
enum Interpolated {
    X2(Vec<[f32; 2]>),
    X3(Vec<[f32; 3]>),
    X4(Vec<[f32; 4]>),
}

impl Interpolated {
    /// A copy of `values` when it is a float attribute this can mix.
    fn of(values: &VertexAttributeValues) -> Option<Self> {
        match values {
            VertexAttributeValues::Float32x2(v) => Some(Self::X2(v.clone())),
            VertexAttributeValues::Float32x3(v) => Some(Self::X3(v.clone())),
            VertexAttributeValues::Float32x4(v) => Some(Self::X4(v.clone())),
            _ => None,
        }
    }

    fn empty(&self) -> Self {
        match self {
            Self::X2(_) => Self::X2(Vec::new()),
            Self::X3(_) => Self::X3(Vec::new()),
            Self::X4(_) => Self::X4(Vec::new()),
        }
    }

    /// Appends `Σ w_k · source[ids_k]`.
    fn push_mix(&mut self, source: &Self, ids: [usize; 3], w: [f64; 3]) {
        fn mix<const N: usize>(v: &[[f32; N]], ids: [usize; 3], w: [f64; 3]) -> [f32; N] {
            std::array::from_fn(|c| {
                (0..3).map(|k| w[k] * f64::from(v[ids[k]][c])).sum::<f64>() as f32
            })
        }
        match (self, source) {
            (Self::X2(out), Self::X2(v)) => out.push(mix(v, ids, w)),
            (Self::X3(out), Self::X3(v)) => out.push(mix(v, ids, w)),
            (Self::X4(out), Self::X4(v)) => out.push(mix(v, ids, w)),
            _ => {}
        }
    }

    /// The attribute values; with `normalise`, the xyz part made unit
    /// length (normals, tangents; a tangent keeps its handedness w).
    fn finish(self, normalise: bool) -> VertexAttributeValues {
        let unit = |v: Vec3| v.try_normalize().unwrap_or(Vec3::Z);
        match self {
            Self::X2(v) => VertexAttributeValues::Float32x2(v),
            Self::X3(v) if normalise => VertexAttributeValues::Float32x3(
                v.into_iter()
                    .map(|a| unit(Vec3::from(a)).to_array())
                    .collect(),
            ),
            Self::X3(v) => VertexAttributeValues::Float32x3(v),
            Self::X4(v) if normalise => VertexAttributeValues::Float32x4(
                v.into_iter()
                    .map(|a| {
                        unit(Vec3::new(a[0], a[1], a[2]))
                            .extend(a[3].signum())
                            .to_array()
                    })
                    .collect(),
            ),
            Self::X4(v) => VertexAttributeValues::Float32x4(v),
        }
    }
}
