//! Models for tests and benchmarks: the bundled `models/*.urdf` (embedded at compile time) and
//! planar pendulum chains of any length.

use articula_model::{LoadOptions, Model};

/// The file stems of the bundled models, in `models/`.
pub const BUNDLED: [&str; 8] = [
    "chain10",
    "chain30",
    "chain100",
    "chain300",
    "chain1000",
    "humanoid",
    "plant",
    "rope",
];

/// The URDF text of a bundled model by file stem (`humanoid`, `chain300`, ...; see
/// [`BUNDLED`]). Panics on another name.
pub fn bundled_urdf(name: &str) -> &'static str {
    match name {
        "chain10" => include_str!("../../../models/chain10.urdf"),
        "chain30" => include_str!("../../../models/chain30.urdf"),
        "chain100" => include_str!("../../../models/chain100.urdf"),
        "chain300" => include_str!("../../../models/chain300.urdf"),
        "chain1000" => include_str!("../../../models/chain1000.urdf"),
        "humanoid" => include_str!("../../../models/humanoid.urdf"),
        "plant" => include_str!("../../../models/plant.urdf"),
        "rope" => include_str!("../../../models/rope.urdf"),
        _ => panic!("no bundled model `{name}` (expected one of {BUNDLED:?})"),
    }
}

/// A bundled model by file stem, its root welded to the world.
pub fn bundled(name: &str) -> Model {
    bundled_with(name, false)
}

