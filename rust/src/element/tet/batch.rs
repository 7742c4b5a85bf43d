//! The `f64` kernels of [`LANES`] tets at once, as structure of arrays: every scalar of the
//! one-tet kernels becomes an array of one value per tet, so that the compiler evaluates
//! the tets side by side in vector registers.
//!
//! Every lane performs exactly the floating-point operations of the one-tet path, in the
//! same order ([`local_tet`](crate::local_tet) for a tet in R^3, [`super::well_shaped`],
//! [`super::primal_weights`], [`super::dual`], [`super::volume`]), so its values are bit for
//! bit those of that path. A lane that the one-tet path would send anywhere else is not
//! [`Frames::plain`]: its differences leave the normal range (the frame's prescaling), its
//! determinant is not trusted (computed exactly instead), it is not well shaped (the
//! precise path), or it is flat. The caller computes those lanes one by one
//! (`crate::element::evaluate`).
//!
//! Operation counts per tet (additions, multiplications, divisions, comparisons; the
//! `criterion` bench `benches/kernels.rs` prints them beside the time per tet):
//! [`FRAME_FLOPS`], [`PRIMAL_FLOPS`], [`DUAL_FLOPS`], [`MASS_FLOPS`].

use super::{EDGES, OPPOSITE, WELL_SHAPED};
use crate::element::exact::{DET_ERROR, DET_RTOL};
use crate::element::metric::Tensor;

/// Tets per batch.
pub const LANES: usize = 8;

/// One value per tet of a batch.
pub type Lanes = [f64; LANES];

/// Floating-point operations per tet of [`Frames::new`]: edges and their scaling (12), the
/// determinant and its error bound (9 + 15 + 3), the face normals (6 + 4 x 9), their
/// squared lengths (4 x 5), the circumcentre (3 x 5 + 6 + 4) and the well-shapedness test
/// (3 + 4 + 5 + 3), range checks and maxima (13).
pub const FRAME_FLOPS: u32 = 12 + 27 + 42 + 20 + 25 + 15 + 13;
/// Floating-point operations per tet of [`Frames::primal`] beyond the frame: the factor
/// (3), six dot products of normals, scaled (6 x 6), and the four diagonal entries (4).
pub const PRIMAL_FLOPS: u32 = 3 + 36 + 4;
/// Floating-point operations per tet of [`Frames::dual`] beyond the frame: barycentric
/// coordinates of the circumcentre (3 + 4 x 6), their factors (4 x 3), and per edge two
/// dot products of differences (2 x 11), the weight (4), the pieces (9) and their sums (2),
/// then the scaling of the cell volumes (12).
pub const DUAL_FLOPS: u32 = 27 + 12 + 6 * (22 + 4 + 9 + 2) + 12;
/// Floating-point operations per tet of [`Frames::volume`] (the barycentric mass adds 1).
pub const MASS_FLOPS: u32 = 5;

/// `f(lane)` for every lane.
#[inline(always)]
pub(crate) fn lanes(f: impl FnMut(usize) -> f64) -> Lanes {
    std::array::from_fn(f)
}

/// Three coordinates of one vector per lane.
#[derive(Clone, Copy)]
struct V3 {
    x: Lanes,
    y: Lanes,
    z: Lanes,
}

