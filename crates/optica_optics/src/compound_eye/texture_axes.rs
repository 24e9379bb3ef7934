//! Texture-axis vectors `U_p`, `V_p` and the origin `P_c` of one triangle
//! (thesis §6.3.1, eq. 6.1–6.15), and the maps between polygon points and
//! texture coordinates (eq. 6.2, 6.25–6.27).

use glam::{DVec2, DVec3, DVec4};

use super::error::CompoundEyeError;
use crate::input::{self, InvalidInput};

/// A UV triangle is degenerate when `|det A| ≤ UV_DET_REL_EPS · |T_10|·|T_20|`,
/// i.e. when the sine of the angle between its UV edges is at most `1e-6`.
/// The axes of eq. 6.15 grow like `1/sin`: at `1e-6` they are a million
/// facets long per UV unit of error, and `f32` on the GPU (7 significant
/// digits) has no digit of the texture coordinate left, long before `f64`
/// fails. [`TextureAxes::from_triangle_or_fallback`] uses its fallback frame
/// below this.
pub const UV_DET_REL_EPS: f64 = 1e-6;

/// A position triangle is degenerate when `|P_10 × P_20| ≤ AREA_REL_EPS ·
/// |P_10|·|P_20|` (the sine of its angle at `P_0`). `1e-12` is about 4500
/// `f64` ulps of 1: the cross product of two collinear edges is round-off of that
/// order, so below it the normal's direction is noise.
pub const AREA_REL_EPS: f64 = 1e-12;

/// Relative tolerance of [`TextureAxes::from_axes`]'s perpendicularity check:
/// a given normal `N` is accepted when `|N̂·(U_p × V_p)| / |U_p × V_p| ≥ 1 −
/// NORMAL_COS_EPS`, i.e. within `√(2·1e-9) ≈ 4.5e-5` rad of the lattice
/// plane's normal. That admits a normal computed in `f32` or taken from a
/// mesh (errors ~1e-7 rad) and refuses one that is visibly tilted; the
/// stored normal is then exactly `±(U_p × V_p)/|U_p × V_p|`.
pub const NORMAL_COS_EPS: f64 = 1e-9;

/// The smallest cosine between a shading normal and the lattice's normal
/// that [`TextureAxes::on_normal`] follows (60°). Further off, the shading
/// normal is not the surface's own (a hard edge averaged away, or a broken
/// normal), and the triangle's plane is kept.
pub const MIN_SHADING_COS: f64 = 0.5;

/// Eq. 6.1: texture coordinates sent to the shader are the mesh's scaled by
/// the texture resolution `R_t` (facets per UV unit), so `R_t` sets how many
/// facets cover the surface. `R_t` must be finite and positive and `t_obj`
/// finite.
pub fn scale_uv(t_obj: DVec2, texture_resolution: f64) -> Result<DVec2, InvalidInput> {
    let r_t = input::positive(
        "texture resolution R_t (facets per UV unit)",
        texture_resolution,
    )?;
    let t = input::finite_vec2("mesh texture coordinate (UV units)", t_obj)?;
    Ok(r_t * t)
}

/// The shader's degeneracy threshold for `f32` axes (its
/// `UV_DET_REL_EPS`).
const SHADER_UV_DET_REL_EPS: f64 = 1e-4;

/// The side of the fallback frame's facets when the caller's is not finite
/// and positive: one mesh unit.
const DEFAULT_FALLBACK_CELL: f64 = 1.0;

/// The texture frame of one triangle: `P = P_c + a·U_p + b·V_p` (eq. 6.2).
///
/// Handedness: eq. 6.8–6.15 give `U_p × V_p = (P_10 × P_20) / det A`, so a
/// mirrored UV triangle (`det A < 0`) has `U_p × V_p` pointing *into* the
/// surface. The thesis never forms that cross product, and neither do we: the
/// normal `N` comes from the winding (`P_10 × P_20`), so the lenses stay
/// under the surface (eq. 6.22) on mirrored triangles too, and the sign is
/// kept in [`TextureAxes::handedness`] for code that builds a tangent frame
/// (Bevy's `Mesh::ATTRIBUTE_TANGENT` `w`, see [`TextureAxes::tangent_vec4`]).
///
/// Invariants every constructor establishes and the rest of the module relies
/// on: `U_p`, `V_p` finite and not parallel, `N` a unit vector exactly along
/// `±(U_p × V_p)` (so depth along `N` and the `uv` projection are independent
/// and each lens stays inside its cell's column), and the cached Gram
/// determinant of eq. 6.26–6.27 matching `U_p`, `V_p`. The fields are private
/// so that these cannot be broken after construction; read them with the
/// getters.
///
/// ```
/// # use optica_optics::compound_eye::TextureAxes;
/// # use optica_optics::glam::{DVec2, DVec3};
/// let a = TextureAxes::from_axes(DVec3::ZERO, 2.0 * DVec3::X, DVec3::Y, DVec3::Z).unwrap();
/// assert_eq!(a.u(), 2.0 * DVec3::X);
/// assert_eq!(a.uv_of(DVec3::new(1.0, 1.0, 0.0)), DVec2::new(0.5, 1.0));
/// ```
///
/// A field cannot be assigned (it would leave the cached Gram determinant stale):
///
/// ```compile_fail
/// # use optica_optics::compound_eye::TextureAxes;
/// # use optica_optics::glam::DVec3;
/// let mut a = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
/// a.u = 2.0 * DVec3::X;
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureAxes {
    /// `P_c`: the point with texture coordinate (0, 0) (eq. 6.3).
    origin: DVec3,
    /// `U_p = ∂P/∂a` (eq. 6.8): one facet along the texture's `a` axis, in world units.
    u: DVec3,
    /// `V_p = ∂P/∂b` (eq. 6.9): one facet along the texture's `b` axis, in world units.
    v: DVec3,
    /// Unit outward normal `N`, from the winding `P_10 × P_20` (not from `U_p × V_p`).
    normal: DVec3,
    /// `sign(det A)`: `+1` when `(U_p, V_p, N)` is right-handed, `−1` for mirrored UVs.
    handedness: f64,
    /// `None` when the axes are eq. 6.15's; otherwise why the fallback frame
    /// of [`TextureAxes::from_triangle_or_fallback`] was used.
    fallback: Option<CompoundEyeError>,
    /// Gram determinant `(U·U)(V·V) − (U·V)²`, the denominator of eq. 6.26–6.27.
    gram: f64,
}

