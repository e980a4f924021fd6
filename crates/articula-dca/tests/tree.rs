//! Trees with many children on one link (docs/design.md#assembly-tree): a star (one hub link
//! with K children), a hair head (a head with strands of segments), and a hub of hubs. Their
//! assembly trees gather each hub's children in one node, so every node keeps at most two
//! handles; DCA through those gather nodes agrees with ABA, CRBA and the double-double
//! reference.

use articula_dca::{forward_dynamics, Data, Method, State};
use articula_model::{LoadOptions, Model, NodeKind};
use articula_testkit::{hair_urdf, rel_error, star_urdf, Dd, ReferenceModel};

fn load(urdf: &str, floating_base: bool) -> Model {
    Model::from_urdf_str(
        urdf,
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .expect("the tree loads")
}

/// A hub of 18 links, each with 18 children of its own on revolute joints (343 bodies with a
/// fixed base): gather nodes inside a gather node.
fn hub_of_hubs_urdf() -> String {
    let star = star_urdf(18);
    let mut s = star.trim_end().trim_end_matches("</robot>").to_string();
    for i in 0..18 {
        for k in 0..18 {
            let a = std::f64::consts::TAU * k as f64 / 18.0;
            s += &format!(
                "<link name=\"l{i}_{k}\"><inertial><origin xyz=\"0 0 -0.03\"/><mass value=\"0.05\"/><inertia ixx=\"2e-5\" iyy=\"3e-5\" izz=\"1e-5\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n<joint name=\"j{i}_{k}\" type=\"revolute\"><parent link=\"l{i}\"/><child link=\"l{i}_{k}\"/><origin xyz=\"{} {} -0.1\"/><axis xyz=\"0 {} 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"10\"/></joint>\n",
                0.02 * a.cos(),
                0.02 * a.sin(),
                (k % 3) as f64 - 1.0,
            );
        }
    }
    s + "</robot>\n"
}

/// The trees under test: (label, model).
fn trees() -> Vec<(String, Model)> {
    let mut out = Vec::new();
    for floating_base in [false, true] {
        out.push((
            format!("star200 floating={floating_base}"),
            load(&star_urdf(200), floating_base),
        ));
        out.push((
            format!("hair20x10 floating={floating_base}"),
            load(&hair_urdf(20, 10), floating_base),
        ));
        out.push((
            format!("hub of hubs floating={floating_base}"),
            load(&hub_of_hubs_urdf(), floating_base),
        ));
    }
    out
}

#[test]
fn gather_trees_keep_few_handles() {
    for (label, model) in trees() {
        let tree = &model.assembly;
        let gathers = tree
            .nodes
            .iter()
            .filter(|n| matches!(n.kind, NodeKind::Gather { .. }))
            .count();
        assert!(gathers > 0, "{label}: no gather node");
        assert!(tree.max_handles() <= 2, "{label}: {}", tree.max_handles());
        // Every body is in exactly one leaf or gather node, every joint absorbed once.
        let mut bodies = vec![0usize; model.bodies.len()];
        let mut joints = vec![0usize; model.bodies.len()];
        for (i, n) in tree.nodes.iter().enumerate() {
            match n.kind {
                NodeKind::Body(b) | NodeKind::Gather { body: Some(b), .. } => bodies[b] += 1,
                _ => {}
            }
            match n.kind {
                NodeKind::Join { joint, .. } => joints[joint] += 1,
                NodeKind::Gather { .. } => {
                    for &c in tree.gather_children(i) {
                        assert_eq!(tree.nodes[c].handles.len(), 1, "{label}");
                        assert_eq!(tree.nodes[c].parent, Some(i), "{label}");
                        joints[tree.nodes[c].handles[0]] += 1;
                    }
                }
                _ => {}
            }
        }
        assert!(bodies.iter().all(|&c| c == 1), "{label}: bodies {bodies:?}");
        assert!(joints.iter().all(|&c| c == 1), "{label}: joints {joints:?}");
    }
    // Bounded-degree trees keep today's tree: no gather node in any bundled model.
    for name in articula_testkit::BUNDLED {
        for floating_base in [false, true] {
            let model = articula_testkit::bundled_with(name, floating_base);
            assert!(!model.assembly.has_gather(), "{name}");
        }
    }
}

/// DCA through gather nodes against ABA and CRBA (fixed and floating base, with external forces
/// on odd seeds) and against the double-double reference: 1e-10 relative.
#[test]
fn dca_agrees_on_trees_with_many_children() {
    for (label, model) in trees() {
        let mut data = Data::new(&model);
        let reference = Some(ReferenceModel::new(&model).unwrap());
        for seed in 0..4 {
            let mut s = State::random(&model, seed, 1.0);
            if seed % 2 == 1 {
                s.randomize_forces(seed, 0.1);
            }
            let solve = |data: &mut Data, method| {
                forward_dynamics(&model, data, &s, method).unwrap().to_vec()
            };
            let dca = solve(&mut data, Method::Dca);
            let aba = solve(&mut data, Method::Aba);
            let crba = solve(&mut data, Method::Crba);
            let (e_aba, e_crba) = (rel_error(&dca, &aba), rel_error(&dca, &crba));
            let e_ref = reference.as_ref().map_or(0.0, |r| {
                let exact: Vec<f64> = r
                    .aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
                    .into_iter()
                    .map(Dd::to_f64)
                    .collect();
                rel_error(&dca, &exact)
            });
            eprintln!("{label} seed {seed}: ABA {e_aba:.1e}, CRBA {e_crba:.1e}, ref {e_ref:.1e}");
            assert!(e_aba < 1e-10, "{label} seed {seed}: DCA vs ABA {e_aba:e}");
            assert!(
                e_crba < 1e-10,
                "{label} seed {seed}: DCA vs CRBA {e_crba:e}"
            );
            assert!(
                e_ref < 1e-10,
                "{label} seed {seed}: DCA vs reference {e_ref:e}"
            );
        }
    }
}
