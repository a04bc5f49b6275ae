//! Height field against a convex geom, as MuJoCo 4 computes it
//! (`mjc_ConvexHField`, engine_collision_convex.c): the field is cut into
//! triangular prisms and each prism near the geom meets it through the
//! general convex collider ([`super::convex`]), one contact per prism.
//!
//! Everything runs in the field's frame (see [`HField`](crate::model::hfield::HField) for its grid):
//! - the geom's extent along the field's axes (its support points, without
//!   margin) culls the pair when it is off the field's box, and bounds the
//!   sub-grid of cells: columns floor((xmin + sx) / 2sx (ncol - 1)) to
//!   ceil((xmax + sx) / 2sx (ncol - 1)), rows likewise along y;
//! - each cell (r, c) of the sub-grid gives two prisms, walked row by row
//!   as a strip: the triangle of grid points (c-1, r+1), (c-1, r), (c, r+1),
//!   then (c-1, r), (c, r+1), (c, r); a prism's top vertices sit at the
//!   elevations raised by the pair's margin, its bottom ones at -size[3];
//! - a prism whose top lies wholly below the geom's lowest point is
//!   skipped; the others meet the geom (grown by half the margin, as the
//!   convex collider grows a geom) and give a contact when they overlap,
//!   its distance that of the grown bodies (MuJoCo passes margin 0 here);
//! - at most [`MAXCONPAIR`] contacts, in the walk's order.
//!
//! The margin's part is MuJoCo's published source; MuJoCo 4.0.0's binary
//! differs (it reports the bare shapes' contacts up to the margin), so
//! pairs with a margin are refused (the table's entry, [`super::Entry`])
//! and run with zero.
//!
//! Contacts are transformed back to the world; the normal points from the
//! field into the geom. A zero-size cell gives a flat prism, which GJK
//! handles like any other polytope.

use nalgebra::{convert_ref_unchecked, Vector3};

use super::convex::{contact, Body};
use super::{Assets, Placed, Pre};
use crate::model::Shape;
use crate::spatial::{lift, Real};

/// MuJoCo's mjMAXCONPAIR: the most contacts of one geom pair.
pub const MAXCONPAIR: usize = 50;

/// The contacts of the height field geom `s1` at `p1` (its field in
/// `assets`) with the geom `s2` at `p2` within `margin`; see the module
/// documentation. The table takes it for a sphere, capsule, ellipsoid or
/// cylinder without margin. Not yet for a box or a mesh (it reads a mesh's
/// hull from `assets`): a prism and a box or mesh without margin are
/// MuJoCo's "discrete" pair (`discreteGeoms`, engine_collision_gjk.c: GJK
/// with tolerance 0, EPA with mjMINEPATOL that also ends when a support
/// point repeats a polytope vertex's pair of vertex indices, a prism's
/// being -1), which gjk.rs and epa.rs do not run yet; run through them as
/// they are, 5 of 20 box states and 8 of 20 irregular-mesh states agree
/// with MuJoCo 4.0.0 to 1e-9 and the others differ by up to 1.6 in the
/// frame (harness/tests/test_hfield.py's states). Not with a margin, which
/// MuJoCo 4.0.0 measures other than its published source (no raised prism,
/// no grown geom: the contacts of the bare shapes); not for a plane or
/// another height field, as in MuJoCo.
pub(super) fn hfield<T: Real>(
    assets: &Assets,
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let Shape::HField { hfield, .. } = *s1 else {
        return;
    };
    let field = &assets.hfields[hfield];
    let pos = p1.mat.tr_mul(&(p2.pos - p1.pos));
    let mat = p1.mat.tr_mul(&p2.mat);
    let bounds = extent(&Body::placed(s2, (pos, mat), T::zero()).with_assets(assets));
    let m: f64 = convert_ref_unchecked(&margin);
    let [sx, sy, sz, base] = field.size;
    let [xmin, xmax, ymin, ymax, zmin, zmax] = bounds;
    if xmin - m > sx || xmax + m < -sx || ymin - m > sy || ymax + m < -sy {
        return;
    }
    if zmin - m > sz || zmax + m < -base {
        return;
    }
    let geom = Body::placed(s2, (pos, mat), margin).with_assets(assets);
    let start = out.len();
    let (cols, rows) = (
        span(xmin, xmax, sx, field.ncol),
        span(ymin, ymax, sy, field.nrow),
    );
    if cols.0 >= cols.1 || rows.0 >= rows.1 {
        return;
    }
    let (dx, dy) = (
        2.0 * sx / (field.ncol - 1) as f64,
        2.0 * sy / (field.nrow - 1) as f64,
    );
    let vertex = |r: usize, c: usize| {
        let z = f64::from(field.data[r * field.ncol + c]) * sz;
        (dx * c as f64 - sx, dy * r as f64 - sy, z)
    };
    let mut prism = [Vector3::new(T::zero(), T::zero(), lift(-base)); 6];
    for r in rows.0..rows.1 {
        push(&mut prism, vertex(r + 1, cols.0), margin);
        push(&mut prism, vertex(r, cols.0), margin);
        for c in cols.0 + 1..=cols.1 {
            for dr in [1, 0] {
                push(&mut prism, vertex(r + dr, c), margin);
                if prism[3..].iter().all(|v| v.z < lift(zmin)) {
                    continue;
                }
                if let Some(c) = contact(&Body::prism(s1, &prism), &geom, T::zero()) {
                    out.push(Pre {
                        pos: p1.mat * c.pos + p1.pos,
                        normal: p1.mat * c.normal,
                        ..c
                    });
                    if out.len() - start >= MAXCONPAIR {
                        return;
                    }
                }
            }
        }
    }
}

