//! The paper's refinement on the CPU: each mesh a dome camera sees gets a
//! *twin*, refined for the camera (see `twin_mesh.rs`): its triangles
//! clipped behind the viewer and split until every edge's projected chord
//! lies within the camera's pixel tolerance of the true curved image
//! (`optica_optics::dome::refine_triangle`, §3.3 with neighbours sharing
//! their split edges, so no crack opens), its lines split likewise.
//!
//! Why the CPU: WGSL has no geometry shader, and the split depends on the
//! camera only through the mesh's placement in view space, which for most
//! scenes changes rarely; so a twin is rebuilt only when its mesh, its
//! placement relative to the camera or the camera's settings change. The
//! paper's classification (§3.1) saves more: a mesh marked
//! [`DomeApparentSize::NearlyConstant`] (stars, sky art) is split once for
//! every view direction and rebuilt only when the viewer moves in its space.
//! The twins a frame needs are found first and then built all at once
//! ([`crate::twins_of_meshes`]: the triangles of every mesh share Bevy's
//! compute pool), so a scene of many small meshes keeps every thread busy.
//!
//! Each vertex-mode dome camera draws its own render layer ([`DomeLayer`],
//! from [`DOME_LAYER`] up) where its twins live (and which the lights that
//! light its scene are given), so other cameras keep drawing the originals
//! and several dome cameras (a preview and a master, a stereo pair) each
//! see the twins refined for them. A camera sees the meshes whose
//! `RenderLayers` meet its [`DomeSees`]. A twin carries its original's material when that material's
//! type has a [`crate::DomeMaterialPlugin`] (`StandardMaterial` has one by
//! default); it casts no shadow (its original does). Float vertex attributes
//! (`Float32x2/3/4`) are carried, others (joints, integer data) are not.

use std::marker::PhantomData;

use bevy::camera::visibility::RenderLayers;
use bevy::ecs::entity::EntityHashMap;
use bevy::light::NotShadowCaster;
use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;
use optica_optics::dome::{
    ApparentSize, SplitRule, Treatment, classify, pre_subdivision_piece_rad,
};

use crate::{DomeApparentSize, DomeCamera, DomeSees};
use crate::twin_mesh::{Twin, TwinJob, pre_subdivide_mesh_asset, primitive_kind, twins_of_meshes};

/// The first render layer of the refined twins and of dome cameras: each
/// vertex-mode dome camera gets its own ([`DomeLayer`]), from this one up,
/// and sees only the twins refined for it.
pub const DOME_LAYER: usize = 29;

/// On a vertex-mode dome camera: the render layer it draws, where its
/// twins live. Given by the plugin.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct DomeLayer(pub usize);

impl From<DomeApparentSize> for ApparentSize {
    fn from(size: DomeApparentSize) -> Self {
        match size {
            DomeApparentSize::Changing => ApparentSize::Changing,
            DomeApparentSize::NearlyConstant => ApparentSize::NearlyConstant,
        }
    }
}

/// On an original mesh entity: its twins, one per vertex-mode dome camera
/// that sees it.
#[derive(Component, Debug, Default)]
pub struct DomeTwins(pub Vec<DomeTwin>);

/// One twin of a mesh and what it was built for.
#[derive(Debug)]
pub struct DomeTwin {
    /// The dome camera it was refined for.
    pub camera: Entity,
    /// The twin entity (a child of the original).
    pub twin: Entity,
    /// The twin's own mesh, rewritten in place when it is refined again: a
    /// new handle every frame would make Bevy re-specialise the twin each
    /// frame and never draw it while the camera moves. `None` until a
    /// refinement first changes the mesh.
    twin_mesh: Option<Handle<Mesh>>,
    /// Whether the twin draws its original's mesh itself (every triangle is
    /// its own refinement: small and in front, [`Twin::Same`]) rather than
    /// its own.
    shows_original: bool,
    built_for: BuiltFor,
    /// The original mesh's size (largest distance of a vertex from its
    /// origin), for [`BuiltFor::serves`].
    extent: f32,
}

impl DomeTwin {
    /// How the twin was refined: from the view ([`Treatment::Dynamic`]) or
    /// once for every view direction ([`Treatment::PreSubdivided`]).
    pub fn treatment(&self) -> Treatment {
        match self.built_for.placement {
            Placement::View(_) => Treatment::Dynamic,
            Placement::Viewer { .. } => Treatment::PreSubdivided,
        }
    }
}