impl TextureAxes {
    /// The axes of a triangle with positions `p` and (already scaled, eq. 6.1)
    /// texture coordinates `t`, by eq. 6.4–6.15, with `P_c` from eq. 6.3 at
    /// `P_e = P_0`.
    ///
    /// Errors: [`CompoundEyeError::Input`] for a non-finite position or
    /// texture coordinate, [`CompoundEyeError::DegenerateTriangle`] (see
    /// [`AREA_REL_EPS`]) and [`CompoundEyeError::DegenerateUv`] (see
    /// [`UV_DET_REL_EPS`]).
    pub fn from_triangle(p: [DVec3; 3], t: [DVec2; 3]) -> Result<Self, CompoundEyeError> {
        for x in p {
            input::finite_vec3("triangle vertex position (mesh units)", x)?;
        }
        for x in t {
            input::finite_vec2("triangle texture coordinate (facets)", x)?;
        }
        let p10 = p[1] - p[0]; // (6.4)
        let p20 = p[2] - p[0]; // (6.5)
        let t10 = t[1] - t[0]; // (6.6)
        let t20 = t[2] - t[0]; // (6.7)
        let cross = p10.cross(p20);
        let area2 = cross.length();
        if !(area2 > AREA_REL_EPS * p10.length() * p20.length()) || !area2.is_finite() {
            return Err(CompoundEyeError::DegenerateTriangle);
        }
        let normal = cross / area2;
        // (6.14): A = (T10, T20) as columns; det A is the doubled signed UV area.
        let det = t10.x * t20.y - t20.x * t10.y;
        if !(det.abs() > UV_DET_REL_EPS * t10.length() * t20.length()) {
            return Err(CompoundEyeError::DegenerateUv { det });
        }
        // (6.15): [[i, k], [j, l]] = A⁻¹ = (1/det)·[[T20.y, −T20.x], [−T10.y, T10.x]].
        let i = t20.y / det;
        let j = -t10.y / det;
        let k = -t20.x / det;
        let l = t10.x / det;
        let u = i * p10 + j * p20; // (6.8)
        let v = k * p10 + l * p20; // (6.9)
        let origin = p[0] - t[0].x * u - t[0].y * v; // (6.3)
        let axes = Self::assemble(origin, u, v, normal, det.signum(), None);
        if axes.gram > 0.0 && axes.gram.is_finite() && axes.origin.is_finite() {
            Ok(axes)
        } else {
            // Only reachable with extreme magnitudes (overflow); same as a degenerate UV.
            Err(CompoundEyeError::DegenerateUv { det })
        }
    }

    /// [`TextureAxes::from_triangle`], or a defined fallback frame when it fails.
    ///
    /// Fallback (`fallback` holds the reason): an orthogonal frame in the
    /// triangle's plane with both axes `fallback_cell` long (one facet, in
    /// mesh units; a non-finite or non-positive value means 1), `U_p` along the longer of
    /// `P_10`, `P_20`, right-handed, and `P_0 ↦ T_0` (eq. 6.3). A triangle
    /// with no plane (zero area) or with non-finite input gets the world
    /// frame (`N = +z`) through `P_0` (or the origin if `P_0` is not finite).
    /// The rasteriser draws no fragment of a zero-area triangle, so this only
    /// has to be finite.
    pub fn from_triangle_or_fallback(p: [DVec3; 3], t: [DVec2; 3], fallback_cell: f64) -> Self {
        let reason = match Self::from_triangle(p, t) {
            Ok(axes) => return axes,
            Err(e) => e,
        };
        let s = input::positive("fallback facet size (mesh units)", fallback_cell)
            .unwrap_or(DEFAULT_FALLBACK_CELL);
        let t0 = if t[0].is_finite() { t[0] } else { DVec2::ZERO };
        let p0 = if p[0].is_finite() { p[0] } else { DVec3::ZERO };
        let (u_hat, v_hat, normal) = match reason {
            CompoundEyeError::DegenerateUv { .. } => {
                let p10 = p[1] - p[0];
                let p20 = p[2] - p[0];
                let normal = p10.cross(p20).normalize();
                let long = if p10.length_squared() >= p20.length_squared() {
                    p10
                } else {
                    p20
                };
                let u_hat = long.normalize();
                (u_hat, normal.cross(u_hat), normal)
            }
            _ => (DVec3::X, DVec3::Y, DVec3::Z),
        };
        let u = s * u_hat;
        let v = s * v_hat;
        let origin = p0 - t0.x * u - t0.y * v; // (6.3)
        let axes = Self::assemble(origin, u, v, normal, 1.0, Some(reason));
        if axes.origin.is_finite() && axes.gram > 0.0 && axes.gram.is_finite() {
            axes
        } else {
            // Huge-but-finite input overflowed: the world frame at the origin.
            Self::assemble(
                DVec3::ZERO,
                s * DVec3::X,
                s * DVec3::Y,
                DVec3::Z,
                1.0,
                Some(reason),
            )
        }
    }

