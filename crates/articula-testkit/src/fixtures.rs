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

/// A branched tree: a welded base, a head on a ball joint (three revolute parts about z, x, y
/// through massless links: one body of three degrees of freedom), and one chain of rod links
/// (0.1 kg, 0.1 m) per entry of `branches`, of that many links, hanging from points around the
/// head. A branch's links turn about y and x in turn; its first link and every fifth after it
/// hang on a ball joint instead. `branches_urdf(&[n; k])` is `k` equal branches;
/// `branches_urdf(&[big, small, small])` a lopsided tree.
pub fn branches_urdf(branches: &[usize]) -> String {
    let mut s = String::from("<robot name=\"branches\">\n");
    s += &hub_link("base");
    s += &hub_link("head");
    s += &ball("neck", "base", "head", [0.0, 0.0, 0.2]);
    for (i, &links) in branches.iter().enumerate() {
        let a = std::f64::consts::TAU * i as f64 / branches.len() as f64;
        let mut parent = "head".to_string();
        for k in 0..links {
            let name = format!("b{i}_{k}");
            let at = if k == 0 {
                [0.1 * a.cos(), 0.1 * a.sin(), -0.05]
            } else {
                [0.0, 0.0, -0.1]
            };
            s += &rod_link(&name, 0.1, 0.1);
            let joint = format!("j{i}_{k}");
            if k % 5 == 0 {
                s += &ball(&joint, &parent, &name, at);
            } else {
                let axis = if k % 2 == 0 { "0 1 0" } else { "1 0 0" };
                s += &revolute(&joint, &parent, &name, at, axis);
            }
            parent = name;
        }
    }
    s + "</robot>\n"
}

