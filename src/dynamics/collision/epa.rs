//! MuJoCo 4's penetration recovery (engine_collision_gjk.c, `polytope2/3/4`
//! and `epa`): from GJK's simplex that holds the origin, an initial
//! polytope of the Minkowski difference A - B (a hexahedron around a
//! segment or a triangle, or the tetrahedron itself), expanded towards the
//! boundary face nearest the origin until its support bound is within the
//! tolerance of its distance.
//!
//! Conventions: a face stores the origin's projection on its plane, pointing
//! out of the polytope (its normal scaled by its distance). The result is
//! the nearest face's witness points on A and B (the same affine
//! combination of its vertices' support points) and the penetration depth,
//! negative. Between discrete bodies (boxes and meshes without margin,
//! [`Body::discrete`]) the loop ends at a repeated support vertex, its
//! tolerance MuJoCo's minimum (mjMINEPATOL, mjMINVAL in double precision).

use nalgebra::{Matrix3, Vector3};

use super::convex::Body;
use super::gjk::{affine, combine, project_origin_plane, Vertex};
use crate::model::MINVAL;
use crate::spatial::{lift, Real};

/// One triangle of the polytope.
struct Face<T: Real> {
    verts: [usize; 3],
    /// The faces across edges (v1, v2), (v2, v3), (v3, v1).
    adj: [usize; 3],
    /// The origin projected on the face's plane, outward.
    v: Vector3<T>,
    dist2: T,
    /// Position in the candidate map; -1 outside it, -2 deleted.
    index: isize,
}

/// The expanding polytope: vertices, faces, the candidate faces (`map`) and
/// the horizon of the last expansion.
struct Polytope<T: Real> {
    verts: Vec<Vertex<T>>,
    faces: Vec<Face<T>>,
    map: Vec<usize>,
    max_faces: usize,
    center: Vector3<T>,
    horizon: Vec<(usize, usize)>,
}

/// The outcome of EPA: witness points on A and B, their signed distance,
/// and the vertices of the polytope's nearest face (multiccd's features).
pub(super) struct Penetration<T: Real> {
    pub x1: Vector3<T>,
    pub x2: Vector3<T>,
    pub dist: T,
    pub face: [Vertex<T>; 3],
}

/// Builds the initial polytope from GJK's simplex (2 to 4 vertices) and
/// expands it; None when the bodies do not overlap or the polytope cannot be
/// built (MuJoCo's mjEPA_P* statuses: no contact).
pub(super) fn penetration<T: Real>(
    simplex: &[Vertex<T>],
    (a, b): (&Body<T>, &Body<T>),
    tolerance: f64,
    max_iterations: usize,
) -> Option<Penetration<T>> {
    let mut pt = Polytope {
        verts: Vec::with_capacity(5 + max_iterations),
        faces: Vec::with_capacity(6 * max_iterations),
        map: vec![],
        max_faces: 6 * max_iterations,
        center: Vector3::zeros(),
        horizon: vec![],
    };
    let bodies = (a, b);
    let built = match simplex.len() {
        2 => pt.around_segment([simplex[0], simplex[1]], bodies),
        3 => pt.around_triangle([simplex[0], simplex[1], simplex[2]], bodies),
        4 => pt.around_tetrahedron(simplex, bodies),
        _ => false,
    };
    if !built {
        return None;
    }
    pt.expand(bodies, tolerance, max_iterations.min(1000))
}

/// The 120-degree rotation about `axis` (MuJoCo's `rotmat`).
fn third_turn<T: Real>(axis: &Vector3<T>) -> Matrix3<T> {
    let u = axis / axis.norm();
    let (s, c): (T, T) = (lift(0.86602540378), lift(-0.5));
    let k = T::one() - c;
    Matrix3::new(
        c + u.x * u.x * k,
        u.x * u.y * k - u.z * s,
        u.x * u.z * k + u.y * s,
        u.y * u.x * k + u.z * s,
        c + u.y * u.y * k,
        u.y * u.z * k - u.x * s,
        u.x * u.z * k - u.y * s,
        u.y * u.z * k + u.x * s,
        c + u.z * u.z * k,
    )
}

/// Whether the ray from v1 through v2 meets the triangle v3 v4 v5.
fn ray_meets_triangle<T: Real>(v: [&Vector3<T>; 5]) -> bool {
    let d = |i: usize| v[i] - v[0];
    let det = |a: Vector3<T>, b: Vector3<T>, c: Vector3<T>| a.dot(&b.cross(&c));
    let vol = [
        det(d(2), d(3), d(1)),
        det(d(3), d(4), d(1)),
        det(d(4), d(2), d(1)),
    ];
    vol.iter().all(|x| *x >= T::zero()) || vol.iter().all(|x| *x <= T::zero())
}

