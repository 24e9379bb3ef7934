//! The mesh path: a chain of simplified meshes built once per mesh
//! ([`LodChain`]), and each object's level picked from where its bounds lie
//! in the visual field, switched with hysteresis and dwell ([`GazeLod`]).

use std::collections::HashMap;
use std::sync::Arc;

use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use optica_optics::foveated_lod::{LodHysteresis, lod_for_level, polygon_budget};
use thiserror::Error;

use crate::head::GazeState;
use crate::settings::{CheckedFoveation, FieldEyes};
use crate::settings::GazeLod;

impl Default for GazeLod {
    fn default() -> Self {
        Self {
            min_triangles: 500,
            max_triangles: None,
            hide_outside_field: false,
        }
    }
}

/// What [`GazeLod`] chose for an entity (read it; the plugin writes it).
#[derive(Component, Clone, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct GazeLodState {
    /// The level of the object's most central point this frame, in [0, 1].
    pub level: f32,
    /// The held level step k (level k/S).
    pub step: u32,
    /// The index into the chain's meshes drawn now.
    pub lod: usize,
    /// Its triangle count.
    pub triangles: usize,
    /// How many times the step changed.
    pub switches: u64,
    /// Hidden because it is outside the visual field.
    pub hidden: bool,
    /// The chain, once built.
    #[reflect(ignore)]
    pub chain: Option<Arc<LodChain>>,
    #[reflect(ignore)]
    hysteresis: Option<LodHysteresis>,
}

/// Why a mesh has no LOD chain.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LodError {
    /// Not a triangle list.
    #[error("the mesh is not a triangle list")]
    NotTriangles,
    /// No index buffer: without shared vertices there is no edge to collapse.
    #[error("the mesh has no indices (edge collapse needs shared vertices)")]
    NotIndexed,
    /// No `Float32x3` positions.
    #[error("the mesh has no Float32x3 positions")]
    NoPositions,
    /// No triangles, or an index past the vertices.
    #[error("the mesh has no triangles or an index out of range")]
    Invalid,
}

/// A mesh's chain of simplifications, coarsest first, and which one each
/// level step draws.
#[derive(Debug)]
pub struct LodChain {
    /// The source mesh the chain was simplified from (also its finest level
    /// when N_max is the mesh's own).
    pub source: Handle<Mesh>,
    /// The meshes, coarsest first.
    pub meshes: Vec<Handle<Mesh>>,
    /// Their triangle counts, increasing.
    pub triangles: Vec<usize>,
    /// The mesh index of each level step k = 0..=S (eq. 10's budget, then
    /// the coarsest mesh with at least that many triangles).
    pub step_lod: Vec<usize>,
    /// The source mesh's bounding sphere in its own coordinates.
    pub bounds: (Vec3, f32),
    /// Time the chain took to build (ms, main thread).
    pub build_ms: f32,
}