    /// Axes given directly (for lattices built without a mesh).
    ///
    /// `normal` must be perpendicular to the lattice plane: only its side
    /// is taken from it. It is accepted when `|N̂·(U_p × V_p)| / |U_p × V_p|
    /// ≥ 1 − NORMAL_COS_EPS` and then *replaced* by exactly
    /// `±(U_p × V_p)/|U_p × V_p|` with the sign of `N·(U_p × V_p)`; that sign
    /// is the handedness. A tilted normal is rejected (it would put the
    /// lenses off their cells' columns and mix depth into the texture
    /// coordinates) rather than silently projected.
    ///
    /// Errors: [`CompoundEyeError::Input`] for a non-finite `origin`, `u`,
    /// `v` or `normal`, or a zero `normal`;
    /// [`CompoundEyeError::DegenerateUv`] when `u`, `v` are (nearly) parallel
    /// (see [`UV_DET_REL_EPS`]) and
    /// [`CompoundEyeError::NormalNotPerpendicular`] for a tilted `normal`.
    pub fn from_axes(
        origin: DVec3,
        u: DVec3,
        v: DVec3,
        normal: DVec3,
    ) -> Result<Self, CompoundEyeError> {
        let origin = input::finite_vec3("lattice origin P_c (mesh units)", origin)?;
        let u = input::finite_vec3("lattice axis U_p (mesh units per facet)", u)?;
        let v = input::finite_vec3("lattice axis V_p (mesh units per facet)", v)?;
        let given = input::direction("lattice normal", normal)?;
        let cross = u.cross(v);
        let sin_len = cross.length();
        let lengths = u.length() * v.length();
        if !(sin_len > UV_DET_REL_EPS * lengths) || !sin_len.is_finite() {
            let sin = if lengths > 0.0 && (sin_len / lengths).is_finite() {
                sin_len / lengths
            } else {
                0.0
            };
            return Err(CompoundEyeError::DegenerateUv { det: sin });
        }
        let plane_normal = cross / sin_len;
        let cos = given.dot(plane_normal);
        if !(cos.abs() >= 1.0 - NORMAL_COS_EPS) {
            return Err(CompoundEyeError::NormalNotPerpendicular { cos: cos.abs() });
        }
        let handed = if cos < 0.0 { -1.0 } else { 1.0 };
        let axes = Self::assemble(origin, u, v, handed * plane_normal, handed, None);
        if axes.gram > 0.0 && axes.gram.is_finite() {
            Ok(axes)
        } else {
            // Only reachable with extreme magnitudes (overflow or underflow of U·U, V·V).
            Err(CompoundEyeError::DegenerateUv {
                det: sin_len / lengths,
            })
        }
    }

    /// `P_c`: the point with texture coordinate (0, 0) (eq. 6.3).
    #[inline]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// `U_p = ∂P/∂a` (eq. 6.8): one facet along the texture's `a` axis, in world units.
    #[inline]
    pub fn u(&self) -> DVec3 {
        self.u
    }

    /// `V_p = ∂P/∂b` (eq. 6.9): one facet along the texture's `b` axis, in world units.
    #[inline]
    pub fn v(&self) -> DVec3 {
        self.v
    }

    /// Unit outward normal `N`, perpendicular to `U_p` and `V_p`: from the
    /// winding `P_10 × P_20` for triangles, `±(U_p × V_p)/|U_p × V_p|` for
    /// [`TextureAxes::from_axes`].
    #[inline]
    pub fn normal(&self) -> DVec3 {
        self.normal
    }

    /// `sign(det A)`: `+1` when `(U_p, V_p, N)` is right-handed, `−1` for mirrored UVs.
    #[inline]
    pub fn handedness(&self) -> f64 {
        self.handedness
    }

    /// `None` when the axes are eq. 6.15's (or given directly); otherwise why
    /// the fallback frame of [`TextureAxes::from_triangle_or_fallback`] was used.
    #[inline]
    pub fn fallback(&self) -> Option<CompoundEyeError> {
        self.fallback
    }

    fn assemble(
        origin: DVec3,
        u: DVec3,
        v: DVec3,
        normal: DVec3,
        handedness: f64,
        fallback: Option<CompoundEyeError>,
    ) -> Self {
        let uu = u.dot(u);
        let vv = v.dot(v);
        let uv = u.dot(v);
        Self {
            origin,
            u,
            v,
            normal,
            handedness,
            fallback,
            gram: uu * vv - uv * uv,
        }
    }

    /// Eq. 6.2: the polygon point with texture coordinate `uv` (in facets).
    pub fn point_of(&self, uv: DVec2) -> DVec3 {
        self.origin + uv.x * self.u + uv.y * self.v
    }

    /// Eq. 6.25–6.27: the texture coordinate of `p` by least squares, i.e.
    /// of `p`'s orthogonal projection onto the polygon's plane.
    pub fn uv_of(&self, p: DVec3) -> DVec2 {
        self.uv_rate(p - self.origin) // (6.25)
    }

    /// The linear part of [`TextureAxes::uv_of`]: how fast the texture
    /// coordinate changes along `d` (eq. 6.26–6.27 applied to a direction).
    pub fn uv_rate(&self, d: DVec3) -> DVec2 {
        let uu = self.u.dot(self.u);
        let vv = self.v.dot(self.v);
        let uv = self.u.dot(self.v);
        let du = d.dot(self.u);
        let dv = d.dot(self.v);
        DVec2::new(
            (vv * du - uv * dv) / self.gram, // (6.26)
            (uu * dv - uv * du) / self.gram, // (6.27)
        )
    }

    /// Depth of `p` below the polygon plane along `−N` (negative above it).
    pub fn depth(&self, p: DVec3) -> f64 {
        (self.origin - p).dot(self.normal)
    }

    /// Heights of the lattice cell (a parallelogram with sides `U_p`, `V_p`):
    /// its width across the `V_p` sides and across the `U_p` sides, in world units.
    pub fn cell_heights(&self) -> (f64, f64) {
        let area = self.gram.sqrt();
        (area / self.v.length(), area / self.u.length())
    }

    /// The lattice through `at` laid into the plane perpendicular to a
    /// shading normal (the mesh's interpolated vertex normal), so that it
    /// bends with a curved surface instead of following each flat triangle:
    /// `U_p`, `V_p` are projected into that plane, `N` becomes the shading
    /// normal (on this normal's side) and `at` keeps its texture coordinate.
    /// Across a triangle edge the projected axes of the two triangles agree
    /// to second order in the angle between them, so a coarse mesh shows
    /// no seams.
    ///
    /// Returns `self` unchanged when `shading` is not finite or zero, is
    /// more than 60° off `N` (see [`MIN_SHADING_COS`]), or the projected
    /// axes are (nearly) parallel. `UV_DET_REL_EPS` is the shader's `f32`
    /// threshold here (`1e-4`), since this is what the shader does per
    /// fragment.
    pub fn on_normal(&self, at: DVec3, shading: DVec3) -> Self {
        let Some(m) = shading.try_normalize() else {
            return *self;
        };
        let m = if m.dot(self.normal) < 0.0 { -m } else { m };
        if !(m.dot(self.normal) > MIN_SHADING_COS) {
            return *self;
        }
        let u = self.u - self.u.dot(m) * m;
        let v = self.v - self.v.dot(m) * m;
        if !(u.cross(v).length() > SHADER_UV_DET_REL_EPS * u.length() * v.length()) {
            return *self;
        }
        let t = self.uv_of(at);
        let origin = at - t.x * u - t.y * v;
        Self::assemble(origin, u, v, m, self.handedness, self.fallback)
    }

