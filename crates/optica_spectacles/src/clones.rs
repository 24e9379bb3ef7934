//! The clones (paper §4.2) in the main world: for the eye camera, a clone
//! camera that draws all `S` clones of the scene into one atlas of `S`
//! tiles in a single pass, and for every `StandardMaterial` mesh `S` twins
//! (children, tagged with their clone number) carrying a [`CloneMaterial`]
//! copy of the mesh's material.
//!
//! One camera draws every clone, so the clones share that view's light
//! culling and shadow maps, and Bevy culls, batches and instances them like
//! any mesh (the twins of a mesh share one material: they are instanced).
//! The eye camera itself then draws nothing but the clones' average (see
//! `render`), so the scene is not drawn a further time, sharp.

use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{CameraProjection, Hdr, RenderTarget, SubCameraView};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::NotShadowCaster;
use bevy::light::cluster::ClusterConfig;
use bevy::math::Vec3A;
use bevy::mesh::MeshTag;
use bevy::pbr::{ExtendedMaterial, MaterialExtension};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::render_resource::{
    AsBindGroup, RenderPipelineDescriptor, SpecializedMeshPipelineError, TextureFormat,
    TextureUsages,
};
use bevy::render::storage::ShaderBuffer;
use bevy::render::view::Msaa;
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{MaterialExtensionKey, MaterialExtensionPipeline};
use bevy::shader::{ShaderRef, load_shader_library};

/// Where `embedded_asset!` puts the clone material's shader.
const CLONE_SHADER: &str = "embedded://optica_spectacles/shaders/clone.wgsl";
use bevy::camera::primitives::Frustum;
use bevy::render::extract_component::ExtractComponent;

use crate::precompute::{CloneUniform, EyeOptics};
use crate::settings::{CloneDefocus, CloneShading};

/// The render layer the clones live on: only clone cameras see it (and
/// every light is given it, so the clones are lit).
pub const CLONE_LAYER: usize = 28;

/// A `StandardMaterial` drawn as a clone: the base material's own look,
/// every vertex moved by its clone's displacement vector.
pub type CloneMaterial = ExtendedMaterial<StandardMaterial, CloneExtension>;

/// The clone part of a [`CloneMaterial`]: the eye's numbers and the field.
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone, Default)]
#[bind_group_data(CloneKey)]
pub struct CloneExtension {
    /// The eye, the field's grid and the atlas layout.
    #[uniform(100)]
    pub params: CloneUniform,
    /// The field's vectors (`cells × S × 3` floats), or a stand-in when
    /// the eye is naked.
    #[storage(101, read_only)]
    pub field: Handle<ShaderBuffer>,
    /// Whether the device clips by distances the vertex shader writes
    /// ([`SpectaclesDevice::clip_distances`](crate::SpectaclesDevice)):
    /// clones are then cut at their tiles by the rasteriser; without it,
    /// by a discard in the fragment shader.
    pub clip_distances: bool,
}

/// What the clone pipelines are specialised on: a reprojected clone's
/// fragment shader only records where its surface lies (no shading at
/// all: a CPU rasteriser pays for both sides of a branch).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CloneKey {
    reprojected: bool,
    clip_distances: bool,
}

impl From<&CloneExtension> for CloneKey {
    fn from(e: &CloneExtension) -> Self {
        Self {
            reprojected: e.params.shading == 1,
            clip_distances: e.clip_distances,
        }
    }
}

impl MaterialExtension for CloneExtension {
    fn vertex_shader() -> ShaderRef {
        CLONE_SHADER.into()
    }

    fn fragment_shader() -> ShaderRef {
        CLONE_SHADER.into()
    }

    // Clones are drawn by the clone camera alone, which has no prepass;
    // their originals cast the shadows.
    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }

    fn specialize(
        _pipeline: &MaterialExtensionPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        _layout: &MeshVertexBufferLayoutRef,
        key: MaterialExtensionKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        // The fragment stage reads the clone number (the mesh tag) to cut
        // each clone at its tile.
        let def = "VERTEX_OUTPUT_INSTANCE_INDEX";
        descriptor.vertex.shader_defs.push(def.into());
        let clip = key.bind_group_data.clip_distances;
        if clip {
            descriptor.vertex.shader = crate::CLONE_CLIP_SHADER;
        }
        if let Some(fragment) = descriptor.fragment.as_mut() {
            fragment.shader_defs.push(def.into());
            if clip {
                fragment.shader_defs.push("CLIP_DISTANCES".into());
            }
            if key.bind_group_data.reprojected {
                fragment.shader_defs.push("REPROJECTED".into());
            }
        }
        Ok(())
    }
}

