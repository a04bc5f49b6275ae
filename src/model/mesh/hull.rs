//! The convex hull of a mesh's vertices, as MuJoCo builds it with qhull
//! (`mjCMesh::MakeGraph`, options `Qt`, and `Q9 TA(maxhullvert - 4)` when
//! the vertex count is bounded): triangles with outward normals (counter-
//! clockwise seen from outside), as indices into the mesh's vertices.
//!
//! Quickhull: start from a tetrahedron of extreme points, then add the
//! point farthest outside any face (qhull's Q9 order), replacing the faces
//! it sees by a cone from their horizon, until no point lies farther than
//! the round-off tolerance outside (or the vertex budget is spent). Points
//! within the tolerance of a face are inside (qhull's default).
//!
//! MuJoCo refuses colocated, collinear and coplanar vertex sets first, with
//! its own tests and messages ([`check_spread`]).

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::model::MINVAL;

/// A convex hull: the mesh vertices on it and its triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct Hull {
    /// Indices of the mesh vertices that are hull vertices, ascending.
    pub vertices: Vec<usize>,
    /// Outward triangles, as mesh vertex indices.
    pub faces: Vec<[usize; 3]>,
}

struct Face {
    v: [usize; 3],
    normal: Vector3<f64>,
    offset: f64,
    outside: Vec<usize>,
    alive: bool,
}

impl Face {
    fn new(p: &[Vector3<f64>], v: [usize; 3]) -> Face {
        let n = (p[v[1]] - p[v[0]]).cross(&(p[v[2]] - p[v[0]]));
        let normal = n / n.norm().max(f64::MIN_POSITIVE);
        Face {
            v,
            normal,
            offset: normal.dot(&p[v[0]]),
            outside: vec![],
            alive: true,
        }
    }

    fn distance(&self, x: &Vector3<f64>) -> f64 {
        self.normal.dot(x) - self.offset
    }
}

/// MuJoCo's checks before qhull, with its messages (`name` is the mesh's).
pub fn check_spread(p: &[Vector3<f64>], name: &str) -> Result<(), String> {
    let Some((v1, len1)) = p
        .iter()
        .enumerate()
        .skip(1)
        .map(|(i, x)| (i, (x - p[0]).norm()))
        .find(|(_, d)| *d > MINVAL)
    else {
        return Err(format!(
            "mesh '{name}' has colocated vertices, cannot compute convex hull. \
             Consider using a small sphere instead"
        ));
    };
    let edge1 = p[v1] - p[0];
    let normal = p.iter().enumerate().skip(1).find_map(|(i, x)| {
        let edge2 = x - p[0];
        let len2 = edge2.norm();
        if i == v1 || len2 < MINVAL {
            return None;
        }
        let n = edge1.cross(&edge2);
        (n.norm() > MINVAL * len1 * len2).then(|| n / n.norm())
    });
    let Some(normal) = normal else {
        return Err(format!(
            "mesh '{name}' has collinear vertices, cannot compute convex hull. \
             Consider using a thin capsule instead"
        ));
    };
    let d = normal.dot(&p[0]);
    if p.iter().all(|x| (normal.dot(x) - d).abs() <= MINVAL * len1) {
        return Err(format!(
            "mesh '{name}' has coplanar vertices, cannot compute convex hull. \
             Consider using a primitive geom type (plane or thin box) instead"
        ));
    }
    Ok(())
}