    /// The lattice through `at` laid along a tangent frame (the mesh's
    /// interpolated `Mesh::ATTRIBUTE_TANGENT`): `U_p` along the tangent
    /// projected into the lattice's plane, `V_p` perpendicular to it on
    /// `V_p`'s side, both as long as the square root of the cell's area,
    /// so that facets keep their area and one shape (square, or regular
    /// hexagons). Unlike the UVs' own axes, which change at every triangle
    /// edge of a mesh whose UVs are piecewise linear, the tangent frame is
    /// interpolated across the edges, so the lattice shows no seams; what
    /// it gives up is the UVs' stretch and shear. `N` and the texture
    /// coordinate of `at` are kept.
    ///
    /// Returns `self` unchanged when `tangent` is not finite, zero, or
    /// within `1e-4` (in sine) of the normal.
    pub fn on_tangent(&self, at: DVec3, tangent: DVec3) -> Self {
        let n = self.normal;
        let in_plane = tangent - tangent.dot(n) * n;
        // Also false for a zero, NaN or infinite tangent.
        if !(in_plane.length() > SHADER_UV_DET_REL_EPS * tangent.length()) {
            return *self;
        }
        let (t, b) = self.unit_frame(in_plane);
        let side = self.gram.sqrt().sqrt();
        let (u, v) = (side * t, side * b);
        let uv = self.uv_of(at);
        let origin = at - uv.x * u - uv.y * v;
        Self::assemble(origin, u, v, n, self.handedness, self.fallback)
    }

    /// The unit frame (T, B) of a tangent's in-plane part (not zero): T
    /// along it on `U_p`'s side, B = N × T on `V_p`'s side.
    fn unit_frame(&self, in_plane: DVec3) -> (DVec3, DVec3) {
        let t = in_plane.normalize();
        let t = if t.dot(self.u) < 0.0 { -t } else { t };
        let b = self.normal.cross(t);
        let b = if b.dot(self.v) < 0.0 { -b } else { b };
        (t, b)
    }

    /// The lattice through `at` laid along a smooth axis field (see
    /// [`axis_field`]): `U_p` along the interpolated `tangent` projected
    /// into the lattice's plane, `V_p = |U_p|·(shear·T + aspect·B)` with
    /// `(shear, aspect) = shape` (B = N × T, on `V_p`'s side), and the
    /// cell's area kept. Both the tangent and the shape are interpolated
    /// across triangle edges, so the lattice shows no seams, and unlike
    /// [`TextureAxes::on_tangent`] it keeps the UVs' stretch and shear.
    /// `N` and the texture coordinate of `at` are kept.
    ///
    /// Falls back to [`TextureAxes::on_tangent`] (square facets) when the
    /// shape is not finite or its aspect is not above `1e-4`, and returns
    /// `self` unchanged where that does.
    pub fn on_field(&self, at: DVec3, tangent: DVec3, shape: DVec2) -> Self {
        let n = self.normal;
        let in_plane = tangent - tangent.dot(n) * n;
        if !(in_plane.length() > SHADER_UV_DET_REL_EPS * tangent.length()) {
            return *self;
        }
        if !(shape.is_finite() && shape.y > SHADER_UV_DET_REL_EPS) {
            return self.on_tangent(at, tangent);
        }
        let (t, b) = self.unit_frame(in_plane);
        // |U × V| = L²·aspect keeps the cell's area.
        let side = (self.gram.sqrt() / shape.y).sqrt();
        let (u, v) = (side * t, side * (shape.x * t + shape.y * b));
        let uv = self.uv_of(at);
        let origin = at - uv.x * u - uv.y * v;
        Self::assemble(origin, u, v, n, self.handedness, self.fallback)
    }

    /// A tangent in Bevy's `Mesh::ATTRIBUTE_TANGENT` convention: `xyz` is
    /// `U_p` normalised, `w` the handedness, so that `w · (N × T)` points
    /// along `V_p`'s component orthogonal to `U_p`.
    pub fn tangent_vec4(&self) -> DVec4 {
        self.u.normalize_or_zero().extend(self.handedness)
    }
}

/// One vertex of a smooth axis field ([`axis_field`]): the lattice's
/// direction and shape there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldVertex {
    /// `U_p`'s direction in the plane of the vertex normal, in Bevy's
    /// `Mesh::ATTRIBUTE_TANGENT` convention (`w` the handedness); zero where
    /// the vertex has no usable triangle.
    pub tangent: DVec4,
    /// `V_p` in units of `|U_p|` in the frame (T, B = w·N × T):
    /// `(shear, aspect)`, so `V_p = |U_p|·(shear·T + aspect·B)`; `(0, 1)`
    /// (a square) where the vertex has no usable triangle.
    pub shape: DVec2,
}