/// The perspective of the eye camera, kept whatever the size of the atlas
/// the clone camera draws into: each tile is a whole view.
#[derive(Clone, Debug)]
pub(crate) struct TileProjection {
    perspective: PerspectiveProjection,
    /// Whether the clones are shaded (and so need shadow maps).
    shaded: bool,
}

/// Depth (m) of the sliver a clone camera that shades nothing gives its
/// directional lights' shadow cascades: Bevy fits a cascade set to every
/// camera's frustum; this keeps them (a millimetre in front of the lens)
/// empty, so no shadow caster is drawn for a camera that never reads them.
const UNSHADED_CASCADE_DEPTH: f32 = 1e-3;

impl CameraProjection for TileProjection {
    fn get_clip_from_view(&self) -> Mat4 {
        self.perspective.get_clip_from_view()
    }

    fn get_clip_from_view_for_sub(&self, sub_view: &SubCameraView) -> Mat4 {
        self.perspective.get_clip_from_view_for_sub(sub_view)
    }

    // The atlas's aspect is not the view's: keep the eye's.
    fn update(&mut self, _width: f32, _height: f32) {}

    fn far(&self) -> f32 {
        self.perspective.far()
    }

    // Only shadow cascades use these corners (culling uses the frustum).
    fn get_frustum_corners(&self, z_near: f32, z_far: f32) -> [Vec3A; 8] {
        if self.shaded {
            self.perspective.get_frustum_corners(z_near, z_far)
        } else {
            let near = -self.perspective.near;
            self.perspective
                .get_frustum_corners(near, near - UNSHADED_CASCADE_DEPTH)
        }
    }

    fn compute_frustum(&self, camera_transform: &GlobalTransform) -> Frustum {
        self.perspective.compute_frustum(camera_transform)
    }
}

/// On an eye camera while its clones are drawn: the clone camera, the
/// atlas, its layout, and the layers the eye camera had.
#[derive(Component, Clone, Debug)]
pub struct CloneRig {
    /// The camera that draws the clones.
    pub camera: Entity,
    /// The atlas: `tiles.x × tiles.y` tiles of `tile` pixels, linear HDR.
    pub atlas: Handle<Image>,
    /// Tiles across and down.
    pub tiles: UVec2,
    /// One tile's size (px): the eye camera's view.
    pub tile: UVec2,
    /// `S`.
    pub clones: u32,
    /// How the clones are shaded.
    pub shading: CloneShading,
    /// The perspective the clone camera draws with.
    perspective: PerspectiveProjection,
}

/// The clone camera's clear colour: the eye camera's when the clones are
/// shaded, transparent when they only record where their surface lies (a
/// zero alpha marks "no geometry" for the resolve).
fn clone_clear(shading: CloneShading, eye: &ClearColorConfig) -> ClearColorConfig {
    match shading {
        CloneShading::Full => *eye,
        CloneShading::Reprojected => ClearColorConfig::Custom(Color::NONE),
    }
}

/// Whether two clear colours are the same.
fn same_clear(a: &ClearColorConfig, b: &ClearColorConfig) -> bool {
    match (a, b) {
        (ClearColorConfig::Default, ClearColorConfig::Default)
        | (ClearColorConfig::None, ClearColorConfig::None) => true,
        (ClearColorConfig::Custom(x), ClearColorConfig::Custom(y)) => x == y,
        _ => false,
    }
}

/// Whether two perspectives draw the same view.
fn same_perspective(a: &PerspectiveProjection, b: &PerspectiveProjection) -> bool {
    a.fov == b.fov
        && a.aspect_ratio == b.aspect_ratio
        && a.near == b.near
        && a.far == b.far
        && a.near_clip_plane == b.near_clip_plane
}

/// What the eye camera's resolve pass reads (extracted to the render world).
#[derive(Component, Clone, Debug, PartialEq, ExtractComponent)]
pub struct CloneResolve {
    /// The atlas.
    pub atlas: AssetId<Image>,
    /// Tiles across and down.
    pub tiles: UVec2,
    /// `S`.
    pub clones: u32,
    /// How the clones were shaded: the atlas holds colours, or where each
    /// clone's surface lies in the sharp view.
    pub shading: crate::CloneShading,
    /// The colour a clone shows where it has no geometry (linear RGB).
    pub background: Vec4,
}