/// The hull of points `p` (at least 4, spread in 3D: see [`check_spread`])
/// with at most `max_vertices` vertices (None: all it needs).
pub fn hull(p: &[Vector3<f64>], max_vertices: Option<usize>) -> Result<Hull, String> {
    let scale = p.iter().map(|x| x.amax()).fold(0.0, f64::max);
    let eps = 1e-12 * scale.max(MINVAL);
    let start = initial_simplex(p, eps).ok_or("the convex hull is degenerate (flat)")?;
    let mut faces: Vec<Face> = vec![];
    let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
    let add = |faces: &mut Vec<Face>, edges: &mut HashMap<_, _>, v: [usize; 3]| {
        for k in 0..3 {
            edges.insert((v[k], v[(k + 1) % 3]), faces.len());
        }
        faces.push(Face::new(p, v));
    };
    let [a, b, c, d] = start;
    let (b, c) = if Face::new(p, [a, b, c]).distance(&p[d]) > 0.0 {
        (c, b)
    } else {
        (b, c)
    };
    for v in [[a, b, c], [a, c, d], [a, d, b], [b, d, c]] {
        add(&mut faces, &mut edges, v);
    }
    let points: Vec<usize> = (0..p.len()).filter(|i| !start.contains(i)).collect();
    assign(p, &mut faces, 0..4, points, eps);
    let mut count = 4;
    while max_vertices.is_none_or(|m| count < m) {
        let Some((f, apex)) = farthest(p, &faces) else {
            break;
        };
        let visible = visible_from(p, &faces, &edges, f, apex, eps)?;
        let mut horizon = vec![];
        let mut orphans = vec![];
        for &i in &visible {
            let v = faces[i].v;
            for k in 0..3 {
                let (x, y) = (v[k], v[(k + 1) % 3]);
                if !visible.contains(twin(&edges, (y, x))?) {
                    horizon.push((x, y));
                }
            }
            orphans.append(&mut faces[i].outside);
            faces[i].alive = false;
        }
        for &i in &visible {
            let v = faces[i].v;
            for k in 0..3 {
                if edges.get(&(v[k], v[(k + 1) % 3])) == Some(&i) {
                    edges.remove(&(v[k], v[(k + 1) % 3]));
                }
            }
        }
        let first = faces.len();
        for (x, y) in horizon {
            add(&mut faces, &mut edges, [x, y, apex]);
        }
        orphans.retain(|&i| i != apex);
        let last = faces.len();
        assign(p, &mut faces, first..last, orphans, eps);
        count += 1;
    }
    let faces: Vec<[usize; 3]> = faces.iter().filter(|f| f.alive).map(|f| f.v).collect();
    let mut vertices: Vec<usize> = faces.iter().flatten().copied().collect();
    vertices.sort_unstable();
    vertices.dedup();
    Ok(Hull { vertices, faces })
}

/// Four extreme points spanning a tetrahedron of positive volume.
fn initial_simplex(p: &[Vector3<f64>], eps: f64) -> Option<[usize; 4]> {
    let by = |key: &dyn Fn(&Vector3<f64>) -> f64| {
        (0..p.len()).max_by(|&i, &j| key(&p[i]).total_cmp(&key(&p[j])))
    };
    let (mut a, mut b, mut spread) = (0, 0, -1.0);
    for axis in 0..3 {
        let hi = by(&|x| x[axis])?;
        let lo = by(&|x| -x[axis])?;
        let s = p[hi][axis] - p[lo][axis];
        if s > spread {
            (a, b, spread) = (lo, hi, s);
        }
    }
    let line = (p[b] - p[a]).normalize();
    let c = by(&|x| (x - p[a]).cross(&line).norm())?;
    let normal = (p[b] - p[a]).cross(&(p[c] - p[a]));
    let d = by(&|x| normal.dot(&(x - p[a])).abs())?;
    let height = normal.dot(&(p[d] - p[a])).abs() / normal.norm().max(f64::MIN_POSITIVE);
    (height > eps && normal.norm() > 0.0).then_some([a, b, c, d])
}

/// Gives each point to the new face (of `range`) it is farthest outside,
/// dropping points inside all of them.
fn assign(
    p: &[Vector3<f64>],
    faces: &mut [Face],
    range: std::ops::Range<usize>,
    points: Vec<usize>,
    eps: f64,
) {
    for i in points {
        let best = range
            .clone()
            .map(|f| (f, faces[f].distance(&p[i])))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((f, d)) = best {
            if d > eps {
                faces[f].outside.push(i);
            }
        }
    }
}

