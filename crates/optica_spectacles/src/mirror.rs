//! A curved mirror by per-vertex ray tracing (the paper's §3.2, Fig. 2: a
//! car's door mirror), and the cube-map reflection a Bevy user would
//! otherwise reach for, to compare them.
//!
//! Per vertex (the default): every frame the mirror or its viewer moves,
//! the CPU reflects the ray from the viewer at every vertex of the mirror
//! (`optica_optics::spectacles::CurvedMirror`), fits the virtual viewpoint
//! those reflected rays come from, and points an environment camera from
//! there along them; on the GPU each vertex's reflected ray finds the scene
//! in that camera's depth (the march of the lens's refraction), and the
//! mirror, drawn in the scene with [`MirrorMaterial`], shows the
//! environment image at those points.
//!
//! The cube map ([`MirrorMethod::CubeMap`]): six cameras at the mirror
//! render a cube map every frame, and the mirror is a `StandardMaterial`
//! mirror (metallic, smooth) lit by it as a Bevy reflection probe: exact
//! for what lies far away, wrong by the mirror's size for what lies near
//! it. [`MirrorMethod::ParallaxCorrectedCubeMap`] captures at the centre of
//! a room's box and lets Bevy correct the parallax against that box: exact
//! on the box's walls, wrong for what stands inside the room.

use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{Exposure, Hdr, RenderTarget};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::{EnvironmentMapLight, LightProbe, ParallaxCorrection};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::render_resource::{
    AsBindGroup, Extent3d, TextureDimension, TextureFormat, TextureUsages, TextureViewDescriptor,
    TextureViewDimension,
};
use bevy::render::storage::ShaderBuffer;
use bevy::render::view::Msaa;
use bevy::shader::ShaderRef;
use optica_optics::glam::{DAffine3, DVec3};
use optica_optics::spectacles::{CurvedMirror as MirrorOptics, DEFAULT_VIEWPOINT_REGULARISATION};

use crate::settings::{CurvedMirror, MirrorMethod, MirrorViewer};
use crate::{Error, SpectaclesDevice};
use crate::refraction::LensVertex;

/// The render layer the plugin puts mirrors on: the viewer sees it, the
/// cameras that render what a mirror shows do not (a mirror must not
/// render itself).
pub const MIRROR_LAYER: usize = 27;

/// The per-vertex mirror's material shader (embedded by the plugin).
const MIRROR_SHADER: &str = "embedded://optica_spectacles/shaders/mirror.wgsl";

/// The widest field of view of a mirror's environment camera (the
/// per-vertex method): what a mirror reflects beyond it takes the image's
/// edge.
pub const MAX_ENVIRONMENT_FOV_DEG: f32 = 150.0;

/// What the plugin made for a mirror, and the last trace's figures.
#[derive(Component, Clone, Debug)]
pub struct MirrorState {
    /// The environment image (per vertex) or the cube map.
    pub environment: Handle<Image>,
    /// The cameras rendering it (one, or six faces), and the light probe.
    pub helpers: Vec<Entity>,
    /// The virtual viewpoint (world, m).
    pub viewpoint: Vec3,
    /// How far the reflected rays pass from it, root mean square (m).
    pub viewpoint_rms_m: f32,
    /// Vertices the viewer sees from behind (masked).
    pub masked: u32,
    /// Time of the last per-vertex trace (ms).
    pub trace_ms: f32,
    /// Whether a parallax-corrected cube map is drawn as asked; false
    /// where the device has no reflection probes and the plain cube map
    /// stands in.
    pub parallax_corrected: bool,
    settings: CurvedMirror,
    warned_scale: bool,
    optics: MirrorOptics,
    vertices: Vec<DVec3>,
    traced_from: Option<(Mat4, Mat4)>,
}

/// The per-vertex mirror's material: the environment image at each
/// vertex's traced coordinate (`mirror.wgsl`).
#[derive(Asset, TypePath, AsBindGroup, Clone, Debug)]
pub struct MirrorMaterial {
    /// Reflectance per channel (linear).
    #[uniform(0)]
    pub tint: LinearRgba,
    /// What the environment camera sees.
    #[texture(1)]
    #[sampler(2)]
    pub environment: Handle<Image>,
    /// Per vertex: texture coordinate, hit flag, whether it is seen from the front.
    #[storage(3, read_only)]
    pub coords: Handle<ShaderBuffer>,
}