/// The body's extent along the field's axes (the body placed in the
/// field's frame): [xmin, xmax, ymin, ymax, zmin, zmax] of its support
/// points.
fn extent<T: Real>(body: &Body<T>) -> [f64; 6] {
    let mut out = [0.0; 6];
    for (k, o) in out.iter_mut().enumerate() {
        let mut dir = Vector3::zeros();
        dir[k / 2] = if k % 2 == 0 { -T::one() } else { T::one() };
        *o = convert_ref_unchecked(&body.support(&dir).0[k / 2]);
    }
    out
}

/// The grid lines (first, last) that a geom spanning [lo, hi] reaches on
/// an axis of half-size `half` with `n` lines, clamped to the grid.
fn span(lo: f64, hi: f64, half: f64, n: usize) -> (usize, usize) {
    let at = |x: f64| (x + half) / (2.0 * half) * (n - 1) as f64;
    let first = at(lo).floor().max(0.0) as usize;
    let last = at(hi).ceil().min((n - 1) as f64).max(0.0) as usize;
    (first, last)
}

/// MuJoCo's prism update: the strip's oldest grid point leaves, the grid
/// point (x, y, elevation) enters as the third top and bottom vertex.
fn push<T: Real>(prism: &mut [Vector3<T>; 6], (x, y, z): (f64, f64, f64), margin: T) {
    prism[0] = prism[1];
    prism[1] = prism[2];
    prism[3] = prism[4];
    prism[4] = prism[5];
    let (x, y) = (lift::<T>(x), lift::<T>(y));
    prism[2].x = x;
    prism[2].y = y;
    prism[5] = Vector3::new(x, y, lift::<T>(z) + margin);
}

/// A prism's support point: the vertex farthest along `dir` among the top
/// three (dir.z >= 0) or the bottom three, the first of equals.
pub(super) fn prism_support<T: Real>(prism: &[Vector3<T>; 6], dir: &Vector3<T>) -> Vector3<T> {
    let half = if dir.z < T::zero() { 0 } else { 3 };
    let mut best = prism[half];
    for v in &prism[half + 1..half + 3] {
        if v.dot(dir) > best.dot(dir) {
            best = *v;
        }
    }
    best
}