/// Whether the origin and p3 lie strictly on the same side of the plane of
/// p0, p1, p2.
fn same_side<T: Real>(p0: &Vector3<T>, p1: &Vector3<T>, p2: &Vector3<T>, p3: &Vector3<T>) -> bool {
    let n = (p1 - p0).cross(&(p2 - p0));
    let (d1, d2) = (n.dot(&(p3 - p0)), n.dot(&-p0));
    (d1 > T::zero() && d2 > T::zero()) || (d1 < T::zero() && d2 < T::zero())
}

/// Whether the tetrahedron holds the origin.
fn holds_origin<T: Real>(p: [&Vector3<T>; 4]) -> bool {
    same_side(p[0], p[1], p[2], p[3])
        && same_side(p[1], p[2], p[3], p[0])
        && same_side(p[2], p[3], p[0], p[1])
        && same_side(p[3], p[0], p[1], p[2])
}

/// Whether p lies in the triangle (within mjMINVAL of its plane).
fn in_triangle<T: Real>(v: [&Vector3<T>; 3], p: &Vector3<T>) -> bool {
    let l = affine(v, p);
    if l.iter().any(|x| *x < T::zero()) {
        return false;
    }
    let pr = v[0] * l[0] + v[1] * l[1] + v[2] * l[2];
    (pr - p).norm() < lift(MINVAL)
}

impl<T: Real> Polytope<T> {
    fn insert(&mut self, v: Vertex<T>) -> usize {
        self.verts.push(v);
        self.verts.len() - 1
    }

    /// Adds the support vertex along d (unit after dividing by |d|, +x when
    /// |d| is tiny).
    fn support(&mut self, (a, b): (&Body<T>, &Body<T>), d: &Vector3<T>, norm: T) -> usize {
        let dir = if norm > lift(MINVAL) {
            d / norm
        } else {
            Vector3::x()
        };
        self.insert(Vertex::along(a, b, &dir))
    }

    fn reset(&mut self) {
        self.verts.clear();
        self.faces.clear();
        self.map.clear();
    }

    /// Attaches face (v1, v2, v3) with its neighbours; the squared distance
    /// of its plane from the origin (zero when degenerate).
    fn attach(&mut self, v: [usize; 3], adj: [usize; 3]) -> T {
        let w = |i: usize| self.verts[v[i]].w;
        let (projection, ok) = match project_origin_plane(&w(2), &w(1), &w(0)) {
            Some(p) => (p, true),
            None => (Vector3::zeros(), false),
        };
        let outward = w(0) - self.center;
        let p = if projection.dot(&outward) < T::zero() {
            -projection
        } else {
            projection
        };
        let dist2 = p.dot(&p);
        self.faces.push(Face {
            verts: v,
            adj,
            v: p,
            dist2,
            index: -1,
        });
        if ok {
            dist2
        } else {
            T::zero()
        }
    }

    fn map_all(&mut self) {
        self.map = (0..self.faces.len()).collect();
        for (i, f) in self.faces.iter_mut().enumerate() {
            f.index = i as isize;
        }
    }

    /// MuJoCo's `polytope2`: a hexahedron about the segment, from three
    /// support points 120 degrees apart around it.
    fn around_segment(&mut self, s: [Vertex<T>; 2], bodies: (&Body<T>, &Body<T>)) -> bool {
        let (v1, v2) = (s[0].w, s[1].w);
        self.center = (v1 + v2) * lift::<T>(0.5);
        let diff = v2 - v1;
        let mut index = 0;
        let mut value = lift::<T>(f64::MAX);
        for i in 0..3 {
            if diff[i].abs() < value {
                value = diff[i].abs();
                index = i;
            }
        }
        let mut e = Vector3::zeros();
        e[index] = T::one();
        let d1 = e.cross(&diff);
        let r = third_turn(&diff);
        let d2 = r * d1;
        let d3 = r * d2;
        let i1 = self.insert(s[0]);
        let i2 = self.insert(s[1]);
        let i3 = self.support(bodies, &d1, d1.norm());
        let i4 = self.support(bodies, &d2, d2.norm());
        let i5 = self.support(bodies, &d3, d3.norm());
        let faces = [
            ([i1, i3, i4], [1, 3, 2]),
            ([i1, i5, i3], [2, 4, 0]),
            ([i1, i4, i5], [0, 5, 1]),
            ([i2, i4, i3], [5, 0, 4]),
            ([i2, i3, i5], [3, 1, 5]),
            ([i2, i5, i4], [4, 2, 3]),
        ];
        for (v, adj) in faces {
            if self.attach(v, adj) < lift(MINVAL * MINVAL) {
                let tri = v.map(|i| self.verts[i]);
                self.reset();
                return self.around_triangle(tri, bodies);
            }
        }
        let p = |i: usize| self.verts[i].w;
        if !ray_meets_triangle([&p(i1), &p(i2), &p(i3), &p(i4), &p(i5)]) {
            return false;
        }
        self.map_all();
        true
    }