/// On a clone camera: the eye camera it draws for (a relationship: the
/// eye's [`CloneCamera`] lists it, and despawning the eye despawns it).
#[derive(Component, Clone, Copy, Debug)]
#[relationship(relationship_target = CloneCamera)]
pub struct CloneCameraOf(pub Entity);

/// On an eye camera that draws clones: its clone camera.
#[derive(Component, Debug)]
#[relationship_target(relationship = CloneCameraOf, linked_spawn)]
pub struct CloneCamera(Entity);

/// On a twin: the mesh entity it clones (a relationship: the mesh's
/// [`CloneTwins`] lists it, and despawning the mesh despawns it).
#[derive(Component, Clone, Copy, Debug)]
#[relationship(relationship_target = CloneTwins)]
pub struct CloneOf(pub Entity);

/// On a mesh entity that has twins: them, in clone order (kept by Bevy
/// from their [`CloneOf`]).
#[derive(Component, Debug, Default)]
#[relationship_target(relationship = CloneOf, linked_spawn)]
pub struct CloneTwins(Vec<Entity>);

/// The largest side of the clone atlas: wgpu's default
/// `max_texture_dimension_2d` (the limit Bevy asks devices for).
pub const MAX_ATLAS_SIDE: u32 = 8192;

/// The tiles (across, down) of an atlas holding `clones` tiles of `tile`
/// pixels within [`MAX_ATLAS_SIDE`]: the layout with the fewest unused
/// tiles (each is cleared every frame), then the squarest; `None` when
/// even a full atlas holds fewer tiles than `clones`.
pub fn tile_layout(clones: u32, tile: UVec2) -> Option<UVec2> {
    let s = clones.max(1);
    let (fit_x, fit_y) = (MAX_ATLAS_SIDE / tile.x.max(1), MAX_ATLAS_SIDE / tile.y.max(1));
    (1..=s)
        .map(|rows| UVec2::new(s.div_ceil(rows), rows))
        .filter(|t| t.x <= fit_x && t.y <= fit_y)
        .min_by_key(|t| (t.x * t.y - s, (t.x * tile.x).max(t.y * tile.y)))
}

/// The most tiles of `tile` pixels an atlas holds.
pub fn max_tiles(tile: UVec2) -> u32 {
    (MAX_ATLAS_SIDE / tile.x.max(1)) * (MAX_ATLAS_SIDE / tile.y.max(1))
}

/// The clone materials: one per original material, all sharing the eye's
/// clone part.
#[derive(Resource, Default)]
pub(crate) struct CloneMaterials {
    by_base: HashMap<AssetId<StandardMaterial>, Handle<CloneMaterial>>,
    extension: CloneExtension,
    /// A one-vector stand-in for the field of a naked eye.
    empty_field: Option<Handle<ShaderBuffer>>,
}

/// The eye camera whose clones are drawn: the first with an enabled
/// [`CloneDefocus`] and optics.
type EyeCamera<'a> = (
    Entity,
    &'a Camera,
    &'a Camera3d,
    &'a CloneDefocus,
    &'a EyeOptics,
    &'a Projection,
    Option<&'a CloneRig>,
    Option<&'a CloneResolve>,
);

/// What `sync_rig` keeps in step on a clone camera.
type CloneCameraParts = (&'static mut Projection, &'static mut Camera);
/// Clone cameras, never an eye camera.
type CloneCameraOnly = (With<CloneCameraOf>, Without<CloneDefocus>);
/// Every kind of light.
type AnyLight = Or<(With<DirectionalLight>, With<PointLight>, With<SpotLight>)>;

