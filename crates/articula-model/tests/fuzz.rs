//! Property test: mutated URDF texts never make the loader panic. Every input either loads —
//! and then the model satisfies every structural invariant — or fails with a `ModelError`.
//!
//! Seeds are real URDFs (a small hand-written one exercising every feature of the loader, the
//! bundled humanoid and rope); mutations are byte flips, insertions, deletions, truncations,
//! swapped attribute values, duplicated or deleted lines, numbers replaced by edge cases and
//! changed joint types. Each test prints how many cases it ran and how they ended.

mod common;

use articula_model::{InertiaPolicy, LoadOptions, MasslessLeafPolicy, Model, ModelError};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::cell::RefCell;
use std::collections::BTreeMap;

/// A small robot touching every part of the loader: fixed joints (merged), a 3-DOF hip through
/// massless links (composed), a mimic joint, prismatic and continuous joints, inertial and
/// joint origins with rpy and (URDF 1.1) quaternions, non-unit axis, geometry, materials,
/// `<gazebo>`, `<transmission>`.
/// Elements sit one per line so line mutations move whole elements.
const SMALL: &str = r#"<?xml version="1.0"?>
<robot name="small" version="1.1">
<material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
<link name="base"><inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="4"/><inertia ixx="0.04" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.06"/></inertial><visual><geometry><box size="0.2 0.2 0.1"/></geometry><material name="grey"/></visual></link>
<link name="plate"><inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.002"/></inertial></link>
<link name="hip_a"/>
<link name="hip_b"><inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
<link name="thigh"><inertial><origin xyz="0 0 -0.2" rpy="0.1 0 0"/><mass value="2"/><inertia ixx="0.03" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.005"/></inertial><collision><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision></link>
<link name="shin"><inertial><origin xyz="0 0 -0.2"/><mass value="1.5"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.003"/></inertial><visual><geometry><mesh filename="package://x/shin.stl" scale="1 1 1"/></geometry></visual></link>
<link name="foot"><inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial></link>
<link name="toe"><inertial><origin xyz="0.05 0 0" quat_xyzw="0.1 0 0 1"/><mass value="0.1"/><inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial></link>
<link name="slider"><inertial><mass value="0.3"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
<link name="wheel"><inertial><mass value="0.2"/><inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.001"/></inertial></link>
<joint name="bolt" type="fixed"><origin xyz="0 0 0.1" quat_xyzw="0 0 0.7071 0.7071"/><parent link="base"/><child link="plate"/></joint>
<joint name="hip_yaw" type="revolute"><origin xyz="0 0.1 -0.05"/><parent link="base"/><child link="hip_a"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="50" velocity="5"/></joint>
<joint name="hip_roll" type="revolute"><parent link="hip_a"/><child link="hip_b"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="50" velocity="5"/></joint>
<joint name="hip_pitch" type="revolute"><parent link="hip_b"/><child link="thigh"/><axis xyz="0 1 0"/><limit lower="-2" upper="1" effort="50" velocity="5"/></joint>
<joint name="knee" type="revolute"><origin xyz="0 0 -0.4" rpy="0 0 0"/><parent link="thigh"/><child link="shin"/><axis xyz="0 2 0"/><dynamics damping="0.1"/></joint>
<joint name="ankle" type="continuous"><origin xyz="0 0 -0.4"/><parent link="shin"/><child link="foot"/><axis xyz="0 1 0"/><mimic joint="knee" multiplier="-1" offset="0"/></joint>
<joint name="toe_weld" type="fixed"><origin xyz="0.1 0 0"/><parent link="foot"/><child link="toe"/></joint>
<joint name="rail" type="prismatic"><origin xyz="0.1 0 0" rpy="0 1.57 0"/><parent link="plate"/><child link="slider"/><axis xyz="1 0 0"/><limit lower="0" upper="0.2" effort="10" velocity="1"/></joint>
<joint name="spin" type="continuous"><parent link="slider"/><child link="wheel"/><axis xyz="0 0 1"/></joint>
<gazebo reference="wheel"><mu1>0.5</mu1></gazebo>
<transmission name="t"><type>SimpleTransmission</type><joint name="knee"><hardwareInterface>Effort</hardwareInterface></joint></transmission>
</robot>
"#;

