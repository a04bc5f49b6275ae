//! `<asset><hfield>`: height fields from a PNG image, MuJoCo's binary file
//! format or inline `elevation` data (see [`crate::model::hfield`]), found like mesh
//! files (at `meshdir`, as MuJoCo looks for them). `elevation` lists the
//! rows from the top (y = +size[1]) down, as MuJoCo reads it; without it
//! and without a file the field is flat. A field without a name takes its
//! file's. Attributes read: name, file, nrow, ncol, size, elevation;
//! content_type is accepted and ignored (a `.png` file is an image, any
//! other MuJoCo's binary format).

use std::collections::HashMap;

use super::attributes::{value, Attrs};
use super::meshes::file_stem;
use super::schema::{check_attributes, HFIELD_ATTRS};
use super::{children, Node, Reader, Result};
use crate::model::hfield::{self, HField};

/// The model's height fields, in document order, and their indices by name.
#[derive(Default)]
pub struct HFields {
    pub compiled: Vec<HField>,
    names: HashMap<String, usize>,
}

impl HFields {
    /// The index of the height field named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.get(name).copied()
    }
}

impl<'a> Reader<'a> {
    /// Reads and compiles every `<asset><hfield>`.
    pub(super) fn read_hfields(&self, root: Node<'a>) -> Result<HFields> {
        let mut fields = HFields::default();
        for asset in children(root, "asset") {
            for node in children(asset, "hfield") {
                let field = self.read_hfield(node)?;
                let name = field.name.clone();
                if name.is_empty() {
                    return Err(self.error(node, "empty name in height field"));
                }
                if fields
                    .names
                    .insert(name.clone(), fields.compiled.len())
                    .is_some()
                {
                    return Err(self.error(node, format!("repeated name '{name}'")));
                }
                fields.compiled.push(field);
            }
        }
        Ok(fields)
    }

    fn read_hfield(&self, node: Node<'a>) -> Result<HField> {
        check_attributes(self.file, node, HFIELD_ATTRS)?;
        let a = Attrs::of(self.file, node);
        let file = a.text("file");
        let name = match (value(node, "name"), file) {
            (Some(n), _) => n.to_string(),
            (None, Some(f)) => file_stem(f),
            (None, None) => String::new(),
        };
        let size = a.exact::<4>("size")?.unwrap_or([0.0; 4]);
        let count = |key| -> Result<usize> {
            let n = a.int(key)?.unwrap_or(0);
            usize::try_from(n).map_err(|_| self.error(node, format!("{key} must not be negative")))
        };
        let (nrow, ncol) = (count("nrow")?, count("ncol")?);
        let elevation = a
            .text("elevation")
            .map(|t| self.elevation(node, t))
            .transpose()?;
        let (dims, data) = match (file, elevation) {
            (Some(_), _) if nrow > 0 || ncol > 0 || a.text("elevation").is_some() => {
                return Err(self.error(node, "hfield specified from file and manually"));
            }
            (Some(f), _) => {
                let path = self.mesh_path(f);
                hfield::read_file(&path).map_err(|e| {
                    self.error(node, format!("hfield file '{}': {e}", path.display()))
                })?
            }
            (None, Some(rows)) => ((nrow, ncol), flip_rows(&rows, ncol)),
            (None, None) => ((nrow, ncol), vec![0.0; nrow * ncol]),
        };
        HField::compile(&name, size, dims, data)
            .map_err(|e| self.error(node, format!("hfield '{name}': {e}")))
    }

    /// `elevation`'s numbers at single precision, as MuJoCo reads them.
    fn elevation(&self, node: Node, text: &str) -> Result<Vec<f32>> {
        text.split_whitespace()
            .map(|w| {
                w.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        self.error(node, format!("elevation: '{w}' is not a finite number"))
                    })
            })
            .collect()
    }
}

