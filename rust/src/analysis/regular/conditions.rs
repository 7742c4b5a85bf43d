//! The local regularity condition of every interior face, linear in the vertex weights.
//!
//! For the interior face `abc` shared by the tets `t1 = abcp` and `t2 = abcq`, lift every
//! point to `(x, |x|^2 - w)`. The face is *locally regular* when the lifted `q` lies above
//! the hyperplane through the lifted `a, b, c, p`: the sign of the lifted determinant
//!
//! ```text
//! D(w) = orient(t1) * det[ e_i , |e_i|^2 - (w_i - w_q) ]_{i = corners of t1},  e_i = x_i - x_q
//! ```
//!
//! Divided by `norm = 2 |n| |h_p| |h_q| l` (`|n|` twice the face's area, `h_p`, `h_q` the
//! heights of `p` and `q` over it, `l` its RMS edge length) it is the face's *margin*: the
//! signed length of its power-diagram edge, from the power centre of `t1` to that of `t2`
//! along the face normal towards `t2`, over `l`. Scale-free, and affine in `w`:
//!
//! ```text
//! margin(w) = g0 + sum_k coefficients[k] * w[vertices[k]]
//! ```
//!
//! with `vertices` the four corners of `t1` in its element order, then `q`. It vanishes for
//! `w = |x|^2` (a flat lifting). A *folded* face (both tets on one side of it) has a second
//! row, seen from `t2`, of the opposite sign for every `w`.
//!
//! Every face is computed in its own frame: translated to `x_q` and scaled by the power of
//! two that brings the largest difference into `[1/2, 1)` (exact), so that coordinates
//! near the float range neither overflow nor underflow. A row whose rounding errors there
//! may exceed `2^-20` (bounded from the permanents of its determinants: a needle's base
//! seen from its far apex, a sliver) is computed in exact rational arithmetic instead, so
//! that only an exactly flat tet has no row, and only a value beyond the `f64` range is
//! infinite, as everywhere in the library.

use crate::element::exact::DET_ERROR;
use crate::element::rational::{exactly, ldexp, Exact};
use crate::element::tet::FACES;
use crate::error::{Error, Result};
use crate::mesh::TetView;
use crate::options::Options;
use crate::assembly::CHUNK;
use glam::DVec3;
use rayon::prelude::*;

/// The affine margins of the interior faces of a mesh (module docs).
///
/// Row `f < n_faces` is interior face `f` (the order of [`crate::Faces::interior`]) seen from
/// its first tet; the rows after those are the folded faces seen from their second tet.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Conditions {
    /// The five vertices of every row: the first tet's corners in its element order, then
    /// the opposite vertex of the second tet.
    pub vertices: Vec<[u32; 5]>,
    /// Every row's margin at `w = 0`.
    pub g0: Vec<f64>,
    /// `d margin / d w` of every row's five vertices (units `1 / length^2`).
    pub coefficients: Vec<[f64; 5]>,
    /// The interior face of every row.
    pub face: Vec<u32>,
    /// Number of interior faces (the first `n_faces` rows).
    pub n_faces: usize,
    /// Per interior face: both tets lie on the same side of it.
    pub folded: Vec<bool>,
    /// Interior faces with an exactly flat tet on one side (no power centre: the margin is
    /// undefined), ascending; their rows hold NaN.
    pub flat: Vec<u32>,
    /// Interior faces with a value of a row beyond the `f64` range (infinite), ascending.
    pub beyond_range: Vec<u32>,
}

/// One row: `(vertices, g0, coefficients, defined)`; not defined: a tet of the face is
/// exactly flat (no power centre), its values NaN.
type Row = ([u32; 5], f64, [f64; 5], bool);

/// A row and whether the face is folded (both tets strictly on one side of it).
type Viewed = (Row, bool);

/// The accuracy a row computed in `f64` must be proved to have, else it is computed
/// exactly: `2^-20` (about `1e-6`) relative for the face's size and heights and absolute on
/// the margin scale (the margin at `w = 0` and each weight's term for weights of the
/// frame's squared size). The search needs no more (the answers are checked on their own),
/// and the bounds are pessimistic: slivers keep their `f64` rows (accurate to about
/// `1e-12` on the corpus), needles beyond an aspect of about `1e5` take the exact path.
const ROW_TOL: f64 = 1.0 / (1u64 << 20) as f64;