impl LodChain {
    /// Builds the chain of `mesh` for N_min, N_max and `steps` level steps.
    /// `add` stores each simplified mesh (the source itself is kept by
    /// `source_handle` and not copied).
    pub fn build(
        mesh: &Mesh,
        source_handle: &Handle<Mesh>,
        lod: &GazeLod,
        steps: u32,
        mut add: impl FnMut(Mesh) -> Handle<Mesh>,
    ) -> Result<Self, LodError> {
        let start = std::time::Instant::now();
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err(LodError::NotTriangles);
        }
        let Some(VertexAttributeValues::Float32x3(positions)) =
            mesh.attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            return Err(LodError::NoPositions);
        };
        let indices: Vec<u32> = mesh
            .indices()
            .ok_or(LodError::NotIndexed)?
            .iter()
            .map(|i| i as u32)
            .collect();
        if indices.len() < 3 || indices.iter().any(|&i| i as usize >= positions.len()) {
            return Err(LodError::Invalid);
        }
        let full = indices.len() / 3;
        let n_max = lod
            .max_triangles
            .map_or(full, |n| (n as usize).clamp(1, full));
        let n_min = (lod.min_triangles as usize).clamp(1, n_max);
        let s = steps.max(1);
        // Eq. 10's budget of each step, rounded up: a mesh with at least that
        // many triangles serves the step.
        let mut targets: Vec<usize> = (0..=s)
            .map(|k| polygon_budget(k as f64 / s as f64, n_min, n_max).ceil() as usize)
            .collect();
        targets.dedup();
        let mut meshes = Vec::new();
        let mut triangles = Vec::new();
        for &target in &targets {
            if target >= full {
                meshes.push(source_handle.clone());
                triangles.push(full);
                continue;
            }
            // No error limit (1.0 is the mesh's whole extent): the count is
            // what eq. 10 asks for. The edge collapse stops early where the
            // topology allows no more collapses; the count it reached is kept.
            let simplified = meshopt::simplify_decoder(
                &indices,
                positions,
                target * 3,
                1.0,
                meshopt::SimplifyOptions::None,
                None,
            );
            let n = simplified.len() / 3;
            if n == 0 || triangles.last().is_some_and(|&last| n <= last) && n < target {
                // Collapsed to nothing, or no finer than the previous level.
                continue;
            }
            let mut lod_mesh = mesh.clone();
            lod_mesh.insert_indices(Indices::U32(simplified));
            meshes.push(add(lod_mesh));
            triangles.push(n);
        }
        let step_lod = (0..=s)
            .map(|k| {
                let level = k as f64 / s as f64;
                let budget = polygon_budget(level, n_min, n_max).ceil() as usize;
                // The coarsest mesh with at least the budget; the finest when
                // simplification fell short of it everywhere.
                triangles
                    .iter()
                    .position(|&n| n >= budget)
                    .unwrap_or(triangles.len() - 1)
            })
            .collect();
        let (lo, hi) = positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
        );
        let centre = (lo + hi) / 2.0;
        let radius = positions
            .iter()
            .map(|p| Vec3::from(*p).distance(centre))
            .fold(0.0, f32::max);
        // `lod_for_level` is eq. 10 over the same counts; kept in step with
        // the choice above by the tests.
        debug_assert_eq!(
            lod_for_level(&triangles, 1.0),
            triangles.len() - 1,
            "the finest level draws the finest mesh"
        );
        Ok(Self {
            source: source_handle.clone(),
            meshes,
            triangles,
            step_lod,
            bounds: (centre, radius),
            build_ms: start.elapsed().as_secs_f32() * 1e3,
        })
    }

    /// The mesh of level step `k`.
    pub fn mesh_of_step(&self, k: u32) -> usize {
        self.step_lod[(k as usize).min(self.step_lod.len() - 1)]
    }
}

/// A chain is one per source mesh, N_min, N_max and level steps.
type ChainKey = (AssetId<Mesh>, u32, Option<u32>, u32);

/// Chains already built, shared by the entities that draw the same mesh.
#[derive(Resource, Default)]
pub(crate) struct LodChains {
    chains: HashMap<ChainKey, Arc<LodChain>>,
    failed: HashMap<AssetId<Mesh>, LodError>,
}

/// Builds (or finds) the chain of every [`GazeLod`] entity whose mesh or
/// setting changed; an entity whose mesh has not loaded yet is retried.
pub(crate) fn build_chains(
    mut objects: Query<(Entity, Ref<GazeLod>, Ref<Mesh3d>, &mut GazeLodState)>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut chains: ResMut<LodChains>,
    settings: Res<CheckedFoveation>,
    mut work: ResMut<FoveationWork>,
) {
    let steps = settings.hysteresis.steps();
    for (entity, lod, mesh, mut state) in &mut objects {
        let current = mesh.id();
        let stale = match &state.chain {
            None => true,
            Some(chain) => {
                lod.is_changed()
                    || settings.is_changed()
                    || (mesh.is_changed() && !chain.meshes.iter().any(|m| m.id() == current))
            }
        };
        if !stale {
            continue;
        }
        // The source is the mesh the user set: while a chain's mesh is drawn,
        // that chain's source (not its finest level, which N_max may have
        // simplified).
        let source_handle = match &state.chain {
            Some(chain) if chain.meshes.iter().any(|m| m.id() == current) => chain.source.clone(),
            _ => mesh.0.clone(),
        };
        let source_id = source_handle.id();
        let key = (source_id, lod.min_triangles, lod.max_triangles, steps);
        if let Some(chain) = chains.chains.get(&key) {
            state.chain = Some(chain.clone());
            state.hysteresis = None;
            continue;
        }
        if chains.failed.contains_key(&source_id) {
            continue;
        }
        let Some(source) = meshes.get(source_id).cloned() else {
            continue; // Not loaded yet.
        };
        match LodChain::build(&source, &source_handle, &lod, steps, |m| meshes.add(m)) {
            Ok(chain) => {
                debug!(
                    "foveated LOD: chain of {entity} ({:?} triangles) built in {:.2} ms",
                    chain.triangles, chain.build_ms
                );
                let chain = Arc::new(chain);
                work.chains_built += 1;
                chains.chains.insert(key, chain.clone());
                state.chain = Some(chain);
                state.hysteresis = None;
            }
            Err(e) => {
                warn!("foveated LOD: {entity}'s mesh gets no LOD chain: {e}; it is drawn as it is");
                chains.failed.insert(source_id, e);
            }
        }
    }
}

