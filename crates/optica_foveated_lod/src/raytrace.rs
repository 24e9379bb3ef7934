//! The paper's method: a GPU Whitted ray tracer with a level per ray.
//! What users put on entities ([`GazeRayTracer`] on a camera, [`RayTraced`]
//! on meshes), the scene the tracer sees ([`TracedScene`], rebuilt only when
//! something in it changed) and each view's foveation decision
//! ([`GazeRayTracerState`]). The GPU side is the `render` module.

use std::sync::Arc;

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::extract_resource::ExtractResource;
use optica_optics::foveated_lod::{
    EyeModel, FlatScene, Layers, LevelQuantization, LodObject, TracerLight, TracerMaterial,
    TracerScene, TriangleMesh, VisualField,
};
use optica_optics::glam::{DAffine3, DVec3};

use crate::settings::CaveView;
use crate::head::{Eye, GazeState};
use crate::lod::GazeLodState;
use crate::settings::{CheckedFoveation, FieldEyes};
use crate::settings::{GazeRayTracer, RayTraced};

/// The most bounces eq. 9 may allow on the GPU (its tree of pending rays
/// has eight slots).
pub const MAX_REFLECT: u32 = 7;

/// Nodes the shader's BVH walk can hold (`STACK` in `raytrace.wgsl`).
const BVH_STACK: u32 = 40;

/// The coarsest middle layer [`GazeRayTracer::periphery_scale`] may ask for.
pub const MAX_PERIPHERY_SCALE: u32 = 64;

/// Bevy's default camera exposure (EV100 9.7): traced light is scaled by it,
/// so a [`PointLight`] lights a traced object about as it lights a
/// rasterised one.
const DEFAULT_EXPOSURE: f64 = 1.0 / (1.2 * 831.746_6);

impl Default for GazeRayTracer {
    fn default() -> Self {
        Self {
            reflect_max: 3,
            foveate: true,
            periphery_scale: 2,
            outer_level: 0.5,
            background: LinearRgba::rgb(0.05, 0.06, 0.1),
            ambient: LinearRgba::rgb(0.08, 0.08, 0.08),
        }
    }
}

impl GazeRayTracer {
    /// The layers as the CPU twin takes them
    /// (`optica_optics::foveated_lod::render_layered`).
    pub fn layers(&self) -> Layers {
        Layers {
            scale: self.periphery_scale.clamp(1, MAX_PERIPHERY_SCALE),
            outer_level: outer_level(self) as f64,
        }
    }
}

/// What the tracer of a [`GazeRayTracer`] camera does this frame.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct GazeRayTracerState {
    /// Rays follow the visual field (else every pixel at level 1).
    pub foveating: bool,
    /// The estimated fraction of primary rays foveation saves against
    /// tracing every pixel: 1 − (central + middle / scale² + outer /
    /// (2·scale)²), the fractions of the image in each layer, from a
    /// 32 × 32 sample of the level map.
    pub saving: f32,
    /// Fractions of the image in the central field (traced per pixel), the
    /// periphery (traced on the coarse grid) and outside the field.
    pub central: f32,
    /// See [`GazeRayTracerState::central`].
    pub peripheral: f32,
    /// See [`GazeRayTracerState::central`].
    pub outside: f32,
}

impl RayTraced {
    fn from_tracer(m: TracerMaterial) -> Self {
        let c = m.color.as_vec3();
        Self {
            color: LinearRgba::rgb(c.x, c.y, c.z),
            diffuse: m.diffuse as f32,
            specular: m.specular as f32,
            shininess: m.shininess as f32,
            reflectance: if m.reflective {
                m.reflectance as f32
            } else {
                0.0
            },
            transmittance: m.transmittance as f32,
            ior: m.ior as f32,
        }
    }

    /// A diffuse object (the paper's scene B).
    pub fn diffuse(color: LinearRgba) -> Self {
        Self::from_tracer(TracerMaterial::diffuse(lin(color)))
    }

    /// A mirror of this colour reflecting `reflectance` (the paper's scene A).
    pub fn mirror(color: LinearRgba, reflectance: f32) -> Self {
        Self::from_tracer(TracerMaterial::mirror(lin(color), reflectance as f64))
    }

    /// Glass or water: `transmittance` refracted at index `ior`.
    pub fn glass(color: LinearRgba, transmittance: f32, ior: f32) -> Self {
        Self::from_tracer(TracerMaterial::glass(
            lin(color),
            transmittance as f64,
            ior as f64,
        ))
    }

    /// The reference tracer's material.
    pub fn material(&self) -> TracerMaterial {
        TracerMaterial {
            color: lin(self.color),
            diffuse: self.diffuse as f64,
            specular: self.specular as f64,
            shininess: self.shininess as f64,
            reflective: self.reflectance > 0.0,
            reflectance: self.reflectance as f64,
            transmittance: self.transmittance as f64,
            ior: self.ior as f64,
        }
    }
}