impl Material for MirrorMaterial {
    fn vertex_shader() -> ShaderRef {
        MIRROR_SHADER.into()
    }

    fn fragment_shader() -> ShaderRef {
        MIRROR_SHADER.into()
    }
}

/// On an environment camera: the mirror's reflected rays in its view space,
/// marched in its depth into `coords` (`render::mirror`).
#[derive(Component, Clone, Debug, ExtractComponent)]
pub struct MirrorEnvironment {
    /// One per mirror vertex (`back` unused; `exits` 0 where masked).
    pub vertices: Vec<LensVertex>,
    /// Where the march writes the vertices' coordinates.
    pub coords: Handle<ShaderBuffer>,
}

/// On a cube-map face camera: the cube and the layer its view is copied to.
#[derive(Component, Clone, Debug, ExtractComponent)]
pub struct CubeFace {
    /// The cube map.
    pub cube: Handle<Image>,
    /// Its layer (Bevy's order: +X, −X, +Y, −Y, then world −Z, +Z: cube
    /// maps are left-handed).
    pub layer: u32,
}

/// On what the plugin made for a mirror (its cameras, its probe): the
/// mirror's entity (a relationship: the mirror's [`MirrorHelpers`] lists
/// them, and despawning the mirror despawns them).
#[derive(Component, Clone, Copy, Debug)]
#[relationship(relationship_target = MirrorHelpers)]
pub struct MirrorHelperOf(pub Entity);

/// On a mirror: the cameras and probe the plugin made for it.
#[derive(Component, Debug)]
#[relationship_target(relationship = MirrorHelperOf, linked_spawn)]
pub struct MirrorHelpers(Vec<Entity>);

/// On a viewer lit by a mirror's cube map (where the device has no
/// reflection probes): the mirror, and the viewer's own environment map
/// to give back when the mirror goes.
#[derive(Component, Clone)]
pub(crate) struct LitByMirrorCube(Entity, Option<EnvironmentMapLight>);

/// Despawns what the plugin made for `mirror` and takes its cube map off
/// the viewer.
fn release(
    commands: &mut Commands,
    mirror: Entity,
    helpers: &Query<(Entity, &MirrorHelperOf)>,
    lit: &Query<(Entity, &LitByMirrorCube)>,
) {
    for (h, of) in helpers {
        if of.0 == mirror {
            commands.entity(h).despawn();
        }
    }
    for (v, by) in lit {
        if by.0 == mirror {
            let mut e = commands.entity(v);
            e.remove::<(EnvironmentMapLight, LitByMirrorCube)>();
            if let Some(own) = by.1.clone() {
                e.insert(own);
            }
        }
    }
}

/// Cube faces as Bevy samples them: layer, the face camera's forward and up.
const FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::NEG_Z),
    (Vec3::NEG_Z, Vec3::Y),
    (Vec3::Z, Vec3::Y),
];

fn layers_without_mirrors(viewer: Option<&RenderLayers>) -> RenderLayers {
    viewer.cloned().unwrap_or_default().without(MIRROR_LAYER)
}

fn helper_camera(
    target: Handle<Image>,
    order: isize,
    exposure: Exposure,
    layers: RenderLayers,
    clear: ClearColorConfig,
) -> impl Bundle {
    (
        Camera3d {
            depth_texture_usages: (TextureUsages::RENDER_ATTACHMENT
                | TextureUsages::TEXTURE_BINDING)
                .into(),
            ..default()
        },
        Camera {
            order,
            clear_color: clear,
            ..default()
        },
        RenderTarget::Image(target.into()),
        Hdr,
        Tonemapping::None,
        Msaa::Off,
        exposure,
        layers,
    )
}

fn hdr_target(side: u32) -> Image {
    let mut image = Image::new_target_texture(side, side, TextureFormat::Rgba16Float, None);
    image.sampler = bevy::image::ImageSampler::linear();
    image
}

fn cube_image(side: u32) -> Image {
    let mut image = Image::new_fill(
        Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 6,
        },
        TextureDimension::D2,
        &[0; 8],
        TextureFormat::Rgba16Float,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.texture_view_descriptor = Some(TextureViewDescriptor {
        dimension: Some(TextureViewDimension::Cube),
        ..default()
    });
    image.texture_descriptor.usage = TextureUsages::TEXTURE_BINDING | TextureUsages::COPY_DST;
    image
}