/// Creates, resizes or removes the clone camera and atlas of the eye
/// camera, and keeps the clone materials' numbers up to date.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sync_rig(
    mut commands: Commands,
    eyes: Query<EyeCamera>,
    rigs: Query<(Entity, &CloneRig)>,
    mut clone_cameras: Query<CloneCameraParts, CloneCameraOnly>,
    clear: Res<ClearColor>,
    mut images: ResMut<Assets<Image>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut materials: ResMut<CloneMaterials>,
    mut clone_assets: ResMut<Assets<CloneMaterial>>,
    device: Option<Res<crate::SpectaclesDevice>>,
) {
    let active = eyes
        .iter()
        .find(|(_, camera, _, defocus, ..)| camera.is_active && defocus.enabled);
    // Stop the rigs of every other camera.
    for (entity, rig) in &rigs {
        if active.is_some_and(|a| a.0 == entity) {
            continue;
        }
        stop_rig(&mut commands, entity, rig);
    }
    let Some((entity, camera, camera3d, defocus, optics, projection, rig, resolve)) = active
    else {
        return;
    };
    let shading = defocus.shading;
    let Some(tile) = camera.physical_viewport_size().filter(|s| s.x > 0 && s.y > 0) else {
        return;
    };
    let Projection::Perspective(perspective) = projection else {
        bevy::log::warn_once!("optica_spectacles: an eye camera needs a perspective projection; its view stays sharp");
        return;
    };
    let (clones, tiles) = clones_and_tiles(defocus.clones, tile);
    let mut tile_projection = perspective.clone();
    tile_projection.aspect_ratio = tile.x as f32 / tile.y as f32;

    // The clone part every clone material shares.
    let empty = materials
        .empty_field
        .get_or_insert_with(|| {
            buffers.add(ShaderBuffer::new(&[0u8; 12], RenderAssetUsages::RENDER_WORLD))
        })
        .clone();
    let mut extension = CloneExtension {
        params: optics.uniform,
        field: optics.field.as_ref().map_or(empty, |(h, _)| h.clone()),
        clip_distances: device.is_some_and(|d| d.clip_distances),
    };
    extension.params.clones = clones;
    extension.params.tile_cols = tiles.x;
    extension.params.tile_rows = tiles.y;
    if extension.params != materials.extension.params
        || extension.field != materials.extension.field
        || extension.clip_distances != materials.extension.clip_distances
    {
        materials.extension = extension.clone();
        for handle in materials.by_base.values() {
            if let Some(mut m) = clone_assets.get_mut(handle) {
                m.extension = extension.clone();
            }
        }
    }

    // What the resolve reads: kept up to date with the rig (below) and the
    // eye's clear colour.
    let background = match &camera.clear_color {
        ClearColorConfig::Custom(c) => *c,
        _ => clear.0,
    }
    .to_linear()
    .to_vec4();
    let wanted = |atlas: AssetId<Image>| CloneResolve {
        atlas,
        tiles,
        clones,
        shading,
        background,
    };

    match rig {
        Some(rig)
            if rig.tiles == tiles
                && rig.tile == tile
                && rig.clones == clones
                && rig.shading == shading =>
        {
            // Keep the clone camera in step with the eye's perspective,
            // clear colour and order, touching it only when they change.
            if let Ok((mut p, mut c)) = clone_cameras.get_mut(rig.camera) {
                if !same_perspective(&rig.perspective, &tile_projection) {
                    *p = Projection::custom(TileProjection {
                        perspective: tile_projection.clone(),
                        shaded: shading == CloneShading::Full,
                    });
                    commands.entity(entity).insert(CloneRig {
                        perspective: tile_projection,
                        ..rig.clone()
                    });
                }
                let wanted_clear = clone_clear(shading, &camera.clear_color);
                if !same_clear(&c.clear_color, &wanted_clear) || c.order != camera.order - 1 {
                    c.clear_color = wanted_clear;
                    c.order = camera.order - 1;
                }
            }
            let want = wanted(rig.atlas.id());
            if resolve.is_none_or(|r| *r != want) {
                commands.entity(entity).insert(want);
            }
        }
        _ => {
            if let Some(old) = rig {
                commands.entity(old.camera).despawn();
            }
            let atlas = images.add(atlas_image(tile * tiles));
            let clone_camera = commands
                .spawn(clone_camera(entity, camera, shading, &atlas, &tile_projection))
                .id();
            commands.entity(entity).insert((
                CloneRig {
                    camera: clone_camera,
                    atlas: atlas.clone(),
                    tiles,
                    tile,
                    clones,
                    shading,
                    perspective: tile_projection,
                },
                wanted(atlas.id()),
                Hdr,
            ));
            // The eye camera still draws the scene, sharp: reprojected clones
            // take their colours from it, and the lens's refraction finds the
            // scene in its depth.
            let usages = TextureUsages::from(camera3d.depth_texture_usages);
            if !usages.contains(TextureUsages::TEXTURE_BINDING) {
                commands.entity(entity).insert(Camera3d {
                    depth_texture_usages: (usages | TextureUsages::TEXTURE_BINDING).into(),
                    ..camera3d.clone()
                });
            }
        }
    }
}