fn lin(c: LinearRgba) -> DVec3 {
    DVec3::new(c.red as f64, c.green as f64, c.blue as f64)
}

/// The scene the tracer draws: every [`RayTraced`] object's LOD chain in
/// world space with its BVHs, and the point lights. Rebuilt (and uploaded)
/// only when an object, its transform or material, or a light changed.
#[derive(Resource, Clone, Default, ExtractResource)]
pub struct TracedScene {
    /// The scene as the CPU reference tracer takes it (ambient and
    /// background zero: they are each camera's), `None` before the first
    /// object's chain is built.
    pub scene: Option<Arc<TracerScene>>,
    /// The same, flattened for the GPU.
    pub flat: Arc<FlatScene>,
    /// Counts rebuilds; the GPU re-uploads when it changes.
    pub generation: u64,
    /// Time of the last rebuild (ms, main thread).
    pub build_ms: f32,
    /// What the last rebuild saw, to tell whether anything changed.
    signature: Vec<u64>,
    /// A chain's mesh was not loaded at the last rebuild: look again.
    retry: bool,
}

/// Converts a Bevy triangle mesh, placed by `affine`, into the tracer's mesh.
fn world_mesh(mesh: &Mesh, affine: &DAffine3) -> Option<TriangleMesh> {
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return None;
    };
    let normal_matrix = affine.matrix3.inverse().transpose();
    let normals = match mesh.attribute(Mesh::ATTRIBUTE_NORMAL) {
        Some(VertexAttributeValues::Float32x3(n)) if n.len() == positions.len() => Some(
            n.iter()
                .map(|n| (normal_matrix * Vec3::from(*n).as_dvec3()).normalize_or_zero())
                .collect(),
        ),
        _ => None,
    };
    let indices: Vec<u32> = mesh.indices()?.iter().map(|i| i as u32).collect();
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let positions = positions
        .iter()
        .map(|p| affine.transform_point3(Vec3::from(*p).as_dvec3()))
        .collect();
    TriangleMesh::new(positions, normals, triangles).ok()
}

/// Rebuilds [`TracedScene`] when what it was built from changed.
#[allow(clippy::type_complexity)]
pub(crate) fn build_traced_scene(
    objects: Query<(Entity, &RayTraced, &GazeLodState, &GlobalTransform)>,
    lights: Query<(Entity, &PointLight, &GlobalTransform)>,
    touched: Query<
        (),
        (
            Or<(With<RayTraced>, With<PointLight>)>,
            Or<(
                Changed<RayTraced>,
                Changed<GazeLodState>,
                Changed<GlobalTransform>,
                Changed<PointLight>,
            )>,
        ),
    >,
    mut removed_objects: RemovedComponents<RayTraced>,
    mut removed_lights: RemovedComponents<PointLight>,
    meshes: Res<Assets<Mesh>>,
    mut traced: ResMut<TracedScene>,
) {
    // Most frames nothing was touched: no signature is computed. A touched
    // component may still hold the same values; the signature tells.
    let removed = removed_objects.read().count() + removed_lights.read().count() > 0;
    if !removed && !traced.retry && touched.is_empty() {
        return;
    }
    let mut items: Vec<_> = objects
        .iter()
        .filter_map(|(e, m, s, t)| s.chain.as_ref().map(|c| (e, m, c, t)))
        .collect();
    items.sort_by_key(|(e, ..)| *e);
    let mut signature = Vec::with_capacity(items.len() * 24);
    for (e, m, chain, t) in &items {
        signature.push(e.to_bits());
        signature.push(Arc::as_ptr(chain) as usize as u64);
        let a = t.affine();
        signature.extend(a.to_cols_array().map(|x| x.to_bits() as u64));
        signature.extend(
            [
                m.color.red,
                m.color.green,
                m.color.blue,
                m.diffuse,
                m.specular,
                m.shininess,
                m.reflectance,
                m.transmittance,
                m.ior,
            ]
            .map(|x| x.to_bits() as u64),
        );
    }
    // By entity, so that a light moving between archetypes rebuilds nothing.
    let mut lights: Vec<_> = lights.iter().collect();
    lights.sort_by_key(|(e, ..)| *e);
    for (e, l, t) in &lights {
        signature.push(e.to_bits());
        let c = l.color.to_linear();
        let p = t.translation();
        signature.extend(
            [p.x, p.y, p.z, c.red, c.green, c.blue, l.intensity].map(|x| x.to_bits() as u64),
        );
    }
    if signature == traced.signature {
        return;
    }
    let start = std::time::Instant::now();
    let mut lods_missing = false;
    let mut built = Vec::with_capacity(items.len());
    for (entity, material, chain, transform) in &items {
        let affine = transform.affine();
        let affine = DAffine3::from_mat4(Mat4::from(affine).as_dmat4());
        let Some(sources) = chain
            .meshes
            .iter()
            .map(|h| meshes.get(h))
            .collect::<Option<Vec<&Mesh>>>()
        else {
            lods_missing = true;
            continue;
        };
        let Some(lods) = sources
            .into_iter()
            .map(|m| world_mesh(m, &affine))
            .collect::<Option<Vec<TriangleMesh>>>()
        else {
            warn!(
                "foveated LOD: {entity} is not traced: its mesh has no indexed Float32x3 positions, \
                 or a non-finite one"
            );
            continue;
        };
        match LodObject::new(lods, material.material()) {
            Ok(o) => built.push(o),
            Err(e) => warn!("foveated LOD: {entity} is not traced: {e}"),
        }
    }
    traced.retry = lods_missing;
    if lods_missing {
        // A chain's mesh is not in the assets yet: try again next frame.
        return;
    }
    let lights = lights
        .iter()
        .map(|(_, l, t)| TracerLight {
            position: t.translation().as_dvec3(),
            intensity: lin(l.color.to_linear()) * light_scale(l.intensity),
        })
        .collect();
    match TracerScene::new(built, lights, DVec3::ZERO, DVec3::ZERO) {
        Ok(scene) => {
            traced.flat = Arc::new(FlatScene::from_scene(&scene));
            if traced.flat.max_depth > BVH_STACK {
                warn!(
                    "foveated LOD: a traced mesh's BVH is {} deep, more than the tracer's stack of \
                     {BVH_STACK}: rays may miss parts of it; split the mesh",
                    traced.flat.max_depth
                );
            }
            traced.scene = Some(Arc::new(scene));
            traced.generation += 1;
            traced.build_ms = start.elapsed().as_secs_f32() * 1e3;
            traced.signature = signature;
            debug!(
                "foveated LOD: traced scene rebuilt ({} triangles, {} KiB) in {:.1} ms",
                traced.flat.triangles.len(),
                traced.flat.gpu_bytes() / 1024,
                traced.build_ms
            );
        }
        Err(e) => {
            warn!("foveated LOD: the traced scene is invalid: {e}");
            traced.signature = signature;
        }
    }
}