/// The mirror's mesh: positions and normals in its frame, and each
/// vertex's index in `UV_0.x` (the material reads its traced coordinate
/// by it).
fn mirror_mesh(vertices: &[DVec3], triangles: &[[u32; 3]], optics: &MirrorOptics) -> Mesh {
    let positions: Vec<[f32; 3]> = vertices.iter().map(|v| v.as_vec3().to_array()).collect();
    // The twin's normal points to the viewer (−z at the vertex).
    let normals: Vec<[f32; 3]> = vertices
        .iter()
        .map(|&v| optics.surface().normal_at(v).as_vec3().to_array())
        .collect();
    let index: Vec<[f32; 2]> = (0..vertices.len()).map(|i| [i as f32, 0.0]).collect();
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, index)
    .with_inserted_indices(Indices::U32(triangles.iter().flatten().copied().collect()))
}

/// Builds (or rebuilds, when its settings change) each mirror's mesh,
/// material and helper cameras.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn build_mirrors(
    mut commands: Commands,
    mirrors: Query<(Entity, &CurvedMirror, Option<&MirrorState>), Changed<CurvedMirror>>,
    viewers: Query<
        (
            Entity,
            &Camera,
            Option<&RenderLayers>,
            Option<&Exposure>,
            Option<&EnvironmentMapLight>,
        ),
        With<MirrorViewer>,
    >,
    mut meshes: ResMut<Assets<Mesh>>,
    mut images: ResMut<Assets<Image>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut mirror_materials: ResMut<Assets<MirrorMaterial>>,
    mut standard_materials: ResMut<Assets<StandardMaterial>>,
    owned: Query<(Entity, &MirrorHelperOf)>,
    lit: Query<(Entity, &LitByMirrorCube)>,
    device: Option<Res<SpectaclesDevice>>,
) {
    let device = device.map_or_else(SpectaclesDevice::default, |d| *d);
    let (viewer, order, layers, exposure) = viewers
        .iter()
        .next()
        .map(|(v, c, l, e, _)| {
            (
                Some(v),
                c.order - 1,
                layers_without_mirrors(l),
                e.copied().unwrap_or_default(),
            )
        })
        .unwrap_or((None, -1, RenderLayers::default(), Exposure::default()));
    for (entity, mirror, state) in &mirrors {
        if let Some(state) = state {
            if state.settings == *mirror {
                continue;
            }
            release(&mut commands, entity, &owned, &lit);
        }
        let (optics, vertices, triangles) = match mirror_geometry(mirror) {
            Ok(b) => b,
            Err(e) => {
                warn!("optica_spectacles: mirror {entity}: {e}");
                commands.entity(entity).remove::<MirrorDrawn>();
                continue;
            }
        };
        let side = mirror.resolution.clamp(16, 4096);
        let coords = buffers.add(ShaderBuffer::with_size(
            16 * vertices.len(),
            RenderAssetUsages::RENDER_WORLD,
        ));
        let mesh = meshes.add(mirror_mesh(&vertices, &triangles, &optics));
        let mut e = commands.entity(entity);
        e.insert((Mesh3d(mesh), RenderLayers::layer(MIRROR_LAYER)));
        e.remove::<(
            MeshMaterial3d<MirrorMaterial>,
            MeshMaterial3d<StandardMaterial>,
        )>();
        let helper = Helper {
            mirror: entity,
            order,
            exposure,
            layers: layers.clone(),
        };
        let (environment, helpers) = match &mirror.method {
            MirrorMethod::PerVertex => {
                let image = images.add(hdr_target(side));
                e.insert(MeshMaterial3d(mirror_materials.add(MirrorMaterial {
                    tint: LinearRgba::gray(mirror.reflectance),
                    environment: image.clone(),
                    coords: coords.clone(),
                })));
                let camera = commands
                    .spawn((
                        helper.camera(image.clone()),
                        MirrorEnvironment {
                            vertices: Vec::new(),
                            coords: coords.clone(),
                        },
                        MirrorHelperOf(entity),
                        Name::new("optica mirror environment camera"),
                    ))
                    .id();
                (image, vec![camera])
            }
            MirrorMethod::CubeMap | MirrorMethod::ParallaxCorrectedCubeMap { .. } => {
                let cube = images.add(cube_image(side));
                e.insert(MeshMaterial3d(standard_materials.add(StandardMaterial {
                    base_color: Color::linear_rgb(
                        mirror.reflectance,
                        mirror.reflectance,
                        mirror.reflectance,
                    ),
                    metallic: 1.0,
                    perceptual_roughness: 0.0,
                    ..default()
                })));
                let mut helpers = spawn_cube_faces(&mut commands, &mut images, &helper, &cube, side);
                let light = EnvironmentMapLight {
                    diffuse_map: cube.clone(),
                    specular_map: cube.clone(),
                    // The cube holds what the viewer's exposure already
                    // scaled; Bevy scales the map's light by it again.
                    intensity: 1.0 / exposure.exposure(),
                    ..default()
                };
                let viewer = viewer.map(|v| {
                    // The viewer's own map, to give back (or the one a
                    // mirror before this one kept).
                    let own = match lit.iter().find(|(v2, _)| *v2 == v) {
                        Some((_, by)) => by.1.clone(),
                        None => viewers.get(v).ok().and_then(|(.., m)| m.cloned()),
                    };
                    (v, own)
                });
                helpers.extend(light_with_cube(
                    &mut commands,
                    entity,
                    &mirror.method,
                    device.reflection_probes,
                    light,
                    viewer,
                ));
                (cube, helpers)
            }
        };
        commands.entity(entity).insert(MirrorState {
            environment,
            helpers,
            viewpoint: Vec3::ZERO,
            viewpoint_rms_m: 0.0,
            masked: 0,
            trace_ms: 0.0,
            parallax_corrected: matches!(
                mirror.method,
                MirrorMethod::ParallaxCorrectedCubeMap { .. }
            ) && device.reflection_probes,
            settings: mirror.clone(),
            warned_scale: false,
            optics,
            vertices,
            traced_from: None,
        });
    }
}