impl V3 {
    const ZERO: V3 = V3 { x: [0.0; LANES], y: [0.0; LANES], z: [0.0; LANES] };

    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3 { x: lanes(|i| self.x[i] - o.x[i]), y: lanes(|i| self.y[i] - o.y[i]), z: lanes(|i| self.z[i] - o.z[i]) }
    }

    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3 { x: lanes(|i| self.x[i] + o.x[i]), y: lanes(|i| self.y[i] + o.y[i]), z: lanes(|i| self.z[i] + o.z[i]) }
    }

    /// `s v` (glam's `f64 * DVec3`).
    #[inline(always)]
    fn scaled(s: Lanes, v: V3) -> V3 {
        V3 { x: lanes(|i| s[i] * v.x[i]), y: lanes(|i| s[i] * v.y[i]), z: lanes(|i| s[i] * v.z[i]) }
    }

    #[inline(always)]
    fn times(self, s: Lanes) -> V3 {
        V3 { x: lanes(|i| self.x[i] * s[i]), y: lanes(|i| self.y[i] * s[i]), z: lanes(|i| self.z[i] * s[i]) }
    }

    #[inline(always)]
    fn over(self, s: Lanes) -> V3 {
        V3 { x: lanes(|i| self.x[i] / s[i]), y: lanes(|i| self.y[i] / s[i]), z: lanes(|i| self.z[i] / s[i]) }
    }

    /// glam's `dot`: `(x x') + (y y') + (z z')`.
    #[inline(always)]
    fn dot(self, o: V3) -> Lanes {
        lanes(|i| (self.x[i] * o.x[i]) + (self.y[i] * o.y[i]) + (self.z[i] * o.z[i]))
    }

    /// glam's `cross`, term for term.
    #[inline(always)]
    fn cross(self, o: V3) -> V3 {
        V3 {
            x: lanes(|i| self.y[i] * o.z[i] - o.y[i] * self.z[i]),
            y: lanes(|i| self.z[i] * o.x[i] - o.z[i] * self.x[i]),
            z: lanes(|i| self.x[i] * o.y[i] - o.x[i] * self.y[i]),
        }
    }

    #[inline(always)]
    fn length_squared(self) -> Lanes {
        self.dot(self)
    }
}

/// `if a > b { a } else { b }` per lane (glam's maximum).
#[inline(always)]
fn max(a: Lanes, b: Lanes) -> Lanes {
    lanes(|i| if a[i] > b[i] { a[i] } else { b[i] })
}

/// The frames of [`LANES`] tets in R^3 and the quantities the kernels share.
pub struct Frames {
    /// The corners in the frame: `0, e1, e2, e3`.
    x: [V3; 4],
    normals: [V3; 4],
    /// `|n_l|^2`.
    normal2: [Lanes; 4],
    /// The circumcentre relative to corner 0.
    centre: V3,
    /// The scale of each frame (a power of two).
    pub scale: Lanes,
    /// `det[e1, e2, e3]` of the scaled edges.
    pub det: Lanes,
    /// Whether each lane is a plain tet: one that the one-tet path computes by the formulas
    /// of this batch (see the module docs); the others' values here are meaningless.
    pub plain: [bool; LANES],
}

/// The scaled edges of [`LANES`] tets in R^3, their scales, float determinants and
/// whether each is the one-tet path's frame: what [`Frames`] are built from.
pub struct Edges {
    e: [V3; 3],
    /// The scale of each frame (a power of two).
    pub scale: Lanes,
    /// `det[e1, e2, e3]` of the scaled edges, in `f64`.
    pub det: Lanes,
    /// Whether each lane's frame is the one-tet path's: its differences in range, its float
    /// determinant trusted (well-shaped or not).
    pub framed: [bool; LANES],
}

impl Edges {
    /// The edges of the tets with corners `corners[k][axis][lane]`.
    #[inline(always)]
    pub fn new(corners: &[[Lanes; 3]; 4]) -> Self {
        let p = |k: usize| V3 { x: corners[k][0], y: corners[k][1], z: corners[k][2] };
        let e = [p(1).sub(p(0)), p(2).sub(p(0)), p(3).sub(p(0))];
        // the largest difference component, in [2^-1000, 2^1000) for the plain frame
        let (a0, a1, a2) = (abs(e[0]), abs(e[1]), abs(e[2]));
        let m = V3 { x: max(max(a0.x, a1.x), a2.x), y: max(max(a0.y, a1.y), a2.y), z: max(max(a0.z, a1.z), a2.z) };
        let max_abs = max(max(m.x, m.y), m.z);
        // 2^-k and 2^k for the exponent k with max_abs / 2^k in [1/2, 1): from the biased
        // exponent b of max_abs, k = b - 1022 (meaningless, but harmless, out of range)
        let biased: [u64; LANES] = std::array::from_fn(|i| (max_abs[i].to_bits() >> 52) & 0x7ff);
        let inv = lanes(|i| f64::from_bits(2045u64.wrapping_sub(biased[i]) << 52));
        let scale = lanes(|i| f64::from_bits(biased[i].wrapping_add(1) << 52));
        let e = e.map(|v| v.times(inv));
        let in_range = std::array::from_fn(|i| (TINY_DIFF..HUGE_DIFF).contains(&max_abs[i]));
        let (det, framed) = trusted(&e, in_range);
        Edges { e, scale, det, framed }
    }