/// A prism's centroid, where GJK starts.
pub(super) fn centroid<T: Real>(prism: &[Vector3<T>; 6]) -> Vector3<T> {
    prism.iter().fold(Vector3::zeros(), |s, v| s + v) * lift::<T>(1.0 / 6.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::hfield::HField;
    use nalgebra::Matrix3;

    /// A 3 x 3 grid over [-1, 1]^2, elevations `data` (row-major from y = -1) scaled by 0.5, base 0.2.
    fn field(data: [f32; 9]) -> (HField, Shape) {
        let size = [1.0, 1.0, 0.5, 0.2];
        let h = HField::compile("h", size, (3, 3), data.to_vec()).unwrap();
        (h, Shape::HField { hfield: 0, size })
    }

    fn contacts(data: [f32; 9], ball: Vector3<f64>, radius: f64) -> Vec<Pre<f64>> {
        let (h, s1) = field(data);
        let at = |pos| Placed {
            pos,
            mat: Matrix3::identity(),
        };
        let mut out = vec![];
        let s2 = Shape::Sphere { radius };
        let assets = Assets {
            hfields: vec![h],
            ..Assets::default()
        };
        hfield(
            &assets,
            (&s1, &at(Vector3::zeros())),
            (&s2, &at(ball)),
            0.0,
            &mut out,
        );
        out
    }

    #[test]
    fn a_sphere_on_a_sloped_cell_touches_its_plane() {
        // Elevations rise along x: the surface z = 0.25 (x + 1) over the grid, one plane.
        let slope = [0.0, 0.5, 1.0, 0.0, 0.5, 1.0, 0.0, 0.5, 1.0];
        let n = Vector3::new(-0.25, 0.0, 1.0).normalize();
        let foot = Vector3::new(0.4, 0.3, 0.35);
        let c = contacts(slope, foot + n * 0.08, 0.1);
        assert_eq!(c.len(), 1);
        assert!((c[0].dist + 0.02).abs() < 1e-12, "{}", c[0].dist);
        assert!((c[0].normal - n).norm() < 1e-12, "{}", c[0].normal);
        assert!(
            (c[0].pos - (foot - n * 0.01)).norm() < 1e-12,
            "{}",
            c[0].pos
        );
        // Apart: none; beyond the field: none.
        assert!(contacts(slope, foot + n * 0.11, 0.1).is_empty());
        assert!(contacts(slope, Vector3::new(1.2, 0.0, 0.5), 0.1).is_empty());
    }

    #[test]
    fn deep_and_flat_contacts_are_finite() {
        // A sphere sunk below a flat field's surface, and one on a flat field with
        // a zero-height base cell: finite contacts, one per prism met.
        let flat = [0.0; 9];
        for centre in [Vector3::new(0.1, 0.2, -0.05), Vector3::new(0.0, 0.0, 0.05)] {
            let c = contacts(flat, centre, 0.1);
            assert!(!c.is_empty());
            for k in &c {
                assert!(k.dist.is_finite() && k.pos.iter().all(|x| x.is_finite()));
                assert!(k.normal.iter().all(|x| x.is_finite()) && k.dist < 0.0);
            }
        }
    }

    #[test]
    fn the_prism_support_takes_the_top_or_bottom_triangle() {
        let v = |x, y, z| Vector3::new(x, y, z);
        let prism = [
            v(0.0, 0.0, -1.0),
            v(1.0, 0.0, -1.0),
            v(0.0, 1.0, -1.0),
            v(0.0, 0.0, 0.5),
            v(1.0, 0.0, 0.2),
            v(0.0, 1.0, 0.9),
        ];
        assert_eq!(prism_support(&prism, &v(0.0, 0.0, 1.0)), prism[5]);
        assert_eq!(prism_support(&prism, &v(1.0, 0.0, -0.1)), prism[1]);
        // Ties go to the first vertex.
        assert_eq!(prism_support(&prism, &v(0.0, 0.0, -1.0)), prism[0]);
        assert!((centroid(&prism) - v(1.0 / 3.0, 1.0 / 3.0, -1.4 / 6.0)).norm() < 1e-15);
        assert_eq!(span(-0.3, 0.3, 1.0, 3), (0, 2));
        assert_eq!(span(0.1, 0.3, 1.0, 5), (2, 3));
        assert_eq!(span(-3.0, -2.0, 1.0, 5), (0, 0));
    }

    /// A model of the field `hfield` (MJCF attributes) and a free body of `geom`.
    fn on_field(hfield: &str, geom: &str) -> crate::Model {
        let xml = format!(
            r#"<mujoco><asset><hfield name="h" {hfield}/></asset><worldbody>
            <geom type="hfield" hfield="h"/><body><freejoint/>{geom}</body></worldbody></mujoco>"#
        );
        crate::Model::from_mjcf(&xml, "test.xml").unwrap()
    }

    #[test]
    fn a_step_refuses_a_height_field_pair_without_a_collider_within_reach() {
        use crate::dynamics::StepError;
        use crate::model::{Inputs, State};
        let field = r#"nrow="2" ncol="3" size="1 2 0.5 0.1" elevation="1 2 3 4 5 7""#;
        let at = |z: f64| State::new(vec![0.0, 0.0, z, 1.0, 0.0, 0.0, 0.0], vec![0.0; 6]);
        let tau = Inputs::tau(&[0.0; 6]);
        let ball = on_field(field, r#"<geom size="0.1"/>"#);
        assert!(ball.step(&mut ball.data(), &at(0.3), &tau).is_ok());
        for geom in [
            r#"<geom type="box" size="0.1 0.1 0.1"/>"#,
            r#"<geom size="0.1" margin="0.01"/>"#,
        ] {
            let m = on_field(field, geom);
            let mut data = m.data();
            let err = m.step(&mut data, &at(0.3), &tau).unwrap_err();
            assert_eq!(err, StepError::NoCollider([0, 1]));
            // Beyond the bounding sphere's reach it steps.
            assert!(m.step(&mut data, &at(3.0), &tau).is_ok());
        }
    }

    #[test]
    fn tiny_cells_and_deep_geoms_step_finitely() {
        use crate::model::{Inputs, State};
        // Cells of 5e-10 (the field lies inside the geom), a flat field of
        // zero relief over a base of 1e-12 (flat prisms), and a rough one:
        // a cylinder (EPA on flat faces) and an ellipsoid sunk by a quarter,
        // by half, and tilted deeper; each state holds contacts.
        let fields = [
            r#"nrow="3" ncol="5" size="1e-9 1e-9 1e-9 1e-9" elevation="0 1 0 1 0 1 0 1 0 1 0 1 0 1 0""#,
            r#"nrow="3" ncol="3" size="1 1 0.2 1e-12""#,
            r#"nrow="3" ncol="3" size="1 1 0.2 0.1" elevation="0 1 0 1 0 1 0 1 0""#,
        ];
        let tau = Inputs::tau(&[0.0; 6]);
        let geoms = [
            r#"<geom type="cylinder" size="0.2 0.1"/>"#,
            r#"<geom type="ellipsoid" size="0.1 0.2 0.1"/>"#,
        ];
        for (field, geom) in fields.iter().flat_map(|f| geoms.map(|g| (f, g))) {
            let m = on_field(field, geom);
            let mut data = m.data();
            for (z, w) in [(0.05, 1.0f64), (0.0, 1.0), (-0.05, 0.8)] {
                let x = (1.0 - w * w).sqrt();
                let state = State::new(vec![0.01, 0.02, z, w, x, 0.0, 0.0], vec![0.1; 6]);
                let contacts = m.contacts(&mut data, &state, &tau).unwrap();
                assert!(!contacts.is_empty(), "{field} {geom} {z}");
                let next = m.step(&mut data, &state, &tau).unwrap();
                assert!(
                    next.q.iter().chain(&next.v).all(|x| x.is_finite()),
                    "{field} {geom} {z}"
                );
            }
        }
    }
}