/// How many clones are drawn (at most what one atlas of `tile`-sized
/// tiles holds) and the atlas's tiles across and down.
fn clones_and_tiles(asked: u32, tile: UVec2) -> (u32, UVec2) {
    let clones = asked.clamp(1, crate::settings::MAX_CLONES);
    if let Some(tiles) = tile_layout(clones, tile) {
        return (clones, tiles);
    }
    let fit = max_tiles(tile).max(1);
    bevy::log::warn_once!(
        "optica_spectacles: {clones} clones of {}×{} px do not fit one {MAX_ATLAS_SIDE}² atlas; drawing {fit}",
        tile.x,
        tile.y
    );
    (fit, tile_layout(fit, tile).unwrap_or(UVec2::ONE))
}

/// The clone atlas: `size` texels of HDR colour the resolve samples.
fn atlas_image(size: UVec2) -> Image {
    let mut atlas = Image::new_target_texture(size.x, size.y, TextureFormat::Rgba16Float, None);
    atlas.asset_usage = RenderAssetUsages::RENDER_WORLD;
    atlas.texture_descriptor.usage |= TextureUsages::TEXTURE_BINDING;
    atlas
}

/// The camera that draws the clones of `eye` into `atlas`, just before
/// the eye camera, one tile per clone.
fn clone_camera(
    eye: Entity,
    camera: &Camera,
    shading: CloneShading,
    atlas: &Handle<Image>,
    tile_projection: &PerspectiveProjection,
) -> impl Bundle {
    (
        Camera3d::default(),
        Camera {
            order: camera.order - 1,
            clear_color: clone_clear(shading, &camera.clear_color),
            ..default()
        },
        RenderTarget::Image(atlas.clone().into()),
        Hdr,
        Tonemapping::None,
        Msaa::Off,
        // Clusters assume one view per target: one cluster serves every tile.
        ClusterConfig::Single,
        Projection::custom(TileProjection {
            perspective: tile_projection.clone(),
            shaded: shading == CloneShading::Full,
        }),
        RenderLayers::layer(CLONE_LAYER),
        CloneCameraOf(eye),
        Transform::IDENTITY,
        ChildOf(eye),
    )
}

/// Removes a rig: its camera and the resolve.
fn stop_rig(commands: &mut Commands, eye: Entity, rig: &CloneRig) {
    commands.entity(rig.camera).despawn();
    commands.entity(eye).remove::<(CloneRig, CloneResolve)>();
}

/// An eye camera whose exposure or rig changed.
type ExposureOrRigChanged = Or<(Changed<bevy::camera::Exposure>, Changed<CloneRig>)>;

/// Gives a clone camera its eye camera's exposure (it scales the light a
/// clone shaded in full receives), when the rig is made or the exposure
/// changes.
pub(crate) fn follow_exposure(
    mut commands: Commands,
    eyes: Query<(&CloneRig, Option<&bevy::camera::Exposure>), ExposureOrRigChanged>,
) {
    for (rig, exposure) in &eyes {
        match exposure {
            Some(e) => commands.entity(rig.camera).insert(*e),
            None => commands.entity(rig.camera).remove::<bevy::camera::Exposure>(),
        };
    }
}

/// Removes the rig of an eye camera whose `Eye` was removed.
pub(crate) fn stop_removed(
    mut commands: Commands,
    mut removed: RemovedComponents<crate::Eye>,
    rigs: Query<&CloneRig>,
) {
    for entity in removed.read() {
        if let Ok(rig) = rigs.get(entity) {
            stop_rig(&mut commands, entity, rig);
        }
    }
}

/// Gives every light the clone layer, so that the clones are lit.
pub(crate) fn light_the_clones(
    mut commands: Commands,
    lights: Query<(Entity, Option<&RenderLayers>), AnyLight>,
) {
    for (entity, layers) in &lights {
        let layers = layers.cloned().unwrap_or_default();
        if !layers.intersects(&RenderLayers::layer(CLONE_LAYER)) {
            commands.entity(entity).insert(layers.with(CLONE_LAYER));
        }
    }
}