/// What a twin depends on: when any of it changes, it is built again.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BuiltFor {
    mesh: AssetId<Mesh>,
    camera: DomeCamera,
    size_px: UVec2,
    placement: Placement,
}

/// The part of the mesh's placement relative to the camera a twin depends
/// on.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Placement {
    /// Refined from the view: all of it.
    View(Affine3A),
    /// Split once: the viewer's position in the mesh's space and the
    /// mesh's scale (angles at the viewer do not change under rotation).
    Viewer { eye: Vec3A, scale: Vec3A },
}

/// How far the viewer may drift in a pre-subdivided mesh's space, relative
/// to its distance from the mesh's origin plus the mesh's size, before the
/// mesh is split again; and the relative change of scale allowed. Turning
/// the camera recomposes its transform and moves the computed eye by
/// rounding (~1e-7 relative); a real move of 1e-5 changes the angles the
/// split was made for by about as much, far below any tolerance.
const VIEWER_DRIFT_REL: f32 = 1e-5;

impl BuiltFor {
    /// Whether a twin built for `self` still serves `now`; `extent` is the
    /// mesh's size (largest distance of a vertex from its origin).
    fn serves(&self, now: &BuiltFor, extent: f32) -> bool {
        let same =
            self.mesh == now.mesh && self.camera == now.camera && self.size_px == now.size_px;
        same && match (self.placement, now.placement) {
            (Placement::View(a), Placement::View(b)) => a == b,
            (
                Placement::Viewer { eye: e0, scale: s0 },
                Placement::Viewer { eye: e1, scale: s1 },
            ) => {
                (e1 - e0).length() <= VIEWER_DRIFT_REL * (e0.length() + extent)
                    && ((s1 - s0).abs()).max_element() <= VIEWER_DRIFT_REL * s0.max_element()
            }
            _ => false,
        }
    }
}

impl Placement {
    fn of(treatment: Treatment, view_from_local: Affine3A) -> Self {
        match treatment {
            Treatment::Dynamic => Self::View(view_from_local),
            Treatment::PreSubdivided => {
                let m = view_from_local.matrix3;
                Self::Viewer {
                    eye: view_from_local.inverse().translation,
                    scale: Vec3A::new(m.x_axis.length(), m.y_axis.length(), m.z_axis.length()),
                }
            }
        }
    }
}

/// What the last refinement pass did: how many twins it built or rebuilt,
/// how many it kept as they were, and the CPU time it took. Shown by the
/// `dome` example's panel; a static scene rebuilds nothing.
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Resource, Default)]
pub struct DomeRefineStats {
    /// Twins built or rebuilt in the last pass.
    pub rebuilt: usize,
    /// Twins still right for the camera, kept.
    pub kept: usize,
    /// Of those, twins that draw their original's mesh as it is (every
    /// triangle small and in front: nothing to split, nothing to build).
    pub unsplit: usize,
    /// Vertices of the twins rebuilt in the last pass.
    pub vertices: usize,
    /// CPU time of the last pass, in milliseconds.
    pub cpu_ms: f32,
}

/// On a twin: the original it refines (a relationship: the original's
/// [`DomeTwinEntities`] lists it, and despawning the original despawns
/// it).
#[derive(Component, Debug, Clone, Copy)]
#[relationship(relationship_target = DomeTwinEntities)]
pub struct DomeTwinOf(pub Entity);

/// On an original mesh entity: its twin entities, kept by Bevy from their
/// [`DomeTwinOf`] (what each was built for is in [`DomeTwins`]).
#[derive(Component, Debug)]
#[relationship_target(relationship = DomeTwinOf, linked_spawn)]
pub struct DomeTwinEntities(Vec<Entity>);

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

/// Gives every light the layer of each dome camera that sees it (the
/// light's own layers meet the camera's [`DomeSees`]), and takes away the
/// dome layers of cameras that do not, so that dome cameras are lit as
/// their scene is.
pub(crate) fn light_the_dome_layer(
    mut commands: Commands,
    lights: Query<(Entity, Option<&RenderLayers>), AnyLight>,
    cameras: Query<(&DomeLayer, Option<&DomeSees>), With<DomeCamera>>,
    mut known: Local<Vec<usize>>,
) {
    // Every dome layer ever given out, so that a freed one is taken away.
    for (layer, _) in &cameras {
        if !known.contains(&layer.0) {
            known.push(layer.0);
        }
    }
    for (entity, layers) in &lights {
        let layers = layers.cloned().unwrap_or_default();
        let own = known.iter().fold(layers.clone(), |l, &d| l.without(d));
        let mut want = own.clone();
        for (layer, sees) in &cameras {
            let sees = sees.map_or_else(RenderLayers::default, |s| s.0.clone());
            if sees.intersects(&own) {
                want = want.with(layer.0);
            }
        }
        if want != layers {
            commands.entity(entity).insert(want);
        }
    }
}

