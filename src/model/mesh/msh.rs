//! MuJoCo's binary MSH format (`mjCMesh::LoadMSH`): four little-endian
//! int32 counts (vertices nv, normals nn, texture coordinates nt, faces
//! nf), then 3 nv float32 positions, 3 nn normals, 2 nt texture
//! coordinates and 3 nf int32 vertex indices. MuJoCo requires nv >= 4, nn
//! and nt each 0 or nv, and the file size to match the counts exactly.

use super::RawMesh;

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let word = |k: usize| -> [u8; 4] { std::array::from_fn(|i| bytes[4 * k + i]) };
    if bytes.len() < 16 {
        return Err("missing header in MSH file".into());
    }
    let [nv, nn, nt, nf] = std::array::from_fn(|k| i32::from_le_bytes(word(k)) as i64);
    if nv < 4 || nf < 0 || nn < 0 || nt < 0 || (nn > 0 && nn != nv) || (nt > 0 && nt != nv) {
        return Err(format!(
            "invalid sizes in MSH file (vertices {nv}, normals {nn}, texcoords {nt}, faces {nf})"
        ));
    }
    let words = 4 + 3 * nv + 3 * nn + 2 * nt + 3 * nf;
    if bytes.len() as i64 != 4 * words {
        return Err(format!(
            "unexpected MSH file size {} for its counts ({} expected)",
            bytes.len(),
            4 * words
        ));
    }
    let (nv, nf) = (nv as usize, nf as usize);
    let vertices = (0..nv)
        .map(|i| std::array::from_fn(|c| f32::from_le_bytes(word(4 + 3 * i + c))))
        .collect();
    let first_face = 4 + 3 * nv + 3 * nn as usize + 2 * nt as usize;
    let faces = (0..nf)
        .map(|i| {
            let f: [i32; 3] =
                std::array::from_fn(|c| i32::from_le_bytes(word(first_face + 3 * i + c)));
            match f.map(usize::try_from) {
                [Ok(a), Ok(b), Ok(c)] => Ok([a, b, c]),
                _ => Err(format!("face {i} has a negative vertex index {f:?}")),
            }
        })
        .collect::<Result<_, _>>()?;
    Ok(RawMesh { vertices, faces })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msh(counts: [i32; 4], floats: &[f32], ints: &[i32]) -> Vec<u8> {
        let mut b: Vec<u8> = counts.iter().flat_map(|c| c.to_le_bytes()).collect();
        b.extend(floats.iter().flat_map(|x| x.to_le_bytes()));
        b.extend(ints.iter().flat_map(|x| x.to_le_bytes()));
        b
    }

    #[test]
    fn counts_and_size_are_checked() {
        let v = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.];
        let f = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
        let m = read(&msh([4, 0, 0, 4], &v, &f)).unwrap();
        assert_eq!((m.vertices.len(), m.faces[3]), (4, [1, 2, 3]));
        assert!(read(&msh([4, 0, 0, 5], &v, &f))
            .unwrap_err()
            .contains("size"));
        assert!(read(&msh([3, 0, 0, 0], &v[..9], &[])).is_err());
        assert!(read(&msh([4, 2, 0, 0], &v, &[])).is_err());
        assert!(read(&msh([i32::MAX, 0, 0, i32::MAX], &[], &[])).is_err());
        assert!(read(&msh([4, 0, 0, 1], &v, &[0, -1, 2]))
            .unwrap_err()
            .contains("negative"));
        assert!(read(&[1, 2, 3]).is_err());
    }
}
