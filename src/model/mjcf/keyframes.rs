//! `<keyframe>`: its `<key>`s, read into [`Keyframe`]s once the model's
//! sizes are known. A vector left out (or empty) takes MuJoCo's default (see
//! [`Keyframe`]). One given may be shorter than the model's size, its tail
//! then the default's, as MuJoCo 4.0.0 fills it; a longer one is refused.
//! Unnamed keys are named `key<i>` after their index (as `tree.rs` names
//! other objects).

use super::attributes::Attrs;
use super::schema::check_attributes;
use super::{children, elements, tag, tree, unrecognized, Node, Reader, Result};
use crate::model::{Keyframe, Spec};

const KEY_ATTRS: &[&str] = &[
    "name", "time", "qpos", "qvel", "act", "mpos", "mquat", "ctrl",
];

impl Reader<'_> {
    /// Every `<key>` of every `<keyframe>` section, sized for `spec`.
    pub(super) fn read_keyframes(&self, root: Node, spec: &Spec) -> Result<Vec<Keyframe>> {
        let mut keys = vec![];
        let mut names = std::collections::HashSet::new();
        for section in children(root, "keyframe") {
            check_attributes(self.file, section, &[])?;
            for node in elements(section) {
                if tag(node) != "key" {
                    return Err(unrecognized(self.file, node));
                }
                let key = self.read_key(node, spec)?;
                if !key.name.is_empty() && !names.insert(key.name.clone()) {
                    return Err(self.error(node, format!("repeated name '{}'", key.name)));
                }
                keys.push(key);
            }
        }
        tree::fill_names(&mut keys, "key", |k| &mut k.name);
        Ok(keys)
    }

    fn read_key(&self, node: Node, spec: &Spec) -> Result<Keyframe> {
        check_attributes(self.file, node, KEY_ATTRS)?;
        let a = Attrs::of(self.file, node);
        let (nq, nv, nu, na) = (spec.nq(), spec.nv(), spec.actuators.len(), spec.na());
        let (mpos, mquat) = spec.mocap_default();
        let vector = |name: &str, size: usize, mut default: Vec<f64>| -> Result<Vec<f64>> {
            match a.list(name)? {
                Some(v) if v.len() > size => Err(self.error(
                    node,
                    format!("{name} has {} numbers, the model has {size}", v.len()),
                )),
                Some(v) => {
                    default[..v.len()].copy_from_slice(&v);
                    Ok(default)
                }
                None => Ok(default),
            }
        };
        Ok(Keyframe {
            name: node.attribute("name").unwrap_or("").to_string(),
            time: a.number("time")?.unwrap_or(0.0),
            q: vector("qpos", nq, spec.reference_q())?,
            v: vector("qvel", nv, vec![0.0; nv])?,
            act: vector("act", na, vec![0.0; na])?,
            ctrl: vector("ctrl", nu, vec![0.0; nu])?,
            mpos: vector("mpos", mpos.len(), mpos)?,
            mquat: vector("mquat", mquat.len(), mquat)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;

    const BODIES: &str = r#"
        <body name="f" pos="1 2 3" euler="0 0 90"><freejoint/><geom size="0.1"/>
          <body pos="0 0 1"><joint name="h" ref="30"/><joint name="s" type="slide" ref="0.5"/><geom size="0.1"/></body>
        </body>"#;

    fn keys(keys: &str) -> String {
        let tail = format!(r#"<actuator><motor joint="h"/></actuator><keyframe>{keys}</keyframe>"#);
        model("", BODIES, &tail)
    }

    /// MuJoCo 4.0.0's key_time, key_qpos, key_qvel and key_ctrl.
    #[test]
    fn keys_hold_what_mujoco_compiles() {
        let m = load(&keys(
            r#"<key name="home" time="1.5" qpos="0 0 1 1 0 0 0 0.1 0.2" qvel="1 2 3 4 5 6 7 8" ctrl="0.5"/>
               <key/><key qpos="5 6" qvel="5 6"/>"#,
        ));
        let names: Vec<&str> = m.keyframes.iter().map(|k| k.name.as_str()).collect();
        assert_eq!(names, ["home", "key1", "key2"]);
        let home = m.keyframe("home").unwrap();
        assert_eq!(home.time, 1.5);
        assert_eq!(home.q, [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.1, 0.2]);
        assert_eq!(home.v, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert_eq!((home.ctrl.as_slice(), home.act.len()), (&[0.5][..], 0));
        // The free joint's quaternion is a quarter turn about z.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let qpos0 = [1.0, 2.0, 3.0, h, 0.0, 0.0, h, 0.5235987755982988, 0.5];
        let plain = m.keyframe("key1").unwrap();
        assert_close(&plain.q, &qpos0, 2e-16);
        assert_eq!(
            (plain.time, plain.v.as_slice(), plain.ctrl.as_slice()),
            (0.0, &[0.0; 8][..], &[0.0][..])
        );
        let short = m.keyframe("key2").unwrap();
        assert_close(&short.q[2..], &qpos0[2..], 2e-16);
        assert_eq!(
            (&short.q[..2], &short.v[..3]),
            (&[5.0, 6.0][..], &[5.0, 6.0, 0.0][..])
        );
        assert!(m.keyframe("nope").is_none());
    }

    #[test]
    fn keys_are_written_and_read_back() {
        let m = load(&keys(
            r#"<key name="home" time="0.25" qpos="0.1 0.2 0.3" ctrl="-1"/><key/>"#,
        ));
        let text = super::super::write(&m).unwrap();
        let back = super::super::parse(&text, "written.xml").unwrap();
        assert_eq!(back.keyframes, m.keyframes);
    }

    #[test]
    fn bad_keys_are_rejected() {
        #[rustfmt::skip]
        let cases = [
            (r#"<key qpos="1 2 3 4 5 6 7 8 9 10"/>"#, "qpos has 10 numbers, the model has 9"),
            (r#"<key qvel="1 2 3 4 5 6 7 8 9"/>"#, "qvel has 9 numbers, the model has 8"),
            (r#"<key ctrl="1 2"/>"#, "ctrl has 2 numbers, the model has 1"),
            (r#"<key act="1"/>"#, "act has 1 numbers, the model has 0"),
            (r#"<key mpos="1 2 3"/>"#, "mpos has 3 numbers"),
            (r#"<key qpos="1 x"/>"#, "must be finite numbers"),
            (r#"<key name="a"/><key name="a"/>"#, "repeated name 'a'"),
            (r#"<key qacc="1"/>"#, "unrecognized attribute 'qacc'"),
            ("<pose/>", "unrecognized element <pose>"),
        ];
        for (key, expected) in cases {
            assert_rejects(&keys(key), expected);
        }
    }
}