/// A vertex-mode dome camera as the refinement sees it.
struct DomeView<'a> {
    entity: Entity,
    camera: &'a DomeCamera,
    layer: usize,
    sees: RenderLayers,
    size_px: UVec2,
    view_from_world: Affine3A,
    projection: optica_optics::dome::Panorama,
    rule: SplitRule,
    /// The pre-subdivision's piece angle; `None` for the panorama, whose
    /// seam cuts depend on the view, so it refines every mesh from it.
    piece: Option<f64>,
}

/// Builds or rebuilds, for every vertex-mode dome camera, the twin of every
/// mesh it may see (its [`DomeSees`] layers meet the mesh's
/// `RenderLayers`), when what the twin was built for changed (see
/// [`BuiltFor`]); removes the twins of cameras that are gone, left the
/// vertex mode or no longer see the mesh. A camera whose settings are
/// invalid keeps its twins as they were.
pub(crate) fn refine_twins(
    mut commands: Commands,
    cameras: Query<DomeCameraParts>,
    mut originals: Query<OriginalParts, Without<DomeTwinOf>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    mut edited: Local<Vec<AssetId<Mesh>>>,
    mut stats: ResMut<DomeRefineStats>,
) {
    let start = std::time::Instant::now();
    let mut pass = DomeRefineStats::default();
    *stats = pass;
    // Meshes edited in place keep their id: their twins are stale too.
    // Kept until a pass has run (the camera may be invalid for a while).
    edited.extend(mesh_events.read().filter_map(|e| match e {
        AssetEvent::Modified { id } => Some(*id),
        _ => None,
    }));
    let (views, frozen) = dome_views(&cameras);
    let pending = stale_twins(
        &mut commands,
        &mut originals,
        &views,
        &frozen,
        &meshes,
        &edited,
        &mut pass,
    );
    // Every twin to build, built at once: the triangles of all the meshes
    // share the compute pool (see `twins_of_meshes`).
    let twins = build_twins(&pending, &views, &meshes);
    write_twins(
        &mut commands,
        &mut originals,
        &views,
        pending.into_iter().zip(twins),
        &mut meshes,
        &mut pass,
    );
    edited.clear();
    pass.cpu_ms = start.elapsed().as_secs_f32() * 1000.0;
    *stats = pass;
}

/// What [`refine_twins`] reads of a dome camera.
type DomeCameraParts = (
    Entity,
    &'static DomeCamera,
    &'static Camera,
    &'static GlobalTransform,
    Option<&'static DomeLayer>,
    Option<&'static DomeSees>,
);

/// What [`refine_twins`] reads of a mesh that may have twins.
type OriginalParts = (
    Entity,
    &'static Mesh3d,
    &'static GlobalTransform,
    Option<&'static DomeApparentSize>,
    Option<&'static RenderLayers>,
    Option<&'static mut DomeTwins>,
);

/// The vertex-mode dome cameras with valid settings, and the cameras whose
/// twins stay as they are (invalid settings for now).
fn dome_views<'a>(cameras: &'a Query<DomeCameraParts>) -> (Vec<DomeView<'a>>, Vec<Entity>) {
    let mut frozen = Vec::new();
    let mut views = Vec::new();
    for (entity, camera, render, transform, layer, sees) in cameras.iter() {
        let Some(layer) = layer.filter(|_| camera.mode == crate::DomeMode::Vertex) else {
            continue;
        };
        let size_px = render
            .physical_target_size()
            .unwrap_or(UVec2::splat(DEFAULT_SIZE_PX))
            .max(UVec2::ONE);
        let tolerance = f64::from(camera.tolerance_px);
        // (Building the projection checks the lens.)
        let ready = camera.validate_numbers().ok().and_then(|_| {
            let projection = camera.panorama(size_px.x, size_px.y).ok()?;
            let rule = SplitRule::chord_gap(tolerance).ok()?;
            let piece = match projection.fisheye() {
                Some(fisheye) => Some(pre_subdivision_piece_rad(fisheye, tolerance).ok()?),
                None => None,
            };
            Some((projection, rule, piece))
        });
        let Some((projection, rule, piece)) = ready else {
            frozen.push(entity);
            continue;
        };
        views.push(DomeView {
            entity,
            camera,
            layer: layer.0,
            sees: sees.map_or_else(RenderLayers::default, |s| s.0.clone()),
            size_px,
            view_from_world: transform.affine().inverse(),
            projection,
            rule,
            piece,
        });
    }
    (views, frozen)
}