/// What a mirror's helper cameras share: the mirror they serve, drawn
/// just before its viewer, with its exposure and layers.
struct Helper {
    mirror: Entity,
    order: isize,
    exposure: Exposure,
    layers: RenderLayers,
}

/// The mirror's optics and its tessellated surface, or why it is refused.
#[allow(clippy::type_complexity)]
fn mirror_geometry(
    mirror: &CurvedMirror,
) -> Result<(MirrorOptics, Vec<DVec3>, Vec<[u32; 3]>), Error> {
    let optics = mirror.optics()?;
    let (cols, rows) = (
        mirror.tessellation.x as usize,
        mirror.tessellation.y as usize,
    );
    let (vertices, triangles) = optics.mesh(cols, rows).map_err(Error::Mirror)?;
    Ok((optics, vertices, triangles))
}

/// What a mirror's drawing adds to it (removed when it is refused).
type MirrorDrawn = (
    MirrorState,
    Mesh3d,
    MeshMaterial3d<MirrorMaterial>,
    MeshMaterial3d<StandardMaterial>,
);

impl Helper {
    /// A helper camera drawing into `image`.
    fn camera(&self, image: Handle<Image>) -> impl Bundle {
        helper_camera(
            image,
            self.order,
            self.exposure,
            self.layers.clone(),
            ClearColorConfig::Default,
        )
    }
}

/// The six cameras that draw a cube-map mirror's cube, one per face.
fn spawn_cube_faces(
    commands: &mut Commands,
    images: &mut Assets<Image>,
    helper: &Helper,
    cube: &Handle<Image>,
    side: u32,
) -> Vec<Entity> {
    (0..6u32)
        .map(|layer| {
            commands
                .spawn((
                    helper.camera(images.add(hdr_target(side))),
                    Projection::Perspective(PerspectiveProjection {
                        fov: std::f32::consts::FRAC_PI_2,
                        aspect_ratio: 1.0,
                        near: 0.01,
                        ..default()
                    }),
                    CubeFace {
                        cube: cube.clone(),
                        layer,
                    },
                    MirrorHelperOf(helper.mirror),
                    Name::new("optica mirror cube face"),
                ))
                .id()
        })
        .collect()
}