    /// The volume of every lane ([`super::volume`]).
    #[inline]
    pub fn volume(&self) -> Lanes {
        let s = self.scale;
        lanes(|i| self.det[i].abs() / 6.0 * s[i] * s[i] * s[i])
    }
}

/// `|v|` per component.
#[inline(always)]
fn abs(v: V3) -> V3 {
    V3 { x: lanes(|i| v.x[i].abs()), y: lanes(|i| v.y[i].abs()), z: lanes(|i| v.z[i].abs()) }
}

/// The float determinant of the edges `e` and which lanes have it trusted
/// ([`crate::element::exact::trusted`], its error bound from the permanent) among those
/// `in_range`.
#[inline(always)]
fn trusted(e: &[V3; 3], in_range: [bool; LANES]) -> (Lanes, [bool; LANES]) {
    let [e1, e2, e3] = *e;
    let det = e1.dot(e2.cross(e3));
    let a = [abs(e1), abs(e2), abs(e3)];
    let permanent = lanes(|i| {
        a[0].x[i] * (a[1].y[i] * a[2].z[i] + a[1].z[i] * a[2].y[i])
            + a[0].y[i] * (a[1].x[i] * a[2].z[i] + a[1].z[i] * a[2].x[i])
            + a[0].z[i] * (a[1].x[i] * a[2].y[i] + a[1].y[i] * a[2].x[i])
    });
    (det, std::array::from_fn(|i| in_range[i] && DET_ERROR * permanent[i] <= DET_RTOL * det[i].abs()))
}

impl Frames {
    /// The frames of the tets with corners `corners[k][axis][lane]`.
    #[inline]
    pub fn new(corners: &[[Lanes; 3]; 4]) -> Self {
        Self::of(&Edges::new(corners))
    }

    /// The frames of `edges`.
    #[inline(always)]
    pub fn of(edges: &Edges) -> Self {
        Self::with(edges.e, edges.det, edges.scale, None, edges.framed)
    }

    /// The frames of edges `e` (scaled by `scale`) of determinant `det`: the quantities the
    /// kernels share, and which lanes are plain: `framed`, and well-shaped with the
    /// radius-ratio bound widened by `sqrt(slack)` ([`super::well_shaped_within`]; `None`:
    /// [`super::well_shaped`]).
    #[inline(always)]
    fn with(e: [V3; 3], det: Lanes, scale: Lanes, slack: Option<Lanes>, framed: [bool; LANES]) -> Self {
        let [e1, e2, e3] = e;
        let normals = [e3.sub(e1).cross(e2.sub(e1)), e2.cross(e3), e3.cross(e1), e1.cross(e2)];
        let normal2 = normals.map(|n| n.length_squared());
        let x = [V3::ZERO, e1, e2, e3];
        let centre = V3::scaled(e1.length_squared(), normals[1])
            .add(V3::scaled(e2.length_squared(), normals[2]))
            .add(V3::scaled(e3.length_squared(), normals[3]))
            .over(lanes(|i| 2.0 * det[i]));
        // well shaped (radius ratio >= WELL_SHAPED), as super::well_shaped tests it
        let largest = max(max(normal2[0], normal2[1]), max(normal2[2], normal2[3]));
        let c2 = centre.length_squared();
        let plain = std::array::from_fn(|i| {
            let det2 = det[i] * det[i];
            let bound = match slack {
                None => 16.0 * WELL_SHAPED * WELL_SHAPED * largest[i] * c2[i],
                Some(slack) => 16.0 * WELL_SHAPED * WELL_SHAPED * slack[i] * largest[i] * c2[i],
            };
            framed[i] && det2 >= f64::MIN_POSITIVE && 9.0 * det2 >= bound
        });
        Frames { x, normals, normal2, centre, scale, det, plain }
    }