/// The tracer's radiant intensity of a [`PointLight`] of `lumens`: its
/// candela (lm / 4π) over π (the tracer's Lambert term has no 1/π) at
/// Bevy's default exposure.
pub fn light_scale(lumens: f32) -> f64 {
    lumens as f64 / (4.0 * std::f64::consts::PI) / std::f64::consts::PI * DEFAULT_EXPOSURE
}

/// What a [`GazeRayTracer`] view needs on the GPU this frame, beyond its
/// camera matrices.
#[derive(Component, Clone, Debug, PartialEq, ExtractComponent)]
pub(crate) struct TracerView {
    pub(crate) gaze_forward: Vec3,
    pub(crate) gaze_right: Vec3,
    pub(crate) gaze_up: Vec3,
    pub(crate) field: VisualField,
    pub(crate) steps: u32,
    pub(crate) full_quality: bool,
    pub(crate) scale: u32,
    pub(crate) outer_level: f32,
    pub(crate) reflect_max: u32,
    pub(crate) background: Vec3,
    pub(crate) ambient: Vec3,
}

/// The level map's sample grid for the saving estimate (per side).
const GATE_SAMPLES: u32 = 32;

/// Chooses each tracer view's gaze and field, and whether it foveates.
#[allow(clippy::type_complexity)]
pub(crate) fn prepare_tracer_views(
    mut commands: Commands,
    mut views: Query<(
        Entity,
        Ref<GazeRayTracer>,
        &mut GazeRayTracerState,
        Ref<Camera>,
        Ref<GlobalTransform>,
        Option<Ref<CaveView>>,
        Has<TracerView>,
    )>,
    gaze: Res<GazeState>,
    settings: Res<CheckedFoveation>,
    mut work: ResMut<crate::FoveationWork>,
) {
    for (entity, tracer, mut state, camera, transform, cave, prepared) in &mut views {
        // Nothing to redo while the gaze, the settings and the view stand still.
        let changed = gaze.is_changed()
            || settings.is_changed()
            || tracer.is_changed()
            || camera.is_changed()
            || transform.is_changed()
            || cave.as_ref().is_some_and(|c| c.is_changed());
        if prepared && !changed {
            continue;
        }
        work.tracer_views += 1;
        let eye = match (settings.eyes, cave) {
            (FieldEyes::PerEye, Some(ref c)) => c.eye,
            _ => Eye::Cyclopean,
        };
        let estimate = gaze.estimate(eye);
        let field = *gaze.field(eye);
        let steps = settings.hysteresis.steps();
        let scale = tracer.periphery_scale.clamp(1, MAX_PERIPHERY_SCALE);
        let frame = estimate.frame().copied();
        let wants = settings.enabled && tracer.foveate;
        let next = match (frame, wants) {
            (Some(frame), true) => {
                // As the shader: rotation only, the near-plane point is the direction.
                let (_, rotation, _) = transform.to_scale_rotation_translation();
                let world_from_clip = Mat4::from_quat(rotation) * camera.clip_from_view().inverse();
                let quant = LevelQuantization::Steps(steps);
                let outer = outer_level(&tracer) as f64;
                let (mut central, mut outside, mut far) = (0u32, 0u32, 0u32);
                for j in 0..GATE_SAMPLES {
                    for i in 0..GATE_SAMPLES {
                        let ndc = Vec2::new(
                            (2 * i + 1) as f32 / GATE_SAMPLES as f32 - 1.0,
                            1.0 - (2 * j + 1) as f32 / GATE_SAMPLES as f32,
                        );
                        let p = world_from_clip.project_point3(ndc.extend(1.0));
                        let d = p.as_dvec3();
                        let level = quant.apply(field.level(&frame, d));
                        if level >= 1.0 {
                            central += 1;
                        } else if level <= 0.0 {
                            outside += 1;
                        } else if level < outer {
                            far += 1;
                        }
                    }
                }
                let n = (GATE_SAMPLES * GATE_SAMPLES) as f32;
                let central = central as f32 / n;
                let outside = outside as f32 / n;
                let peripheral = 1.0 - central - outside;
                let far = far as f32 / n;
                let s2 = (scale * scale) as f32;
                let saving = 1.0 - central - (peripheral - far) / s2 - far / (4.0 * s2);
                // On at the threshold, off below half of it, as the mesh path.
                let on = if state.foveating {
                    saving >= settings.min_saving / 2.0
                } else {
                    saving >= settings.min_saving
                };
                GazeRayTracerState {
                    foveating: on,
                    saving,
                    central,
                    peripheral,
                    outside,
                }
            }
            _ => GazeRayTracerState::default(),
        };
        state.set_if_neq(next.clone());
        let (f, r, u) = match frame {
            Some(fr) => (
                fr.forward().as_vec3(),
                fr.right().as_vec3(),
                fr.up().as_vec3(),
            ),
            None => (Vec3::NEG_Z, Vec3::X, Vec3::Y),
        };
        commands.entity(entity).insert(TracerView {
            gaze_forward: f,
            gaze_right: r,
            gaze_up: u,
            field,
            steps,
            full_quality: !next.foveating,
            scale,
            outer_level: outer_level(&tracer),
            reflect_max: tracer.reflect_max.min(MAX_REFLECT),
            background: tracer_colour(tracer.background),
            ambient: tracer_colour(tracer.ambient),
        });
    }
}