/// Lights the mirror with its cube: a reflection probe where the device
/// has them (returned, a helper of the mirror), else the viewer's
/// environment map (the viewer given with the map it had, to give back).
fn light_with_cube(
    commands: &mut Commands,
    entity: Entity,
    method: &MirrorMethod,
    probes: bool,
    light: EnvironmentMapLight,
    viewer: Option<(Entity, Option<EnvironmentMapLight>)>,
) -> Option<Entity> {
    let parallax = match *method {
        MirrorMethod::ParallaxCorrectedCubeMap {
            room_centre,
            room_half_size,
        } => Some((room_centre, room_half_size)),
        _ => None,
    };
    if probes {
        // A reflection probe: the room's box, corrected for parallax; or
        // (placed on the mirror each frame) a box holding only the
        // mirror, uncorrected.
        let (correction, place) = match parallax {
            // Bevy samples the cube map along the box hit point in the
            // probe's own space, which is the world's direction from the
            // probe only under a uniform scale: the probe is a cube round
            // the room and the room's box is its parallax bound. (Scaled
            // to the room's box, a 7 × 7 × 3 m room showed its walls
            // 19 px away from where they are, worse than no correction.)
            Some((centre, half)) => {
                let side = 2.0 * half.max_element();
                (
                    ParallaxCorrection::Custom(half / side),
                    Transform::from_translation(centre).with_scale(Vec3::splat(side)),
                )
            }
            None => (ParallaxCorrection::None, Transform::default()),
        };
        return Some(
            commands
                .spawn((
                    LightProbe::default(),
                    light,
                    correction,
                    place,
                    MirrorHelperOf(entity),
                    Name::new("optica mirror reflection probe"),
                ))
                .id(),
        );
    }
    // No reflection probes: the cube becomes the viewer's environment map,
    // which Bevy treats as infinitely far (and which lights every mesh the
    // viewer sees).
    if parallax.is_some() {
        warn!(
            "optica_spectacles: mirror {entity}: this device has no reflection probes \
             (binding arrays); the plain cube map stands in for the parallax-corrected one"
        );
    }
    if let Some((viewer, own)) = viewer {
        commands
            .entity(viewer)
            .insert((light, LitByMirrorCube(entity, own)));
    }
    None
}

/// Gives the viewer the mirrors' layer.
pub(crate) fn show_mirrors_to_the_viewer(
    mut commands: Commands,
    viewers: Query<(Entity, Option<&RenderLayers>), With<MirrorViewer>>,
) {
    for (entity, layers) in &viewers {
        let layers = layers.cloned().unwrap_or_default();
        if !layers.intersects(&RenderLayers::layer(MIRROR_LAYER)) {
            commands.entity(entity).insert(layers.with(MIRROR_LAYER));
        }
    }
}

/// Removes what the plugin made for mirrors that are gone (the component
/// removed or the entity despawned): whatever is marked with a mirror that
/// no longer has a [`CurvedMirror`].
pub(crate) fn remove_mirrors(
    mut commands: Commands,
    mirrors: Query<(), With<CurvedMirror>>,
    owned: Query<(Entity, &MirrorHelperOf)>,
    lit: Query<(Entity, &LitByMirrorCube)>,
    stale: Query<Entity, (With<MirrorState>, Without<CurvedMirror>)>,
) {
    let gone: std::collections::BTreeSet<Entity> = owned
        .iter()
        .map(|(_, of)| of.0)
        .chain(lit.iter().map(|(_, by)| by.0))
        .filter(|m| !mirrors.contains(*m))
        .collect();
    for mirror in gone {
        release(&mut commands, mirror, &owned, &lit);
    }
    for entity in &stale {
        commands.entity(entity).remove::<MirrorState>();
    }
}

/// Places each mirror's helper cameras: per vertex, retraces the mirror
/// when it or the viewer moved and points the environment camera from the
/// virtual viewpoint; cube maps, puts the six faces at the mirror (or the
/// room's centre).
type Helpers<'w, 's> = Query<
    'w,
    's,
    (
        &'static mut Transform,
        &'static mut GlobalTransform,
        Option<&'static mut Projection>,
        Option<&'static mut MirrorEnvironment>,
    ),
    (Without<MirrorState>, Without<MirrorViewer>),
>;