    /// The frames of tets (their `edges`, corners `x(lane)`) mapped by `tensors` (one per
    /// lane), as [`crate::element::metric::mapped_tet`] maps one tet, bit for bit: the
    /// mapped edges (`metric::map_edges_lanes`) scaled by a power of two,
    /// their determinant from the tet's, the shape test with its slack. Lanes whose frame
    /// is not [`Edges::framed`] are not plain.
    #[inline(always)]
    pub fn mapped<'p>(edges: &Edges, x: impl Fn(usize) -> [&'p [f64]; 4], tensors: &[Tensor<3>; LANES]) -> Frames {
        let e = edges.e.map(|v| [v.x, v.y, v.z]);
        let (y, err) = crate::element::metric::map_edges_lanes(x, e, edges.scale, tensors);
        let mut scale = [0.0; LANES];
        let mut det = [0.0; LANES];
        let mut slack = [f64::INFINITY; LANES];
        let mut in_range = [false; LANES];
        let mut mapped = [V3::ZERO; 3];
        for i in 0..LANES {
            let frame = crate::element::metric::frame_of_mapped(&y[i], err[i], edges.det[i], edges.scale[i], &tensors[i]);
            let Some((inv, s, d, q)) = frame else { continue };
            for (v, edge) in mapped.iter_mut().enumerate() {
                (edge.x[i], edge.y[i], edge.z[i]) = (y[i][v][0] * inv, y[i][v][1] * inv, y[i][v][2] * inv);
            }
            (scale[i], det[i], slack[i], in_range[i]) = (s, d, q, edges.framed[i]);
        }
        let (_, framed) = trusted(&mapped, in_range);
        Self::with(mapped, det, scale, Some(slack), framed)
    }

    /// The primal weights and diagonal entries of every lane ([`super::primal`]),
    /// `[edge][lane]` and `[corner][lane]`.
    #[inline]
    pub fn primal(&self) -> ([Lanes; 6], [Lanes; 4]) {
        let k = lanes(|i| -self.scale[i] / (6.0 * self.det[i].abs()));
        let weights = EDGES.map(|(a, b)| {
            let d = self.normals[a].dot(self.normals[b]);
            lanes(|i| d[i] * k[i])
        });
        (weights, self.normal2.map(|n| lanes(|i| n[i] * k[i])))
    }

    /// The dual weights and cell volumes of every lane ([`super::dual`]), `[edge][lane]`
    /// and `[corner][lane]`.
    #[inline]
    pub fn dual(&self) -> ([Lanes; 6], [Lanes; 4]) {
        let (x, n, c, det) = (&self.x, &self.normals, self.centre, self.det);
        let lambda = [n[0].dot(c.sub(x[1])), n[1].dot(c), n[2].dot(c), n[3].dot(c)].map(|d| lanes(|i| d[i] / det[i]));
        let g: [Lanes; 4] = std::array::from_fn(|l| lanes(|i| lambda[l][i] * det[i].abs() / 4.0));
        let g: [Lanes; 4] = std::array::from_fn(|l| lanes(|i| g[l][i] / self.normal2[l][i]));
        let mut weights = [[0.0; LANES]; 6];
        let mut cells = [[0.0; LANES]; 4];
        for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
            let dot_k = x[a].sub(x[k]).dot(x[b].sub(x[k]));
            let dot_l = x[a].sub(x[l]).dot(x[b].sub(x[l]));
            let w = lanes(|i| dot_k[i] * g[l][i] + dot_l[i] * g[k][i]);
            weights[e] = lanes(|i| w[i] * self.scale[i]);
            let ab = x[a].sub(x[b]).length_squared();
            let pieces = lanes(|i| ab[i] * w[i] / 6.0);
            cells[a] = lanes(|i| cells[a][i] + pieces[i]);
            cells[b] = lanes(|i| cells[b][i] + pieces[i]);
        }
        let s = self.scale;
        (weights, cells.map(|v| lanes(|i| v[i] * s[i] * s[i] * s[i])))
    }

    /// The volume of every lane ([`super::volume`]).
    #[inline]
    pub fn volume(&self) -> Lanes {
        let s = self.scale;
        lanes(|i| self.det[i].abs() / 6.0 * s[i] * s[i] * s[i])
    }
}