/// The most a channel of an `Rgba16Float` target holds: a brighter
/// background or ambient would be infinite there.
const MAX_CHANNEL: f32 = 65504.0;

/// A [`GazeRayTracer`] colour as the tracer uses it: each channel in
/// `0..=MAX_CHANNEL`, NaN as 0 (a negative or infinite channel, from code
/// or a panel dragged to its end, would otherwise draw NaN pixels).
fn tracer_colour(c: LinearRgba) -> Vec3 {
    let channel = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, MAX_CHANNEL) };
    Vec3::new(channel(c.red), channel(c.green), channel(c.blue))
}

/// The outer layer's level threshold in use: in [0, 1], 0 (none) for NaN
/// or when the periphery is traced per pixel.
fn outer_level(tracer: &GazeRayTracer) -> f32 {
    if tracer.periphery_scale <= 1 || tracer.outer_level.is_nan() {
        0.0
    } else {
        tracer.outer_level.clamp(0.0, 1.0)
    }
}

/// The shader's eye model code.
pub(crate) fn eye_model_code(field: &VisualField) -> u32 {
    match field.eye_model() {
        EyeModel::Paper => 0,
        EyeModel::LeftEye => 1,
        EyeModel::RightEye => 2,
    }
}

/// The reference tracer's camera for a plain perspective camera, and the
/// scene with a view's ambient and background: what the GPU image is held to.
pub fn reference_of(traced: &TracedScene, tracer: &GazeRayTracer) -> Option<TracerScene> {
    let scene = traced.scene.as_ref()?;
    TracerScene::new(
        scene.objects().to_vec(),
        scene.lights().to_vec(),
        tracer_colour(tracer.ambient).as_dvec3(),
        tracer_colour(tracer.background).as_dvec3(),
    )
    .ok()
}