/// A bundled model by file stem, its root welded to the world or (`floating_base`) free.
pub fn bundled_with(name: &str, floating_base: bool) -> Model {
    Model::from_urdf_str(
        bundled_urdf(name),
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .unwrap_or_else(|e| panic!("bundled model {name}: {e}"))
}

/// A planar revolute pendulum chain of `n` links (0.1 m, 0.1 kg rods hanging along −z, all
/// joints about y), the bodies of the bundled `models/chainN.urdf` for any `n` (their
/// rotational inertias written to 5 significant digits instead of 8).
pub fn chain_urdf(n: usize) -> String {
    let mut s = String::from("<robot name=\"chain\"><link name=\"base\"><inertial><mass value=\"1\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n");
    for i in 1..=n {
        let parent = if i == 1 {
            "base".to_string()
        } else {
            format!("link{}", i - 1)
        };
        let z = if i == 1 { -0.05 } else { -0.1 };
        s += &format!(
            "<link name=\"link{i}\"><inertial><origin xyz=\"0 0 -0.05\"/><mass value=\"0.1\"/><inertia ixx=\"8.5833e-5\" iyy=\"8.5833e-5\" izz=\"5e-6\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n<joint name=\"joint{i}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"link{i}\"/><origin xyz=\"0 0 {z}\"/><axis xyz=\"0 1 0\"/><limit lower=\"-3.14\" upper=\"3.14\" effort=\"100\" velocity=\"10\"/></joint>\n"
        );
    }
    s + "</robot>"
}

/// The chain of [`chain_urdf`], loaded with a fixed base.
pub fn chain(n: usize) -> Model {
    Model::from_urdf_str(&chain_urdf(n), &LoadOptions::default()).expect("chain loads")
}

/// A star: a hub link (2 kg) with `k` rod links (0.1 kg, 0.1 m) on revolute joints around it,
/// their axes alternating between x and y, 0.1 m from the hub's centre. With a fixed base the hub
/// is the ground; with a floating base it is a body with `k` children.
pub fn star_urdf(k: usize) -> String {
    let mut s = String::from("<robot name=\"star\">\n");
    s += &hub_link("hub");
    for i in 0..k {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        let axis = if i % 2 == 0 { "1 0 0" } else { "0 1 0" };
        s += &rod_link(&format!("l{i}"), 0.1, 0.1);
        s += &revolute(
            &format!("j{i}"),
            "hub",
            &format!("l{i}"),
            [0.1 * a.cos(), 0.1 * a.sin(), 0.0],
            axis,
        );
    }
    s + "</robot>\n"
}

/// A "hair head": a base, a head on a revolute neck, and `strands` chains of `segments` rod
/// links (10 g, 2 cm) hanging from points around the head, their joints alternating between y
/// and x. With a fixed base the head is a body with `strands` children.
pub fn hair_urdf(strands: usize, segments: usize) -> String {
    let mut s = String::from("<robot name=\"hair\">\n");
    s += &hub_link("base");
    s += &hub_link("head");
    s += &revolute("neck", "base", "head", [0.0, 0.0, 0.2], "0 0 1");
    for i in 0..strands {
        let a = std::f64::consts::TAU * i as f64 / strands as f64;
        let z = 0.1 * (0.37 * i as f64).cos();
        let mut parent = "head".to_string();
        for k in 0..segments {
            let name = format!("s{i}_{k}");
            let at = if k == 0 {
                [0.1 * a.cos(), 0.1 * a.sin(), z]
            } else {
                [0.0, 0.0, -0.02]
            };
            let axis = if k % 2 == 0 { "0 1 0" } else { "1 0 0" };
            s += &rod_link(&name, 0.01, 0.02);
            s += &revolute(&format!("j{i}_{k}"), &parent, &name, at, axis);
            parent = name;
        }
    }
    s + "</robot>\n"
}

/// A 2 kg link with a 0.02 kg m² isotropic rotational inertia.
fn hub_link(name: &str) -> String {
    format!("<link name=\"{name}\"><inertial><mass value=\"2\"/><inertia ixx=\"0.02\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n")
}

/// A rod of mass `m` and length `l` (radius 1 cm) hanging along −z from its joint.
fn rod_link(name: &str, m: f64, l: f64) -> String {
    let ixx = m * (3.0 * 0.01 * 0.01 + l * l) / 12.0;
    let izz = m * 0.01 * 0.01 / 2.0;
    let z = -l / 2.0;
    format!("<link name=\"{name}\"><inertial><origin xyz=\"0 0 {z}\"/><mass value=\"{m}\"/><inertia ixx=\"{ixx}\" iyy=\"{ixx}\" izz=\"{izz}\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n")
}

fn revolute(name: &str, parent: &str, child: &str, at: [f64; 3], axis: &str) -> String {
    format!("<joint name=\"{name}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"{child}\"/><origin xyz=\"{} {} {}\"/><axis xyz=\"{axis}\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"10\"/></joint>\n", at[0], at[1], at[2])
}

/// A pendulum chain of `n` rods (0.1 m long) whose odd links have mass 0.1 kg and even links
/// `0.1 ratio` kg, with inertias scaled alike (same shape, density ratio `ratio`).
pub fn ratio_chain_urdf(n: usize, ratio: f64) -> String {
    let mut s = String::from(
        "<robot name=\"ratio_chain\"><link name=\"base\"><inertial><mass value=\"1\"/>\
         <inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>\
         </inertial></link>\n",
    );
    for i in 1..=n {
        let k = if i % 2 == 0 { ratio } else { 1.0 };
        let parent = if i == 1 {
            "base".to_string()
        } else {
            format!("link{}", i - 1)
        };
        let z = if i == 1 { -0.05 } else { -0.1 };
        let (m, ixx, izz) = (0.1 * k, 8.5833e-5 * k, 5e-6 * k);
        let _ = std::fmt::Write::write_fmt(
            &mut s,
            format_args!(
            "<link name=\"link{i}\"><inertial><origin xyz=\"0 0 -0.05\"/><mass value=\"{m:e}\"/>\
             <inertia ixx=\"{ixx:e}\" iyy=\"{ixx:e}\" izz=\"{izz:e}\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>\
             </inertial></link>\n<joint name=\"joint{i}\" type=\"revolute\"><parent link=\"{parent}\"/>\
             <child link=\"link{i}\"/><origin xyz=\"0 0 {z}\"/><axis xyz=\"0 1 0\"/>\
             <limit lower=\"-3.14\" upper=\"3.14\" effort=\"100\" velocity=\"10\"/></joint>\n"
            ),
        );
    }
    s + "</robot>"
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every bundled name loads, and the procedural chain is the bundled one: the same joints
    /// and masses to the bit, the rotational inertias to their written digits.
    #[test]
    fn procedural_chains_are_the_bundled_ones() {
        for name in BUNDLED {
            assert!(!bundled(name).bodies.is_empty(), "{name}");
        }
        for n in [10, 30, 100, 300, 1000] {
            let (a, b) = (chain(n), bundled(&format!("chain{n}")));
            assert_eq!(a.bodies.len(), b.bodies.len());
            for (x, y) in a.bodies.iter().zip(&b.bodies) {
                let label = format!("chain{n} body {}", x.name);
                assert_eq!(x.joint[0].origin, y.joint[0].origin, "{label}");
                assert_eq!(x.joint[0].axis, y.joint[0].axis, "{label}");
                assert_eq!(x.inertia.mass, y.inertia.mass, "{label}");
                assert_eq!(x.inertia.h, y.inertia.h, "{label}");
                let (i, j) = (x.inertia.ibar, y.inertia.ibar);
                let rel = (i - j)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0, f64::max)
                    / j.abs().to_cols_array().into_iter().fold(0.0, f64::max);
                assert!(rel < 1e-5, "{label}: {rel:e}");
            }
        }
    }

    #[test]
    #[should_panic(expected = "no bundled model")]
    fn an_unknown_name_panics() {
        bundled_urdf("chain7");
    }
}
