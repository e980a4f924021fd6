//! STATE.json: the state of a model keyed by URDF joint name (`docs/state-format.md`).
//!
//! ```json
//! {"q": {"l_knee": [0.3], "floating_base": [0, 0, 1, 1, 0, 0, 0]},
//!  "qd": {"l_knee": [0.1]},
//!  "tau": {"l_knee": [2.0]}}
//! ```
//!
//! Every key is optional; a joint left out is at its neutral position (zero, or the identity
//! orientation of a floating joint), at rest, without force. Unknown top-level keys, unknown or
//! repeated joints, vectors of the wrong length and anything that is not a finite number are
//! errors naming what is wrong.

use articula_dca::State;
use articula_model::{JointPart, Model, FLOATING_BASE_JOINT};
use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use std::fmt;

/// One section of a state file (`q`, `qd` or `tau`): joint names and their vectors, in file
/// order.
pub type Section = Vec<(String, Vec<f64>)>;

/// A parsed state file, not yet checked against a model. The top level must be a JSON object
/// with no keys but `q`, `qd` and `tau`, each at most once (serde's `deny_unknown_fields`, and
/// a sequence is not accepted in place of the object).
#[derive(Debug, Default, PartialEq)]
pub struct StateFile {
    /// Positions per joint.
    pub q: Option<Section>,
    /// Velocities per joint.
    pub qd: Option<Section>,
    /// Joint forces/torques per joint.
    pub tau: Option<Section>,
}

const FIELDS: &[&str] = &["q", "qd", "tau"];

impl<'de> Deserialize<'de> for StateFile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<StateFile, D::Error> {
        d.deserialize_map(StateFileVisitor)
    }
}

struct StateFileVisitor;

impl<'de> Visitor<'de> for StateFileVisitor {
    type Value = StateFile;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON object with optional keys \"q\", \"qd\" and \"tau\"")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<StateFile, A::Error> {
        let mut out = StateFile::default();
        while let Some(key) = map.next_key::<String>()? {
            let (slot, name) = match key.as_str() {
                "q" => (&mut out.q, "q"),
                "qd" => (&mut out.qd, "qd"),
                "tau" => (&mut out.tau, "tau"),
                _ => return Err(de::Error::unknown_field(&key, FIELDS)),
            };
            if slot.is_some() {
                return Err(de::Error::duplicate_field(name));
            }
            *slot = Some(map.next_value_seed(SectionSeed(name))?);
        }
        Ok(out)
    }
}

impl StateFile {
    /// Parses the JSON text of a state file (syntax and types only).
    pub fn parse(text: &str) -> Result<StateFile, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }

    /// The model's state: neutral and at rest, overwritten by every joint the file names.
    /// Checks names and lengths; normalises the quaternion of a floating joint.
    pub fn to_state(&self, model: &Model) -> Result<State, String> {
        let mut state = State::neutral(model);
        // One name lookup table (a 100,000-joint state would otherwise scan the joints per name).
        let parts: std::collections::HashMap<&str, &articula_model::JointPart> = model
            .coordinate_parts()
            .map(|p| (p.name.as_str(), p))
            .collect();
        for (what, section) in [("q", &self.q), ("qd", &self.qd), ("tau", &self.tau)] {
            let Some(section) = section else { continue };
            for (name, values) in section {
                let Some(&part) = parts.get(name.as_str()) else {
                    return Err(unknown_joint(model, what, name));
                };
                let (target, expected) = match what {
                    "q" => (
                        &mut state.q[part.q_offset..part.q_offset + part.nq()],
                        part.nq(),
                    ),
                    "qd" => (
                        &mut state.qd[part.v_offset..part.v_offset + part.nv()],
                        part.nv(),
                    ),
                    _ => (
                        &mut state.tau[part.v_offset..part.v_offset + part.nv()],
                        part.nv(),
                    ),
                };
                if values.len() != expected {
                    return Err(format!(
                        "{what} of joint '{name}' has {} {}, a {} joint needs {expected} ({})",
                        values.len(),
                        if values.len() == 1 {
                            "entry"
                        } else {
                            "entries"
                        },
                        kind_name(part),
                        layout(what, part),
                    ));
                }
                target.copy_from_slice(values);
                if let (Some(o), "q") = (part.kind.quaternion_offset(), what) {
                    normalize_quaternion(name, &mut target[o..o + 4])?;
                }
            }
        }
        Ok(state)
    }
}