/// One edit of the text.
#[derive(Clone, Debug)]
enum Mutation {
    FlipByte { at: usize, mask: u8 },
    InsertByte { at: usize, byte: u8 },
    DeleteBytes { at: usize, len: usize },
    Truncate { at: usize },
    SwapAttributeValues { a: usize, b: usize },
    DuplicateLine { line: usize, to: usize },
    DeleteLine { line: usize },
    ReplaceNumber { at: usize, with: usize },
    ChangeJointType { at: usize, to: usize },
    DeleteElement { tag: usize, at: usize },
}

const NUMBERS: &[&str] = &[
    "nan",
    "-1",
    "1e308",
    "",
    "inf",
    "-inf",
    "0",
    "-0",
    "1e-308",
    "NaN",
    "1e309",
    "-1e308",
    "0x10",
    "1.2.3",
    " ",
    "1 2",
    "1e",
    ".",
    "+5",
    "999999999999999999999",
    "&amp;",
    "-0.0001",
    "1e200",
    "-1e300",
    "1e154",
    "5e-324",
];

const JOINT_TYPES: &[&str] = &[
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
    "hinge",
    "",
    "Revolute",
    "fixed fixed",
];

/// Elements deleted whole by [`Mutation::DeleteElement`].
const TAGS: &[&str] = &[
    "inertial", "origin", "axis", "mass", "inertia", "parent", "child", "link", "joint", "limit",
];

/// Bytes likely to matter to an XML parser, inserted more often than random ones.
const SPECIAL: &[u8] = b"<>\"'/=&;!?- \n\t\0#x[]:0123456789.eE";

fn mutation() -> impl Strategy<Value = Mutation> {
    let byte = prop_oneof![any::<u8>(), prop::sample::select(SPECIAL)];
    prop_oneof![
        2 => (any::<usize>(), 1u8..=255).prop_map(|(at, mask)| Mutation::FlipByte { at, mask }),
        2 => (any::<usize>(), byte).prop_map(|(at, byte)| Mutation::InsertByte { at, byte }),
        2 => (any::<usize>(), 1usize..16).prop_map(|(at, len)| Mutation::DeleteBytes { at, len }),
        1 => any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        2 => (any::<usize>(), any::<usize>())
            .prop_map(|(a, b)| Mutation::SwapAttributeValues { a, b }),
        2 => (any::<usize>(), any::<usize>())
            .prop_map(|(line, to)| Mutation::DuplicateLine { line, to }),
        2 => any::<usize>().prop_map(|line| Mutation::DeleteLine { line }),
        3 => (any::<usize>(), 0..NUMBERS.len())
            .prop_map(|(at, with)| Mutation::ReplaceNumber { at, with }),
        2 => (any::<usize>(), 0..JOINT_TYPES.len())
            .prop_map(|(at, to)| Mutation::ChangeJointType { at, to }),
        2 => (0..TAGS.len(), any::<usize>()).prop_map(|(tag, at)| Mutation::DeleteElement { tag, at }),
    ]
}

/// Byte spans of every double-quoted attribute value.
fn attribute_values(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i + 1 < text.len() {
        if text[i] == b'=' && text[i + 1] == b'"' {
            let start = i + 2;
            match text[start..].iter().position(|&b| b == b'"') {
                Some(len) => {
                    spans.push((start, start + len));
                    i = start + len + 1;
                }
                None => break,
            }
        } else {
            i += 1;
        }
    }
    spans
}

/// Byte spans of the numbers inside attribute values.
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    for (start, end) in attribute_values(text) {
        let mut i = start;
        while i < end {
            if text[i].is_ascii_whitespace() {
                i += 1;
                continue;
            }
            let t = i;
            while i < end && !text[i].is_ascii_whitespace() {
                i += 1;
            }
            if std::str::from_utf8(&text[t..i]).is_ok_and(|s| s.parse::<f64>().is_ok()) {
                spans.push((t, i));
            }
        }
    }
    spans
}

