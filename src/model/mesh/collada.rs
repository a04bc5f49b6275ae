//! COLLADA (`.dae`) geometry, for URDF collision meshes, as PyBullet's URDF
//! importer and Pinocchio's mesh loader (coal, through assimp) read it.
//! MuJoCo reads no COLLADA; MJCF files do not accept it.
//!
//! The mesh is every `<instance_geometry>` of the scene's visual scene
//! (`<scene><instance_visual_scene>`, else the first `<visual_scene>`),
//! reached through its `<node>` tree. Each instance adds the positions of
//! its geometry's `<vertices>` that its faces use (in file order; both
//! engines drop the others, which would change the hull) and the triangles
//! of its `<triangles>`, `<polylist>`, `<polygons>` (a polygon as a fan
//! from its first corner), `<trifans>` and `<tristrips>`; `<lines>` and
//! `<linestrips>` have no faces and are skipped, as both engines skip
//! them. Frames: a position is carried to the file frame by the node
//! transforms from the root down, each node's `<matrix>` (row-major),
//! `<translate>`, `<rotate>` (axis, degrees) and `<scale>` post-multiplied
//! in document order, as the COLLADA specification and coal compose them.
//! PyBullet applies a node's `<scale>` outside its rotations; the two
//! differ only for a non-uniform scale under a rotation. Units: lengths
//! times `<asset><unit meter>` (1 if absent), as PyBullet scales them.
//! `<up_axis>` is ignored: neither engine turns the geometry.
//!
//! Refused with a message: `<instance_node>`, `<instance_controller>`
//! (skinned geometry), `<lookat>` and `<skew>` transforms, polygons with
//! holes (`<ph>`), and geometry other than `<mesh>`.

use std::collections::HashMap;

use nalgebra::{Matrix4, Unit, Vector3};
use roxmltree::{Document, Node};

use super::RawMesh;

/// The most vertices one file may expand to (instances repeat geometry).
const MAX_VERTICES: usize = 1 << 24;

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "COLLADA file that is not UTF-8")?;
    let doc = Document::parse(text).map_err(|e| format!("COLLADA XML: {e}"))?;
    let file = Collada::new(&doc);
    let scene = file.visual_scene()?;
    let unit = file.unit()?;
    let mut mesh = RawMesh::default();
    file.node(scene, &Matrix4::new_scaling(unit), &mut mesh)?;
    Ok(mesh)
}

/// A parsed document with its elements by `id`.
struct Collada<'a> {
    root: Node<'a, 'a>,
    ids: HashMap<&'a str, Node<'a, 'a>>,
}

impl<'a> Collada<'a> {
    fn new(doc: &'a Document<'a>) -> Self {
        let ids = doc
            .descendants()
            .filter_map(|n| Some((n.attribute("id")?, n)))
            .collect();
        Collada {
            root: doc.root_element(),
            ids,
        }
    }

    /// The element a `url`/`source` reference `#id` names.
    fn target(&self, at: Node, attribute: &str) -> Result<Node<'a, 'a>, String> {
        let reference = at.attribute(attribute).unwrap_or_default();
        let id = reference.strip_prefix('#').unwrap_or(reference);
        self.ids.get(id).copied().ok_or_else(|| {
            format!(
                "<{}> {attribute}='{reference}' names no element",
                at.tag_name().name()
            )
        })
    }

    fn visual_scene(&self) -> Result<Node<'a, 'a>, String> {
        let instance = child(self.root, "scene").and_then(|s| child(s, "instance_visual_scene"));
        match instance {
            Some(i) => self.target(i, "url"),
            None => self
                .root
                .descendants()
                .find(|n| n.has_tag_name("visual_scene"))
                .ok_or_else(|| "COLLADA file without a <visual_scene>".into()),
        }
    }

    /// Metres per length unit (`<asset><unit meter>`).
    fn unit(&self) -> Result<f64, String> {
        let unit = child(self.root, "asset").and_then(|a| child(a, "unit"));
        match unit.and_then(|u| u.attribute("meter")) {
            None => Ok(1.0),
            Some(text) => match text.trim().parse::<f64>() {
                Ok(m) if m.is_finite() && m > 0.0 => Ok(m),
                _ => Err(format!("<unit> meter='{text}' is not a positive number")),
            },
        }
    }

