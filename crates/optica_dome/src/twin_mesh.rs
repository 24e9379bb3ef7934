//! Building a twin's mesh asset: a user's mesh refined for one dome camera.
//!
//! * Triangles, dynamic (the paper's default class): clipped behind the
//!   viewer or culled past the guard cone and split until every edge's
//!   chord is within the tolerance, from the current view
//!   ([`refine_mesh_asset`]).
//! * Triangles of nearly constant apparent size (§3.1: stars, sky art):
//!   split once with the paper's rotation-invariant step, not clipped
//!   ([`pre_subdivide_mesh_asset`]); the vertex shader drops what lies near
//!   the antipode.
//! * Lines (`LineList`, `LineStrip`; always dynamic in the paper): each
//!   segment clipped and split like a triangle's edge, drawn as a line list.
//!
//! Every `Float32x2/3/4` vertex attribute is carried, interpolated linearly
//! (normals and tangents renormalised); other attributes are left out.

use bevy::asset::RenderAssetUsages;
use bevy::math::{Affine3A, DAffine3, DVec3};
use bevy::mesh::{Indices, MeshVertexAttribute, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, ParallelSlice, TaskPool};
use optica_optics::dome::{Panorama, PrimitiveKind, SplitRule, TriMesh, pre_subdivide};

/// The kind of primitive a mesh is made of, for the paper's classification;
/// `None` for points.
pub(crate) fn primitive_kind(mesh: &Mesh) -> Option<PrimitiveKind> {
    match mesh.primitive_topology() {
        PrimitiveTopology::TriangleList => Some(PrimitiveKind::Triangle),
        PrimitiveTopology::LineList | PrimitiveTopology::LineStrip => Some(PrimitiveKind::Line),
        _ => None,
    }
}

/// `source` refined for a dome camera that sees it through
/// `view_from_local`, in the same local space: a triangle list clipped
/// behind the viewer (or culled past the guard cone) and split by `rule`,
/// so that neighbours share their split edges; a line list or strip clipped
/// and split segment by segment into a line list. Float vertex attributes
/// are interpolated (see the module docs). `None` for other topologies
/// (triangle strips, points) or a mesh without `Float32x3` positions.
pub fn refine_mesh_asset(
    source: &Mesh,
    view_from_local: Affine3A,
    projection: &Panorama,
    rule: SplitRule,
) -> Option<Mesh> {
    Some(
        match twin_of_mesh(source, view_from_local, projection, rule)? {
            Twin::Same => source.clone(),
            Twin::Refined(mesh) => *mesh,
        },
    )
}

/// [`refine_mesh_asset`] without the copy when nothing needs refining: a
/// triangle list whose every triangle is its own refinement (small and in
/// front: [`Panorama::leaves_whole`]) is [`Twin::Same`], and a renderer
/// draws the source mesh itself. For many meshes at once use
/// [`twins_of_meshes`], which spreads them over the threads together.
pub fn twin_of_mesh(
    source: &Mesh,
    view_from_local: Affine3A,
    projection: &Panorama,
    rule: SplitRule,
) -> Option<Twin> {
    let job = TwinJob {
        source,
        view_from_local,
        projection,
        rule,
    };
    twins_of_meshes(&[job]).pop().flatten()
}

/// One mesh to refine for one dome camera, for [`twins_of_meshes`].
#[derive(Clone, Copy)]
pub struct TwinJob<'a> {
    /// The user's mesh.
    pub source: &'a Mesh,
    /// Where the camera sees it from.
    pub view_from_local: Affine3A,
    /// The camera's projection.
    pub projection: &'a Panorama,
    /// The camera's split rule.
    pub rule: SplitRule,
}