/// Rows listed from the top made row-major from the bottom (rows of `ncol`;
/// a length that is no multiple is left to the compiler's check).
fn flip_rows(data: &[f32], ncol: usize) -> Vec<f32> {
    if ncol == 0 || !data.len().is_multiple_of(ncol) {
        return data.to_vec();
    }
    data.chunks(ncol).rev().flatten().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::Shape;

    const FIELD: &str = r#"<asset><hfield name="h" nrow="2" ncol="3" size="1 2 0.5 0.1"
        elevation="1 2 3 4 5 7"/></asset>"#;

    #[test]
    fn a_height_field_loads_and_weighs_as_in_mujoco() {
        let bodies = r#"<geom type="hfield" hfield="h"/>
            <body pos="0 0 3"><freejoint/><geom type="hfield" hfield="h" density="500"/></body>"#;
        let m = load(&model(FIELD, bodies, ""));
        let h = &m.hfields[0];
        assert_eq!((h.name.as_str(), h.nrow, h.ncol), ("h", 2, 3));
        // MuJoCo 4.0.0's hfield_data: the rows flipped, scaled to [0, 1].
        let mujoco = [0.5, 0.6666667, 1.0, 0.0, 0.16666667, 0.33333334];
        assert!(h.data.iter().zip(mujoco).all(|(a, b)| (a - b).abs() < 1e-7));
        let shape = m.geoms[1].shape;
        assert_eq!(
            shape,
            Shape::HField {
                hfield: 0,
                size: [1.0, 2.0, 0.5, 0.1]
            }
        );
        // MuJoCo's geom_size, geom_rbound, body_mass and body_inertia.
        assert_eq!(shape.size(), [1.0, 2.0, 0.175]);
        assert!((m.rbound(&shape) - 2.29128784747792).abs() < 1e-15);
        let b = &m.bodies[1];
        assert!((b.mass - 1400.0).abs() < 1e-12);
        let inertia = [1880.9583333333333, 480.95833333333326, 2333.3333333333335];
        assert_close(b.inertia.diagonal().as_slice(), &inertia, 1e-12);
        // A flat field without elevations.
        let flat = r#"<asset><hfield name="f" nrow="3" ncol="2" size="1 1 1 1"/></asset>"#;
        let m = load(&model(flat, r#"<geom type="hfield" hfield="f"/>"#, ""));
        assert_eq!(m.hfields[0].data, [0.0; 6]);
    }

    #[test]
    fn a_binary_file_reads_as_mujoco_reads_it() {
        let path = std::env::temp_dir().join(format!("diffosi-hfield-{}.bin", std::process::id()));
        let mut bytes = vec![];
        bytes.extend(2i32.to_le_bytes());
        bytes.extend(3i32.to_le_bytes());
        for x in [4.0f32, 5.0, 7.0, 1.0, 2.0, 3.0] {
            bytes.extend(x.to_le_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        let asset = format!(
            r#"<asset><hfield file="{}" size="1 2 0.5 0.1"/></asset>"#,
            path.display()
        );
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        let geom = format!(r#"<geom type="hfield" hfield="{stem}"/>"#);
        let m = load(&model(&asset, &geom, ""));
        // The file's rows are bottom first: the same field as FIELD's.
        let inline = load(&model(FIELD, r#"<geom type="hfield" hfield="h"/>"#, ""));
        assert_eq!(m.hfields[0].data, inline.hfields[0].data);
        let both = asset.replace("size=", r#"nrow="2" size="#);
        assert_rejects(&model(&both, &geom, ""), "specified from file and manually");
        std::fs::remove_file(&path).unwrap();
        assert_rejects(&model(&asset, &geom, ""), "hfield file");
    }

    #[test]
    fn bad_height_fields_are_refused_at_their_element() {
        let field = |attrs: &str| {
            model(
                &format!(r#"<asset><hfield name="h" {attrs}/></asset>"#),
                r#"<geom type="hfield" hfield="h"/>"#,
                "",
            )
        };
        let size = r#"size="1 1 1 1""#;
        assert_rejects(
            &field(r#"nrow="2" ncol="2" size="1 1 0 1""#),
            "not positive",
        );
        assert_rejects(
            &field(&format!(r#"nrow="1" ncol="1" {size}"#)),
            "at least 2",
        );
        let short = format!(r#"nrow="2" ncol="2" {size} elevation="1 2 3""#);
        assert_rejects(&field(&short), "nrow*ncol");
        let nan = format!(r#"nrow="2" ncol="2" {size} elevation="1 nan 3 4""#);
        assert_rejects(&field(&nan), "not a finite number");
        assert_rejects(&field(&format!(r#"nrow="-2" ncol="2" {size}"#)), "negative");
        let png = r#"<asset><hfield file="no-such-terrain.png" size="1 1 1 1"/></asset>"#;
        assert_rejects(&model(png, "", ""), "no-such-terrain.png");
        let geom = |g: &str| model(FIELD, g, "");
        assert_rejects(
            &geom(r#"<geom type="hfield" hfield="x"/>"#),
            "unknown hfield",
        );
        assert_rejects(&geom(r#"<geom type="hfield"/>"#), "needs an hfield");
        assert_rejects(
            &geom(r#"<geom type="box" size="1 1 1" hfield="h"/>"#),
            "cannot name a height field",
        );
    }
}