/// What the plugin's systems did, counted since the app started: read it to
/// see the per-frame work (and that a still head costs nothing).
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource)]
pub struct FoveationWork {
    /// Frames in which the gaze filter ran.
    pub gaze_updates: u64,
    /// Object levels computed (one per object per frame it was revisited).
    pub levels_computed: u64,
    /// Mesh swaps (an object's level step changed its mesh).
    pub mesh_swaps: u64,
    /// LOD chains built.
    pub chains_built: u64,
    /// CAVE cameras re-aimed.
    pub views_aimed: u64,
    /// Ray-tracer views whose levels and foveation were worked out again
    /// (after a gaze, camera or setting change).
    pub tracer_views: u64,
}

/// Whether some object waits for its dwell before it may be made coarser:
/// then the levels are revisited next frame even if nothing moved.
#[derive(Resource, Default)]
pub(crate) struct DwellPending(bool);

/// Whether the mesh path foveates now, and what it would save.
///
/// Coarser meshes pay only when they take away enough triangles: a few
/// percent saves nothing measurable, and distinct meshes break Bevy's
/// batching of entities that share one. So the plugin sums, over every
/// [`GazeLod`] object, the triangles its level would draw (0 when hidden)
/// against its full mesh, and draws the level meshes only while that saves
/// at least [`Foveation::min_saving`](crate::Foveation::min_saving) of the
/// triangles; else every object draws its full mesh, exactly as without
/// foveation. To keep it from flickering, it stops foveating only once the
/// saving falls below half the threshold.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct FoveationGate {
    /// The level meshes are drawn.
    pub active: bool,
    /// The fraction of the triangles the levels would save, in [0, 1].
    pub saving: f32,
}

impl Default for FoveationGate {
    fn default() -> Self {
        Self {
            active: true,
            saving: 0.0,
        }
    }
}