/// Parses a state file's text and applies it to `model`.
pub fn parse_state(text: &str, model: &Model) -> Result<State, String> {
    StateFile::parse(text)?.to_state(model)
}

fn unknown_joint(model: &Model, what: &str, name: &str) -> String {
    let names: Vec<&str> = model.coordinate_parts().map(|p| p.name.as_str()).collect();
    let list = if names.is_empty() {
        "it has none".to_string()
    } else {
        names.join(", ")
    };
    let hint = if name == FLOATING_BASE_JOINT && !model.floating_base {
        "; give the model a floating base with --floating-base"
    } else {
        ""
    };
    format!(
        "{what}: unknown joint '{name}': not a movable joint of model '{}' (fixed joints have \
         no coordinates; movable joints: {list}){hint}",
        model.name
    )
}

fn kind_name(part: &JointPart) -> &'static str {
    part.kind.name()
}

fn layout(what: &str, part: &JointPart) -> &'static str {
    part.kind.coordinates(what)
}

fn normalize_quaternion(name: &str, quat: &mut [f64]) -> Result<(), String> {
    let norm = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(norm.is_finite() && norm > 1e-9) {
        return Err(format!(
            "q of joint '{name}': the orientation quaternion [qw, qx, qy, qz] = {quat:?} has no \
             direction (length {norm})"
        ));
    }
    quat.iter_mut().for_each(|x| *x /= norm);
    Ok(())
}

// ---- deserialisation with messages that name the section and the joint ----

/// A section: an object from joint names to arrays of numbers.
struct SectionSeed(&'static str);

impl<'de> DeserializeSeed<'de> for SectionSeed {
    type Value = Section;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Section, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for SectionSeed {
    type Value = Section;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "an object from joint names to arrays of numbers for '{}'",
            self.0
        )
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Section, A::Error> {
        let mut out: Section = Vec::new();
        let mut seen = std::collections::HashSet::new();
        while let Some(name) = map.next_key::<String>()? {
            if !seen.insert(name.clone()) {
                return Err(de::Error::custom(format!(
                    "{}: joint '{name}' is given twice",
                    self.0
                )));
            }
            let values = map.next_value_seed(VectorSeed {
                what: self.0,
                joint: &name,
            })?;
            out.push((name, values));
        }
        Ok(out)
    }
}

/// The vector of one joint: an array of finite numbers.
struct VectorSeed<'a> {
    what: &'static str,
    joint: &'a str,
}

impl<'de> DeserializeSeed<'de> for VectorSeed<'_> {
    type Value = Vec<f64>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Vec<f64>, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for VectorSeed<'_> {
    type Value = Vec<f64>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "an array of numbers for {} of joint '{}'",
            self.what, self.joint
        )
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<f64>, A::Error> {
        let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(1).min(16));
        loop {
            match seq.next_element_seed(Finite) {
                Ok(Some(x)) => out.push(x),
                Ok(None) => return Ok(out),
                // The parser's own errors (a number out of range, bad syntax) and the element
                // check's carry a position; say where in the state they are, and let the
                // outer parser add the position once.
                Err(e) => {
                    return Err(de::Error::custom(format!(
                        "{} of joint '{}', entry {}: {}",
                        self.what,
                        self.joint,
                        out.len(),
                        strip_position(&e.to_string())
                    )))
                }
            }
        }
    }
}

/// One finite number.
struct Finite;

impl<'de> DeserializeSeed<'de> for Finite {
    type Value = f64;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<f64, D::Error> {
        d.deserialize_f64(self)
    }
}

impl Visitor<'_> for Finite {
    type Value = f64;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a finite number")
    }

    fn visit_f64<E: de::Error>(self, x: f64) -> Result<f64, E> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(E::custom(format!("{x} is not a finite number")))
        }
    }

    fn visit_i64<E: de::Error>(self, x: i64) -> Result<f64, E> {
        Ok(x as f64)
    }

    fn visit_u64<E: de::Error>(self, x: u64) -> Result<f64, E> {
        Ok(x as f64)
    }
}