/// The range of the largest difference component of a plain frame: `[2^-1000, 2^1000)`.
const TINY_DIFF: f64 = f64::from_bits(((1023 - 1000) as u64) << 52);
const HUGE_DIFF: f64 = f64::from_bits(((1023 + 1000) as u64) << 52);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::frame::local_tet;
    use crate::element::tet::{dual, primal, volume, well_shaped};

    /// Tets of every kind the one-tet path tells apart: plain, flat, slivers, needles,
    /// tiny and huge ones, random ones far from the origin.
    fn tets() -> Vec<[[f64; 3]; 4]> {
        let mut state = 7u64;
        let mut uniform = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut out: Vec<[[f64; 3]; 4]> = vec![
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.3, 0.3, 0.0]],
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.3, 0.3, 1e-9]],
            [[0., 0., 0.], [1e-100, 0., 0.], [0., 1e-100, 0.], [0., 0., 1.]],
            [[0., 0., 0.], [1e-310, 0., 0.], [0., 1e-310, 0.], [0., 0., 1e-310]],
            [[0., 0., 0.], [1e300, 0., 0.], [0., 1e300, 0.], [0., 0., 1e300]],
            [[1e6, 1e6, 1e6], [1e6 + 1.0, 1e6, 1e6], [1e6, 1e6 + 1.0, 1e6], [1e6, 1e6, 1e6 + 1e-8]],
        ];
        for k in 0..400 {
            let offset = [uniform() * 100.0, uniform(), uniform() * 1e4];
            let flat = if k % 3 == 0 { 1e-7 } else { 1.0 };
            out.push(std::array::from_fn(|_| {
                let p = [uniform(), uniform(), uniform() * flat];
                std::array::from_fn(|a| p[a] + offset[a])
            }));
        }
        out
    }

    #[test]
    fn every_plain_lane_is_bitwise_the_one_tet_path() {
        let tets = tets();
        let mut plain = 0;
        for batch in tets.chunks(LANES) {
            let corners: [[Lanes; 3]; 4] =
                std::array::from_fn(|k| std::array::from_fn(|a| lanes(|i| batch.get(i).map_or(0.0, |t| t[k][a]))));
            let f = Frames::new(&corners);
            let ((p, pd), (w, m), v) = (f.primal(), f.dual(), f.volume());
            for (i, x) in batch.iter().enumerate() {
                let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
                let expect_plain = t.det != 0.0 && well_shaped(&t) && f.scale[i] == t.scale && f.det[i] == t.det
                    && crate::element::exact::trusted(t.det, crate::element::exact::permanent(t.edges.map(|e| e.to_array())));
                if !f.plain[i] {
                    continue;
                }
                plain += 1;
                assert!(expect_plain, "tet {x:?} is plain in the batch only");
                assert_eq!(f.det[i].to_bits(), t.det.to_bits());
                let (d, q) = (dual(&t), primal(&t));
                for e in 0..6 {
                    assert_eq!(p[e][i].to_bits(), q.weights[e].to_bits(), "{x:?}");
                    assert_eq!(w[e][i].to_bits(), d.weights[e].to_bits(), "{x:?}");
                }
                for c in 0..4 {
                    assert_eq!(pd[c][i].to_bits(), q.diagonal[c].to_bits(), "{x:?}");
                    assert_eq!(m[c][i].to_bits(), d.cell_volumes[c].to_bits(), "{x:?}");
                }
                assert_eq!(v[i].to_bits(), volume(&t).to_bits());
            }
        }
        assert!(plain > 200, "{plain} plain tets");
    }

    #[test]
    fn lanes_the_one_tet_path_treats_otherwise_are_not_plain() {
        for x in tets() {
            let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
            let corners: [[Lanes; 3]; 4] = std::array::from_fn(|k| std::array::from_fn(|a| [x[k][a]; LANES]));
            let f = Frames::new(&corners);
            let trusted = crate::element::exact::trusted(
                t.edges[0].dot(t.edges[1].cross(t.edges[2])),
                crate::element::exact::permanent(t.edges.map(|e| e.to_array())),
            );
            if t.det == 0.0 || !well_shaped(&t) || !trusted {
                assert!(!f.plain[0], "{x:?}");
            }
        }
    }
}