/// A smooth field of lattice axes over a triangle mesh: at each vertex the
/// area-weighted mean of its triangles' `U_p`, `V_p` (eq. 6.8–6.9, from the
/// texture coordinates `uvs`), laid into the plane of its `normals`, as a
/// direction and a shape ([`FieldVertex`]). A shader interpolates both
/// across each triangle and rebuilds the axes with
/// [`TextureAxes::on_field`]: continuous across edges, where each
/// triangle's own axes jump when the UVs' stretch changes (a UV sphere's
/// rows), and with the stretch and shear kept, which a plain tangent frame
/// ([`TextureAxes::on_tangent`]) gives up.
///
/// The shape is a ratio, so the field does not depend on the facets per
/// UV unit nor on a uniform scale of the mesh. Triangles with degenerate
/// positions or UVs, or indices out of range, are skipped; a vertex left
/// with none gets the neutral value. A zero or non-finite normal is
/// replaced by the vertex's triangles' mean normal.
pub fn axis_field(
    positions: &[DVec3],
    normals: &[DVec3],
    uvs: &[DVec2],
    triangles: &[[u32; 3]],
) -> Vec<FieldVertex> {
    let n = positions.len();
    let mut sums = vec![(DVec3::ZERO, DVec3::ZERO, DVec3::ZERO); n];
    for tri in triangles {
        let i = tri.map(|k| k as usize);
        if i.iter().any(|&k| k >= n || k >= uvs.len()) {
            continue;
        }
        let p = i.map(|k| positions[k]);
        let Ok(axes) = TextureAxes::from_triangle(p, i.map(|k| uvs[k])) else {
            continue;
        };
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        for k in i {
            let s = &mut sums[k];
            s.0 += area * axes.u();
            s.1 += area * axes.v();
            s.2 += area * axes.normal();
        }
    }
    let neutral = FieldVertex {
        tangent: DVec4::ZERO,
        shape: DVec2::Y,
    };
    sums.iter()
        .enumerate()
        .map(|(k, &(u, v, mean_normal))| {
            let m = normals
                .get(k)
                .and_then(|m| m.try_normalize())
                .or_else(|| mean_normal.try_normalize());
            let Some(m) = m else {
                return neutral;
            };
            let u = u - u.dot(m) * m;
            let v = v - v.dot(m) * m;
            let (len, cross) = (u.length(), u.cross(v));
            if !(len > 0.0 && cross.length() > SHADER_UV_DET_REL_EPS * len * v.length()) {
                return neutral;
            }
            let t = u / len;
            let handed = if cross.dot(m) < 0.0 { -1.0 } else { 1.0 };
            let b = handed * m.cross(t);
            FieldVertex {
                tangent: t.extend(handed),
                shape: DVec2::new(v.dot(t), v.dot(b)) / len,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;
    use proptest::prelude::*;

    fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).length() <= tol
    }

    #[test]
    fn axes_of_hand_made_skewed_triangle() {
        // Hand computation: P10 = (2,0,0), P20 = (0,1,1); T10 = (2,1), T20 = (0,1)
        // → A = [[2,0],[1,1]], det 2, A⁻¹ = ½[[1,0],[−1,2]]: (i,j) = (½,−½), (k,l) = (0,1)
        // → U_p = ½P10 − ½P20 = (1,−½,−½), V_p = P20 = (0,1,1).
        // T0 = (3,−1) → P_c = P0 − 3U + V = (1,1,0) − (3,−1.5,−1.5) + (0,1,1) = (−2,3.5,2.5).
        let p = [
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(3.0, 1.0, 0.0),
            DVec3::new(1.0, 2.0, 1.0),
        ];
        let t = [
            DVec2::new(3.0, -1.0),
            DVec2::new(5.0, 0.0),
            DVec2::new(3.0, 0.0),
        ];
        let a = TextureAxes::from_triangle(p, t).unwrap();
        assert!(close(a.u, DVec3::new(1.0, -0.5, -0.5), 1e-14), "{:?}", a.u);
        assert!(close(a.v, DVec3::new(0.0, 1.0, 1.0), 1e-14), "{:?}", a.v);
        assert!(
            close(a.origin, DVec3::new(-2.0, 3.5, 2.5), 1e-13),
            "{:?}",
            a.origin
        );
        // N = P10 × P20 / |…| = (0,−2,2)/√8.
        assert!(close(
            a.normal,
            DVec3::new(0.0, -1.0, 1.0) / 2f64.sqrt(),
            1e-15
        ));
        assert_eq!(a.handedness, 1.0);
        assert!(a.fallback.is_none());
        // Every vertex maps back to its UV (eq. 6.2 and 6.26–6.27 are inverses on the plane).
        for k in 0..3 {
            assert!((a.uv_of(p[k]) - t[k]).length() < 1e-13);
            assert!(close(a.point_of(t[k]), p[k], 1e-13));
        }
        // uv_of ignores the normal component (least squares = projection).
        assert!((a.uv_of(p[1] + 5.0 * a.normal) - t[1]).length() < 1e-12);
    }

    #[test]
    fn axes_laid_on_a_shading_normal_bend_with_it_and_keep_the_point() {
        let a = TextureAxes::from_axes(
            DVec3::new(0.3, -0.2, 0.0),
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(-0.1, 0.9, 0.0),
            DVec3::Z,
        )
        .unwrap();
        let at = DVec3::new(2.0, 1.5, 0.0);
        let m = DVec3::new(0.3, -0.2, 1.0).normalize();
        // Given on either side, the normal is taken on the lattice's side.
        for shading in [m, -2.0 * m] {
            let b = a.on_normal(at, shading);
            assert!(close(b.normal(), m, 1e-15));
            assert!(b.u().dot(m).abs() < 1e-15 && b.v().dot(m).abs() < 1e-15);
            // The invariant: N along ±(U × V), with the same handedness.
            assert!(close(b.u().cross(b.v()).normalize(), m, 1e-14));
            assert_eq!(b.handedness(), a.handedness());
            assert!((b.uv_of(at) - a.uv_of(at)).length() < 1e-13);
            // The axes only lose their component along the normal.
            assert!(close(b.u() + a.u().dot(m) * m, a.u(), 1e-15));
        }
        // The triangle's own normal changes nothing; a wild or broken one is ignored.
        assert!(close(a.on_normal(at, DVec3::Z).u(), a.u(), 1e-15));
        for bad in [DVec3::X, DVec3::ZERO, DVec3::NAN, DVec3::new(1.0, 0.0, 0.5)] {
            assert_eq!(a.on_normal(at, bad), a);
        }
    }

    #[test]
    fn axes_laid_on_a_tangent_keep_area_and_point_and_turn_square() {
        let a = TextureAxes::from_axes(
            DVec3::new(0.3, -0.2, 0.0),
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(-0.4, 0.6, 0.0),
            DVec3::Z,
        )
        .unwrap();
        let at = DVec3::new(2.0, 1.5, 0.0);
        // A tangent off the plane and off U: its in-plane part is followed.
        let t = DVec3::new(0.9, 0.3, 0.4);
        for tangent in [t, -3.0 * t] {
            let b = a.on_tangent(at, tangent);
            let along = DVec3::new(0.9, 0.3, 0.0).normalize();
            assert!(close(b.u().normalize(), along, 1e-14));
            assert!(b.u().dot(b.v()).abs() < 1e-14);
            assert!((b.u().length() - b.v().length()).abs() < 1e-14);
            // Area kept: |U × V| as before.
            assert!((b.u().cross(b.v()).length() - a.u().cross(a.v()).length()).abs() < 1e-14);
            // V on V's side, N and the point's coordinate kept.
            assert!(b.v().dot(a.v()) > 0.0);
            assert!(close(b.normal(), a.normal(), 1e-15));
            assert_eq!(b.handedness(), a.handedness());
            assert!((b.uv_of(at) - a.uv_of(at)).length() < 1e-13);
        }
        // Mirrored UVs (V on the other side of U) stay mirrored.
        let m = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::new(0.2, -1.0, 0.0), DVec3::Z)
            .unwrap();
        assert!(m.on_tangent(at, DVec3::X).v().y < 0.0);
        for bad in [DVec3::Z, DVec3::ZERO, DVec3::NAN, DVec3::INFINITY] {
            assert_eq!(a.on_tangent(at, bad), a);
        }
    }

    #[test]
    fn degenerate_uv_is_typed_and_falls_back_to_a_plane_frame() {
        let p = [
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        // Collinear UVs (det = 0) and a collapsed UV edge.
        for t in [
            [DVec2::ZERO, DVec2::new(1.0, 1.0), DVec2::new(2.0, 2.0)],
            [
                DVec2::new(0.5, 0.5),
                DVec2::new(0.5, 0.5),
                DVec2::new(1.0, 0.0),
            ],
            [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, 1e-9)],
        ] {
            let err = TextureAxes::from_triangle(p, t).unwrap_err();
            assert!(
                matches!(err, CompoundEyeError::DegenerateUv { .. }),
                "{err:?}"
            );
            let a = TextureAxes::from_triangle_or_fallback(p, t, 0.25);
            assert_eq!(a.fallback, Some(err));
            // Orthogonal, one facet = 0.25 long, in the triangle's plane (z = 0), right-handed.
            assert!((a.u.length() - 0.25).abs() < 1e-15 && (a.v.length() - 0.25).abs() < 1e-15);
            assert!(a.u.dot(a.v).abs() < 1e-15);
            assert!(a.u.z.abs() < 1e-15 && a.v.z.abs() < 1e-15);
            assert!(close(a.normal, DVec3::Z, 1e-15));
            assert!(a.u.cross(a.v).dot(a.normal) > 0.0);
            // U_p along the longer edge P10 = (2,0,0); P0 ↦ T0 (eq. 6.3).
            assert!(close(a.u, DVec3::new(0.25, 0.0, 0.0), 1e-15));
            assert!((a.uv_of(p[0]) - t[0]).length() < 1e-14);
        }
    }

    #[test]
    fn degenerate_and_non_finite_triangles_are_typed() {
        let t = [DVec2::ZERO, DVec2::X, DVec2::Y];
        let line = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
        assert_eq!(
            TextureAxes::from_triangle(line, t),
            Err(CompoundEyeError::DegenerateTriangle)
        );
        let a = TextureAxes::from_triangle_or_fallback(line, t, 1.0);
        assert_eq!(a.fallback, Some(CompoundEyeError::DegenerateTriangle));
        assert_eq!(a.normal, DVec3::Z);
        let nan = [DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y];
        match TextureAxes::from_triangle(nan, t) {
            Err(CompoundEyeError::Input(e)) => {
                assert_eq!(
                    (e.what, e.expected),
                    (
                        "triangle vertex position (mesh units)",
                        Expected::FiniteVector
                    )
                );
                assert!(e.value.is_nan());
            }
            other => panic!("{other:?}"),
        }
        let inf_uv = [DVec2::ZERO, DVec2::new(0.0, f64::INFINITY), DVec2::Y];
        match TextureAxes::from_triangle(line, inf_uv) {
            Err(CompoundEyeError::Input(e)) => assert_eq!(
                (e.what, e.value),
                ("triangle texture coordinate (facets)", f64::INFINITY)
            ),
            other => panic!("{other:?}"),
        }
        let a = TextureAxes::from_triangle_or_fallback(nan, t, f64::NAN);
        assert!(matches!(a.fallback, Some(CompoundEyeError::Input(_))));
        assert!(
            a.origin.is_finite()
                && a.u.is_finite()
                && (a.u.length() - DEFAULT_FALLBACK_CELL).abs() < 1e-15
        );
    }

    #[test]
    fn mirrored_uv_flips_handedness_not_the_normal() {
        let p = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let t = [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0)];
        let tm = t.map(|x| DVec2::new(-x.x, x.y)); // mirrored in a: det A = −1
        let a = TextureAxes::from_triangle(p, t).unwrap();
        let m = TextureAxes::from_triangle(p, tm).unwrap();
        assert_eq!(a.handedness, 1.0);
        assert_eq!(m.handedness, -1.0);
        // The normal follows the winding in both, so lenses stay under the surface.
        assert_eq!(a.normal, m.normal);
        assert!(close(m.u, -a.u, 1e-15) && close(m.v, a.v, 1e-15));
        assert!(m.u.cross(m.v).dot(m.normal) < 0.0);
        assert_eq!(m.tangent_vec4().w, -1.0);
        // Bevy convention: w·(N × T) has a positive component along V_p.
        let t4 = m.tangent_vec4();
        assert!(t4.w * m.normal.cross(t4.truncate()).dot(m.v) > 0.0);
        let q = DVec3::new(0.3, 0.6, 0.0);
        let (ua, um) = (a.uv_of(q), m.uv_of(q));
        assert!((ua - DVec2::new(-um.x, um.y)).length() < 1e-15);
    }

    #[test]
    fn from_axes_rejects_a_normal_off_the_lattice_plane() {
        // (1, 0, 1)/√2 is 45° off U × V = +z: the lenses would sit off their
        // cells' columns and poke through the polygon.
        let tilted = DVec3::new(1.0, 0.0, 1.0) / 2f64.sqrt();
        match TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, tilted) {
            Err(CompoundEyeError::NormalNotPerpendicular { cos }) => {
                assert!((cos - tilted.z).abs() < 1e-15)
            }
            other => panic!("{other:?}"),
        }
        // In the plane: rejected too, not a handedness of +1.
        assert!(matches!(
            TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::X),
            Err(CompoundEyeError::NormalNotPerpendicular { .. })
        ));
        // 1e-3 rad off: still rejected (the tolerance is 1 − cos ≤ 1e-9).
        let off = DVec3::new(1e-3, 0.0, 1.0);
        assert!(TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, off).is_err());
        // Within the tolerance, and of any length: only the side is taken; the
        // stored normal is exactly ±(U × V)/|U × V|.
        let a = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1e-6, 0.0, 3.0))
            .unwrap();
        assert_eq!((a.normal(), a.handedness()), (DVec3::Z, 1.0));
        let m = TextureAxes::from_axes(
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::new(0.0, -1e-6, -0.5),
        )
        .unwrap();
        assert_eq!((m.normal(), m.handedness()), (DVec3::NEG_Z, -1.0));
        // Depth along N and the uv projection stay independent.
        let q = DVec3::new(0.3, 0.7, -0.4);
        assert_eq!(a.uv_of(q), DVec2::new(0.3, 0.7));
        assert_eq!(a.depth(q), 0.4);
        match TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ZERO) {
            Err(CompoundEyeError::Input(e)) => assert_eq!(
                (e.what, e.expected),
                ("lattice normal", Expected::Direction)
            ),
            other => panic!("{other:?}"),
        }
        match TextureAxes::from_axes(
            DVec3::ZERO,
            DVec3::new(0.0, f64::NAN, 0.0),
            DVec3::Y,
            DVec3::Z,
        ) {
            Err(CompoundEyeError::Input(e)) => {
                assert_eq!(e.what, "lattice axis U_p (mesh units per facet)")
            }
            other => panic!("{other:?}"),
        }
        // Parallel axes: the error carries the sine of their angle.
        match TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1e-7, 0.0), DVec3::Z) {
            Err(CompoundEyeError::DegenerateUv { det }) => {
                assert!((det - 1e-7).abs() < 1e-12, "{det}")
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            TextureAxes::from_axes(DVec3::ZERO, DVec3::ZERO, DVec3::Y, DVec3::Z),
            Err(CompoundEyeError::DegenerateUv { det: 0.0 })
        );
    }

    #[test]
    fn getters_match_the_cached_gram_determinant() {
        // With private fields, the axes read back are the ones the cached Gram
        // determinant belongs to: uv_rate and cell_heights use them consistently.
        let a = TextureAxes::from_axes(
            DVec3::ONE,
            2.0 * DVec3::X,
            DVec3::new(0.5, 1.0, 0.0),
            DVec3::Z,
        )
        .unwrap();
        assert_eq!(
            (a.origin(), a.u(), a.v()),
            (DVec3::ONE, 2.0 * DVec3::X, DVec3::new(0.5, 1.0, 0.0))
        );
        assert_eq!(a.fallback(), None);
        assert!((a.uv_rate(a.u()) - DVec2::X).length() < 1e-15);
        assert!((a.uv_rate(a.v()) - DVec2::Y).length() < 1e-15);
        // Cell: a parallelogram of area 2 with sides 2 and √1.25.
        let (hu, hv) = a.cell_heights();
        assert!((hu - 2.0 / 1.25f64.sqrt()).abs() < 1e-15 && (hv - 1.0).abs() < 1e-15);
    }

    #[test]
    fn scale_uv_is_eq_6_1() {
        assert_eq!(
            scale_uv(DVec2::new(0.25, 0.5), 40.0),
            Ok(DVec2::new(10.0, 20.0))
        );
        for bad in [0.0, -3.0, f64::NAN, f64::INFINITY] {
            let e = scale_uv(DVec2::ONE, bad).unwrap_err();
            assert_eq!(
                (e.what, e.expected),
                (
                    "texture resolution R_t (facets per UV unit)",
                    Expected::Positive
                )
            );
        }
        assert_eq!(
            scale_uv(DVec2::new(f64::NAN, 0.0), 40.0)
                .unwrap_err()
                .expected,
            Expected::FiniteVector
        );
    }

    proptest! {
        #[test]
        fn finite_triangles_give_finite_axes_or_typed_error(
            p in prop::array::uniform9(-1e3f64..1e3),
            t in prop::array::uniform6(-1e2f64..1e2),
        ) {
            let p = [DVec3::new(p[0], p[1], p[2]), DVec3::new(p[3], p[4], p[5]), DVec3::new(p[6], p[7], p[8])];
            let t = [DVec2::new(t[0], t[1]), DVec2::new(t[2], t[3]), DVec2::new(t[4], t[5])];
            match TextureAxes::from_triangle(p, t) {
                Ok(a) => {
                    prop_assert!(a.u.is_finite() && a.v.is_finite() && a.origin.is_finite());
                    for q in p {
                        prop_assert!(a.uv_of(q).is_finite());
                    }
                }
                Err(e) => {
                    let typed = matches!(e, CompoundEyeError::DegenerateUv { .. } | CompoundEyeError::DegenerateTriangle);
                    prop_assert!(typed, "{:?}", e);
                }
            }
            let f = TextureAxes::from_triangle_or_fallback(p, t, 0.5);
            prop_assert!(f.u.is_finite() && f.v.is_finite() && f.origin.is_finite() && f.normal.is_finite());
            prop_assert!(f.uv_of(p[0]).is_finite());
        }

        /// Whatever normal is given, accepted axes have N a unit vector
        /// perpendicular to U_p and V_p, with the handedness its side.
        #[test]
        fn from_axes_normal_is_perpendicular_or_rejected(
            u in prop::array::uniform3(-10.0f64..10.0),
            v in prop::array::uniform3(-10.0f64..10.0),
            n in prop::array::uniform3(-1.0f64..1.0),
            snap in prop::bool::ANY,
        ) {
            let (u, v) = (DVec3::from(u), DVec3::from(v));
            // Half the cases: a normal near ±(U × V), to exercise acceptance.
            let n = if snap { u.cross(v) * n[0].signum() + 1e-7 * DVec3::from(n) * u.cross(v).length() } else { DVec3::from(n) };
            if let Ok(a) = TextureAxes::from_axes(DVec3::ZERO, u, v, n) {
                let scale = u.length() * v.length();
                prop_assert!((a.normal().length() - 1.0).abs() < 1e-15);
                prop_assert!(a.normal().dot(u).abs() <= 1e-12 * u.length());
                prop_assert!(a.normal().dot(v).abs() <= 1e-12 * v.length());
                prop_assert!(a.handedness() * u.cross(v).dot(a.normal()) > 0.0);
                prop_assert!(n.dot(a.normal()) > 0.0);
                prop_assert!(a.depth(u + v).abs() <= 1e-12 * (1.0 + scale));
            }
        }
    }

    /// A plane with sheared, stretched UVs: every triangle has the same
    /// axes, so the field holds them exactly and `on_field` rebuilds them.
    #[test]
    fn a_field_over_affine_uvs_rebuilds_the_triangles_axes() {
        let positions: Vec<DVec3> = (0..9)
            .map(|k| DVec3::new(f64::from(k % 3), f64::from(k / 3), 0.0))
            .collect();
        let uvs: Vec<DVec2> = positions
            .iter()
            .map(|p| DVec2::new(-1.3 * p.x + 0.4 * p.y, 0.8 * p.y + 0.1 * p.x))
            .collect();
        let normals = vec![DVec3::Z; 9];
        let mut triangles = vec![];
        for j in 0..2u32 {
            for i in 0..2u32 {
                let a = j * 3 + i;
                triangles.push([a, a + 1, a + 4]);
                triangles.push([a, a + 4, a + 3]);
            }
        }
        let field = axis_field(&positions, &normals, &uvs, &triangles);
        let tri = [0, 1, 4].map(|k| positions[k]);
        let axes = TextureAxes::from_triangle(tri, [0, 1, 4].map(|k| uvs[k])).unwrap();
        for (k, f) in field.iter().enumerate() {
            let rebuilt = axes.on_field(positions[k], f.tangent.truncate(), f.shape);
            assert!(
                close(rebuilt.u(), axes.u(), 1e-12),
                "{k}: {rebuilt:?} {axes:?}"
            );
            assert!(
                close(rebuilt.v(), axes.v(), 1e-12),
                "{k}: {rebuilt:?} {axes:?}"
            );
            assert!(close(rebuilt.origin(), axes.origin(), 1e-12));
            assert_eq!(f.tangent.w, axes.handedness());
        }
        // Mirrored UVs: the handedness follows.
        let mirrored: Vec<DVec2> = uvs.iter().map(|t| DVec2::new(-t.x, t.y)).collect();
        let field = axis_field(&positions, &normals, &mirrored, &triangles);
        assert!(field.iter().all(|f| f.tangent.w == -axes.handedness()));
    }

    /// On a UV sphere's rows the UVs' stretch changes at every edge; the
    /// field at a vertex lies between its triangles' axes.
    #[test]
    fn the_field_averages_the_stretch_of_a_vertex_s_triangles() {
        // Two rows of a latitude band, stretched differently.
        let ring = |lat: f64| -> Vec<DVec3> {
            (0..3)
                .map(|i| {
                    let lon = f64::from(i) * 0.4;
                    DVec3::new(lat.cos() * lon.cos(), lat.sin(), lat.cos() * lon.sin())
                })
                .collect()
        };
        let positions: Vec<DVec3> = [0.0, 0.45, 0.9].into_iter().flat_map(ring).collect();
        let uvs: Vec<DVec2> = (0..9)
            .map(|k| DVec2::new(f64::from(k % 3) * 0.4, f64::from(k / 3) * 0.45))
            .collect();
        let normals: Vec<DVec3> = positions.clone();
        let triangles = vec![[0, 3, 1], [1, 3, 4], [3, 6, 4], [4, 6, 7]];
        let field = axis_field(&positions, &normals, &uvs, &triangles);
        let aspect = |t: [u32; 3]| {
            let a = TextureAxes::from_triangle(
                t.map(|k| positions[k as usize]),
                t.map(|k| uvs[k as usize]),
            )
            .unwrap();
            a.cell_heights().1 / a.u().length()
        };
        // Vertex 4's triangles: one below it, two above (1.10 to 1.60).
        let aspects = [aspect([1, 3, 4]), aspect([3, 6, 4]), aspect([4, 6, 7])];
        let (lo, hi) = (
            aspects.iter().copied().fold(f64::INFINITY, f64::min),
            aspects.iter().copied().fold(0.0, f64::max),
        );
        let middle = field[4].shape.y;
        assert!(hi > 1.3 * lo, "{aspects:?}");
        assert!(middle > lo && middle < hi, "{lo} < {middle} < {hi}");
        assert!((field[4].tangent.truncate().length() - 1.0).abs() < 1e-12);
        assert!(field[4].tangent.truncate().dot(normals[4]).abs() < 1e-12);
    }

    #[test]
    fn a_field_without_usable_triangles_is_neutral_and_on_field_falls_back() {
        let positions = vec![DVec3::ZERO, DVec3::X, 2.0 * DVec3::X, DVec3::Y];
        let uvs = vec![DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE];
        // Collinear positions, an index out of range.
        let field = axis_field(&positions, &[], &uvs, &[[0, 1, 2], [0, 1, 9]]);
        assert!(
            field
                .iter()
                .all(|f| f.tangent == DVec4::ZERO && f.shape == DVec2::Y)
        );
        let axes = TextureAxes::from_axes(DVec3::ZERO, 2.0 * DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        let at = DVec3::new(0.3, 0.2, 0.0);
        assert_eq!(axes.on_field(at, DVec3::ZERO, DVec2::Y), axes);
        for bad in [DVec2::NAN, DVec2::ZERO, DVec2::new(0.0, -1.0)] {
            assert_eq!(
                axes.on_field(at, DVec3::X, bad),
                axes.on_tangent(at, DVec3::X)
            );
        }
    }

    proptest! {
        /// Any mesh, degenerate, non-finite or with indices out of range,
        /// gives one finite field vertex per position: a unit tangent in
        /// the normal's plane with a positive aspect, or the neutral value.
        #[test]
        fn any_mesh_gives_a_finite_field(
            positions in prop::collection::vec(prop::array::uniform3(prop_oneof![9 => -2.0f64..2.0, 1 => Just(f64::NAN), 1 => Just(1e300)]), 3..12),
            uvs in prop::collection::vec(prop::array::uniform2(prop_oneof![9 => -2.0f64..2.0, 1 => Just(f64::INFINITY)]), 0..12),
            triangles in prop::collection::vec(prop::array::uniform3(0u32..14), 0..16),
        ) {
            let positions: Vec<DVec3> = positions.into_iter().map(DVec3::from).collect();
            let uvs: Vec<DVec2> = uvs.into_iter().map(DVec2::from).collect();
            let field = axis_field(&positions, &[], &uvs, &triangles);
            prop_assert_eq!(field.len(), positions.len());
            for f in field {
                prop_assert!(f.tangent.is_finite() && f.shape.is_finite(), "{:?}", f);
                let t = f.tangent.truncate();
                prop_assert!(t == DVec3::ZERO || ((t.length() - 1.0).abs() < 1e-9 && f.shape.y > 0.0), "{:?}", f);
            }
        }
    }
}
