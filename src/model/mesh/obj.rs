//! Wavefront OBJ as MuJoCo 4 reads it (tinyobjloader, triangulating): every
//! `v` line is a vertex (single precision, in file order, kept whether used
//! or not); `f` lines are faces, indices 1-based or negative (relative to
//! the vertices read so far), `v/vt/vn` forms allowed. A quad is split along
//! its shorter diagonal (as tinyobjloader does, in single precision); a
//! polygon of more vertices is fanned from its first vertex (tinyobjloader
//! clips ears, the same triangles for a convex polygon). MuJoCo keeps only
//! the first shape: faces after a `g` or `o` line that follows faces are
//! not part of the mesh. Other lines (normals, texture, materials) are
//! skipped.

use super::RawMesh;

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let text = String::from_utf8_lossy(bytes);
    let mut mesh = RawMesh::default();
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
            Some("g" | "o") if !mesh.faces.is_empty() => first_shape_done = true,
            Some("f") if !first_shape_done => {
                let corners = words
                    .map(|w| vertex_index(w, mesh.vertices.len()).map_err(&at))
                    .collect::<Result<Vec<usize>, String>>()?;
                triangulate(&mesh.vertices, &corners, &mut mesh.faces);
            }
            _ => {}
        }
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
    for k in 2..p.len() {
        faces.push([p[0], p[k - 1], p[k]]);
    }
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
    fn only_the_first_shape_counts_and_bad_lines_are_named() {
        let text = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng b\nv 0 0 1\nf 1 2 4\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!((m.vertices.len(), m.faces.len()), (4, 1));
        assert!(read(b"v 0 0 x\n").unwrap_err().contains("line 1"));
        assert!(read(b"v 0 0 0\nf 0 1 1\n").unwrap_err().contains("line 2"));
        assert!(read(b"v 0 0 0\nf -2 1 1\n").unwrap_err().contains("-2"));
    }
}
