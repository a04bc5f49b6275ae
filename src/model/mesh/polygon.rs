//! The flat sides of a mesh's convex hull, as MuJoCo's compiler merges them
//! (`mjCMesh::MakePolygons`): hull triangles whose normals round to the same
//! azimuth and polar angle (steps of 0.01 rad, a normal within 1e-7 of ±z
//! taking azimuth 0) form one polygon; each connected patch of them is a
//! side, its boundary a cycle of vertices counter-clockwise seen from
//! outside. MuJoCo's plane-mesh collider takes its extra contacts from the
//! side that faces the plane most.
//!
//! The angles are those of the points the hull was built on (before
//! refpos, refquat and scale, as MuJoCo's); a side's normal is that of its
//! first three vertices in the mesh frame.

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::model::MINVAL;

/// A flat side of the hull.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// Mesh vertex indices, a cycle counter-clockwise seen from outside.
    pub vertices: Vec<usize>,
    /// The unit outward normal in the mesh frame.
    pub normal: Vector3<f64>,
}

/// MuJoCo's angle step for merging hull triangles into sides (rad).
const ANGLE_STEP: f64 = 0.01;

/// The sides of the hull with triangles `faces` over `points` (the hull's
/// points), each a boundary cycle of mesh vertex indices, in the order of
/// their first triangle.
pub fn sides(points: &[Vector3<f64>], faces: &[[usize; 3]]) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<[usize; 3]>> = vec![];
    let mut index: HashMap<(i64, i64), usize> = HashMap::new();
    for f in faces {
        let Some(key) = key(points, f) else {
            continue;
        };
        let g = *index.entry(key).or_insert_with(|| {
            groups.push(vec![]);
            groups.len() - 1
        });
        groups[g].push(*f);
    }
    groups.iter().flat_map(|g| boundary_cycles(g)).collect()
}

/// A triangle's rounded (azimuth, polar) angles of its normal, None when
/// it is degenerate (MuJoCo's MeshPolygonKey).
fn key(p: &[Vector3<f64>], [a, b, c]: &[usize; 3]) -> Option<(i64, i64)> {
    let n = (p[*b] - p[*a]).cross(&(p[*c] - p[*a]));
    let len = n.norm();
    if len < MINVAL {
        return None;
    }
    let n = n / len;
    if n.z.abs() > 1.0 - 1e-7 {
        let polar = if n.z < 0.0 {
            (std::f64::consts::PI / ANGLE_STEP).round()
        } else {
            0.0
        };
        return Some((0, polar as i64));
    }
    // Adding 0.0 turns -0.0 into +0.0, to which atan2 is sensitive.
    let azimuth = ((n.y + 0.0).atan2(n.x + 0.0) / ANGLE_STEP).round();
    let polar = (n.z.acos() / ANGLE_STEP).round();
    Some((azimuth as i64, polar as i64))
}

/// The boundary cycles of a set of triangles: the directed edges whose
/// reverse is not an edge, chained head to tail.
fn boundary_cycles(triangles: &[[usize; 3]]) -> Vec<Vec<usize>> {
    let edges: Vec<(usize, usize)> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .collect();
    let mut next: HashMap<usize, usize> = HashMap::new();
    let mut order = vec![];
    for &(a, b) in &edges {
        if !edges.contains(&(b, a)) {
            next.insert(a, b);
            order.push(a);
        }
    }
    let mut cycles = vec![];
    for start in order {
        let Some(mut at) = next.remove(&start) else {
            continue;
        };
        let mut cycle = vec![start];
        while at != start {
            cycle.push(at);
            match next.remove(&at) {
                Some(n) => at = n,
                None => break,
            }
        }
        if cycle.len() >= 3 {
            cycles.push(cycle);
        }
    }
    cycles
}

/// MuJoCo's normal of a side: that of its first three vertices
/// (`mjuu_makenormal`), in the frame of `points`.
pub fn normal(points: &[Vector3<f64>], cycle: &[usize]) -> Vector3<f64> {
    let [a, b, c] = [0, 1, 2].map(|k| points[cycle[k]]);
    let n = (b - a).cross(&(c - a));
    let len = n.norm();
    if len < MINVAL {
        n
    } else {
        n / len
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::hull::hull;

    #[test]
    fn a_cube_has_six_square_sides_facing_out() {
        let p: Vec<Vector3<f64>> = (0..8)
            .map(|i| Vector3::from_fn(|r, _| if i >> r & 1 == 1 { 1.0 } else { -1.0 }))
            .collect();
        let h = hull(&p, None).unwrap();
        let sides = sides(&p, &h.faces);
        assert_eq!(sides.len(), 6);
        for s in &sides {
            assert_eq!(s.len(), 4);
            let n = normal(&p, s);
            // Every vertex lies on the side's plane, which is a face of the cube.
            assert!((n.abs().max() - 1.0).abs() < 1e-15, "{n}");
            assert!(s.iter().all(|&v| (p[v].dot(&n) - 1.0).abs() < 1e-15));
        }
    }

    #[test]
    fn a_tetrahedron_has_four_triangles() {
        let p = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let h = hull(&p, None).unwrap();
        let sides = sides(&p, &h.faces);
        assert_eq!(sides.len(), 4);
        let centre = Vector3::repeat(0.25);
        for s in &sides {
            assert_eq!(s.len(), 3);
            assert!(normal(&p, s).dot(&(p[s[0]] - centre)) > 0.0);
        }
    }
}