/// Byte spans of the values of `type="…"` attributes.
fn type_values(text: &[u8]) -> Vec<(usize, usize)> {
    attribute_values(text)
        .into_iter()
        .filter(|&(start, _)| start >= 6 && &text[start - 6..start] == b"type=\"")
        .collect()
}

/// Byte spans of the elements `<tag …/>` or `<tag …>…</tag>` (not nested in one another).
fn elements(text: &[u8], tag: &str) -> Vec<(usize, usize)> {
    let open = format!("<{tag}");
    let close = format!("</{tag}>");
    let find = |from: usize, what: &[u8]| {
        text[from..]
            .windows(what.len())
            .position(|w| w == what)
            .map(|p| from + p)
    };
    let mut spans = Vec::new();
    let mut from = 0;
    while let Some(start) = find(from, open.as_bytes()) {
        let after = start + open.len();
        if !text
            .get(after)
            .is_some_and(|&b| b == b'>' || b == b'/' || b.is_ascii_whitespace())
        {
            from = after;
            continue;
        }
        let Some(gt) = find(after, b">") else { break };
        let end = if text[gt - 1] == b'/' {
            gt + 1
        } else {
            match find(gt, close.as_bytes()) {
                Some(c) => c + close.len(),
                None => break,
            }
        };
        spans.push((start, end));
        from = end;
    }
    spans
}

