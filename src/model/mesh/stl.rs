//! STL, binary and ASCII, as MuJoCo 4's STL decoder reads it: each
//! triangle's three corners, single precision, with corners of equal bit
//! patterns merged into one vertex (numbered in order of first appearance).
//! MuJoCo refuses a binary file of more than 200000 triangles or with a
//! coordinate beyond 2^30, and so do we. MuJoCo 4 reads binary STL only;
//! an ASCII file (`solid` ... `endsolid`) is read here with the same rules.

use std::collections::HashMap;

use super::RawMesh;

/// MuJoCo's largest binary STL, in triangles.
const MAX_TRIANGLES: usize = 200_000;
/// MuJoCo's largest coordinate magnitude.
const MAX_COORDINATE: f32 = (1u32 << 30) as f32;

/// Reads binary STL when the size matches its triangle count, else ASCII.
pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    if bytes.len() >= 84 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if (bytes.len() - 84).is_multiple_of(50) && (bytes.len() - 84) / 50 == count {
            return read_binary(&bytes[84..], count);
        }
    }
    if bytes.trim_ascii_start().starts_with(b"solid") {
        return read_ascii(bytes);
    }
    Err(
        "neither binary STL (84-byte header, then 50 bytes per triangle as counted) nor ASCII STL"
            .into(),
    )
}

fn read_binary(data: &[u8], count: usize) -> Result<RawMesh, String> {
    if count == 0 || count > MAX_TRIANGLES {
        return Err(format!(
            "binary STL with {count} triangles; MuJoCo reads 1 to {MAX_TRIANGLES}"
        ));
    }
    let mut corners = Vec::with_capacity(3 * count);
    for triangle in data.chunks_exact(50) {
        for c in 0..3 {
            let at = 12 * (c + 1);
            corners.push(std::array::from_fn(|k| {
                let b = &triangle[at + 4 * k..at + 4 * k + 4];
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            }));
        }
    }
    merge(&corners)
}

fn read_ascii(bytes: &[u8]) -> Result<RawMesh, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "ASCII STL that is not UTF-8".to_string())?;
    let mut corners = vec![];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("vertex") {
            continue;
        }
        let mut corner = [0f32; 3];
        for c in &mut corner {
            let word = words.next().unwrap_or("");
            *c = word
                .parse()
                .map_err(|_| format!("line {}: bad vertex coordinate '{word}'", n + 1))?;
        }
        corners.push(corner);
    }
    if corners.is_empty() || corners.len() % 3 != 0 {
        return Err(format!(
            "ASCII STL with {} vertices, not a positive multiple of 3",
            corners.len()
        ));
    }
    merge(&corners)
}

/// Vertices and triangles from triangle corners, merging equal bit patterns.
fn merge(corners: &[[f32; 3]]) -> Result<RawMesh, String> {
    let mut index: HashMap<[u32; 3], usize> = HashMap::new();
    let mut mesh = RawMesh::default();
    let mut face = [0usize; 3];
    for (k, c) in corners.iter().enumerate() {
        if !c.iter().all(|x| x.abs() <= MAX_COORDINATE) {
            return Err(format!("vertex {c:?} exceeds MuJoCo's bound 2^30"));
        }
        let next = mesh.vertices.len();
        face[k % 3] = *index.entry(c.map(f32::to_bits)).or_insert(next);
        if face[k % 3] == next {
            mesh.vertices.push(*c);
        }
        if k % 3 == 2 {
            mesh.faces.push(face);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            b.extend([0u8; 12]);
            for c in t {
                for x in c {
                    b.extend(x.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
        }
        b
    }

    #[test]
    fn binary_and_ascii_give_the_same_merged_mesh() {
        let t = [
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        ];
        let a = read(&binary(&t)).unwrap();
        assert_eq!(a.vertices.len(), 4);
        assert_eq!(a.faces, vec![[0, 1, 2], [0, 2, 3]]);
        let text = "solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n \
                    vertex 0 1 0\n endloop\n endfacet\n facet normal 0 0 1\n outer loop\n \
                    vertex 0 0 0\n vertex 0 1 0\n vertex 0 0 1\n endloop\n endfacet\nendsolid x\n";
        let b = read(text.as_bytes()).unwrap();
        assert_eq!((a.vertices, a.faces), (b.vertices, b.faces));
    }

    #[test]
    fn bad_counts_and_coordinates_are_refused() {
        let t = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
        let mut b = binary(&t);
        b[80] = 2; // counts 2, holds 1
        assert!(read(&b).unwrap_err().contains("neither"));
        let mut huge = binary(&[]);
        huge[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(read(&huge).is_err());
        assert!(read(&binary(&[])).unwrap_err().contains("0 triangles"));
        let far = [[[0.0, 0.0, 0.0], [2e9, 0.0, 0.0], [0.0, 1.0, 0.0]]];
        assert!(read(&binary(&far)).unwrap_err().contains("2^30"));
        let nan = [[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]];
        assert!(read(&binary(&nan)).is_err());
        assert!(read(b"solid x\n vertex 0 0 zero\n")
            .unwrap_err()
            .contains("line 2"));
    }
}