/// Picks each object's level, decides whether foveating pays
/// ([`FoveationGate`]) and swaps the meshes. Does nothing in a frame where
/// neither the gaze, the settings, the object nor a pending dwell asks for
/// it.
// (A Bevy system: its parameters are what it reads and writes.)
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(crate) fn select_levels(
    gaze: Res<GazeState>,
    settings: Res<CheckedFoveation>,
    time: Res<Time<Real>>,
    head: Res<crate::TrackedHead>,
    mut last_now: Local<Option<f64>>,
    mut pending: ResMut<DwellPending>,
    mut work: ResMut<FoveationWork>,
    mut gate: ResMut<FoveationGate>,
    mut objects: Query<
        (
            Ref<GlobalTransform>,
            &GazeLod,
            &mut GazeLodState,
            &mut Mesh3d,
            Option<&mut Visibility>,
        ),
        // The tracer picks a level per ray; these are never rasterised.
        Without<crate::RayTraced>,
    >,
) {
    let everything = gaze.is_changed() || settings.is_changed() || pending.0;
    let now = crate::head::clock_now(settings.clock, &head, time.elapsed_secs_f64(), *last_now);
    *last_now = Some(now);
    let s = settings.hysteresis.steps();
    let d = settings.hysteresis.dead_band();
    let mut still_pending = false;
    let mut updated = false;
    for (transform, _, mut state, _, _) in &mut objects {
        let fresh = state.hysteresis.is_none();
        if !(everything || fresh || transform.is_changed() || state.is_changed()) {
            continue;
        }
        let Some(chain) = state.chain.clone() else {
            continue;
        };
        work.levels_computed += 1;
        updated = true;
        let (centre, radius) = chain.bounds;
        let affine = transform.affine();
        let world_centre = affine.transform_point3(centre);
        let m = affine.matrix3;
        let scale = m
            .x_axis
            .length()
            .max(m.y_axis.length())
            .max(m.z_axis.length());
        let world_radius = radius * scale;
        let level = level_of_sphere(&gaze, settings.eyes, world_centre, world_radius);
        let params = settings.hysteresis;
        let hysteresis = state
            .hysteresis
            .get_or_insert_with(|| LodHysteresis::new(params));
        let step = hysteresis.update(level, now);
        let switches = hysteresis.switches();
        // A coarser target held back by the dwell: look again next frame.
        let target_below = level <= (step as f64 / s as f64 - d).max(0.0) && step > 0;
        still_pending |= target_below;
        let state = state.bypass_change_detection();
        state.level = level as f32;
        state.step = step;
        state.switches = switches;
    }
    if pending.0 != still_pending {
        pending.0 = still_pending;
    }
    if !updated {
        return;
    }
    // What the levels would draw, against the full meshes.
    let (mut chosen, mut full) = (0usize, 0usize);
    for (_, lod, state, _, _) in &objects {
        if let Some(chain) = &state.chain {
            let hidden = lod.hide_outside_field && state.step == 0;
            if !hidden {
                chosen += chain.triangles[chain.mesh_of_step(state.step)];
            }
            full += chain.triangles[chain.triangles.len() - 1];
        }
    }
    let saving = if full > 0 {
        1.0 - chosen as f32 / full as f32
    } else {
        0.0
    };
    let threshold = settings.min_saving;
    let active = if gate.active {
        saving >= threshold / 2.0
    } else {
        saving >= threshold
    };
    gate.set_if_neq(FoveationGate { active, saving });
    for (_, lod, mut state, mut mesh, mut visibility) in &mut objects {
        let Some(chain) = state.chain.clone() else {
            continue;
        };
        let (lod_index, hide) = if active {
            (
                chain.mesh_of_step(state.step),
                lod.hide_outside_field && state.step == 0,
            )
        } else {
            (chain.meshes.len() - 1, false)
        };
        let state = state.bypass_change_detection();
        state.lod = lod_index;
        state.triangles = chain.triangles[lod_index];
        let handle = &chain.meshes[lod_index];
        if mesh.0.id() != handle.id() {
            mesh.0 = handle.clone();
            work.mesh_swaps += 1;
        }
        if hide != state.hidden
            && let Some(visibility) = visibility.as_mut()
        {
            **visibility = if hide {
                Visibility::Hidden
            } else {
                Visibility::Inherited
            };
            state.hidden = hide;
        }
    }
}

/// The level of the point of a sphere nearest the gaze, for the eyes the
/// field model uses (1 when the eye is inside the sphere or no gaze is known).
pub fn level_of_sphere(gaze: &GazeState, eyes: FieldEyes, centre: Vec3, radius: f32) -> f64 {
    use crate::head::Eye;
    let at = |eye: Eye| -> f64 {
        let estimate = gaze.estimate(eye);
        let (Some(frame), Some(origin)) = (estimate.frame(), estimate.eye()) else {
            return 1.0;
        };
        let to_centre = centre.as_dvec3() - origin;
        let dist = to_centre.length();
        let r = radius.max(0.0) as f64;
        if dist.is_nan() || dist <= r {
            return 1.0;
        }
        let c = to_centre / dist;
        let f = frame.forward();
        let rho = (r / dist).asin();
        let theta = c.dot(f).clamp(-1.0, 1.0).acos();
        let dir = if theta <= rho {
            f
        } else {
            // Turn the centre's direction towards the gaze by the sphere's
            // angular radius (about any axis when the gaze is behind).
            let axis = c.cross(f);
            let axis = if axis.length_squared() > 1e-24 {
                axis.normalize()
            } else {
                c.any_orthonormal_vector()
            };
            optica_optics::glam::DQuat::from_axis_angle(axis, rho) * c
        };
        gaze.level(eye, dir)
    };
    let level = match eyes {
        FieldEyes::Cyclopean => at(Eye::Cyclopean),
        FieldEyes::PerEye => at(Eye::Left).max(at(Eye::Right)),
    };
    if level.is_finite() { level } else { 1.0 }
}
