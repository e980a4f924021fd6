//! Composed joints (docs/design.md#composition): a 3-DOF hip made of three revolute joints with two
//! massless links between them is folded into one body with a 3-DOF joint. DCA on that model
//! must give the q̈ that ABA gives on the uncomposed model — the same URDF with the two links
//! given a negligible mass, so that nothing is composed.

use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::{LoadOptions, Model};

/// A leg on a pelvis: hip_z → hip_link1 → hip_x → hip_link2 → hip_y → thigh → knee → shank.
/// The hip joints have offsets and tilted frames, so the composed subspace is not trivial.
/// `link_inertial` is the `<inertial>` of the two hip links (empty: massless).
fn leg(link_inertial: &str) -> String {
    format!(
        r#"<robot name="leg">
      <link name="pelvis"><inertial><origin xyz="0 0 0.05"/><mass value="6"/>
        <inertia ixx="0.05" iyy="0.04" izz="0.06" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="hip_link1">{link_inertial}</link>
      <link name="hip_link2">{link_inertial}</link>
      <link name="thigh"><inertial><origin xyz="0.01 0.02 -0.2" rpy="0.1 0 0"/><mass value="4.5"/>
        <inertia ixx="0.07" iyy="0.075" izz="0.012" ixy="0.001" ixz="-0.002" iyz="0.003"/></inertial></link>
      <link name="shank"><inertial><origin xyz="0 0.01 -0.21"/><mass value="2.8"/>
        <inertia ixx="0.045" iyy="0.046" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="hip_z" type="revolute"><origin xyz="0.02 0.09 -0.08" rpy="0.1 0 0.2"/>
        <parent link="pelvis"/><child link="hip_link1"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="100" velocity="10"/></joint>
      <joint name="hip_x" type="revolute"><origin xyz="0.03 0 -0.02" rpy="0 0.15 0"/>
        <parent link="hip_link1"/><child link="hip_link2"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="100" velocity="10"/></joint>
      <joint name="hip_y" type="revolute"><origin xyz="0 -0.01 -0.03" rpy="0 0 0.1"/>
        <parent link="hip_link2"/><child link="thigh"/><axis xyz="0 1 0"/>
        <limit lower="-2" upper="1" effort="100" velocity="10"/></joint>
      <joint name="knee" type="revolute"><origin xyz="0 0 -0.43"/>
        <parent link="thigh"/><child link="shank"/><axis xyz="0 1 0"/>
        <limit lower="0" upper="2.4" effort="100" velocity="10"/></joint>
    </robot>"#
    )
}

/// The `<inertial>` of a link of mass `m` (kg) and inertia `m / 1000` (kg·m²) about its origin.
fn tiny(m: f64) -> String {
    format!(
        r#"<inertial><origin xyz="0 0 0"/><mass value="{m:e}"/>
  <inertia ixx="{i:e}" iyy="{i:e}" izz="{i:e}" ixy="0" ixz="0" iyz="0"/></inertial>"#,
        i = m * 1e-3
    )
}

/// The hip links get 1e-9 kg and 1e-12 kg·m². Measured max relative differences (10 states):
/// DCA(composed) vs ABA(uncomposed) 1.3e-10 fixed base, 5.3e-10 floating; ABA(composed) vs
/// ABA(uncomposed) the same to 3 digits — so the difference is the perturbation itself, not
/// either solver (and `perturbation_is_what_remains` shows it shrinks in proportion to the
/// mass). The bound leaves a factor ~20 over the measurement, well inside the ~1e-6 a
/// perturbation of this size could at most explain.
const TOL: f64 = 1e-8;

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().chain(b).fold(1.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// The state of `composed` carried over to `full` by URDF joint and link names.
fn map_state(composed: &Model, full: &Model, s: &State) -> State {
    let mut t = State::neutral(full);
    for (_, part) in composed.joint_parts() {
        let (_, p) = full.find_joint(&part.name).unwrap();
        assert_eq!(p.kind, part.kind);
        t.q[p.q_offset..p.q_offset + p.nq()]
            .copy_from_slice(&s.q[part.q_offset..part.q_offset + part.nq()]);
        t.qd[p.v_offset..p.v_offset + p.nv()]
            .copy_from_slice(&s.qd[part.v_offset..part.v_offset + part.nv()]);
        t.tau[p.v_offset..p.v_offset + p.nv()]
            .copy_from_slice(&s.tau[part.v_offset..part.v_offset + part.nv()]);
    }
    for (i, body) in composed.bodies.iter().enumerate() {
        let j = full
            .bodies
            .iter()
            .position(|b| b.name == body.name)
            .unwrap();
        t.f_ext[j] = s.f_ext[i];
    }
    t
}

/// `full`'s q̈ read back in `composed`'s coordinate order.
fn unmap_qdd(composed: &Model, full: &Model, qdd: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; composed.nv];
    for (_, part) in composed.joint_parts() {
        let (_, p) = full.find_joint(&part.name).unwrap();
        out[part.v_offset..part.v_offset + part.nv()]
            .copy_from_slice(&qdd[p.v_offset..p.v_offset + p.nv()]);
    }
    out
}