/// The smallest magnitude the `f64` path accepts for the heights, the face's size and the
/// normalisation, far enough above the subnormals that no product of the row underflows.
const ROW_TINY: f64 = f64::from_bits(((1023 - 900) as u64) << 52);

/// `2^-k` with `max_abs * 2^-k` in `[1/2, 1)`, or 1 for zero or non-normal `max_abs`.
fn inverse_scale(max_abs: f64) -> f64 {
    if !(max_abs.is_normal()) {
        return 1.0;
    }
    let k = ((max_abs.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    // 2^-k is normal for every normal max_abs except near the top, where it is exact anyway
    2f64.powi(-k)
}

/// The absolute values of the components of `a`, plus those of `b`.
fn spread(a: DVec3, b: DVec3) -> DVec3 {
    a.abs() + b.abs()
}

/// The row of the face opposite corner `c` of `tet` (corner points `x`), seen from `tet`,
/// with `q` the opposite vertex of the other tet (point `xq`): in `f64` when its error
/// bounds prove it accurate to [`ROW_TOL`], else exactly ([`exact_row`]), so that a needle
/// or a sliver gets its true row and only an exactly flat tet none.
fn row(tet: [u32; 4], x: [DVec3; 4], c: usize, q: u32, xq: DVec3) -> Viewed {
    float_row(tet, x, c, q, xq).unwrap_or_else(|| exact_row(tet, x, c, q, xq))
}

/// [`row`] in `f64`, in the frame of `q` scaled to the largest difference; None when its
/// rounding errors (bounded from the permanents of its determinants) may exceed
/// [`ROW_TOL`]: the differences `x_i - x_q` are rounded, so a face far from `q` (a needle's
/// base seen from its apex) loses its shape to them.
fn float_row(tet: [u32; 4], x: [DVec3; 4], c: usize, q: u32, xq: DVec3) -> Option<Viewed> {
    let diff = x.map(|xi| xi - xq);
    let max_abs = diff.iter().fold(0.0f64, |m, d| m.max(d.abs().max_element()));
    let inv = inverse_scale(max_abs);
    let e = diff.map(|d| d * inv);
    let s = e.map(|v| v.length_squared());
    let (x23, x01) = (e[2].cross(e[3]), e[0].cross(e[1]));
    let cof = [-e[1].dot(x23), e[0].dot(x23), -e[3].dot(x01), e[2].dot(x01)];
    let a = e.map(|v| v.to_array());
    let perm = [det_perm(a[1], a[2], a[3]).1, det_perm(a[0], a[2], a[3]).1, det_perm(a[0], a[1], a[3]).1, det_perm(a[0], a[1], a[2]).1];
    // the face and the heights of p (corner c) and of q over it, in the same frame
    let f = FACES[c].map(|k| e[k]);
    let normal = (f[1] - f[0]).cross(f[2] - f[0]);
    let area2 = normal.length();
    let (op, oq) = ((e[c] - f[0]).dot(normal), (-f[0]).dot(normal));
    let hp = op / area2;
    let hq = oq / area2;
    let rms = (((f[1] - f[0]).length_squared() + (f[2] - f[1]).length_squared() + (f[0] - f[2]).length_squared())
        / 3.0)
        .sqrt();
    let norm = 2.0 * area2 * hp.abs() * hq.abs() * rms;
    // the tet's orientation determinant is minus the sum of the cofactors
    let sum = cof[0] + cof[1] + cof[2] + cof[3];
    let orient = -sum.signum();
    let k = orient / norm;
    // error bounds: every difference of two frame points is within 2 eps of the sum of
    // their absolute values, the cross product within 8 eps of the permanent of those sums
    let eps = f64::EPSILON / 2.0;
    let (u1, u2, u3) = (spread(f[1], f[0]), spread(f[2], f[0]), spread(e[c], f[0]));
    let span = DVec3::new(u1.y * u2.z + u1.z * u2.y, u1.z * u2.x + u1.x * u2.z, u1.x * u2.y + u1.y * u2.x);
    let edges = u1.length_squared() + spread(f[2], f[1]).length_squared() + u2.length_squared();
    let total: f64 = perm.iter().sum();
    let lifted: f64 = (0..4).map(|i| perm[i] * s[i]).sum();
    let accurate = [
        (8.0 * eps * span.length(), area2),
        (16.0 * eps * u3.dot(span), op.abs()),
        (16.0 * eps * f[0].abs().dot(span), oq.abs()),
        (2.0 * DET_ERROR * total, sum.abs()),
        (8.0 * eps * edges, rms * rms),
    ]
    .iter()
    .all(|&(error, value)| error <= ROW_TOL * value && value >= ROW_TINY);
    let terms = 3.0 * DET_ERROR * lifted.max(total) * k.abs();
    if !(accurate && norm >= ROW_TINY && norm.is_finite() && terms <= ROW_TOL) {
        return None;
    }
    let g0 = (cof[0] * s[0] + cof[1] * s[1] + cof[2] * s[2] + cof[3] * s[3]) * k;
    // coefficients in user units: the frame's squared lengths are the user's times inv^2
    let kw = k * inv * inv;
    let coefficients = [-cof[0] * kw, -cof[1] * kw, -cof[2] * kw, -cof[3] * kw, sum * kw];
    let vertices = [tet[0], tet[1], tet[2], tet[3], q];
    Some(((vertices, g0, coefficients, true), hp * hq > 0.0))
}

/// [`row`] in exact rational arithmetic from the input coordinates, rounded once per value
/// (within a few ulps): `margin = sign * D / (2 |O_p O_q|) * sqrt(3 N / L)`, with `O_p`,
/// `O_q` the orientation determinants of the face with `p` and with `q`, `N` the squared
/// norm of the face's normal, `L` the sum of its squared edge lengths (module docs). Not
/// defined only for an exactly flat tet; a value beyond the `f64` range is infinite.
fn exact_row(tet: [u32; 4], x: [DVec3; 4], c: usize, q: u32, xq: DVec3) -> Viewed {
    let vertices = [tet[0], tet[1], tet[2], tet[3], q];
    exactly(|| {
        type V3 = [Exact; 3];
        let sub = |a: V3, b: V3| -> V3 { [a[0] - b[0], a[1] - b[1], a[2] - b[2]] };
        let dot = |a: V3, b: V3| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let cross = |a: V3, b: V3| -> V3 {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let point = |v: DVec3| -> V3 { v.to_array().map(Exact::from) };
        let origin = point(xq);
        let e = x.map(|xi| sub(point(xi), origin));
        let s = e.map(|v| dot(v, v));
        let det = |a: V3, b: V3, c: V3| dot(a, cross(b, c));
        let cof = [-det(e[1], e[2], e[3]), det(e[0], e[2], e[3]), -det(e[0], e[1], e[3]), det(e[0], e[1], e[2])];
        let f = FACES[c].map(|k| e[k]);
        let (d1, d2, d3) = (sub(f[1], f[0]), sub(f[2], f[0]), sub(f[2], f[1]));
        let normal = cross(d1, d2);
        let zero = Exact::from(0.0);
        let (op, oq) = (dot(sub(e[c], f[0]), normal), dot(sub([zero; 3], f[0]), normal));
        let folded = op.signum() * oq.signum() > 0;
        if op.signum() == 0 || oq.signum() == 0 {
            return ((vertices, f64::NAN, [f64::NAN; 5], false), folded);
        }
        let sum = cof[0] + cof[1] + cof[2] + cof[3];
        // 2 |O_p O_q| / orientation (minus the sum of the cofactors), and sqrt(3 N / L) as m 2^k
        let product = op * oq;
        let signed = Exact::from(-2.0 * f64::from(sum.signum() * product.signum())) * product;
        let (mut m, mut k) = (Exact::from(3.0) * dot(normal, normal) / (dot(d1, d1) + dot(d2, d2) + dot(d3, d3))).split();
        if k % 2 != 0 {
            (m, k) = (2.0 * m, k - 1);
        }
        let root = (m.sqrt(), k / 2);
        let value = |numerator: Exact| {
            let (m, k) = (numerator / signed).split();
            ldexp(m * root.0, k + root.1)
        };
        let g0 = value(cof[0] * s[0] + cof[1] * s[1] + cof[2] * s[2] + cof[3] * s[3]);
        let coefficients = [value(-cof[0]), value(-cof[1]), value(-cof[2]), value(-cof[3]), value(sum)];
        ((vertices, g0, coefficients, true), folded)
    })
}

/// The conditions of every interior face `[t1, c1, t2, c2]` of `interior` (the table of
/// [`crate::faces`]) of a mesh in R^3.
///
/// Deterministic: every row is computed on its own (in parallel), in a fixed slot.
///
/// ```
/// use tetlap::analysis::regular::conditions;
/// use tetlap::{faces, Options, Tet, TetView};
/// // two tets on the face (1, 2, 3); vertex 4 outside the circumsphere of the first
/// let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.5];
/// let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
/// let mesh = TetView::new(&points, 3, &tets)?;
/// let opts = Options::default();
/// let c = conditions(&mesh, &faces::<Tet>(&tets, 5, &opts)?.interior, &opts)?;
/// assert_eq!((c.n_faces, c.vertices[0]), (1, [0, 1, 2, 3, 4]));
/// assert!(c.g0[0] > 0.0); // locally Delaunay
/// // w = |x|^2 lifts every point flat: the margin vanishes
/// let w: Vec<f64> = (0..5).map(|i| (0..3).map(|k| points[3 * i + k] * points[3 * i + k]).sum()).collect();
/// let m = c.g0[0] + (0..5).map(|k| c.coefficients[0][k] * w[c.vertices[0][k] as usize]).sum::<f64>();
/// assert!(m.abs() < 1e-14);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn conditions(mesh: &TetView, interior: &[[u32; 4]], opts: &Options) -> Result<Conditions> {
    if mesh.dim() != 3 {
        return Err(Error::Shape { what: format!("regular weights need points in R^3, got dimension {}", mesh.dim()) });
    }
    let cells = mesh.cells();
    let m = cells.len() as u32;
    let bad = |f: &[u32; 4]| f[0] >= m || f[2] >= m || f[1] >= 4 || f[3] >= 4;
    if let Some(k) = interior.iter().position(bad) {
        return Err(Error::Shape {
            what: format!("interior face {k} must hold [element, corner, element, corner] of this mesh, got {:?}", interior[k]),
        });
    }
    let points = mesh.points();
    let point = |v: u32| DVec3::new(points[3 * v as usize], points[3 * v as usize + 1], points[3 * v as usize + 2]);
    let n_faces = interior.len();
    let mut first: Vec<Row> = vec![([0; 5], 0.0, [0.0; 5], true); n_faces];
    let mut folded = vec![false; n_faces];
    opts.install(|| {
        first.par_chunks_mut(CHUNK).zip(folded.par_chunks_mut(CHUNK)).zip(interior.par_chunks(CHUNK)).try_for_each(
            |((rows, flags), faces)| {
                opts.cancelled()?;
                for ((slot, flag), &[t1, c1, t2, c2]) in rows.iter_mut().zip(flags.iter_mut()).zip(faces) {
                    let tet = cells[t1 as usize];
                    let q = cells[t2 as usize][c2 as usize];
                    (*slot, *flag) = row(tet, tet.map(point), c1 as usize, q, point(q));
                }
                Ok(())
            },
        )
    })?;
    // the second view of every folded face, in face order
    let second: Vec<(u32, Row)> = folded
        .iter()
        .enumerate()
        .filter(|&(_, &f)| f)
        .map(|(f, _)| {
            let [t1, c1, t2, c2] = interior[f];
            let tet = cells[t2 as usize];
            let p = cells[t1 as usize][c1 as usize];
            (f as u32, row(tet, tet.map(point), c2 as usize, p, point(p)).0)
        })
        .collect();
    let total = n_faces + second.len();
    let mut c = Conditions {
        vertices: Vec::with_capacity(total),
        g0: Vec::with_capacity(total),
        coefficients: Vec::with_capacity(total),
        face: Vec::with_capacity(total),
        n_faces,
        folded,
        flat: vec![],
        beyond_range: vec![],
    };
    let rows = first.into_iter().enumerate().map(|(f, r)| (f as u32, r)).chain(second);
    for (f, (vertices, g0, coefficients, ok)) in rows {
        if !ok {
            c.flat.push(f);
        } else if !(g0.is_finite() && coefficients.iter().all(|v| v.is_finite())) {
            c.beyond_range.push(f);
        }
        c.vertices.push(vertices);
        c.g0.push(g0);
        c.coefficients.push(coefficients);
        c.face.push(f);
    }
    for faces in [&mut c.flat, &mut c.beyond_range] {
        faces.sort_unstable();
        faces.dedup();
    }
    Ok(c)
}

/// Relative tolerance of [`lifted_signs`]: a lifted determinant is decided in float64 when
/// it exceeds this fraction of its permanent (its rounding error is at most a few dozen
/// units in the last place of the permanent, far below).
pub const VERIFY_RTOL: f64 = 1e-12;

/// `(determinant, permanent)` of the 3 x 3 matrix of rows `a, b, c`.
fn det_perm(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> (f64, f64) {
    let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
    let (a, b, c) = (a.map(f64::abs), b.map(f64::abs), c.map(f64::abs));
    let perm = a[0] * (b[1] * c[2] + b[2] * c[1]) + a[1] * (b[0] * c[2] + b[2] * c[0]) + a[2] * (b[0] * c[1] + b[1] * c[0]);
    (det, perm)
}

/// The sign of one view's lifted determinant (tet `tet` against the vertex `q`), or 0 where
/// float64 cannot tell (see [`lifted_signs`]).
fn lifted_sign(points: &[f64], weights: Option<&[f64]>, tet: [u32; 4], q: u32) -> i8 {
    let x = |v: u32| -> [f64; 3] { std::array::from_fn(|k| points[3 * v as usize + k]) };
    let w = |v: u32| weights.map_or(0.0, |w| w[v as usize]);
    let xq = x(q);
    let e: [[f64; 3]; 4] = tet.map(|v| {
        let xv = x(v);
        [xv[0] - xq[0], xv[1] - xq[1], xv[2] - xq[2]]
    });
    let omega = tet.map(|v| w(v) - w(q));
    let rows = [(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)];
    let sign = [-1.0, 1.0, -1.0, 1.0];
    let (mut orient, mut orient_perm, mut d, mut bound) = (0.0, 0.0, 0.0, 0.0);
    for (k, &(a, b, c)) in rows.iter().enumerate() {
        let (det, perm) = det_perm(e[a], e[b], e[c]);
        let cof = sign[k] * det;
        let length = e[k][0] * e[k][0] + e[k][1] * e[k][1] + e[k][2] * e[k][2];
        orient += cof;
        orient_perm += perm;
        d += cof * (length - omega[k]);
        bound += perm * (length + omega[k].abs());
    }
    let sure = orient.abs() > VERIFY_RTOL * orient_perm && d.abs() > VERIFY_RTOL * bound;
    if !sure {
        0
    } else if (orient > 0.0) == (d > 0.0) {
        -1
    } else {
        1
    }
}

/// The sign of the lifted determinant of every view of every interior face `[t1, c1, t2,
/// c2]` of `interior`, for vertex weights `weights` (None: zeros): first the views from
/// the first tets (`t1` against `T[t2][c2]`), then those from the second: `1` strictly
/// locally regular, `-1` not, `0` within [`VERIFY_RTOL`] of the permanent (float64 cannot
/// tell; decide it exactly). The determinant is
/// `D = -sign(sum_i C_i) * sum_i C_i (|e_i|^2 - (w_i - w_q))`, `e_i = x_i - x_q`, `C_i` the
/// cofactors of the lifted column: the test of `tetlap.regular.verify`, evaluated in the
/// same order, independent of the conditions' rows. Deterministic (every view on its own).
pub fn lifted_signs(mesh: &TetView, interior: &[[u32; 4]], weights: Option<&[f64]>, opts: &Options) -> Result<Vec<i8>> {
    if mesh.dim() != 3 {
        return Err(Error::Shape { what: format!("regular weights need points in R^3, got dimension {}", mesh.dim()) });
    }
    let cells = mesh.cells();
    let m = cells.len() as u32;
    if let Some(k) = interior.iter().position(|f| f[0] >= m || f[2] >= m || f[1] >= 4 || f[3] >= 4) {
        return Err(Error::Shape { what: format!("interior face {k} is not [element, corner, element, corner] of this mesh") });
    }
    if weights.is_some_and(|w| w.len() != mesh.n_vertices()) {
        return Err(Error::Shape { what: format!("{} vertex weights expected", mesh.n_vertices()) });
    }
    let f = interior.len();
    let mut signs = vec![0i8; 2 * f];
    let points = mesh.points();
    opts.install(|| {
        signs.par_chunks_mut(CHUNK).enumerate().try_for_each(|(c, chunk)| {
            opts.cancelled()?;
            for (k, slot) in chunk.iter_mut().enumerate() {
                let view = c * CHUNK + k;
                let [t1, c1, t2, c2] = interior[view % f];
                let (tet, q) = if view < f { (t1, cells[t2 as usize][c2 as usize]) } else { (t2, cells[t1 as usize][c1 as usize]) };
                *slot = lifted_sign(points, weights, cells[tet as usize], q);
            }
            Ok::<(), Error>(())
        })
    })?;
    Ok(signs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::faces;
    use crate::element::Tet;

    fn margin(c: &Conditions, r: usize, w: &[f64]) -> f64 {
        c.g0[r] + (0..5).map(|k| c.coefficients[r][k] * w[c.vertices[r][k] as usize]).sum::<f64>()
    }

    /// The power centre of a tet: equal power |c - x_i|^2 - w_i to its four corners.
    fn power_centre(x: [DVec3; 4], w: [f64; 4]) -> DVec3 {
        let (a, b, cc) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let r = |k: usize, e: DVec3| (e.length_squared() + w[0] - w[k]) / 2.0;
        let det = a.dot(b.cross(cc));
        x[0] + (r(1, a) * b.cross(cc) + r(2, b) * cc.cross(a) + r(3, cc) * a.cross(b)) / det
    }

    #[test]
    fn the_margin_is_the_signed_power_edge_over_the_face_size() {
        let points = [0., 0., 0., 1., 0.1, 0., 0.2, 1., 0., 0.1, 0.3, 1., 1.1, 0.9, 0.8];
        let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
        let mesh = TetView::new(&points, 3, &tets).unwrap();
        let opts = Options::default();
        let interior = faces::<Tet>(&tets, 5, &opts).unwrap().interior;
        let c = conditions(&mesh, &interior, &opts).unwrap();
        let p = |v: u32| DVec3::new(points[3 * v as usize], points[3 * v as usize + 1], points[3 * v as usize + 2]);
        for w in [[0.0; 5], [0.1, -0.05, 0.2, 0.0, 0.3]] {
            let c1 = power_centre(tets[0].map(p), tets[0].map(|v| w[v as usize]));
            let c2 = power_centre(tets[1].map(p), tets[1].map(|v| w[v as usize]));
            let f = [p(1), p(2), p(3)];
            let mut n = (f[1] - f[0]).cross(f[2] - f[0]).normalize();
            if n.dot(p(4) - f[0]) < 0.0 {
                n = -n;
            }
            let rms = (((f[1] - f[0]).length_squared() + (f[2] - f[1]).length_squared() + (f[0] - f[2]).length_squared()) / 3.0).sqrt();
            let expected = (c2 - c1).dot(n) / rms;
            assert!((margin(&c, 0, &w) - expected).abs() < 1e-12, "{} {expected}", margin(&c, 0, &w));
        }
    }

    #[test]
    fn a_folded_face_has_two_rows_of_opposite_sign_and_scale_does_not_matter() {
        // the second tet on the same side of the face (1, 2, 3) as the first
        let base = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0.1, 0.1, 0.2];
        let tets = [[0, 1, 2, 3], [4, 1, 2, 3]];
        let opts = Options::default();
        let interior = faces::<Tet>(&tets, 5, &opts).unwrap().interior;
        let mut reference = None;
        for s in [1.0, 1e-150, 1e150] {
            let points: Vec<f64> = base.iter().map(|x| x * s).collect();
            let c = conditions(&TetView::new(&points, 3, &tets).unwrap(), &interior, &opts).unwrap();
            assert_eq!((c.n_faces, c.face.clone(), c.folded.clone()), (1, vec![0, 0], vec![true]));
            let w = [0.3 * s * s, 0.0, -0.1 * s * s, 0.2 * s * s, 0.05 * s * s];
            let (a, b) = (margin(&c, 0, &w), margin(&c, 1, &w));
            assert!(a * b < 0.0, "{a} {b}");
            let r = *reference.get_or_insert((a, b));
            assert!((a - r.0).abs() < 1e-12 && (b - r.1).abs() < 1e-12, "{s}: {a} {b} vs {r:?}");
        }
    }

    #[test]
    fn lifted_signs_agree_with_the_margins_and_leave_a_flat_lifting_undecided() {
        let points = [0., 0., 0., 1., 0.1, 0., 0.2, 1., 0., 0.1, 0.3, 1., 1.1, 0.9, 0.8];
        let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
        let mesh = TetView::new(&points, 3, &tets).unwrap();
        let opts = Options::default();
        let interior = faces::<Tet>(&tets, 5, &opts).unwrap().interior;
        let c = conditions(&mesh, &interior, &opts).unwrap();
        // a large weight on the far vertex 4 makes the face non-regular
        for w in [[0.0; 5], [0.1, -0.05, 0.2, 0.0, 0.3], [0.0, 0.0, 0.0, 0.0, 5.0]] {
            let signs = lifted_signs(&mesh, &interior, Some(&w), &opts).unwrap();
            let expected = if margin(&c, 0, &w) > 0.0 { 1 } else { -1 };
            assert_eq!(signs, vec![expected, expected], "{w:?}");
        }
        assert_eq!(lifted_signs(&mesh, &interior, Some(&[0.0, 0.0, 0.0, 0.0, 5.0]), &opts).unwrap(), vec![-1, -1]);
        // w = |x|^2 lifts every point onto a hyperplane: within rounding of 0, left to exact arithmetic
        let flat: Vec<f64> = (0..5).map(|i| (0..3).map(|k| points[3 * i + k] * points[3 * i + k]).sum()).collect();
        assert_eq!(lifted_signs(&mesh, &interior, Some(&flat), &opts).unwrap(), vec![0, 0]);
    }

    #[test]
    fn the_exact_rows_agree_with_the_float_rows_and_serve_needles() {
        let p = [DVec3::new(0., 0., 0.), DVec3::new(1., 0.1, 0.), DVec3::new(0.2, 1., 0.), DVec3::new(0.1, 0.3, 1.)];
        let q = DVec3::new(1.1, 0.9, 0.8);
        for c in 0..4 {
            let (((_, g, a, ok), folded), ((_, h, b, exact_ok), exact_folded)) =
                (float_row([0, 1, 2, 3], p, c, 4, q).unwrap(), exact_row([0, 1, 2, 3], p, c, 4, q));
            assert!(ok && exact_ok && folded == exact_folded);
            assert!((g - h).abs() < 1e-14 && (0..5).all(|k| (a[k] - b[k]).abs() < 1e-14), "{g} {a:?} {h} {b:?}");
        }
        // a needle: the base (0, 1, 2) of tets with apexes below at -1 and above at height h;
        // power centres at z = -0.29 and (h^2 - 0.42) / (2 h), RMS edge 2 / sqrt(3)
        let base = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(0.3, 0.3, -1.0)];
        for h in [10.0, 1e4, 1e16, 1e50, 1e150, 1e300] {
            let apex = DVec3::new(0.3, 0.3, h);
            let ((_, g, a, ok), folded) = row([0, 1, 2, 3], base, 3, 4, apex);
            let expected = ((h - 0.42 / h) / 2.0 + 0.29) * 3f64.sqrt() / 2.0;
            // float64 within its bounds (1e-12 here); beyond them exact
            let tol = if h < 1e6 { 1e-12 } else { 1e-14 };
            assert!(ok && !folded && (g / expected - 1.0).abs() < tol, "{h}: {g} {expected}");
            // d margin / d w_apex = -1 / (2 h) over the RMS edge
            assert!((a[4] * h * 4.0 / 3f64.sqrt() + 1.0).abs() < tol, "{h}: {a:?}");
            // seen from the needle, against the apex below
            let needle = [DVec3::ZERO, DVec3::X, DVec3::Y, apex];
            let ((_, g, _, ok), _) = row([0, 1, 2, 4], needle, 3, 3, base[3]);
            assert!(ok && (g / expected - 1.0).abs() < tol, "{h}: {g} {expected}");
        }
    }

    #[test]
    fn flat_tets_are_named() {
        let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 1., 1., 0., 0.3, 0.3, 1.];
        let tets = [[0, 1, 2, 3], [4, 1, 2, 3]];
        let opts = Options::default();
        let interior = faces::<Tet>(&tets, 5, &opts).unwrap().interior;
        let c = conditions(&TetView::new(&points, 3, &tets).unwrap(), &interior, &opts).unwrap();
        assert_eq!(c.flat, vec![0]);
    }
}