/// Puts a helper where it goes this frame (after transform propagation,
/// so its global transform too).
fn place(helpers: &mut Helpers, entity: Entity, t: Transform) {
    if let Ok((mut tr, mut gt, ..)) = helpers.get_mut(entity) {
        *tr = t;
        *gt = GlobalTransform::from(t);
    }
}

/// Places a cube-map mirror's face cameras at the room's centre (parallax
/// corrected) or the mirror's, and an uncorrected probe round the mirror.
fn place_cube(helpers: &mut Helpers, state: &MirrorState, translation: Vec3) {
    let centre = match state.settings.method {
        MirrorMethod::ParallaxCorrectedCubeMap { room_centre, .. } if state.parallax_corrected => {
            room_centre
        }
        _ => translation,
    };
    for (k, &(forward, up)) in FACES.iter().enumerate() {
        let t = Transform::from_translation(centre).looking_to(forward, up);
        place(helpers, state.helpers[k], t);
    }
    // An uncorrected probe holds only the mirror.
    if matches!(state.settings.method, MirrorMethod::CubeMap) && state.helpers.len() > 6 {
        let reach = state.settings.size_m.length() * 2.0;
        place(
            helpers,
            state.helpers[6],
            Transform::from_translation(translation).with_scale(Vec3::splat(reach)),
        );
    }
}

/// A mirror vertex for the march, in the environment camera's view space:
/// its reflected ray, or (`None`: the ray is blocked) a dead one.
fn march_vertex(origin: Vec3, dir: Option<Vec3>) -> LensVertex {
    match dir {
        Some(dir) => LensVertex {
            back: origin,
            exits: 1,
            origin,
            dir,
            dir_red: dir,
            dir_blue: dir,
            ..default()
        },
        None => LensVertex {
            back: origin,
            origin,
            dir: Vec3::NEG_Z,
            dir_red: Vec3::NEG_Z,
            dir_blue: Vec3::NEG_Z,
            ..default()
        },
    }
}

