//! The cube-map mode: the scene is drawn by 4, 5 or 6 ordinary perspective
//! cameras (the faces of a cube around the dome camera, as SGCT does) into
//! images, and a full-screen pass on the dome camera resamples them into
//! the domemaster, one direction per output pixel. Any material works,
//! since the faces are plain cameras; the cost is drawing the scene once
//! per face.
//!
//! Which faces: the cube is turned so that as few faces as possible cover
//! the field of view. Up to 180° the dome axis points at the edge between
//! two faces, and four faces cover the hemisphere; up to 250° (cube
//! corners at 125.3° from the axis) the axis points at a face's centre and
//! five faces do; beyond, all six.
//!
//! Seamless filtering: each face is rendered one texel wider on every side
//! than its quarter of the cube (`tan(fov/2) = N/(N − 2)`), so the
//! bilinear footprint of every direction lies inside the face that
//! contains it, with real neighbours across the cube's edges.

use bevy::asset::RenderAssetUsages;
use bevy::camera::Hdr;
use bevy::camera::RenderTarget;
use bevy::camera::visibility::RenderLayers;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::math::Mat3;
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::render_resource::{ShaderType, TextureFormat, TextureUsages};
use bevy::render::view::Msaa;

use crate::{DomeCamera, DomeClip, DomeMode, DomeSees};

/// The six faces in the cube's frame: (looking along, image up). The
/// shader receives this table, so it is written once.
const FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::NEG_Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// The cube's turn and its faces for a field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubeLayout {
    /// Columns: the cube's axes in the dome camera's view space (a proper
    /// rotation).
    pub view_from_cube: Mat3,
    /// Which of the six faces are drawn (indices into the face table:
    /// +X, −X, +Y, −Y, +Z, −Z of the cube).
    pub faces: &'static [usize],
}

/// The widest field of view five faces cover: the cube's corners lie
/// `acos(−1/√3)` = 125.26° from a face's centre.
pub const FIVE_FACE_MAX_FOV_DEG: f32 = 250.0;

impl CubeLayout {
    /// The layout for `camera`'s field of view and tilt (the counts of
    /// SGCT: 4 faces up to 180°, 5 up to 250°, 6 beyond and for the
    /// equirectangular panorama).
    pub fn of(camera: &DomeCamera) -> Self {
        let (right, up, axis) = DomeClip::of(camera).frame();
        let panorama = camera.lens == crate::DomeLens::Equirectangular;
        if panorama {
            Self {
                view_from_cube: Mat3::from_cols(right, up, -axis),
                faces: &[0, 1, 2, 3, 4, 5],
            }
        } else if camera.fov_deg <= 180.0 {
            // The axis between the cube's +Y and −Z faces: directions with
            // d·axis ≥ 0 have y ≥ z, so −Y and +Z are never the nearest.
            let s = std::f32::consts::FRAC_1_SQRT_2;
            Self {
                view_from_cube: Mat3::from_cols(right, s * (axis + up), s * (up - axis)),
                faces: &[0, 1, 2, 5],
            }
        } else if camera.fov_deg <= FIVE_FACE_MAX_FOV_DEG {
            // The axis through the −Z face's centre.
            Self {
                view_from_cube: Mat3::from_cols(right, up, -axis),
                faces: &[0, 1, 2, 3, 5],
            }
        } else {
            Self {
                view_from_cube: Mat3::from_cols(right, up, -axis),
                faces: &[0, 1, 2, 3, 4, 5],
            }
        }
    }

    /// The local transform of face `face` (an index into the face table)
    /// relative to the dome camera.
    pub fn face_transform(&self, face: usize) -> Transform {
        let (forward, up) = FACES[face];
        Transform::IDENTITY.looking_to(self.view_from_cube * forward, self.view_from_cube * up)
    }
}

/// `tan` of half a face camera's field of view for faces of `face_px`:
/// one texel of guard on every side (see the module docs).
pub fn guarded_tan_half(face_px: u32) -> f32 {
    let n = face_px as f32;
    n / (n - 2.0)
}

/// On a cube-mode [`DomeCamera`]: its face cameras and their images.
#[derive(Component, Debug, Clone)]
pub struct DomeCubeFaces {
    /// The face cameras (children of the dome camera), in face-table order
    /// of the drawn faces.
    pub cameras: Vec<Entity>,
    /// Each face's image (Rgba16Float, linear; the dome camera tonemaps).
    pub images: Vec<Handle<Image>>,
    built_for: DomeCamera,
}

/// On a face camera: the dome camera it draws for and its face index.
#[derive(Component, Debug, Clone, Copy)]
pub struct DomeCubeFace {
    /// The dome camera.
    pub dome: Entity,
    /// Index into the face table (+X, −X, +Y, −Y, +Z, −Z of the cube).
    pub face: usize,
}

/// What the resampling pass needs, extracted to the dome camera's view.
#[derive(Component, Clone, ExtractComponent)]
pub(crate) struct DomeCubeSampling {
    /// One image per face-table entry; faces not drawn repeat a drawn one
    /// (never selected).
    pub(crate) images: [Handle<Image>; 6],
    pub(crate) params: CubeParams,
}

/// The resampling pass's uniform (`shaders/cube_resample.wgsl`).
#[derive(ShaderType, Clone, Copy, Debug, PartialEq)]
pub(crate) struct CubeParams {
    /// Dome coordinates (image right, image up, along the axis) to the
    /// cube's frame.
    cube_from_dome: Mat3,
    /// Per face: looking along (xyz) and 1 when drawn, 0 otherwise (w).
    forward: [Vec4; 6],
    /// Per face: image up.
    up: [Vec4; 6],
    theta_max: f32,
    tan_half: f32,
    /// NDC per image-circle radius along x and y (the circle fits the
    /// target's shorter side), from the view's size.
    scale: Vec2,
    /// A polynomial lens's shape, (k₂, k₃, k₄)/k₁.
    shape: Vec3,
    /// The lens's number (`DomeClip::lens_code`).
    lens: u32,
}

