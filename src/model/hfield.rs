//! Height fields as MuJoCo 4's compiler makes them (`mjCHField`): an
//! elevation grid read from MuJoCo's binary format, a PNG image or given
//! inline, scaled to [0, 1].
//!
//! Frame and units: the field spans x in [-size\[0], size\[0]] and y in
//! [-size\[1], size\[1]] of its geom frame; column c lies at x = -size\[0] +
//! 2 size\[0] c / (ncol - 1), row r at y = -size\[1] + 2 size\[1] r /
//! (nrow - 1). The surface at grid point (r, c) is at z = data[r ncol + c]
//! size\[2]; the field's solid reaches down to z = -size\[3] (its base).
//! Elevations are kept at single precision, as MuJoCo keeps them.

use std::path::Path;

/// The largest height-field file read (bytes).
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// A compiled height field (see the module documentation for its frame).
#[derive(Clone, Debug, PartialEq)]
pub struct HField {
    pub name: String,
    /// Half-extents along x and y, elevation scale, base depth (MuJoCo's
    /// hfield_size), all positive.
    pub size: [f64; 4],
    pub nrow: usize,
    pub ncol: usize,
    /// Elevations in [0, 1], row-major from y = -size\[1].
    pub data: Vec<f32>,
}

impl HField {
    /// MuJoCo's compiler: checks the size and the grid, then shifts and
    /// scales the elevations to [0, 1] (only shifted when they span less
    /// than mjEPS). `data` is row-major from y = -size\[1].
    pub fn compile(
        name: &str,
        size: [f64; 4],
        (nrow, ncol): (usize, usize),
        mut data: Vec<f32>,
    ) -> Result<HField, String> {
        if !size.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err("size parameter is not positive in hfield".into());
        }
        if nrow < 2 || ncol < 2 {
            return Err("hfield dimensions must be at least 2".into());
        }
        if data.len() != nrow * ncol {
            return Err("elevation data length must match nrow*ncol".into());
        }
        if let Some(i) = data.iter().position(|x| !x.is_finite()) {
            return Err(format!("elevation {i} is not finite"));
        }
        let (lo, hi) = data
            .iter()
            .fold((1e10f32, -1e10f32), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        for x in &mut data {
            *x -= lo;
            if f64::from(hi - lo) > 1e-14 {
                *x /= hi - lo;
            }
        }
        Ok(HField {
            name: name.to_string(),
            size,
            nrow,
            ncol,
            data,
        })
    }

    /// MuJoCo's geom_size of a height-field geom: the half-sizes of the box
    /// that also gives its mass and inertia.
    pub fn geom_size(size: &[f64; 4]) -> [f64; 3] {
        [size[0], size[1], 0.25 * size[2] + 0.5 * size[3]]
    }

    /// MuJoCo's geom_rbound of a height-field geom.
    pub fn rbound(size: &[f64; 4]) -> f64 {
        (size[0] * size[0] + size[1] * size[1] + (size[2] * size[2]).max(size[3] * size[3])).sqrt()
    }
}

