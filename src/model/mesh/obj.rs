//! Wavefront OBJ as MuJoCo 4 reads it (tinyobjloader, triangulating): every
//! `v` line is a vertex (single precision, in file order, kept whether used
//! or not); `f` lines are faces, indices 1-based or negative (relative to
//! the vertices read so far), `v/vt/vn` forms allowed. Polygons are
//! triangulated as tinyobjloader does, in single precision: a quad along
//! its shorter diagonal, a larger polygon by its ear clipping in the
//! coordinate plane its first corner faces most ([`clip_ears`]). MuJoCo keeps only
//! the first shape: faces after a `g` or `o` line that follows faces are
//! not part of the mesh. Other lines (normals, texture, materials) are
//! skipped.

use super::RawMesh;

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let text = String::from_utf8_lossy(bytes);
    let mut mesh = RawMesh::default();
    let mut polygons: Vec<Vec<usize>> = vec![];
    let mut first_shape_done = false;
    for (n, line) in text.lines().enumerate() {
        let at = |msg: String| format!("line {}: {msg}", n + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut v = [0f32; 3];
                for c in &mut v {
                    let w = words.next().unwrap_or("");
                    *c = w
                        .parse::<f64>()
                        .map_err(|_| at(format!("bad vertex coordinate '{w}'")))?
                        as f32;
                }
                mesh.vertices.push(v);
            }
            Some("g" | "o") if polygons.iter().any(|p| p.len() >= 3) => first_shape_done = true,
            Some("f") if !first_shape_done => {
                let corners = words
                    .map(|w| vertex_index(w, mesh.vertices.len()).map_err(&at))
                    .collect::<Result<Vec<usize>, String>>()?;
                polygons.push(corners);
            }
            _ => {}
        }
    }
    for p in &polygons {
        triangulate(&mesh.vertices, p, &mut mesh.faces);
    }
    Ok(mesh)
}

/// The vertex of a face corner `v[/vt[/vn]]`, 0-based.
fn vertex_index(word: &str, count: usize) -> Result<usize, String> {
    let v = word.split('/').next().unwrap_or("");
    let i: i64 = v
        .parse()
        .map_err(|_| format!("bad face vertex index '{word}'"))?;
    let index = match i {
        1.. => i - 1,
        ..=-1 => count as i64 + i,
        0 => -1,
    };
    usize::try_from(index).map_err(|_| format!("face vertex index {i} does not exist"))
}

/// Appends the triangles of polygon `p` (fewer than 3 corners: none).
fn triangulate(vertices: &[[f32; 3]], p: &[usize], faces: &mut Vec<[usize; 3]>) {
    if p.len() == 4 {
        let d2 = |a: usize, b: usize| -> f32 {
            let (u, w) = (vertices.get(p[a]), vertices.get(p[b]));
            match (u, w) {
                (Some(u), Some(w)) => {
                    let e = [w[0] - u[0], w[1] - u[1], w[2] - u[2]];
                    e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
                }
                _ => 0.0,
            }
        };
        if d2(0, 2) < d2(1, 3) {
            faces.extend([[p[0], p[1], p[2]], [p[0], p[2], p[3]]]);
        } else {
            faces.extend([[p[0], p[1], p[3]], [p[1], p[2], p[3]]]);
        }
        return;
    }
    if p.len() == 3 {
        faces.push([p[0], p[1], p[2]]);
    } else if p.len() > 4 {
        clip_ears(vertices, p, faces);
    }
}