impl CubeParams {
    /// The parameters for a view of `size` pixels: the image circle fits
    /// its shorter side.
    pub(crate) fn for_view(self, size: UVec2) -> Self {
        let size = size.max(UVec2::ONE).as_vec2();
        Self {
            scale: Vec2::splat(size.min_element()) / size,
            ..self
        }
    }
}

/// Spawns, rebuilds or removes the face cameras of every dome camera whose
/// settings changed; drops the faces of cameras that left the cube mode.
#[allow(clippy::type_complexity)]
pub(crate) fn sync_cube_faces(
    mut commands: Commands,
    cameras: Query<
        (
            Entity,
            &DomeCamera,
            &Camera,
            Option<&Msaa>,
            Option<&DomeCubeFaces>,
            Option<&DomeSees>,
        ),
        Changed<DomeCamera>,
    >,
    mut images: ResMut<Assets<Image>>,
) {
    for (entity, dome, camera, msaa, faces, sees) in &cameras {
        let face_px = match dome.mode {
            DomeMode::CubeMap { face_px } if dome.validate().is_ok() => Some(face_px),
            _ => None,
        };
        if face_px.is_some() && faces.is_some_and(|f| f.built_for == *dome) {
            continue;
        }
        // Out of the cube mode, or rebuilt: the old faces go.
        if let Some(faces) = faces {
            for &face in &faces.cameras {
                commands.entity(face).despawn();
            }
            commands
                .entity(entity)
                .remove::<(DomeCubeFaces, DomeCubeSampling)>();
        }
        let Some(face_px) = face_px else {
            continue;
        };
        let layout = CubeLayout::of(dome);
        let tan_half = guarded_tan_half(face_px);
        let mut face_images = Vec::new();
        let mut face_cameras = Vec::new();
        for &face in layout.faces {
            let mut image =
                Image::new_target_texture(face_px, face_px, TextureFormat::Rgba16Float, None);
            // Drawn on the GPU only: no CPU copy (an 8K dome's faces would
            // hold gigabytes of zeros).
            image.data = None;
            image.asset_usage = RenderAssetUsages::RENDER_WORLD;
            image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
            let handle = images.add(image);
            let face_camera = commands
                .spawn((
                    Camera3d::default(),
                    Camera {
                        // Before the dome camera resamples.
                        order: camera.order - 1,
                        clear_color: camera.clear_color,
                        ..default()
                    },
                    RenderTarget::Image(handle.clone().into()),
                    Projection::Perspective(PerspectiveProjection {
                        fov: 2.0 * tan_half.atan(),
                        aspect_ratio: 1.0,
                        near: dome.near,
                        far: dome.far,
                        ..default()
                    }),
                    // Linear light into the faces; the dome camera
                    // tonemaps the resampled image once.
                    Hdr,
                    Tonemapping::None,
                    msaa.copied().unwrap_or_default(),
                    layout.face_transform(face),
                    sees.map_or_else(RenderLayers::default, |s| s.0.clone()),
                    DomeCubeFace { dome: entity, face },
                    ChildOf(entity),
                ))
                .id();
            face_images.push(handle);
            face_cameras.push(face_camera);
        }
        let mut table_images: [Handle<Image>; 6] = std::array::from_fn(|_| face_images[0].clone());
        let mut forward = [Vec4::ZERO; 6];
        let mut up = [Vec4::ZERO; 6];
        for (k, (f, u)) in FACES.iter().enumerate() {
            forward[k] = f.extend(0.0);
            up[k] = u.extend(0.0);
        }
        for (slot, &face) in layout.faces.iter().enumerate() {
            table_images[face] = face_images[slot].clone();
            forward[face].w = 1.0;
        }
        let clip = DomeClip::of(dome);
        let (right, up_axis, axis) = clip.frame();
        let view_from_dome = Mat3::from_cols(right, up_axis, axis);
        let (lens, shape) = clip.lens_code();
        let params = CubeParams {
            cube_from_dome: layout.view_from_cube.transpose() * view_from_dome,
            forward,
            up,
            theta_max: 0.5 * dome.fov_deg.to_radians(),
            tan_half,
            scale: Vec2::ONE,
            shape,
            lens,
        };
        commands.entity(entity).insert((
            DomeCubeFaces {
                cameras: face_cameras,
                images: face_images,
                built_for: *dome,
            },
            DomeCubeSampling {
                images: table_images,
                params,
            },
        ));
    }
}

/// Keeps the face cameras' layers in step with their dome camera's
/// [`DomeSees`].
pub(crate) fn follow_dome_sees(
    domes: Query<(&DomeSees, &DomeCubeFaces), Changed<DomeSees>>,
    mut commands: Commands,
) {
    for (sees, cube) in &domes {
        for &face in &cube.cameras {
            commands.entity(face).insert(sees.0.clone());
        }
    }
}

/// Keeps each face camera's clear colour, order and activity in step with
/// its dome camera.
#[allow(clippy::type_complexity)]
pub(crate) fn follow_dome_camera(
    domes: Query<(&Camera, &DomeCubeFaces), (With<DomeCamera>, Changed<Camera>)>,
    mut faces: Query<&mut Camera, (With<DomeCubeFace>, Without<DomeCamera>)>,
) {
    for (dome, cube) in &domes {
        for &face in &cube.cameras {
            if let Ok(mut camera) = faces.get_mut(face) {
                camera.clear_color = dome.clear_color;
                camera.order = dome.order - 1;
                camera.is_active = dome.is_active;
            }
        }
    }
}