/// [`twin_of_mesh`] for every job, in order: what the plugin runs each
/// frame for every mesh that moved relative to a dome camera. The
/// triangles of all the meshes are refined in chunks on Bevy's compute
/// pool together, so a scene of many small meshes keeps every thread busy
/// without a wake-up per mesh, and one large mesh still spreads over all
/// of them. The result does not depend on the thread count.
pub fn twins_of_meshes(jobs: &[TwinJob]) -> Vec<Option<Twin>> {
    let sources: Vec<Option<Source>> = jobs
        .iter()
        .map(|job| Source::of(job.source, job.view_from_local))
        .collect();
    // A task: a chunk of one job's triangle list, or one job's lines.
    let mut tasks = Vec::new();
    for (j, source) in sources.iter().enumerate() {
        match source.as_ref().map(|s| (s.topology, s.indices.len())) {
            Some((PrimitiveTopology::TriangleList, len)) => {
                let chunk = 3 * TRIANGLES_PER_TASK;
                tasks.extend(
                    (0..len)
                        .step_by(chunk)
                        .map(|at| (j, at..len.min(at + chunk))),
                );
            }
            Some((PrimitiveTopology::LineList | PrimitiveTopology::LineStrip, _)) => {
                tasks.push((j, 0..0));
            }
            _ => {}
        }
    }
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    let done = tasks.par_chunk_map(pool, 1, |_, task| {
        let (j, range) = task[0].clone();
        let (job, source) = (&jobs[j], sources[j].as_ref().expect("a task has a source"));
        if source.topology != PrimitiveTopology::TriangleList {
            return Done::Lines(source.lines(job.projection, job.rule));
        }
        Done::Triangles(source.refine_chunk(
            &source.indices[range],
            |corners| job.projection.leaves_whole(corners, job.rule),
            |corners| {
                if job.projection.leaves_out(corners) {
                    // (Behind the viewer: nothing, without the refiner.)
                    return Some((Vec::new(), Vec::new()));
                }
                job.projection
                    .refine_triangle(corners, job.rule)
                    .ok()
                    .map(|r| r.mesh.into_parts())
            },
        ))
    });
    // Each job's parts, in order.
    let mut parts: Vec<Vec<Output>> = jobs.iter().map(|_| Vec::new()).collect();
    let mut lines: Vec<Option<Mesh>> = jobs.iter().map(|_| None).collect();
    for ((j, _), done) in tasks.iter().zip(done) {
        match done {
            Done::Triangles(part) => parts[*j].push(part),
            Done::Lines(mesh) => lines[*j] = Some(mesh),
        }
    }
    sources
        .iter()
        .zip(parts)
        .zip(lines)
        .map(|((source, parts), lines)| {
            let source = source.as_ref()?;
            match source.topology {
                PrimitiveTopology::TriangleList => Some(source.gather(parts)),
                _ => lines.map(|mesh| Twin::Refined(Box::new(mesh))),
            }
        })
        .collect()
}

/// What a task of [`twins_of_meshes`] made.
enum Done {
    Triangles(Output),
    Lines(Mesh),
}

/// `source`, a triangle list of nearly constant apparent size, split once
/// so that no edge subtends more than `max_piece_rad` at the viewer (the
/// paper's pre-subdivision, §3.1; take the piece from
/// `optica_optics::dome::pre_subdivision_piece_rad`). Only the viewer's
/// position in the mesh's space matters, not the view's direction: the
/// result serves every rotation of the camera or of the mesh about the
/// viewer. Not clipped. `None` for other topologies, a mesh without
/// positions or a piece angle that is not finite and positive.
pub fn pre_subdivide_mesh_asset(
    source_mesh: &Mesh,
    view_from_local: Affine3A,
    max_piece_rad: f64,
) -> Option<Mesh> {
    if !(max_piece_rad.is_finite() && max_piece_rad > 0.0) {
        return None;
    }
    let source = Source::of(source_mesh, view_from_local)?;
    if source.topology != PrimitiveTopology::TriangleList {
        return None;
    }
    let twin = source.triangles(
        |_| false,
        |corners| {
            let one = TriMesh::new(corners.to_vec(), vec![[0, 1, 2]]).ok()?;
            pre_subdivide(&one, max_piece_rad)
                .ok()
                .map(|r| r.mesh.into_parts())
        },
    );
    Some(match twin {
        // (A mesh without triangles.)
        Twin::Same => source_mesh.clone(),
        Twin::Refined(mesh) => *mesh,
    })
}

/// Triangles refined by one task of the compute pool: enough to outweigh
/// a task's cost (~µs), few enough that a 1,000-triangle mesh still spreads
/// over a few threads.
const TRIANGLES_PER_TASK: usize = 256;