/// Reads a height-field file: a PNG image (`.png`, see [`read_png`]) or
/// MuJoCo's binary format (`nrow`, `ncol` as 32-bit integers, then nrow
/// ncol 32-bit floats, little-endian, the first row at y = -size\[1]).
pub fn read_file(path: &Path) -> Result<((usize, usize), Vec<f32>), String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let size = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if size > MAX_FILE_BYTES {
        return Err(format!(
            "hfield file of {size} bytes; at most {MAX_FILE_BYTES} are read"
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    if ext == "png" {
        read_png(&bytes)
    } else {
        read_binary(&bytes)
    }
}

/// A PNG image as MuJoCo reads a height field (lodepng decoding to 8-bit
/// grey): one elevation per pixel, the image's width the columns and its
/// height the rows, its top row at y = +size\[1] (rows reversed); the grey
/// level 0-255 of a grey image (lower bit depths scaled up, 16 bits cut to
/// their high byte), the red level of a colour or palette image; alpha
/// ignored. The compiler then scales the levels to [0, 1].
pub fn read_png(bytes: &[u8]) -> Result<((usize, usize), Vec<f32>), String> {
    let error = |e: png::DecodingError| format!("error decoding PNG: {e}");
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(error)?;
    let size = reader
        .output_buffer_size()
        .ok_or("PNG image too large to decode")?;
    let mut pixels = vec![0; size];
    let frame = reader.next_frame(&mut pixels).map_err(error)?;
    let (ncol, nrow) = (frame.width as usize, frame.height as usize);
    let channels = frame.color_type.samples();
    let level = |r: usize, c: usize| f32::from(pixels[r * frame.line_size + c * channels]);
    let data = (0..nrow)
        .rev()
        .flat_map(|r| (0..ncol).map(move |c| level(r, c)))
        .collect();
    Ok(((nrow, ncol), data))
}

/// MuJoCo's binary height-field format (see [`read_file`]), with its checks.
pub fn read_binary(bytes: &[u8]) -> Result<((usize, usize), Vec<f32>), String> {
    let word = |k: usize| -> [u8; 4] { bytes[4 * k..4 * k + 4].try_into().expect("4 bytes") };
    if bytes.len() < 8 {
        return Err("hfield missing header".into());
    }
    let (nrow, ncol) = (i32::from_le_bytes(word(0)), i32::from_le_bytes(word(1)));
    if nrow < 1 || ncol < 1 {
        return Err("non-positive hfield dimensions".into());
    }
    let (nrow, ncol) = (nrow as usize, ncol as usize);
    if nrow.checked_mul(ncol).and_then(|n| n.checked_mul(4)) != Some(bytes.len() - 8) {
        return Err("unexpected file size".into());
    }
    let data = (0..nrow * ncol)
        .map(|k| f32::from_le_bytes(word(k + 2)))
        .collect();
    Ok(((nrow, ncol), data))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(nrow: i32, ncol: i32, data: &[f32]) -> Vec<u8> {
        let mut b = vec![];
        b.extend(nrow.to_le_bytes());
        b.extend(ncol.to_le_bytes());
        data.iter().for_each(|x| b.extend(x.to_le_bytes()));
        b
    }

    #[test]
    fn the_binary_format_reads_and_is_checked() {
        let data = [1.0, 2.0, 3.0, 4.0, 5.0, 7.0];
        assert_eq!(
            read_binary(&binary(2, 3, &data)),
            Ok(((2, 3), data.to_vec()))
        );
        assert!(read_binary(&[0; 7]).unwrap_err().contains("header"));
        assert!(read_binary(&binary(0, 3, &[]))
            .unwrap_err()
            .contains("non-positive"));
        assert!(read_binary(&binary(2, 3, &data[..5]))
            .unwrap_err()
            .contains("file size"));
        assert!(read_binary(&binary(i32::MAX, i32::MAX, &data)).is_err());
    }

    #[test]
    fn elevations_are_scaled_to_the_unit_range_as_mujoco_does() {
        // MuJoCo 4.0.0's hfield_data for these elevations (rows as given).
        let h = HField::compile(
            "h",
            [1.0, 2.0, 0.5, 0.1],
            (2, 3),
            vec![4.0, 5.0, 7.0, 1.0, 2.0, 3.0],
        )
        .unwrap();
        let mujoco = [0.5, 0.6666667, 1.0, 0.0, 0.16666667, 0.33333334];
        for (a, b) in h.data.iter().zip(mujoco) {
            assert!((a - b).abs() < 1e-7, "{a} {b}");
        }
        let flat = HField::compile("h", [1.0; 4], (2, 2), vec![3.0; 4]).unwrap();
        assert_eq!(flat.data, [0.0; 4]);
        let bad = |size, dims, data| HField::compile("h", size, dims, data).unwrap_err();
        assert!(bad([1.0, 1.0, 0.0, 1.0], (2, 2), vec![0.0; 4]).contains("not positive"));
        assert!(bad([1.0; 4], (1, 1), vec![0.0]).contains("at least 2"));
        assert!(bad([1.0; 4], (2, 2), vec![0.0; 3]).contains("nrow*ncol"));
        assert!(bad([1.0; 4], (2, 2), vec![0.0, f32::NAN, 0.0, 0.0]).contains("not finite"));
        // MuJoCo's geom_size and geom_rbound for size (1, 2, 0.5, 0.1).
        assert_eq!(HField::geom_size(&h.size), [1.0, 2.0, 0.175]);
        assert!((HField::rbound(&h.size) - 2.29128784747792).abs() < 1e-15);
    }

    /// A 3 x 2 PNG image of `color` and `depth` with rows `pixels` (top first).
    fn png(color: png::ColorType, depth: png::BitDepth, pixels: &[u8]) -> Vec<u8> {
        let mut out = vec![];
        let mut encoder = png::Encoder::new(&mut out, 3, 2);
        encoder.set_color(color);
        encoder.set_depth(depth);
        if color == png::ColorType::Indexed {
            encoder.set_palette(vec![10, 0, 0, 90, 50, 50, 200, 9, 9]);
        }
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(pixels).unwrap();
        writer.finish().unwrap();
        out
    }

    #[test]
    fn png_images_read_as_mujoco_reads_them() {
        use png::{BitDepth::*, ColorType::*};
        let compiled = |bytes: Vec<u8>| {
            let (dims, data) = read_png(&bytes).unwrap();
            assert_eq!(dims, (2, 3));
            HField::compile("h", [1.0; 4], dims, data).unwrap().data
        };
        // MuJoCo 4.0.0's hfield_data of the same images (rows reversed, the grey
        // level, a colour's red, a 16-bit level's high byte, scaled to [0, 1]).
        let levels = [0.28, 0.0, 1.0, 0.04, 0.08, 0.16];
        let grey = [10, 20, 40, 70, 0, 250];
        let rgb = [10, 1, 2, 20, 3, 4, 40, 5, 6, 70, 7, 8, 0, 9, 9, 250, 1, 1];
        let wide = [10, 255, 20, 0, 40, 7, 70, 1, 0, 200, 250, 0];
        for data in [
            compiled(png(Grayscale, Eight, &grey)),
            compiled(png(Rgb, Eight, &rgb)),
            compiled(png(Grayscale, Sixteen, &wide)),
        ] {
            assert!(
                data.iter().zip(levels).all(|(a, b)| (a - b).abs() < 1e-7),
                "{data:?}"
            );
        }
        // Palette entries' red levels 10, 90, 200; two-bit grey levels 0 to 3.
        let palette = compiled(png(Indexed, Eight, &[0, 1, 2, 2, 1, 0]));
        let mujoco = [1.0, 0.42105263, 0.0, 0.0, 0.42105263, 1.0];
        assert!(palette
            .iter()
            .zip(mujoco)
            .all(|(a, b)| (a - b).abs() < 1e-7));
        let two_bit = compiled(png(Grayscale, Two, &[0b00011011, 0b11100100]));
        let mujoco = [1.0, 0.6666667, 0.33333334, 0.0, 0.33333334, 0.6666667];
        assert!(two_bit
            .iter()
            .zip(mujoco)
            .all(|(a, b)| (a - b).abs() < 1e-7));
        assert!(read_png(b"not a png").unwrap_err().contains("decoding PNG"));
    }
}