/// A ball joint `name` from `parent` to `child` at `at`: revolute parts about z, x and y
/// through two massless links.
fn ball(name: &str, parent: &str, child: &str, at: [f64; 3]) -> String {
    let (l1, l2) = (format!("{name}_l1"), format!("{name}_l2"));
    let mut s = format!("<link name=\"{l1}\"/>\n<link name=\"{l2}\"/>\n");
    s += &revolute(&format!("{name}_z"), parent, &l1, at, "0 0 1");
    s += &revolute(&format!("{name}_x"), &l1, &l2, [0.0; 3], "1 0 0");
    s += &revolute(&format!("{name}_y"), &l2, child, [0.0; 3], "0 1 0");
    s
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

/// An icub-like humanoid with point masses (zero rotational inertia, as icub's URDF has): a
/// base (5 kg) with two legs of two links, a torso on a yaw joint with two arms of three links
/// and a neck of three links (pitch, roll, yaw) whose last is a 1.3 kg point-mass head 0.4 mm
/// from the yaw axis. The point masses: each leg's thigh, the right arm's forearm, the whole
/// neck. Every point mass hangs below a branch point (the base, the torso), so DCA's leaf
/// clusters hold them all.
pub fn point_mass_humanoid_urdf() -> String {
    let mut s = String::from("<robot name=\"point_mass_humanoid\">\n");
    let link = |name: &str, m: f64, i: [f64; 3], com: [f64; 3]| {
        format!(
            "<link name=\"{name}\"><inertial><origin xyz=\"{} {} {}\"/><mass value=\"{m}\"/><inertia ixx=\"{}\" iyy=\"{}\" izz=\"{}\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n",
            com[0], com[1], com[2], i[0], i[1], i[2]
        )
    };
    let joint = |name: &str, parent: &str, child: &str, at: [f64; 3], axis: &str| {
        format!(
            "<joint name=\"{name}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"{child}\"/><origin xyz=\"{} {} {}\"/><axis xyz=\"{axis}\"/><limit lower=\"-3\" upper=\"3\" effort=\"50\" velocity=\"10\"/></joint>\n",
            at[0], at[1], at[2]
        )
    };
    let solid = [0.02, 0.025, 0.012];
    let point = [0.0; 3];
    s += &link("base", 5.0, [0.05, 0.04, 0.03], [0.0, 0.0, 0.0]);
    for (side, y) in [("l", 0.1), ("r", -0.1)] {
        s += &link(&format!("{side}_thigh"), 2.0, point, [0.0, 0.01, -0.15]);
        s += &joint(
            &format!("{side}_hip"),
            "base",
            &format!("{side}_thigh"),
            [0.0, y, -0.05],
            "0 1 0",
        );
        s += &link(&format!("{side}_shin"), 1.2, solid, [0.01, 0.0, -0.15]);
        s += &joint(
            &format!("{side}_knee"),
            &format!("{side}_thigh"),
            &format!("{side}_shin"),
            [0.0, 0.0, -0.3],
            "0 1 0",
        );
    }
    s += &link("torso", 4.0, [0.06, 0.05, 0.03], [0.0, 0.0, 0.15]);
    s += &joint("torso_yaw", "base", "torso", [0.0, 0.0, 0.1], "0 0 1");
    for (side, y) in [("l", 0.15), ("r", -0.15)] {
        let fore = if side == "r" { point } else { solid };
        s += &link(
            &format!("{side}_upper"),
            0.8,
            [0.004, 0.004, 0.001],
            [0.0, 0.0, -0.1],
        );
        s += &joint(
            &format!("{side}_shoulder"),
            "torso",
            &format!("{side}_upper"),
            [0.0, y, 0.3],
            "1 0 0",
        );
        s += &link(
            &format!("{side}_fore"),
            0.5,
            fore.map(|x| x * 0.1),
            [0.02, 0.0, -0.1],
        );
        s += &joint(
            &format!("{side}_elbow"),
            &format!("{side}_upper"),
            &format!("{side}_fore"),
            [0.0, 0.0, -0.2],
            "0 1 0",
        );
        s += &link(
            &format!("{side}_hand"),
            0.2,
            [2e-4, 2e-4, 1e-4],
            [0.0, 0.0, -0.04],
        );
        s += &joint(
            &format!("{side}_wrist"),
            &format!("{side}_fore"),
            &format!("{side}_hand"),
            [0.0, 0.0, -0.2],
            "0 0 1",
        );
    }
    s += &link("neck_1", 0.1, point, [0.0, 0.0, 0.0]);
    s += &joint("neck_pitch", "torso", "neck_1", [0.0, 0.0, 0.35], "0 1 0");
    s += &link("neck_2", 0.3, point, [0.03, 0.02, 0.02]);
    s += &joint("neck_roll", "neck_1", "neck_2", [0.0, 0.0, 0.03], "1 0 0");
    s += &link("head", 1.3, point, [0.04, 0.0, 0.1]);
    s += &joint("neck_yaw", "neck_2", "head", [0.0, 0.0, 0.03], "0 0 1");
    s + "</robot>\n"
}

/// A random tree of `n` links below a root link, seeded: each link's parent is one of the
/// links before it (a fresh link has a one-in-three chance of starting a new branch off an
/// earlier link, so the tree has branch points with subtrees of every size), its joint
/// revolute about a random unit axis or, one time in five, prismatic; masses 0.2–2 kg, random
/// centres of mass and principal moments (triangle inequality kept) in a random frame.
pub fn random_tree_urdf(n: usize, seed: u64) -> String {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        // SplitMix64
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    };
    let mut s = String::from("<robot name=\"random_tree\">\n");
    s += &hub_link("root");
    let mut last = 0usize; // the link a fresh link continues, 0 the root
    for i in 1..=n {
        let parent = if i == 1 || next() < 0.34 {
            (next() * i as f64) as usize % i
        } else {
            last
        };
        last = i;
        let m = 0.2 + 1.8 * next();
        let (a, b) = (0.002 + 0.01 * next(), 0.002 + 0.01 * next());
        let c = (a + b) * (0.3 + 0.6 * next());
        let name = |k: usize| {
            if k == 0 {
                "root".to_string()
            } else {
                format!("t{k}")
            }
        };
        s += &format!(
            "<link name=\"{}\"><inertial><origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/><mass value=\"{m}\"/><inertia ixx=\"{a}\" iyy=\"{b}\" izz=\"{c}\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n",
            name(i),
            0.1 * next() - 0.05,
            0.1 * next() - 0.05,
            -0.1 * next(),
            3.0 * next(),
            3.0 * next(),
            3.0 * next(),
        );
        let axis = [next() - 0.5, next() - 0.5, next() - 0.5];
        let norm = axis.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-3);
        let kind = if next() < 0.2 {
            "prismatic"
        } else {
            "revolute"
        };
        s += &format!(
            "<joint name=\"j{i}\" type=\"{kind}\"><parent link=\"{}\"/><child link=\"{}\"/><origin xyz=\"{} {} {}\" rpy=\"{} 0 {}\"/><axis xyz=\"{} {} {}\"/><limit lower=\"-3\" upper=\"3\" effort=\"50\" velocity=\"10\"/></joint>\n",
            name(parent),
            name(i),
            0.1 * next() - 0.05,
            0.1 * next() - 0.05,
            -0.1 - 0.1 * next(),
            next(),
            next(),
            axis[0] / norm,
            axis[1] / norm,
            axis[2] / norm,
        );
    }
    s + "</robot>\n"
}