/// Drops serde_json's trailing " at line L column C" (the outer error adds it again).
fn strip_position(msg: &str) -> &str {
    if let Some(i) = msg.rfind(" at line ") {
        let rest = &msg[i + " at line ".len()..];
        let mut words = rest.split(' ');
        let is_position = matches!(
            (words.next(), words.next(), words.next(), words.next()),
            (Some(l), Some("column"), Some(c), None)
                if l.bytes().all(|b| b.is_ascii_digit()) && c.bytes().all(|b| b.is_ascii_digit())
        );
        if is_position {
            return &msg[..i];
        }
    }
    msg
}

#[cfg(test)]
mod tests {
    use super::*;
    use articula_model::LoadOptions;

    const URDF: &str = r#"<robot name="two">
      <link name="base"/>
      <link name="a"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
        <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="b"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
        <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="hinge" type="revolute"><parent link="base"/><child link="a"/>
        <axis xyz="0 1 0"/></joint>
      <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/>
        <origin xyz="0 0 -1"/><axis xyz="0 0 1"/></joint>
    </robot>"#;

    fn model(floating_base: bool) -> Model {
        Model::from_urdf_str(
            URDF,
            &LoadOptions::default().with_floating_base(floating_base),
        )
        .unwrap()
    }

    fn offsets(model: &Model, name: &str) -> (usize, usize) {
        let (_, p) = model.find_joint(name).unwrap();
        (p.q_offset, p.v_offset)
    }