    /// MuJoCo's `polytope3`: a hexahedron of the triangle and the support
    /// points along its two normals.
    fn around_triangle(&mut self, s: [Vertex<T>; 3], bodies: (&Body<T>, &Body<T>)) -> bool {
        let (v1, v2, v3) = (s[0].w, s[1].w, s[2].w);
        self.center = (v1 + v2 + v3) * lift::<T>(1.0 / 3.0);
        let n = (v2 - v1).cross(&(v3 - v1));
        let n_norm = n.norm();
        if n_norm < lift(MINVAL) {
            return false;
        }
        let i1 = self.insert(s[0]);
        let i2 = self.insert(s[1]);
        let i3 = self.insert(s[2]);
        let i5 = self.support(bodies, &-n, n_norm);
        let i4 = self.support(bodies, &n, n_norm);
        let (v4, v5) = (self.verts[i4].w, self.verts[i5].w);
        if in_triangle([&v1, &v2, &v3], &v4) || in_triangle([&v1, &v2, &v3], &v5) {
            return false;
        }
        let faces = [
            ([i4, i1, i2], [1, 3, 2]),
            ([i4, i3, i1], [2, 4, 0]),
            ([i4, i2, i3], [0, 5, 1]),
            ([i5, i2, i1], [5, 0, 4]),
            ([i5, i1, i3], [3, 1, 5]),
            ([i5, i3, i2], [4, 2, 3]),
        ];
        for (v, adj) in faces {
            if self.attach(v, adj) < lift(MINVAL * MINVAL) {
                return false;
            }
        }
        self.map_all();
        true
    }

    /// MuJoCo's `polytope4`: the tetrahedron itself, or its face through
    /// the origin.
    fn around_tetrahedron(&mut self, s: &[Vertex<T>], bodies: (&Body<T>, &Body<T>)) -> bool {
        let i: Vec<usize> = s.iter().map(|v| self.insert(*v)).collect();
        self.center = (s[0].w + s[1].w + s[2].w + s[3].w) * lift::<T>(0.25);
        let faces = [
            ([i[0], i[1], i[2]], [1, 3, 2]),
            ([i[0], i[3], i[1]], [2, 3, 0]),
            ([i[0], i[2], i[3]], [0, 3, 1]),
            ([i[3], i[2], i[1]], [2, 0, 1]),
        ];
        for (v, adj) in faces {
            if self.attach(v, adj) < lift(MINVAL * MINVAL) {
                let tri = v.map(|i| self.verts[i]);
                self.reset();
                return self.around_triangle(tri, bodies);
            }
        }
        if !holds_origin([&s[0].w, &s[1].w, &s[2].w, &s[3].w]) {
            return false;
        }
        self.map_all();
        true
    }

    fn delete(&mut self, f: usize) {
        let index = self.faces[f].index;
        if index >= 0 {
            let last = self.map.pop().expect("a mapped face is in the map");
            if (index as usize) < self.map.len() {
                self.map[index as usize] = last;
                self.faces[last].index = index;
            }
        }
        self.faces[f].index = -2;
    }

    /// The edge of face f that starts at `vertex`.
    fn edge(&self, f: usize, vertex: usize) -> usize {
        let v = self.faces[f].verts;
        if v[0] == vertex {
            0
        } else if v[1] == vertex {
            1
        } else {
            2
        }
    }