/// Drops the twins no camera needs any more and lists the twins to build
/// (missing, or built for another mesh, camera, size or placement).
fn stale_twins(
    commands: &mut Commands,
    originals: &mut Query<OriginalParts, Without<DomeTwinOf>>,
    views: &[DomeView],
    frozen: &[Entity],
    meshes: &Assets<Mesh>,
    edited: &[AssetId<Mesh>],
    pass: &mut DomeRefineStats,
) -> Vec<Pending> {
    let mut pending = Vec::new();
    for (entity, mesh3d, transform, size, layers, twins) in originals.iter_mut() {
        if twins.is_none() && views.is_empty() {
            continue;
        }
        // (A mesh without twins yet gets its list when they are built.)
        let mut none = Vec::new();
        let mut holder;
        let list: &mut Vec<DomeTwin> = match twins {
            Some(t) => {
                holder = t;
                &mut holder.0
            }
            None => &mut none,
        };
        let layers = layers.cloned().unwrap_or_default();
        // Twins of cameras that are gone, not in the vertex mode or no
        // longer seeing this mesh go; frozen cameras keep theirs.
        list.retain(|t| {
            let keep = frozen.contains(&t.camera)
                || views
                    .iter()
                    .any(|v| v.entity == t.camera && v.sees.intersects(&layers));
            if !keep {
                commands.entity(t.twin).despawn();
            }
            keep
        });
        for (v, view) in views.iter().enumerate() {
            if !view.sees.intersects(&layers) {
                continue;
            }
            let slot = list.iter().position(|t| t.camera == view.entity);
            let view_from_local = view.view_from_world * transform.affine();
            let source = meshes.get(&mesh3d.0);
            if source.is_none() && slot.is_some_and(|i| list[i].built_for.mesh == mesh3d.id()) {
                // Its asset is gone for now (being reloaded): keep the twin.
                continue;
            }
            // Nothing to draw (a mesh not loaded yet, points, a triangle
            // strip, no positions, a scale of zero): no twin, and none left
            // showing what the mesh used to be.
            let invertible = view_from_local.matrix3.determinant().is_normal();
            let kind = source.filter(|_| invertible).and_then(primitive_kind);
            let (Some(source), Some(kind)) = (source, kind) else {
                if let Some(i) = slot {
                    commands.entity(list.remove(i).twin).despawn();
                }
                continue;
            };
            let treatment = match view.piece {
                Some(_) => classify(kind, size.copied().unwrap_or_default().into()),
                None => Treatment::Dynamic,
            };
            let built_for = BuiltFor {
                mesh: mesh3d.id(),
                camera: *view.camera,
                size_px: view.size_px,
                placement: Placement::of(treatment, view_from_local),
            };
            let fresh = slot.is_some_and(|i| {
                let t = &list[i];
                t.built_for.serves(&built_for, t.extent) && !edited.contains(&built_for.mesh)
            });
            if fresh {
                pass.kept += 1;
                continue;
            }
            pending.push(Pending {
                original: entity,
                mesh: mesh3d.0.clone(),
                transform: *transform,
                view: v,
                treatment,
                view_from_local,
                built_for,
                extent: extent_of(source),
            });
        }
    }
    pending
}