/// Keeps `S` twins under every `StandardMaterial` mesh the eye camera
/// sees, each with its clone number as mesh tag and the clone material of
/// the mesh's material; removes them when no rig draws clones.
#[allow(clippy::type_complexity)]
pub(crate) fn sync_twins(
    mut commands: Commands,
    rigs: Query<(&CloneRig, Option<&RenderLayers>)>,
    meshes: Query<
        (
            Entity,
            &Mesh3d,
            &MeshMaterial3d<StandardMaterial>,
            Option<&RenderLayers>,
            Option<&CloneTwins>,
        ),
        Without<CloneOf>,
    >,
    mut twins: Query<(&mut Mesh3d, &mut MeshMaterial3d<CloneMaterial>), With<CloneOf>>,
    mut materials: ResMut<CloneMaterials>,
    bases: Res<Assets<StandardMaterial>>,
    mut clone_assets: ResMut<Assets<CloneMaterial>>,
) {
    let Some((rig, eye_layers)) = rigs.iter().next() else {
        // No clones drawn: no twins.
        for (.., twins_of) in &meshes {
            // (Bevy drops the emptied `CloneTwins`.)
            for twin in twins_of.into_iter().flat_map(|t| t.iter()) {
                commands.entity(twin).despawn();
            }
        }
        return;
    };
    let seen = eye_layers.cloned().unwrap_or_default();
    for (entity, mesh, base, layers, twins_of) in &meshes {
        let visible = layers.cloned().unwrap_or_default().intersects(&seen);
        let wanted = if visible { rig.clones as usize } else { 0 };
        let material = if visible {
            let extension = materials.extension.clone();
            let handle = materials
                .by_base
                .entry(base.id())
                .or_insert_with(|| {
                    clone_assets.add(CloneMaterial {
                        base: bases.get(&base.0).cloned().unwrap_or_default(),
                        extension,
                    })
                })
                .clone();
            Some(handle)
        } else {
            None
        };
        let have: &[Entity] = twins_of.map_or(&[], |t| t.collection());
        if have.len() == wanted {
            // Follow the original's mesh and material.
            for &twin in have {
                if let (Ok((mut m, mut mat)), Some(material)) = (twins.get_mut(twin), &material) {
                    if m.0 != mesh.0 {
                        m.0 = mesh.0.clone();
                    }
                    if mat.0 != *material {
                        mat.0 = material.clone();
                    }
                }
            }
            continue;
        }
        for &twin in have {
            commands.entity(twin).despawn();
        }
        let Some(material) = material else {
            continue;
        };
        // Spawned in clone order, which `CloneTwins` keeps.
        for k in 0..wanted as u32 {
            commands.spawn((
                Mesh3d(mesh.0.clone()),
                MeshMaterial3d(material.clone()),
                MeshTag(k),
                RenderLayers::layer(CLONE_LAYER),
                NotShadowCaster,
                CloneOf(entity),
                Transform::IDENTITY,
                ChildOf(entity),
            ));
        }
    }
}

/// Copies an edited `StandardMaterial` into its clone material.
pub(crate) fn follow_base_materials(
    mut events: MessageReader<AssetEvent<StandardMaterial>>,
    bases: Res<Assets<StandardMaterial>>,
    materials: Res<CloneMaterials>,
    mut clone_assets: ResMut<Assets<CloneMaterial>>,
) {
    for event in events.read() {
        let (AssetEvent::Added { id } | AssetEvent::Modified { id }) = event else {
            continue;
        };
        if let (Some(handle), Some(base)) = (materials.by_base.get(id), bases.get(*id))
            && let Some(mut m) = clone_assets.get_mut(handle)
        {
            m.base = base.clone();
        }
    }
}

/// The defocus by clones: the clone material and its shader, the eye's
/// optics and field, the clone camera and the twins.
pub(crate) struct DefocusPlugin;

impl Plugin for DefocusPlugin {
    fn build(&self, app: &mut App) {
        // The clone material's libraries and shader (the clip-distance
        // vertex stage is added once the device is known), and the resolve
        // pass's shader (the pass is in `render`).
        load_shader_library!(app, "shaders/field_lookup.wgsl");
        load_shader_library!(app, "shaders/clone_vertex.wgsl");
        bevy::asset::embedded_asset!(app, "shaders/clone.wgsl");
        bevy::asset::embedded_asset!(app, "shaders/resolve.wgsl");
        app.add_plugins(MaterialPlugin::<CloneMaterial>::default())
            .init_resource::<CloneMaterials>()
            .add_systems(
                PostUpdate,
                (
                    crate::precompute::update_optics,
                    stop_removed,
                    sync_rig,
                    follow_exposure,
                    sync_twins,
                    follow_base_materials,
                    light_the_clones,
                )
                    .chain()
                    .in_set(crate::SpectaclesSystems::Defocus),
            );
    }
}