pub(crate) fn trace_mirrors(
    mut mirrors: Query<(&GlobalTransform, &mut MirrorState)>,
    viewer: Query<&GlobalTransform, (With<MirrorViewer>, Without<MirrorState>)>,
    mut helpers: Helpers,
) {
    let Some(eye) = viewer.iter().next() else {
        return;
    };
    let eye_from = eye.to_matrix();
    for (mirror_at, mut state) in &mut mirrors {
        // The mirror's rigid placement: its shape is its radius and size,
        // and a scale would draw it where it was not traced.
        let (scale, rotation, translation) = mirror_at.to_scale_rotation_translation();
        if (scale - Vec3::ONE).abs().max_element() > 1e-4 && !state.warned_scale {
            warn!(
                "optica_spectacles: a CurvedMirror is scaled by {scale}: its reflection is traced unscaled; \
                 set its size with CurvedMirror::size_m and keep its scale 1"
            );
            state.warned_scale = true;
        }
        let world_from_mirror = Mat4::from_rotation_translation(rotation, translation);
        let key = (world_from_mirror, eye_from);
        if state.traced_from == Some(key) {
            continue;
        }
        state.traced_from = Some(key);
        match &state.settings.method {
            MirrorMethod::CubeMap | MirrorMethod::ParallaxCorrectedCubeMap { .. } => {
                place_cube(&mut helpers, &state, translation);
            }
            MirrorMethod::PerVertex => {
                let started = std::time::Instant::now();
                let to_d = |m: Mat4| DAffine3::from_mat4(m.as_dmat4());
                let world_from_mirror = to_d(world_from_mirror);
                let mirror_from_world = world_from_mirror.inverse();
                let eye_local = mirror_from_world.transform_point3(eye.translation().as_dvec3());
                let rays = state.optics.reflect_vertices(eye_local, &state.vertices);
                let masked = rays.iter().filter(|r| r.is_none()).count() as u32;
                let Ok(fit) = state.optics.virtual_viewpoint(
                    eye_local,
                    &rays,
                    DEFAULT_VIEWPOINT_REGULARISATION,
                ) else {
                    // The viewer sees only the mirror's back: nothing to draw.
                    state.masked = masked;
                    continue;
                };
                // Its axis: the rays' mean direction; up: the mirror's +y.
                let axis = rays
                    .iter()
                    .flatten()
                    .map(|r| r.dir())
                    .sum::<DVec3>()
                    .normalize_or(DVec3::NEG_Z);
                // A concave mirror may focus its rays in front of it: then
                // the viewpoint falls back to the eye's image in the
                // mirror's tangent plane, which always lies behind it.
                let depth_of = |v: DVec3, p: DVec3| (p - v).dot(axis);
                let mut viewpoint = fit.point;
                if state
                    .vertices
                    .iter()
                    .any(|&p| depth_of(viewpoint, p) < 1e-3)
                {
                    viewpoint = DVec3::new(eye_local.x, eye_local.y, -eye_local.z);
                }
                let up_hint = if axis.y.abs() > 0.99 {
                    DVec3::X
                } else {
                    DVec3::Y
                };
                let right = axis.cross(up_hint).normalize();
                let up = right.cross(axis);
                // The field of view holds every ray's direction and every
                // vertex seen from the viewpoint (a hit lies between them).
                let mut tan_max = 0.0f64;
                let mut near = f64::INFINITY;
                for (p, r) in state.vertices.iter().zip(&rays) {
                    let Some(r) = r else { continue };
                    for d in [r.dir(), *p - viewpoint] {
                        let z = d.dot(axis);
                        if z > 1e-6 {
                            tan_max = tan_max.max(d.dot(right).abs() / z).max(d.dot(up).abs() / z);
                        }
                    }
                    near = near.min(depth_of(viewpoint, *p));
                }
                let max_tan = (0.5 * f64::from(MAX_ENVIRONMENT_FOV_DEG).to_radians()).tan();
                let fov = 2.0 * (tan_max * 1.02).min(max_tan).atan();
                let near = near.max(1e-3);
                // The camera in the world; its view space (−z ahead).
                let camera_from_mirror =
                    |p: DVec3| DVec3::new(p.dot(right), p.dot(up), -p.dot(axis));
                let world_view =
                    world_from_mirror * DAffine3::from_cols(right, up, -axis, viewpoint);
                let transform = Transform::from_matrix(world_view.as_mat4_like());
                let vertices: Vec<LensVertex> = state
                    .vertices
                    .iter()
                    .zip(&rays)
                    .map(|(p, r)| {
                        let dir = r.as_ref().map(|r| camera_from_mirror(r.dir()).as_vec3());
                        march_vertex(camera_from_mirror(*p - viewpoint).as_vec3(), dir)
                    })
                    .collect();
                let camera = state.helpers[0];
                place(&mut helpers, camera, transform);
                if let Ok((_, _, projection, environment)) = helpers.get_mut(camera) {
                    if let Some(mut projection) = projection {
                        *projection = Projection::Perspective(PerspectiveProjection {
                            fov: fov as f32,
                            aspect_ratio: 1.0,
                            near: near as f32,
                            ..default()
                        });
                    }
                    if let Some(mut environment) = environment {
                        environment.vertices = vertices;
                    }
                }
                state.viewpoint = world_from_mirror.transform_point3(viewpoint).as_vec3();
                state.viewpoint_rms_m = fit.rms_distance_m as f32;
                state.masked = masked;
                state.trace_ms = started.elapsed().as_secs_f32() * 1e3;
            }
        }
    }
}

/// `DAffine3` to the `Mat4` a `Transform` is made from.
trait AsMat4 {
    fn as_mat4_like(&self) -> Mat4;
}

impl AsMat4 for DAffine3 {
    fn as_mat4_like(&self) -> Mat4 {
        optica_optics::glam::DMat4::from(*self).as_mat4()
    }
}

/// Curved mirrors: their material and shader, their helper cameras and the
/// per-vertex trace.
pub(crate) struct MirrorPlugin;

impl Plugin for MirrorPlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "shaders/mirror.wgsl");
        app.add_plugins(MaterialPlugin::<MirrorMaterial>::default())
            .register_type::<CurvedMirror>()
            .register_type::<MirrorViewer>()
            .add_systems(
                PostUpdate,
                (
                    remove_mirrors,
                    show_mirrors_to_the_viewer,
                    build_mirrors,
                    bevy::ecs::schedule::ApplyDeferred,
                    trace_mirrors,
                )
                    .chain()
                    .in_set(crate::SpectaclesSystems::Mirrors),
            );
    }
}