    #[test]
    fn empty_object_is_the_neutral_state() {
        for fb in [false, true] {
            let m = model(fb);
            assert_eq!(parse_state("{}", &m).unwrap(), State::neutral(&m));
            assert_eq!(
                parse_state(r#"{"q": {}, "qd": {}, "tau": {}}"#, &m).unwrap(),
                State::neutral(&m)
            );
        }
    }

    #[test]
    fn values_land_at_their_joints() {
        let m = model(true);
        let s = parse_state(
            r#"{"q": {"slide": [0.25], "hinge": [-1], "floating_base": [1, 2, 3, 2, 0, 0, 0]},
                "qd": {"hinge": [3.5], "floating_base": [1, 2, 3, 4, 5, 6]},
                "tau": {"slide": [7e-1]}}"#,
            &m,
        )
        .unwrap();
        let (hq, hv) = offsets(&m, "hinge");
        let (sq, sv) = offsets(&m, "slide");
        let (fq, fv) = offsets(&m, "floating_base");
        assert_eq!(s.q[hq], -1.0);
        assert_eq!(s.q[sq], 0.25);
        // quaternion normalised, position kept
        assert_eq!(&s.q[fq..fq + 7], &[1.0, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0]);
        assert_eq!(s.qd[hv], 3.5);
        assert_eq!(s.qd[sv], 0.0);
        assert_eq!(&s.qd[fv..fv + 6], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(s.tau[sv], 0.7);
        assert_eq!(s.tau[hv], 0.0);
    }

    fn err(text: &str, floating_base: bool) -> String {
        parse_state(text, &model(floating_base)).unwrap_err()
    }

    #[test]
    fn unknown_joint_is_named() {
        let e = err(r#"{"qd": {"elbow": [1]}}"#, false);
        assert!(e.contains("unknown joint 'elbow'"), "{e}");
        assert!(e.starts_with("qd:"), "{e}");
        assert!(e.contains("hinge, slide"), "{e}");
        // no floating base unless asked for
        let e = err(r#"{"q": {"floating_base": [0,0,0,1,0,0,0]}}"#, false);
        assert!(e.contains("unknown joint 'floating_base'"), "{e}");
        assert!(e.contains("--floating-base"), "{e}");
    }

    #[test]
    fn wrong_length_is_named() {
        let e = err(r#"{"q": {"hinge": [1, 2]}}"#, false);
        assert!(e.contains("q of joint 'hinge' has 2 entries"), "{e}");
        assert!(e.contains("needs 1"), "{e}");
        let e = err(r#"{"tau": {"slide": []}}"#, false);
        assert!(e.contains("tau of joint 'slide' has 0 entries"), "{e}");
        let e = err(r#"{"q": {"floating_base": [0, 0, 0, 1, 0, 0]}}"#, true);
        assert!(e.contains("needs 7"), "{e}");
        let e = err(r#"{"qd": {"floating_base": [0, 0, 0, 1, 0, 0, 0]}}"#, true);
        assert!(e.contains("needs 6"), "{e}");
    }

    /// A ball joint's `q` is its quaternion, normalised on reading; `qd` and `tau` have three
    /// entries; a wrong length names the layout.
    #[test]
    fn ball_joint_values() {
        let m = Model::from_mjcf_str(
            r#"<mujoco><worldbody><body name="b"><joint name="neck" type="ball"/>
                 <geom size="0.1"/></body></worldbody></mujoco>"#,
            &LoadOptions::default(),
        )
        .unwrap();
        let s = parse_state(
            r#"{"q": {"neck": [0, 2, 0, 0]}, "qd": {"neck": [1, 2, 3]}, "tau": {"neck": [4, 5, 6]}}"#,
            &m,
        )
        .unwrap();
        assert_eq!(s.q, vec![0.0, 1.0, 0.0, 0.0]);
        assert_eq!(s.qd, vec![1.0, 2.0, 3.0]);
        assert_eq!(s.tau, vec![4.0, 5.0, 6.0]);
        let e = parse_state(r#"{"q": {"neck": [1, 0, 0]}}"#, &m).unwrap_err();
        assert!(
            e.contains("a ball joint needs 4") && e.contains("[qw, qx, qy, qz]"),
            "{e}"
        );
        let e = parse_state(r#"{"q": {"neck": [0, 0, 0, 0]}}"#, &m).unwrap_err();
        assert!(e.contains("quaternion"), "{e}");
    }

    #[test]
    fn degenerate_quaternion_is_refused() {
        let e = err(r#"{"q": {"floating_base": [0, 0, 0, 0, 0, 0, 0]}}"#, true);
        assert!(e.contains("quaternion"), "{e}");
    }

    #[test]
    fn non_numbers_and_overflow_are_refused() {
        for (text, needle) in [
            (r#"{"q": {"hinge": ["0.5"]}}"#, "expected a finite number"),
            (r#"{"q": {"hinge": [null]}}"#, "expected a finite number"),
            (r#"{"q": {"hinge": [true]}}"#, "expected a finite number"),
            (r#"{"q": {"hinge": [[1]]}}"#, "expected a finite number"),
            (r#"{"q": {"hinge": ["NaN"]}}"#, "expected a finite number"),
            (r#"{"q": {"hinge": [1e999]}}"#, "out of range"),
            (r#"{"q": {"hinge": [-1e999]}}"#, "out of range"),
        ] {
            let e = err(text, false);
            assert!(e.contains(needle), "{text}: {e}");
            assert!(e.contains("q of joint 'hinge', entry 0"), "{text}: {e}");
            assert_eq!(e.matches(" at line ").count(), 1, "{text}: {e}");
        }
        let e = err(r#"{"q": {"hinge": 0.5}}"#, false);
        assert!(e.contains("array of numbers for q of joint 'hinge'"), "{e}");
        let e = err(r#"{"q": [0.5]}"#, false);
        assert!(e.contains("object from joint names"), "{e}");
        let e = err(r#"{"q": null}"#, false);
        assert!(e.contains("object from joint names"), "{e}");
    }

    #[test]
    fn malformed_json_and_unknown_keys_are_refused() {
        for text in [
            "",
            "{",
            r#"{"q": {"hinge": [NaN]}}"#,
            r#"{"q": {"hinge": [Infinity]}}"#,
            r#"{"q": {"hinge": [0.5,]}}"#,
            "[]",
            "[{}]",
            r#"[{"hinge": [1]}]"#,
            "null",
            "0",
            r#""q""#,
            "{} {}",
        ] {
            assert!(StateFile::parse(text).is_err(), "{text:?} parsed");
        }
        let e = err(r#"{"q": {}, "qdd": {}}"#, false);
        assert!(e.contains("unknown field `qdd`"), "{e}");
        let e = err(r#"{"q": {}, "q": {}}"#, false);
        assert!(e.contains("duplicate field `q`"), "{e}");
        let e = err("[]", false);
        assert!(e.contains("expected a JSON object"), "{e}");
        let e = err(r#"{"q": {"hinge": [1], "hinge": [2]}}"#, false);
        assert!(e.contains("joint 'hinge' is given twice"), "{e}");
    }

    #[test]
    fn strip_position_only_strips_positions() {
        assert_eq!(strip_position("bad at line 3 column 14"), "bad");
        assert_eq!(strip_position("bad"), "bad");
        assert_eq!(strip_position("at line feed"), "at line feed");
        assert_eq!(
            strip_position("x at line 3 column z"),
            "x at line 3 column z"
        );
    }
}