/// Byte spans of lines, newline included.
fn lines(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, &b) in text.iter().enumerate() {
        if b == b'\n' {
            spans.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < text.len() {
        spans.push((start, text.len()));
    }
    spans
}

fn splice(text: &mut Vec<u8>, (start, end): (usize, usize), with: &[u8]) {
    text.splice(start..end, with.iter().copied());
}

fn apply(text: &mut Vec<u8>, m: &Mutation) {
    let n = text.len();
    match *m {
        Mutation::FlipByte { at, mask } if n > 0 => text[at % n] ^= mask,
        Mutation::InsertByte { at, byte } => text.insert(at % (n + 1), byte),
        Mutation::DeleteBytes { at, len } if n > 0 => {
            let at = at % n;
            text.drain(at..(at + len).min(n));
        }
        Mutation::Truncate { at } => text.truncate(at % (n + 1)),
        Mutation::SwapAttributeValues { a, b } => {
            let spans = attribute_values(text);
            if spans.len() >= 2 {
                let (sa, sb) = (spans[a % spans.len()], spans[b % spans.len()]);
                let (first, second) = if sa.0 <= sb.0 { (sa, sb) } else { (sb, sa) };
                if first.1 <= second.0 {
                    let va = text[first.0..first.1].to_vec();
                    let vb = text[second.0..second.1].to_vec();
                    // The later span first, so the earlier one's offsets stay valid.
                    splice(text, second, &va);
                    splice(text, first, &vb);
                }
            }
        }
        Mutation::DuplicateLine { line, to } => {
            let spans = lines(text);
            if !spans.is_empty() {
                let (start, end) = spans[line % spans.len()];
                let copy = text[start..end].to_vec();
                let at = spans[to % spans.len()].0;
                splice(text, (at, at), &copy);
            }
        }
        Mutation::DeleteLine { line } => {
            let spans = lines(text);
            if !spans.is_empty() {
                splice(text, spans[line % spans.len()], b"");
            }
        }
        Mutation::ReplaceNumber { at, with } => {
            let spans = numbers(text);
            if !spans.is_empty() {
                splice(text, spans[at % spans.len()], NUMBERS[with].as_bytes());
            }
        }
        Mutation::ChangeJointType { at, to } => {
            let spans = type_values(text);
            if !spans.is_empty() {
                splice(text, spans[at % spans.len()], JOINT_TYPES[to].as_bytes());
            }
        }
        Mutation::DeleteElement { tag, at } => {
            let spans = elements(text, TAGS[tag]);
            if !spans.is_empty() {
                splice(text, spans[at % spans.len()], b"");
            }
        }
        _ => {}
    }
}

/// The variant name of an error (`Xml`, `Cycle`, ...).
fn variant(e: &ModelError) -> String {
    format!("{e:?}")
        .chars()
        .take_while(|c| c.is_alphanumeric())
        .collect()
}

#[derive(Default)]
struct Tally {
    cases: usize,
    ok: usize,
    errors: BTreeMap<String, usize>,
}

/// Runs `cases` mutated versions of the seeds through the loader; panics (a failed case) on a
/// loader panic or a broken invariant of a model that loaded.
fn fuzz(name: &str, seeds: &[String], cases: u32, max_mutations: usize) {
    // ARTICULA_FUZZ_SCALE=10 runs ten times as many cases, for a deeper search.
    let scale: u32 = std::env::var("ARTICULA_FUZZ_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let cases = cases * scale.max(1);
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (
        0..seeds.len(),
        prop::collection::vec(mutation(), 1..=max_mutations),
        any::<bool>(),
        (0..3usize, any::<bool>()),
    );
    let result = runner.run(
        &strategy,
        |(seed, mutations, floating_base, (inertia, refuse))| {
            let mut bytes = seeds[seed].as_bytes().to_vec();
            for m in &mutations {
                apply(&mut bytes, m);
            }
            let text = String::from_utf8_lossy(&bytes);
            let options = LoadOptions::default()
                .with_floating_base(floating_base)
                .with_inertia(
                    [
                        InertiaPolicy::Accept,
                        InertiaPolicy::Strict,
                        InertiaPolicy::Repair,
                    ][inertia],
                )
                .with_massless_leaf(if refuse {
                    MasslessLeafPolicy::Refuse
                } else {
                    MasslessLeafPolicy::Lock
                });
            let result = Model::from_urdf_str(&text, &options);
            if let Ok(model) = &result {
                common::check_invariants(model);
            }
            let mut t = tally.borrow_mut();
            t.cases += 1;
            match result {
                Ok(_) => t.ok += 1,
                Err(e) => *t.errors.entry(variant(&e)).or_default() += 1,
            }
            Ok(())
        },
    );
    let t = tally.into_inner();
    let errors: usize = t.errors.values().sum();
    eprintln!(
        "fuzz {name}: {} cases, {} loaded, {errors} errors: {:?}",
        t.cases, t.ok, t.errors
    );
    if let Err(e) = result {
        panic!("fuzz {name}: {e}");
    }
    assert!(t.cases >= cases as usize);
}

#[test]
fn fuzz_small_seed() {
    let seeds = [SMALL.to_string()];
    // The seed itself is valid and exercises merging, composition and mimic warnings.
    let m = common::load(SMALL).unwrap();
    assert!(m.bodies.iter().any(|b| b.joint.len() == 3));
    assert!(m.warnings.iter().any(|w| w.to_string().contains("'ankle'")));
    fuzz("small", &seeds, 7000, 4);
}

/// A robot with every inertia oddity the policies handle: a triangle violation, a point mass, an
/// indefinite link welded to a heavy one (fine once merged), a round-off negative moment, a
/// massless finger chain (locked) and a 1e-6 kg placeholder welded by a fixed joint. One
/// element a line.
const ODD: &str = r#"<?xml version="1.0"?>
<robot name="odd">
<link name="base"><inertial><mass value="5"/><inertia ixx="0.05" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial></link>
<link name="placeholder"><inertial><mass value="1e-6"/><inertia ixx="1e-9" ixy="0" ixz="0" iyy="1e-9" iyz="0" izz="1e-5"/></inertial></link>
<link name="arm"><inertial><origin xyz="0 0 -0.2"/><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.03"/></inertial></link>
<link name="bob"><inertial><origin xyz="0.3 0 0"/><mass value="0.5"/><inertia ixx="0" ixy="0" ixz="2.4e-35" iyy="0" iyz="0" izz="0"/></inertial></link>
<link name="shell"><inertial><mass value="2"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
<link name="dent"><inertial><mass value="0.01"/><inertia ixx="-1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>
<link name="rounded"><inertial><mass value="1"/><inertia ixx="-1e-12" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="finger1"/>
<link name="finger2"><inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
<joint name="weld" type="fixed"><origin xyz="0 0 0.1"/><parent link="base"/><child link="placeholder"/></joint>
<joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/></joint>
<joint name="elbow" type="revolute"><origin xyz="0 0 -0.4"/><parent link="arm"/><child link="bob"/><axis xyz="0 0 1"/></joint>
<joint name="hip" type="revolute"><origin xyz="0.2 0 0"/><parent link="base"/><child link="shell"/><axis xyz="1 0 0"/></joint>
<joint name="stud" type="fixed"><parent link="shell"/><child link="dent"/></joint>
<joint name="knee" type="prismatic"><parent link="shell"/><child link="rounded"/><axis xyz="0 0 1"/></joint>
<joint name="f1" type="revolute"><parent link="rounded"/><child link="finger1"/><axis xyz="0 1 0"/></joint>
<joint name="f2" type="revolute"><parent link="finger1"/><child link="finger2"/><axis xyz="0 1 0"/><mimic joint="f1"/></joint>
</robot>
"#;

#[test]
fn fuzz_odd_inertias() {
    // The seed loads by default: a triangle warning (arm), a point mass given an inertia (bob),
    // a rounded negative moment given one too (rounded), two locked finger joints.
    let m = common::load(ODD).unwrap();
    assert_eq!(m.locked_joints(), vec!["f1", "f2"]);
    assert_eq!(m.bodies.len(), 4);
    fuzz("odd", &[ODD.to_string()], 2500, 4);
}

#[test]
fn fuzz_small_seed_many_mutations() {
    fuzz("small-heavy", &[SMALL.to_string()], 1500, 12);
}

#[test]
fn fuzz_humanoid() {
    let seeds = [common::read_model("humanoid")];
    common::load(&seeds[0]).unwrap();
    fuzz("humanoid", &seeds, 1200, 4);
}

#[test]
fn fuzz_rope() {
    let seeds = [common::read_model("rope")];
    common::load(&seeds[0]).unwrap();
    fuzz("rope", &seeds, 600, 4);
}

#[test]
fn mutations_apply_as_described() {
    let text = br#"<a x="1 2" type="fixed"/>
<b y="3"/>
"#;
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::ReplaceNumber { at: 1, with: 0 });
    assert_eq!(
        t,
        br#"<a x="1 nan" type="fixed"/>
<b y="3"/>
"#
    );
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::ChangeJointType { at: 0, to: 7 });
    assert_eq!(
        t,
        br#"<a x="1 2" type="hinge"/>
<b y="3"/>
"#
    );
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::SwapAttributeValues { a: 2, b: 0 });
    assert_eq!(
        t,
        br#"<a x="3" type="fixed"/>
<b y="1 2"/>
"#
    );
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::DuplicateLine { line: 1, to: 0 });
    assert_eq!(
        t,
        br#"<b y="3"/>
<a x="1 2" type="fixed"/>
<b y="3"/>
"#
    );
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::DeleteLine { line: 0 });
    assert_eq!(t, b"<b y=\"3\"/>\n");
    let nested = b"<x><a><b/></a><a/><ab/></x>";
    assert_eq!(elements(nested, "a"), [(3, 14), (14, 18)]);
    assert_eq!(elements(nested, "b"), [(6, 10)]);
    let mut t = nested.to_vec();
    apply(&mut t, &Mutation::DeleteElement { tag: 0, at: 0 });
    assert_eq!(t, nested, "no <inertial> to delete");
    let mut t = text.to_vec();
    apply(&mut t, &Mutation::DeleteLine { line: 0 });
    assert_eq!(t, b"<b y=\"3\"/>\n");
}