/// Marks an output index that refers to a vertex made by refinement (the
/// rest refer to the source's own vertices, which every twin starts with).
const NEW_VERTEX: u32 = 1 << 31;

/// A user's mesh read for refinement: positions in view space, indices,
/// and the attributes to carry (borrowed: a twin rebuilt every frame must
/// not copy them first).
struct Source<'a> {
    topology: PrimitiveTopology,
    local_from_view: DAffine3,
    /// The source's own positions.
    local: &'a [[f32; 3]],
    view: Vec<DVec3>,
    indices: Vec<u32>,
    carried: Vec<(MeshVertexAttribute, &'a VertexAttributeValues)>,
    /// Whether the source has nothing a twin leaves out (attributes other
    /// than float ones, morph targets): only then may a twin be the
    /// source itself.
    all_carried: bool,
}

impl<'a> Source<'a> {
    fn of(source: &'a Mesh, view_from_local: Affine3A) -> Option<Self> {
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
        let view = positions
            .iter()
            .map(|p| view_from_local.transform_point3(DVec3::from(p.map(f64::from))))
            .collect();
        // (An attribute of another length than the positions is malformed;
        // it is left out rather than read out of bounds.)
        let carried: Vec<_> = source
            .attributes()
            .filter(|(a, v)| a.id != Mesh::ATTRIBUTE_POSITION.id && v.len() == positions.len())
            .filter(|(_, v)| mixable(v))
            .map(|(a, v)| (*a, v))
            .collect();
        let all_carried = source.attributes().count() == carried.len() + 1
            && !source.has_morph_targets()
            && positions.len() < NEW_VERTEX as usize;
        Some(Self {
            topology: source.primitive_topology(),
            local_from_view: view_from_local.inverse(),
            local: positions,
            view,
            indices,
            carried,
            all_carried,
        })
    }

    /// A triangle list: each triangle of the source replaced by what
    /// `refine` makes of its view-space corners (points and triangles;
    /// `None` drops it), attributes mixed by barycentric weights. A
    /// triangle `whole` says is its own refinement keeps the source's
    /// vertices (no call to `refine`, no mixing), and so do refined points
    /// that are a corner of their triangle, so neighbours share them bit
    /// for bit. [`Twin::Same`] when every triangle stays whole: the source
    /// mesh serves as it is.
    fn triangles(
        &self,
        whole: impl Fn([DVec3; 3]) -> bool + Sync,
        refine: impl Fn([DVec3; 3]) -> Option<(Vec<DVec3>, Vec<[u32; 3]>)> + Sync,
    ) -> Twin {
        // Triangles are refined independently (shared edges split alike
        // from both sides), so in parallel on Bevy's compute pool, in
        // chunks; then gathered in order, so the twin is the same
        // whatever the thread count.
        let pool = ComputeTaskPool::get_or_init(TaskPool::default);
        let parts = self
            .indices
            .par_chunk_map(pool, 3 * TRIANGLES_PER_TASK, |_, chunk| {
                self.refine_chunk(chunk, &whole, &refine)
            });
        self.gather(parts)
    }

    /// The triangles of `chunk` (whole ones: a remainder is left out), as
    /// [`Self::triangles`] makes them: new vertices marked [`NEW_VERTEX`].
    fn refine_chunk(
        &self,
        chunk: &[u32],
        whole: impl Fn([DVec3; 3]) -> bool,
        refine: impl Fn([DVec3; 3]) -> Option<(Vec<DVec3>, Vec<[u32; 3]>)>,
    ) -> Output {
        // (About a new vertex per triangle where a scene is refined.)
        let mut out = Output::with_capacity(self, chunk.len() / 3);
        out.indices.reserve(chunk.len());
        let mut at = Vec::new();
        for t in chunk.chunks_exact(3) {
            let ids = [t[0] as usize, t[1] as usize, t[2] as usize];
            if ids.iter().any(|&i| i >= self.view.len()) {
                out.changed = true;
                continue;
            }
            let corners = ids.map(|i| self.view[i]);
            if corners.iter().all(|c| c.is_finite()) && whole(corners) {
                out.indices.extend_from_slice(t);
                continue;
            }
            out.changed = true;
            let Some((points, triangles)) = refine(corners) else {
                continue;
            };
            // (One index map for the whole chunk, refilled per triangle.)
            at.clear();
            for p in &points {
                at.push(match corners.iter().position(|c| c == p) {
                    Some(k) => ids[k] as u32,
                    None => {
                        out.push(self, *p, ids, barycentric(corners, *p));
                        NEW_VERTEX | (out.positions.len() as u32 - 1)
                    }
                });
            }
            out.indices
                .extend(triangles.iter().flatten().map(|&i| at[i as usize]));
        }
        out
    }