/// Runs the comparison with hip links of mass `m`; returns the worst relative difference of
/// DCA(composed) and ABA(uncomposed).
fn check(floating_base: bool, m: f64) -> f64 {
    let options = LoadOptions::default().with_floating_base(floating_base);
    let composed = Model::from_urdf_str(&leg(""), &options).unwrap();
    let full = Model::from_urdf_str(&leg(&tiny(m)), &options).unwrap();

    // The composed model: the hip is one body (the thigh) with a 3-part joint.
    let base = usize::from(floating_base);
    assert_eq!(composed.bodies.len(), 2 + base);
    assert_eq!(full.bodies.len(), 4 + base);
    assert!(composed.bodies.len() < full.bodies.len());
    assert_eq!((composed.nv, full.nv), (full.nv, 4 + 6 * base));
    let (thigh, _) = composed.find_joint("hip_x").unwrap();
    let thigh = &composed.bodies[thigh];
    assert_eq!(thigh.name, "thigh");
    assert_eq!(
        thigh
            .joint
            .iter()
            .map(|p| p.name.as_str())
            .collect::<Vec<_>>(),
        ["hip_z", "hip_x", "hip_y"]
    );
    assert_eq!(thigh.massless_links, ["hip_link1", "hip_link2"]);
    assert!(full.bodies.iter().all(|b| b.joint.len() == 1));

    let mut dc = Data::new(&composed);
    let mut df = Data::new(&full);
    let (mut worst, mut worst_aba, mut worst_dca_full) = (0.0f64, 0.0f64, 0.0f64);
    for seed in 0..10 {
        let mut s = State::random(&composed, seed, 2.0);
        if seed % 2 == 0 {
            s.randomize_forces(seed, 1.0);
        }
        let t = map_state(&composed, &full, &s);
        let dca = forward_dynamics_slices(
            &composed,
            &mut dc,
            &s.q,
            &s.qd,
            &s.tau,
            &s.f_ext,
            Method::Dca,
        )
        .unwrap()
        .to_vec();
        let aba_composed = forward_dynamics_slices(
            &composed,
            &mut dc,
            &s.q,
            &s.qd,
            &s.tau,
            &s.f_ext,
            Method::Aba,
        )
        .unwrap()
        .to_vec();
        let aba_full =
            forward_dynamics_slices(&full, &mut df, &t.q, &t.qd, &t.tau, &t.f_ext, Method::Aba)
                .unwrap();
        let aba_full = unmap_qdd(&composed, &full, aba_full);
        let dca_full =
            forward_dynamics_slices(&full, &mut df, &t.q, &t.qd, &t.tau, &t.f_ext, Method::Dca)
                .unwrap();
        let dca_full = unmap_qdd(&composed, &full, dca_full);

        let e = rel_diff(&dca, &aba_full);
        worst = worst.max(e);
        worst_aba = worst_aba.max(rel_diff(&aba_composed, &aba_full));
        worst_dca_full = worst_dca_full.max(rel_diff(&dca_full, &aba_full));
        assert!(
            e < TOL,
            "floating={floating_base} seed {seed}: DCA composed {dca:?} vs ABA uncomposed {aba_full:?} ({e:e})"
        );
        assert!(rel_diff(&aba_composed, &aba_full) < TOL);
    }
    eprintln!(
        "composed hip, floating={floating_base}: max relative difference DCA(composed) vs ABA(uncomposed, {m:e} kg links) {worst:e}; ABA(composed) vs ABA(uncomposed) {worst_aba:e}; for information, DCA(uncomposed) vs ABA(uncomposed) {worst_dca_full:e}"
    );
    worst
}

#[test]
fn composed_hip_matches_aba_on_the_uncomposed_leg_fixed_base() {
    check(false, 1e-9);
}

#[test]
fn composed_hip_matches_aba_on_the_uncomposed_leg_floating_base() {
    check(true, 1e-9);
}

/// The composed model is the limit of the perturbed one: 100 times less mass on the hip links,
/// ~100 times smaller difference (measured ratios printed).
#[test]
fn perturbation_is_what_remains() {
    for floating_base in [false, true] {
        let (a, b) = (check(floating_base, 1e-9), check(floating_base, 1e-11));
        eprintln!(
            "floating={floating_base}: difference ratio for 1e-9 kg -> 1e-11 kg: {:.1}",
            a / b
        );
        assert!(a / b > 50.0 && a / b < 200.0, "ratio {}", a / b);
    }
}

/// Why compose: DCA run directly on the uncomposed leg, whose hip links are light but not
/// massless, inverts their ill-conditioned inertias and loses digits as the links get lighter
/// (ABA does not). Measured worst relative difference DCA vs ABA over 10 states:
/// 1e-4 kg links 3.2e-10, 1e-6 kg 1.8e-8, 1e-9 kg 3.1e-5 — where the composed model gives
/// ~1e-13 between DCA and ABA. (Before the rework of commit 5cd285a — handle vectors about
/// their own points, leaf Φ in closed form about the centre of mass — DCA returned q̈ ~ -4e12
/// for 1e-9 kg links where ABA gives ~40, with no error.) Bounds ~3x above the measurements.
#[test]
fn dca_on_light_links_loses_digits_gracefully() {
    for (m, bound) in [(1e-4, 1e-9), (1e-6, 5e-8), (1e-9, 1e-4)] {
        let full = Model::from_urdf_str(&leg(&tiny(m)), &LoadOptions::default()).unwrap();
        let mut data = Data::new(&full);
        let mut worst = 0.0f64;
        for seed in 0..10 {
            let s = State::random(&full, seed, 2.0);
            let aba = forward_dynamics_slices(
                &full,
                &mut data,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Aba,
            )
            .unwrap()
            .to_vec();
            let dca = forward_dynamics_slices(
                &full,
                &mut data,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            worst = worst.max(rel_diff(&dca, &aba));
        }
        eprintln!(
            "uncomposed leg, hip links {m:e} kg: DCA vs ABA worst relative difference {worst:e}"
        );
        assert!(worst < bound, "m = {m:e}: DCA vs ABA {worst:e}");
    }
}