    /// Deletes face f if w sees it and walks on through its other edges;
    /// whether it was seen.
    fn horizon_from(&mut self, f: usize, e: usize, w: &Vector3<T>) -> bool {
        if self.faces[f].v.dot(w) - self.faces[f].dist2 <= lift(MINVAL) {
            return false;
        }
        let (verts, adj) = (self.faces[f].verts, self.faces[f].adj);
        self.delete(f);
        for k in 1..3 {
            let i = (e + k) % 3;
            if self.faces[adj[i]].index > -2 {
                let edge = self.edge(adj[i], verts[(i + 1) % 3]);
                if !self.horizon_from(adj[i], edge, w) {
                    self.horizon.push((adj[i], edge));
                }
            }
        }
        true
    }

    /// The horizon seen from w, starting at face f (which w sees).
    fn horizon(&mut self, f: usize, w: &Vector3<T>) {
        self.delete(f);
        let (verts, adj) = (self.faces[f].verts, self.faces[f].adj);
        for (k, start) in [(0, verts[1]), (1, verts[2]), (2, verts[0])] {
            if k > 0 && self.faces[adj[k]].index <= -2 {
                continue;
            }
            let edge = self.edge(adj[k], start);
            if !self.horizon_from(adj[k], edge, w) {
                self.horizon.push((adj[k], edge));
            }
        }
    }

    /// The witness points of face f and its signed distance.
    fn witness(&self, f: usize) -> Penetration<T> {
        let face = &self.faces[f];
        let v = face.verts.map(|i| self.verts[i]);
        let l = affine([&v[0].w, &v[1].w, &v[2].w], &face.v);
        Penetration {
            x1: combine(&l, v.iter().map(|x| x.p1)),
            x2: combine(&l, v.iter().map(|x| x.p2)),
            dist: -face.dist2.sqrt(),
            face: v,
        }
    }

    /// Whether vertex `wi` repeats the shape vertices of an earlier one.
    fn repeated(&self, wi: usize) -> bool {
        let w = &self.verts[wi];
        self.verts[..wi]
            .iter()
            .any(|v| v.i1 == w.i1 && v.i2 == w.i2)
    }

    /// MuJoCo's `epa` loop.
    fn expand(
        &mut self,
        bodies: (&Body<T>, &Body<T>),
        tolerance: f64,
        max_iterations: usize,
    ) -> Option<Penetration<T>> {
        let far = lift::<T>(f64::MAX);
        let (mut upper, mut upper2) = (far, far);
        // Discrete bodies end in finitely many steps; a small tolerance keeps
        // the bounds from vanishing.
        let discrete = bodies.0.discrete() && bodies.1.discrete();
        let tolerance = lift::<T>(if discrete { MINVAL } else { tolerance });
        let mut face: Option<usize> = None;
        for k in 0..max_iterations {
            let previous = face;
            let mut lower2 = far;
            for &f in &self.map {
                if self.faces[f].dist2 < lower2 {
                    face = Some(f);
                    lower2 = self.faces[f].dist2;
                }
            }
            let Some(f) = face.filter(|_| lower2 <= upper2) else {
                face = previous;
                break;
            };
            if lower2 <= T::zero() {
                break;
            }
            let lower = lower2.sqrt();
            let v = self.faces[f].v;
            let wi = self.support(bodies, &v, lower);
            let w = self.verts[wi].w;
            let upper_k = v.dot(&w) / lower;
            if upper_k < upper {
                upper = upper_k;
                upper2 = upper * upper;
            }
            if upper - lower < tolerance {
                if k == 0 && upper < lower - lift(1e-10) {
                    face = None;
                }
                break;
            }
            if discrete && self.repeated(wi) {
                break;
            }
            self.horizon.clear();
            self.horizon(f, &w);
            if self.horizon.len() < 3 {
                face = None;
                break;
            }
            let (nfaces, nedges) = (self.faces.len(), self.horizon.len());
            if nedges > self.max_faces - nfaces {
                break;
            }
            for i in 0..nedges {
                let cur = nfaces + i;
                let prev = if i == 0 { nfaces + nedges - 1 } else { cur - 1 };
                let next = nfaces + (i + 1) % nedges;
                let (hf, he) = self.horizon[i];
                let hv = self.faces[hf].verts;
                let (v1, v2) = (hv[he], hv[(he + 1) % 3]);
                self.faces[hf].adj[he] = cur;
                let dist2 = self.attach([wi, v2, v1], [prev, hf, next]);
                if dist2 == T::zero() {
                    face = None;
                    break;
                }
                if dist2 >= lower2 && dist2 <= upper2 {
                    self.faces[cur].index = self.map.len() as isize;
                    self.map.push(cur);
                }
            }
            if self.map.is_empty() || face.is_none() {
                break;
            }
        }
        face.map(|f| self.witness(f))
    }
}