    /// The twin from the refined chunks of every triangle, in order:
    /// [`Twin::Same`] when none changed and the source has nothing a twin
    /// leaves out, else the source's vertices, then each chunk's new ones.
    fn gather(&self, parts: Vec<Output>) -> Twin {
        if self.all_carried && parts.iter().all(|p| !p.changed) {
            return Twin::Same;
        }
        let vertices = self.local.len() + parts.iter().map(|p| p.positions.len()).sum::<usize>();
        let mut out = Output::with_capacity(self, vertices);
        out.indices
            .reserve(parts.iter().map(|p| p.indices.len()).sum::<usize>());
        out.positions.extend_from_slice(self.local);
        for (mine, (_, values)) in out.carried.iter_mut().zip(&self.carried) {
            mine.extend_from(values);
        }
        for part in parts {
            out.append(part);
        }
        Twin::Refined(Box::new(out.finish(self, PrimitiveTopology::TriangleList)))
    }

    /// A line list: each segment clipped and split by `rule`, attributes
    /// mixed along the segment.
    fn lines(&self, projection: &Panorama, rule: SplitRule) -> Mesh {
        let pairs: Vec<[u32; 2]> = match self.topology {
            PrimitiveTopology::LineStrip => self.indices.windows(2).map(|w| [w[0], w[1]]).collect(),
            _ => self.indices.chunks_exact(2).map(|w| [w[0], w[1]]).collect(),
        };
        let mut out = Output::new(self);
        for [i, j] in pairs {
            let (i, j) = (i as usize, j as usize);
            if i >= self.view.len() || j >= self.view.len() {
                continue;
            }
            let (a, b) = (self.view[i], self.view[j]);
            // Non-finite ends, a segment through the viewer: left out.
            let Ok(refined) = projection.refine_segment(a, b, rule) else {
                continue;
            };
            let d = b - a;
            for strip in refined.strips {
                let base = out.positions.len() as u32;
                for p in &strip {
                    let t = if d.length_squared() > 0.0 {
                        ((*p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    out.push(self, *p, [i, j, j], [1.0 - t, t, 0.0]);
                }
                let n = strip.len() as u32;
                out.indices
                    .extend((1..n).flat_map(|k| [base + k - 1, base + k]));
            }
        }
        out.finish(self, PrimitiveTopology::LineList)
    }
}

/// What a triangle list becomes for one dome camera.
pub enum Twin {
    /// Every triangle is its own refinement (small and in front, the common
    /// case for distant meshes): draw the source mesh itself.
    Same,
    /// The refined mesh (boxed: the enum is passed around by value).
    Refined(Box<Mesh>),
}

/// A twin mesh being written.
struct Output {
    positions: Vec<[f32; 3]>,
    carried: Vec<Interpolated>,
    indices: Vec<u32>,
    /// Whether a triangle was refined or dropped (the twin differs from
    /// the source).
    changed: bool,
}

impl Output {
    fn new(source: &Source) -> Self {
        Self::with_capacity(source, 0)
    }

    /// An empty output with room for `vertices` vertices (growing a twin's
    /// arrays vertex by vertex showed in the profile).
    fn with_capacity(source: &Source, vertices: usize) -> Self {
        Self {
            positions: Vec::with_capacity(vertices),
            carried: source
                .carried
                .iter()
                .map(|(_, v)| Interpolated::empty_like(v, vertices))
                .collect(),
            indices: Vec::new(),
            changed: false,
        }
    }

    /// Appends `other`'s new vertices after this one's, and its triangles
    /// (indices of source vertices as they are, of new ones moved past
    /// this one's vertices).
    fn append(&mut self, other: Output) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        for (mine, theirs) in self.carried.iter_mut().zip(other.carried) {
            mine.append(theirs);
        }
        self.indices.extend(other.indices.into_iter().map(|i| {
            if i & NEW_VERTEX != 0 {
                base + (i & !NEW_VERTEX)
            } else {
                i
            }
        }));
    }

    /// Appends the view-space point `p`, its attributes `Σ w_k · a[ids_k]`.
    fn push(&mut self, source: &Source, p: DVec3, ids: [usize; 3], weights: [f64; 3]) {
        let local = source.local_from_view.transform_point3(p);
        self.positions.push(local.as_vec3().to_array());
        for (out, (_, values)) in self.carried.iter_mut().zip(&source.carried) {
            out.push_mix(values, ids, weights);
        }
    }

    fn finish(self, source: &Source, topology: PrimitiveTopology) -> Mesh {
        let mut mesh = Mesh::new(topology, RenderAssetUsages::default());
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, self.positions);
        for ((attribute, _), values) in source.carried.iter().zip(self.carried) {
            let normalise = attribute.id == Mesh::ATTRIBUTE_NORMAL.id
                || attribute.id == Mesh::ATTRIBUTE_TANGENT.id;
            mesh.insert_attribute(*attribute, values.finish(normalise));
        }
        mesh.insert_indices(Indices::U32(self.indices));
        mesh
    }
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

/// Whether a twin carries an attribute of these values (the float ones
/// [`Interpolated`] can mix).
fn mixable(values: &VertexAttributeValues) -> bool {
    matches!(
        values,
        VertexAttributeValues::Float32x2(_)
            | VertexAttributeValues::Float32x3(_)
            | VertexAttributeValues::Float32x4(_)
    )
}

impl Interpolated {
    /// No values yet, of the kind of `values` (a [`mixable`] attribute).
    fn empty_like(values: &VertexAttributeValues, capacity: usize) -> Self {
        match values {
            VertexAttributeValues::Float32x2(_) => Self::X2(Vec::with_capacity(capacity)),
            VertexAttributeValues::Float32x4(_) => Self::X4(Vec::with_capacity(capacity)),
            _ => Self::X3(Vec::with_capacity(capacity)),
        }
    }

    /// Appends every value of `values` (of the same kind) as it is.
    fn extend_from(&mut self, values: &VertexAttributeValues) {
        match (self, values) {
            (Self::X2(out), VertexAttributeValues::Float32x2(v)) => out.extend_from_slice(v),
            (Self::X3(out), VertexAttributeValues::Float32x3(v)) => out.extend_from_slice(v),
            (Self::X4(out), VertexAttributeValues::Float32x4(v)) => out.extend_from_slice(v),
            _ => {}
        }
    }

    /// Appends `other`'s values (of the same kind).
    fn append(&mut self, other: Self) {
        match (self, other) {
            (Self::X2(a), Self::X2(b)) => a.extend(b),
            (Self::X3(a), Self::X3(b)) => a.extend(b),
            (Self::X4(a), Self::X4(b)) => a.extend(b),
            _ => {}
        }
    }

    /// Appends `Σ w_k · source[ids_k]`.
    fn push_mix(&mut self, source: &VertexAttributeValues, ids: [usize; 3], w: [f64; 3]) {
        fn mix<const N: usize>(v: &[[f32; N]], ids: [usize; 3], w: [f64; 3]) -> [f32; N] {
            std::array::from_fn(|c| {
                (0..3).map(|k| w[k] * f64::from(v[ids[k]][c])).sum::<f64>() as f32
            })
        }
        match (self, source) {
            (Self::X2(out), VertexAttributeValues::Float32x2(v)) => out.push(mix(v, ids, w)),
            (Self::X3(out), VertexAttributeValues::Float32x3(v)) => out.push(mix(v, ids, w)),
            (Self::X4(out), VertexAttributeValues::Float32x4(v)) => out.push(mix(v, ids, w)),
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