    /// Adds the instances under scene node `node`, placed by `parent`.
    fn node(&self, node: Node, parent: &Matrix4<f64>, mesh: &mut RawMesh) -> Result<(), String> {
        let mut frame = *parent;
        for c in node.children().filter(Node::is_element) {
            match c.tag_name().name() {
                "matrix" | "translate" | "rotate" | "scale" => frame *= transform(c)?,
                "lookat" | "skew" | "instance_node" | "instance_controller" => {
                    return Err(format!("<{}> is not read", c.tag_name().name()))
                }
                "instance_geometry" => self.instance(self.target(c, "url")?, &frame, mesh)?,
                "node" => self.node(c, &frame, mesh)?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Adds one instance of `<geometry>` `geometry` placed by `frame`.
    fn instance(
        &self,
        geometry: Node,
        frame: &Matrix4<f64>,
        mesh: &mut RawMesh,
    ) -> Result<(), String> {
        let id = geometry.attribute("id").unwrap_or_default();
        let Some(m) = child(geometry, "mesh") else {
            return Err(format!("<geometry> '{id}': only <mesh> geometry is read"));
        };
        let positions = self.positions(m, id)?;
        let mut faces = vec![];
        for primitive in m.children().filter(Node::is_element) {
            let corners = |p: Node| self.corners(primitive, p, positions.len());
            let listed = || child(primitive, "p").map_or(Ok(vec![]), corners);
            let polygons = match primitive.tag_name().name() {
                "triangles" => chunks(listed()?, 3),
                "polylist" => polylist(primitive, listed()?)?,
                "polygons" | "trifans" | "tristrips" => {
                    if child(primitive, "ph").is_some() {
                        return Err(format!("<geometry> '{id}': polygons with holes"));
                    }
                    let each = children(primitive, "p").map(corners);
                    each.collect::<Result<Vec<_>, _>>()?
                }
                _ => continue,
            };
            let strips = primitive.has_tag_name("tristrips");
            for corners in polygons {
                triangulate(&corners, strips, |f| faces.push(f));
            }
        }
        // Only the positions that faces use, in file order.
        let mut index = vec![usize::MAX; positions.len()];
        faces.iter().flatten().for_each(|&i| index[i] = 0);
        for (i, p) in positions.iter().enumerate() {
            if index[i] == usize::MAX {
                continue;
            }
            if mesh.vertices.len() >= MAX_VERTICES {
                return Err(format!("more than {MAX_VERTICES} vertices in the scene"));
            }
            index[i] = mesh.vertices.len();
            let v = frame.transform_point(&(*p).into());
            if !v.iter().all(|x| x.is_finite()) {
                return Err(format!("<geometry> '{id}': a vertex is not finite"));
            }
            mesh.vertices.push([v.x as f32, v.y as f32, v.z as f32]);
        }
        mesh.faces.extend(faces.iter().map(|f| f.map(|i| index[i])));
        Ok(())
    }

    /// The positions of `<mesh>` `m`: its `<vertices>`' POSITION source.
    fn positions(&self, m: Node, id: &str) -> Result<Vec<[f64; 3]>, String> {
        let vertices = required(m, "vertices")?;
        let input = children(vertices, "input")
            .find(|i| i.attribute("semantic") == Some("POSITION"))
            .ok_or_else(|| format!("<geometry> '{id}': <vertices> without a POSITION input"))?;
        let source = self.target(input, "source")?;
        let numbers = numbers::<f64>(required(source, "float_array")?)?;
        let accessor = child(source, "technique_common")
            .and_then(|t| child(t, "accessor"))
            .ok_or_else(|| format!("<geometry> '{id}': a source without an <accessor>"))?;
        let [count, stride, offset] = ["count", "stride", "offset"].map(|a| {
            let default = if a == "stride" { "1" } else { "0" };
            accessor.attribute(a).unwrap_or(default).parse::<usize>()
        });
        let (Ok(count), Ok(stride), Ok(offset)) = (count, stride, offset) else {
            return Err(format!(
                "<geometry> '{id}': a bad <accessor> count, stride or offset"
            ));
        };
        let fits = count
            .checked_mul(stride)
            .and_then(|n| n.checked_add(offset))
            .is_some_and(|n| n <= numbers.len() + stride.saturating_sub(3));
        if stride < 3 || !fits {
            return Err(format!(
                "<geometry> '{id}': an <accessor> of {count} points of stride {stride} \
                 beyond its {} numbers",
                numbers.len()
            ));
        }
        Ok((0..count)
            .map(|i| std::array::from_fn(|c| numbers[offset + i * stride + c]))
            .collect())
    }

    /// The vertex indices of the corners listed in `<p>` `p` of
    /// `primitive`, checked against `count` positions.
    fn corners(&self, primitive: Node, p: Node, count: usize) -> Result<Vec<usize>, String> {
        let inputs: Vec<Node> = children(primitive, "input").collect();
        let offset = |i: &Node| i.attribute("offset").and_then(|o| o.parse::<usize>().ok());
        let stride = inputs.iter().filter_map(offset).max().unwrap_or(0) + 1;
        let vertex = inputs
            .iter()
            .find(|i| i.attribute("semantic") == Some("VERTEX"))
            .ok_or_else(|| format!("<{}> without a VERTEX input", primitive.tag_name().name()))?;
        let at = offset(vertex).unwrap_or(0);
        let indices = numbers::<usize>(p)?;
        if indices.len() % stride != 0 {
            return Err(format!(
                "<p> of {} indices, not a multiple of its {stride} inputs",
                indices.len()
            ));
        }
        let corners: Vec<usize> = indices.iter().skip(at).step_by(stride).copied().collect();
        match corners.iter().find(|&&i| i >= count) {
            Some(i) => Err(format!("vertex index {i} of {count} vertices")),
            None => Ok(corners),
        }
    }
}

/// The polygons of a `<polylist>`: `<vcount>` corners each.
fn polylist(primitive: Node, corners: Vec<usize>) -> Result<Vec<Vec<usize>>, String> {
    let counts = numbers::<usize>(required(primitive, "vcount")?)?;
    if counts.iter().try_fold(0usize, |a, &n| a.checked_add(n)) != Some(corners.len()) {
        return Err("<vcount> does not add up to the corners of <p>".into());
    }
    let mut rest = corners.as_slice();
    Ok(counts
        .iter()
        .map(|&n| {
            let (polygon, tail) = rest.split_at(n);
            rest = tail;
            polygon.to_vec()
        })
        .collect())
}

/// Consecutive groups of `n` (a trailing partial group dropped).
fn chunks(corners: Vec<usize>, n: usize) -> Vec<Vec<usize>> {
    corners.chunks_exact(n).map(<[usize]>::to_vec).collect()
}

/// Triangles of a polygon or fan (from its first corner) or of a strip
/// (every other triangle flipped to keep the orientation).
fn triangulate(c: &[usize], strip: bool, mut face: impl FnMut([usize; 3])) {
    for k in 2..c.len() {
        face(match (strip, k % 2) {
            (false, _) => [c[0], c[k - 1], c[k]],
            (true, 0) => [c[k - 2], c[k - 1], c[k]],
            (true, _) => [c[k - 1], c[k - 2], c[k]],
        });
    }
}

/// The matrix of a node transform element.
fn transform(e: Node) -> Result<Matrix4<f64>, String> {
    let v = numbers::<f64>(e)?;
    let name = e.tag_name().name();
    let wanted = match name {
        "matrix" => 16,
        "rotate" => 4,
        _ => 3,
    };
    if v.len() != wanted || !v.iter().all(|x| x.is_finite()) {
        return Err(format!("<{name}> needs {wanted} finite numbers"));
    }
    Ok(match name {
        "matrix" => Matrix4::from_row_slice(&v),
        "translate" => Matrix4::new_translation(&Vector3::new(v[0], v[1], v[2])),
        "scale" => Matrix4::new_nonuniform_scaling(&Vector3::new(v[0], v[1], v[2])),
        _ => match Unit::try_new(Vector3::new(v[0], v[1], v[2]), 0.0) {
            Some(axis) => Matrix4::from_axis_angle(&axis, v[3].to_radians()),
            None if v[3] == 0.0 => Matrix4::identity(),
            None => return Err("<rotate> about a zero axis".into()),
        },
    })
}

/// The whitespace-separated numbers of an element's text.
fn numbers<T: std::str::FromStr>(e: Node) -> Result<Vec<T>, String> {
    let text = e.text().unwrap_or_default();
    text.split_ascii_whitespace()
        .map(|w| {
            w.parse()
                .map_err(|_| format!("<{}>: bad number '{w}'", e.tag_name().name()))
        })
        .collect()
}

fn child<'a>(node: Node<'a, 'a>, name: &str) -> Option<Node<'a, 'a>> {
    children(node, name).next()
}

fn children<'a, 'n>(node: Node<'a, 'a>, name: &'n str) -> impl Iterator<Item = Node<'a, 'a>> + 'n
where
    'a: 'n,
{
    node.children().filter(move |c| c.has_tag_name(name))
}

fn required<'a>(node: Node<'a, 'a>, name: &str) -> Result<Node<'a, 'a>, String> {
    child(node, name).ok_or_else(|| format!("<{}> without <{name}>", node.tag_name().name()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A document with `scene` as its visual scene's content, `unit` in its
    /// asset and one geometry `g` of six positions, the fifth unused.
    fn dae(unit: &str, primitives: &str, scene: &str) -> String {
        format!(
            "<?xml version=\"1.0\"?><COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\">\
             <asset>{unit}<up_axis>Z_UP</up_axis></asset><library_geometries><geometry id=\"g\"><mesh>\
             <source id=\"p\"><float_array id=\"pa\">0 0 0 1 0 0 0 2 0 0 0 3 9 9 9 1 1 1</float_array>\
             <technique_common><accessor source=\"#pa\" count=\"6\" stride=\"3\"/></technique_common></source>\
             <source id=\"n\"><float_array id=\"na\">0 0 1</float_array>\
             <technique_common><accessor source=\"#na\" count=\"1\" stride=\"3\"/></technique_common></source>\
             <vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>{primitives}\
             </mesh></geometry></library_geometries><library_visual_scenes><visual_scene id=\"s\">{scene}\
             </visual_scene></library_visual_scenes><scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>"
        )
    }

    const PRIMITIVES: &str = "<triangles count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>\
        <input semantic=\"NORMAL\" source=\"#n\" offset=\"1\"/><p>0 0 2 0 1 0 0 0 1 0 3 0</p></triangles>\
        <polylist count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><vcount>3 4</vcount>\
        <p>0 3 2 1 2 3 5</p></polylist>";

    const NODES: &str = "<node id=\"a\"><translate>1 2 3</translate><rotate>0 0 1 90</rotate>\
        <scale>2 2 2</scale><node id=\"b\"><matrix>1 0 0 0 0 0 -1 0 0 1 0 1 0 0 0 1</matrix>\
        <instance_geometry url=\"#g\"/></node></node>";

    #[test]
    fn transforms_units_and_polygons_are_read_as_the_engines_read_them() {
        let m = read(dae("<unit meter=\"0.5\"/>", PRIMITIVES, NODES).as_bytes()).unwrap();
        // coal 3.0.3's MeshLoader().load(file).vertices() for this file (the
        // used positions through the node transforms; its duplicates per
        // primitive merged), times the unit 0.5 as PyBullet 3.2's
        // getMeshData scales it (PyBullet reads the polylist's quad as
        // triangles and loses its last corner, the fifth vertex below).
        let coal = [
            [1., 2., 5.],
            [1., 4., 5.],
            [1., 2., 9.],
            [7., 2., 5.],
            [3., 4., 7.],
        ];
        let expected: Vec<[f32; 3]> = coal.iter().map(|v| v.map(|x| 0.5 * x)).collect();
        assert_eq!(m.vertices, expected);
        // The quad 1 2 3 5 is a fan from its first corner.
        assert_eq!(
            m.faces,
            [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [1, 3, 4]]
        );
        let plain = read(dae("", PRIMITIVES, NODES).as_bytes()).unwrap();
        assert_eq!(plain.vertices[4], [3.0, 4.0, 7.0]);
    }

    #[test]
    fn fans_strips_and_polygons_triangulate() {
        let tri = |c: &[usize], strip| {
            let mut f = vec![];
            triangulate(c, strip, |t| f.push(t));
            f
        };
        assert_eq!(tri(&[0, 1, 2, 3], false), [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(tri(&[0, 1, 2, 3], true), [[0, 1, 2], [2, 1, 3]]);
        let polygons =
            "<polygons count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>\
                        <p>0 1 2 3</p></polygons>";
        let m = read(dae("", polygons, NODES).as_bytes()).unwrap();
        assert_eq!(m.faces, [[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn malformed_files_are_refused_with_a_message() {
        let refused = |unit: &str, primitives: &str, scene: &str, says: &str| {
            let err = read(dae(unit, primitives, scene).as_bytes()).unwrap_err();
            assert!(err.contains(says), "{err}");
        };
        let triangles = |p: &str| {
            format!(
                "<triangles><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>{p}</p></triangles>"
            )
        };
        let geometry = "<node><instance_geometry url=\"#g\"/></node>";
        refused("", &triangles("0 1 6"), geometry, "vertex index 6 of 6");
        refused("", &triangles("0 1 x"), geometry, "bad number 'x'");
        refused("", &triangles("0 1 -2"), geometry, "bad number '-2'");
        refused("<unit meter=\"0\"/>", PRIMITIVES, geometry, "meter='0'");
        refused(
            "",
            PRIMITIVES,
            "<node><instance_geometry url=\"#h\"/></node>",
            "'#h' names no element",
        );
        refused(
            "",
            PRIMITIVES,
            "<node><rotate>0 0 0 1</rotate></node>",
            "zero axis",
        );
        refused(
            "",
            PRIMITIVES,
            "<node><matrix>1 0 0</matrix></node>",
            "16 finite numbers",
        );
        refused(
            "",
            PRIMITIVES,
            "<node><instance_node url=\"#a\"/></node>",
            "<instance_node> is not read",
        );
        let vcount = "<polylist><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>\
                      <vcount>3 3</vcount><p>0 1 2</p></polylist>";
        refused("", vcount, geometry, "<vcount> does not add up");
        assert!(read(b"<COLLADA>").unwrap_err().contains("COLLADA XML"));
        assert!(read(b"<COLLADA/>").unwrap_err().contains("<visual_scene>"));
        assert!(read(&[0xff, 0xfe]).unwrap_err().contains("UTF-8"));
    }
}