/// tinyobjloader's ear clipping (single precision): project on the two
/// axes the first corner with a turn faces least, then repeatedly cut off
/// the ear at the guessed corner unless its turn is reflex (by
/// tinyobjloader's sign test) or another corner lies inside it; what is
/// left after a full round without progress is dropped.
fn clip_ears(vertices: &[[f32; 3]], p: &[usize], faces: &mut Vec<[usize; 3]>) {
    let at = |i: usize| vertices.get(i).copied().unwrap_or([0.0; 3]);
    let n = p.len();
    let mut axes = [1, 2];
    for k in 0..n {
        let [a, b, c] = [p[k], p[(k + 1) % n], p[(k + 2) % n]];
        if [a, b, c].iter().any(|&i| i >= vertices.len()) {
            continue;
        }
        let (a, b, c) = (at(a), at(b), at(c));
        let e0 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e1 = [c[0] - b[0], c[1] - b[1], c[2] - b[2]];
        let cx = (e0[1] * e1[2] - e0[2] * e1[1]).abs();
        let cy = (e0[2] * e1[0] - e0[0] * e1[2]).abs();
        let cz = (e0[0] * e1[1] - e0[1] * e1[0]).abs();
        if cx > f32::EPSILON || cy > f32::EPSILON || cz > f32::EPSILON {
            if !(cx > cy && cx > cz) {
                axes[0] = 0;
                if cz > cx && cz > cy {
                    axes[1] = 1;
                }
            }
            break;
        }
    }
    let plane = |i: usize| {
        let v = at(i);
        (v[axes[0]], v[axes[1]])
    };
    let mut left = p.to_vec();
    let (mut guess, mut tries, mut before) = (0, n, n);
    while left.len() > 3 && tries > 0 {
        let m = left.len();
        if guess >= m {
            guess -= m;
        }
        if before != m {
            (before, tries) = (m, m);
        } else {
            tries -= 1;
        }
        let ind: [usize; 3] = std::array::from_fn(|k| left[(guess + k) % m]);
        let (x, y): (Vec<f32>, Vec<f32>) = ind.iter().map(|&i| plane(i)).unzip();
        let cross = (x[1] - x[0]) * (y[2] - y[1]) - (y[1] - y[0]) * (x[2] - x[1]);
        let area = (x[0] * y[1] - y[0] * x[1]) * 0.5;
        let inside = |k: usize| {
            let (tx, ty) = plane(left[(guess + k) % m]);
            in_triangle(&x, &y, tx, ty)
        };
        if cross * area < 0.0 || (3..m).any(inside) {
            guess += 1;
            continue;
        }
        faces.push(ind);
        left.remove((guess + 1) % m);
    }
    if left.len() == 3 {
        faces.push([left[0], left[1], left[2]]);
    }
}

/// The even-odd crossing test of a point against a triangle.
fn in_triangle(x: &[f32], y: &[f32], tx: f32, ty: f32) -> bool {
    let mut inside = false;
    let mut j = 2;
    for i in 0..3 {
        if (y[i] > ty) != (y[j] > ty) && tx < (x[j] - x[i]) * (ty - y[i]) / (y[j] - y[i]) + x[i] {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_split_along_the_shorter_diagonal_and_indices_resolve() {
        let text = "# a quad\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nvn 0 0 1\n\
                    f 1//1 2//1 3//1 4//1\nf -4 -2 -1\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.vertices.len(), 4);
        // Diagonals 0-2 and 1-3 are equal here: tinyobjloader takes 1-3.
        assert_eq!(m.faces, vec![[0, 1, 3], [1, 2, 3], [0, 2, 3]]);
        let skew = read(b"v 0 0 0\nv 3 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(skew.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn larger_polygons_are_clipped_into_ears_covering_them() {
        // A concave pentagon (a notch at corner 3) in the z = 1 plane.
        let text = "v 0 0 1\nv 4 0 1\nv 4 3 1\nv 2 1 1\nv 0 3 1\nf 1 2 3 4 5\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.faces.len(), 3);
        let area = |f: &[usize; 3]| {
            let [a, b, c] = f.map(|i| m.vertices[i]);
            ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2.0
        };
        // Every ear turns the polygon's way and together they cover it.
        assert!(m.faces.iter().all(|f| area(f) > 0.0), "{:?}", m.faces);
        assert_eq!(m.faces.iter().map(area).sum::<f32>(), 8.0);
    }

    #[test]
    fn only_the_first_shape_counts_and_bad_lines_are_named() {
        let text = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng b\nv 0 0 1\nf 1 2 4\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!((m.vertices.len(), m.faces.len()), (4, 1));
        assert!(read(b"v 0 0 x\n").unwrap_err().contains("line 1"));
        assert!(read(b"v 0 0 0\nf 0 1 1\n").unwrap_err().contains("line 2"));
        assert!(read(b"v 0 0 0\nf -2 1 1\n").unwrap_err().contains("-2"));
    }
}