/// The point farthest outside any live face, with that face (qhull's Q9).
fn farthest(p: &[Vector3<f64>], faces: &[Face]) -> Option<(usize, usize)> {
    faces
        .iter()
        .enumerate()
        .filter(|(_, f)| f.alive)
        .flat_map(|(k, f)| f.outside.iter().map(move |&i| (k, i, f.distance(&p[i]))))
        .max_by(|x, y| x.2.total_cmp(&y.2).then(y.1.cmp(&x.1)))
        .map(|(k, i, _)| (k, i))
}

/// The live faces that see `apex`, connected to face `f`.
fn visible_from(
    p: &[Vector3<f64>],
    faces: &[Face],
    edges: &HashMap<(usize, usize), usize>,
    f: usize,
    apex: usize,
    eps: f64,
) -> Result<Vec<usize>, String> {
    let mut visible = vec![f];
    let mut k = 0;
    while k < visible.len() {
        let v = faces[visible[k]].v;
        for e in 0..3 {
            let n = *twin(edges, (v[(e + 1) % 3], v[e]))?;
            if !visible.contains(&n) && faces[n].distance(&p[apex]) > eps {
                visible.push(n);
            }
        }
        k += 1;
    }
    Ok(visible)
}

/// The face holding directed edge `e`; none means round-off broke the
/// hull's surface (MuJoCo's "qhull error").
fn twin(edges: &HashMap<(usize, usize), usize>, e: (usize, usize)) -> Result<&usize, String> {
    edges
        .get(&e)
        .ok_or_else(|| "qhull error: the convex hull lost an edge to round-off".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_with_inner_points() -> Vec<Vector3<f64>> {
        let mut p: Vec<Vector3<f64>> = (0..8)
            .map(|k| Vector3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64))
            .collect();
        p.push(Vector3::new(0.5, 0.5, 0.5));
        p.push(Vector3::new(0.5, 0.5, 1.0)); // on a face: not a hull vertex
        p
    }

    fn volume(p: &[Vector3<f64>], h: &Hull) -> f64 {
        h.faces
            .iter()
            .map(|f| p[f[0]].dot(&p[f[1]].cross(&p[f[2]])) / 6.0)
            .sum()
    }

    #[test]
    fn a_cube_hull_has_its_corners_and_twelve_outward_triangles() {
        let p = cube_with_inner_points();
        let h = hull(&p, None).unwrap();
        assert_eq!(h.vertices, (0..8).collect::<Vec<_>>());
        assert_eq!(h.faces.len(), 12);
        assert!((volume(&p, &h) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_sphere_of_points_gives_a_closed_hull_within_the_budget() {
        let p: Vec<Vector3<f64>> = (0..300)
            .map(|k| {
                let (a, b) = (
                    k as f64 * 2.399963,
                    (1.0 - 2.0 * (k as f64 + 0.5) / 300.0).acos(),
                );
                Vector3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos())
            })
            .collect();
        let h = hull(&p, None).unwrap();
        assert_eq!(h.vertices.len(), 300);
        // Euler: a closed triangulated sphere has 2V - 4 faces.
        assert_eq!(h.faces.len(), 2 * 300 - 4);
        let v = volume(&p, &h);
        assert!(v < 4.0 / 3.0 * std::f64::consts::PI && v > 4.0, "{v}");
        // Every point lies inside every face's plane.
        for f in &h.faces {
            let n = (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]]));
            assert!(p.iter().all(|x| n.dot(&(x - p[f[0]])) <= 1e-12), "{f:?}");
        }
        let small = hull(&p, Some(12)).unwrap();
        assert_eq!(small.vertices.len(), 12);
        assert_eq!(small.faces.len(), 20);
    }

    #[test]
    fn degenerate_sets_are_refused_as_mujoco_refuses_them() {
        let z = Vector3::zeros();
        let x = Vector3::x();
        let spread = |p: &[Vector3<f64>]| check_spread(p, "m").unwrap_err();
        assert!(spread(&[z, z, z, z]).contains("colocated"));
        assert!(spread(&[z, x, 2.0 * x, 3.0 * x]).contains("collinear"));
        assert!(spread(&[z, x, Vector3::y(), x + Vector3::y()]).contains("coplanar"));
        assert!(check_spread(&cube_with_inner_points(), "m").is_ok());
    }
}