/// Writes each built twin into its original's [`DomeTwins`]: a new twin
/// entity, the original's mesh again, or the refined mesh (in place when
/// the twin already has one).
fn write_twins(
    commands: &mut Commands,
    originals: &mut Query<OriginalParts, Without<DomeTwinOf>>,
    views: &[DomeView],
    built: impl Iterator<Item = (Pending, Option<Twin>)>,
    meshes: &mut Assets<Mesh>,
    pass: &mut DomeRefineStats,
) {
    let mut new_lists: EntityHashMap<Vec<DomeTwin>> = EntityHashMap::default();
    for (job, twin) in built {
        let view = &views[job.view];
        let existing = match originals.get_mut(job.original) {
            Ok((.., Some(twins))) => Some(twins.into_inner()),
            _ => None,
        };
        let Some(twin) = twin else {
            // Nothing to draw: no twin, and none left showing the mesh.
            if let Some(list) = existing
                && let Some(i) = list.0.iter().position(|t| t.camera == view.entity)
            {
                commands.entity(list.0.remove(i).twin).despawn();
            }
            continue;
        };
        let list = match existing {
            Some(twins) => &mut twins.0,
            None => new_lists.entry(job.original).or_default(),
        };
        let slot = list.iter().position(|t| t.camera == view.entity);
        pass.rebuilt += 1;
        let entry = match slot {
            Some(i) => &mut list[i],
            None => {
                let twin = commands
                    .spawn((
                        Transform::IDENTITY,
                        // Right from the first frame (propagation has run).
                        job.transform,
                        ChildOf(job.original),
                        RenderLayers::layer(view.layer),
                        NotShadowCaster,
                        DomeTwinOf(job.original),
                    ))
                    .id();
                list.push(DomeTwin {
                    camera: view.entity,
                    twin,
                    twin_mesh: None,
                    shows_original: false,
                    built_for: job.built_for,
                    extent: job.extent,
                });
                list.last_mut().expect("just pushed")
            }
        };
        // (A new entry was pushed with `built_for` already.)
        let same_original = slot.is_some() && entry.built_for.mesh == job.built_for.mesh;
        entry.built_for = job.built_for;
        entry.extent = job.extent;
        match twin {
            Twin::Same => {
                pass.unsplit += 1;
                if !(entry.shows_original && same_original) {
                    commands.entity(entry.twin).insert(Mesh3d(job.mesh));
                    entry.shows_original = true;
                }
            }
            Twin::Refined(refined) => {
                pass.vertices += refined.count_vertices();
                let unwritten = match entry.twin_mesh.as_ref().and_then(|h| meshes.get_mut(h)) {
                    Some(mut mesh) => {
                        *mesh = *refined;
                        None
                    }
                    None => Some(refined),
                };
                let fresh_handle = unwritten.is_some();
                if let Some(refined) = unwritten {
                    entry.twin_mesh = Some(meshes.add(*refined));
                }
                if fresh_handle || entry.shows_original || slot.is_none() {
                    let handle = entry.twin_mesh.clone().expect("set above");
                    commands.entity(entry.twin).insert(Mesh3d(handle));
                    entry.shows_original = false;
                }
            }
        }
    }
    for (original, list) in new_lists {
        commands.entity(original).insert(DomeTwins(list));
    }
}

/// A twin to build, found by [`refine_twins`]: built for all such at once
/// ([`build_twins`]), then written.
struct Pending {
    original: Entity,
    mesh: Handle<Mesh>,
    transform: GlobalTransform,
    /// Index of its camera in the pass's views.
    view: usize,
    treatment: Treatment,
    view_from_local: Affine3A,
    built_for: BuiltFor,
    extent: f32,
}

/// The twin of every pending mesh, in order (`None`: nothing to draw): the
/// ones refined from the view all together on the compute pool, the
/// pre-subdivided ones (rebuilt only when the viewer moves in their space)
/// one by one.
fn build_twins(
    pending: &[Pending],
    views: &[DomeView],
    meshes: &Assets<Mesh>,
) -> Vec<Option<Twin>> {
    let source = |p: &Pending| meshes.get(&p.mesh).expect("checked when found");
    let jobs: Vec<TwinJob> = pending
        .iter()
        .filter(|p| p.treatment == Treatment::Dynamic)
        .map(|p| TwinJob {
            source: source(p),
            view_from_local: p.view_from_local,
            projection: &views[p.view].projection,
            rule: views[p.view].rule,
        })
        .collect();
    let mut dynamic = twins_of_meshes(&jobs).into_iter();
    pending
        .iter()
        .map(|p| match p.treatment {
            Treatment::Dynamic => dynamic.next().flatten(),
            Treatment::PreSubdivided => views[p.view]
                .piece
                .and_then(|piece| pre_subdivide_mesh_asset(source(p), p.view_from_local, piece))
                .map(|mesh| Twin::Refined(Box::new(mesh))),
        })
        .collect()
}

/// The largest distance of a vertex of `mesh` from its origin (0 without
/// positions).
fn extent_of(mesh: &Mesh) -> f32 {
    match mesh.attribute(Mesh::ATTRIBUTE_POSITION) {
        Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) => p
            .iter()
            .map(|v| Vec3::from_array(*v).length())
            .filter(|d| d.is_finite())
            .fold(0.0, f32::max),
        _ => 0.0,
    }
}

/// The domemaster size assumed before the camera's target is known.
const DEFAULT_SIZE_PX: u32 = 2048;