/// example-robot-data's `robots/` folder: `$ROBOTS`, or the copy `pip install
/// example-robot-data` put in the workspace's `target/peers-venv` (as `.ci/run` does). `None`
/// when neither exists.
pub fn example_robots_dir() -> Option<std::path::PathBuf> {
    if let Some(d) = std::env::var_os("ROBOTS") {
        return Some(d.into());
    }
    let lib = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/peers-venv/lib");
    std::fs::read_dir(lib).ok()?.flatten().find_map(|e| {
        let d = e
            .path()
            .join("site-packages/cmeel.prefix/share/example-robot-data/robots");
        d.is_dir().then_some(d)
    })
}

/// Every `.urdf` under `dir` (recursively), sorted.
pub fn urdfs_under(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "urdf") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// An MJCF model with armature, damping and springs: a free torso with a 3-hinge hip composed
/// in one body (anchored off the body origin, with `ref`), a slide, a 2-hinge shoulder,
/// armature and damping on every joint (some different per class) and springs on three joints
/// (the knee slide, a shoulder hinge with `springref`, the wrist).
pub const ARMATURE_MJCF: &str = r#"<mujoco model="armature">
  <compiler angle="degree"/>
  <default>
    <joint armature="0.02" damping="0.5"/>
    <default class="big"><joint armature="1.5" damping="3"/></default>
  </default>
  <worldbody>
    <body name="torso" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="capsule" fromto="0 -.07 0 0 .07 0" size=".07"/>
      <body name="thigh" pos="0 -.1 -.04" euler="10 0 -20">
        <joint name="hip_x" axis="1 0 0" pos="0 0 .05" range="-25 5"/>
        <joint name="hip_z" axis="0 0 1" pos="0 0 .05" ref="12"/>
        <joint name="hip_y" axis="0 1 0" pos="0 .01 .05" class="big"/>
        <geom type="capsule" fromto="0 0 0 0 .01 -.34" size=".06"/>
        <body name="shin" pos="0 .01 -.403">
          <joint name="knee" type="slide" axis="0 0 1" class="big" stiffness="40"/>
          <geom type="box" size=".05 .04 .1" pos="0 0 -.1"/>
        </body>
      </body>
      <body name="arm" pos=".1 .2 0" quat="0.9 0.1 0.3 0.2">
        <joint name="sh1" axis="2 1 1" stiffness="3" springref="20"/>
        <joint name="sh2" axis="0 -1 1" pos=".02 0 0"/>
        <geom type="ellipsoid" size=".05 .08 .12"/>
        <body name="hand" pos="0 0 -.2">
          <joint name="wrist" axis="1 0 0" stiffness="0.5"/>
          <geom type="sphere" size=".04"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"#;

/// A planar swimmer on a fixed base: a composed slide–slide–hinge root whose middle part alone
/// has armature (a DCA join whose `Zᵀ Z D⁻¹` is no identity), and two hinged links.
pub const SWIMMER_MJCF: &str = r#"<mujoco>
  <default><joint armature="0.1"/></default>
  <worldbody>
    <body name="torso">
      <geom fromto="0 0 0 0.5 0 0" size="0.1" type="capsule"/>
      <joint axis="1 0 0" name="slider1" type="slide" armature="0"/>
      <joint axis="0 1 0" name="slider2" type="slide"/>
      <joint axis="0 0 1" name="rot" armature="0"/>
      <body name="mid" pos="0.5 0 0">
        <geom fromto="0 0 0 -1 0 0" size="0.1" type="capsule"/>
        <joint axis="0 0 1" name="motor1" armature="0.3"/>
        <body name="back" pos="-1 0 0">
          <geom fromto="0 0 0 -1 0 0" size="0.1" type="capsule"/>
          <joint axis="0 0 1" name="motor2" armature="0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"#;

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
