//! Shared helpers of the articula-model integration tests: URDF snippets, the bundled models,
//! and a checker of the structural invariants of a model and its assembly tree.

#![allow(dead_code)]

use articula_model::{JointKind, LoadOptions, Model, ModelError, NodeKind};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// The workspace's `models/` directory.
pub fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

/// Every bundled `models/*.urdf`, sorted by name.
pub fn bundled_models() -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(models_dir())
        .expect("models/ is readable")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "urdf"))
        .collect();
    paths.sort();
    paths
}

/// The text of a bundled model, e.g. `read_model("humanoid")`.
pub fn read_model(name: &str) -> String {
    let path = models_dir().join(format!("{name}.urdf"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Loads with a fixed base.
pub fn load(text: &str) -> Result<Model, ModelError> {
    Model::from_urdf_str(text, &LoadOptions::default())
}

/// Loads with a floating base.
pub fn load_floating(text: &str) -> Result<Model, ModelError> {
    Model::from_urdf_str(text, &LoadOptions::default().with_floating_base(true))
}

/// Loads and expects an error.
pub fn load_err(text: &str) -> ModelError {
    match load(text) {
        Ok(m) => panic!(
            "expected an error, the model loaded with {} bodies",
            m.bodies.len()
        ),
        Err(e) => e,
    }
}

/// `<robot name="test">…</robot>`.
pub fn robot(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<robot name=\"test\">\n{body}</robot>\n")
}

/// A link of the given mass with its centre of mass at its origin and a full, physical
/// rotational inertia (0.01·mass on the diagonal).
pub fn link(name: &str, mass: f64) -> String {
    let i = 0.01 * mass;
    format!(
        "  <link name=\"{name}\">\n    <inertial>\n      <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n      <mass value=\"{mass}\"/>\n      <inertia ixx=\"{i}\" ixy=\"0\" ixz=\"0\" iyy=\"{i}\" iyz=\"0\" izz=\"{i}\"/>\n    </inertial>\n  </link>\n"
    )
}

/// A link with the given mass and diagonal inertia attributes as written (off-diagonal 0).
pub fn link_raw(name: &str, mass: &str, ixx: &str, iyy: &str, izz: &str) -> String {
    format!(
        "  <link name=\"{name}\">\n    <inertial>\n      <mass value=\"{mass}\"/>\n      <inertia ixx=\"{ixx}\" ixy=\"0\" ixz=\"0\" iyy=\"{iyy}\" iyz=\"0\" izz=\"{izz}\"/>\n    </inertial>\n  </link>\n"
    )
}

/// A link without `<inertial>` (massless).
pub fn bare_link(name: &str) -> String {
    format!("  <link name=\"{name}\"/>\n")
}

/// A joint of the given type with axis z and no origin.
pub fn joint(name: &str, kind: &str, parent: &str, child: &str) -> String {
    format!(
        "  <joint name=\"{name}\" type=\"{kind}\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>\n    <axis xyz=\"0 0 1\"/>\n  </joint>\n"
    )
}

/// A joint with extra inner XML (origin, axis, limit, ...), no default axis.
pub fn joint_with(name: &str, kind: &str, parent: &str, child: &str, inner: &str) -> String {
    format!(
        "  <joint name=\"{name}\" type=\"{kind}\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>\n    {inner}\n  </joint>\n"
    )
}

/// A small valid robot: base + pendulum `bob` on revolute joint `swing`.
pub fn pendulum() -> String {
    robot(
        &[
            link("base", 1.0),
            link("bob", 1.0),
            joint("swing", "revolute", "base", "bob"),
        ]
        .concat(),
    )
}

/// The vertex set of every assembly node (bodies `0..n`, the ground as `n`).
fn vertex_sets(model: &Model) -> Vec<BTreeSet<usize>> {
    let n = model.bodies.len();
    let tree = &model.assembly;
    let mut sets: Vec<BTreeSet<usize>> = Vec::with_capacity(tree.nodes.len());
    for node in &tree.nodes {
        let set = match node.kind {
            NodeKind::Cluster { .. } => panic!("`Model::assembly` has no leaf clusters"),
            NodeKind::Ground => BTreeSet::from([n]),
            NodeKind::Body(b) => BTreeSet::from([b]),
            NodeKind::Join {
                parent_side,
                child_side,
                ..
            } => {
                let (a, b) = (&sets[parent_side], &sets[child_side]);
                assert!(a.is_disjoint(b), "the two sides of a join overlap");
                a.union(b).copied().collect()
            }
            NodeKind::Gather { body, first, count } => {
                let mut set = BTreeSet::from([body.unwrap_or(n)]);
                for &c in &tree.gathered[first..first + count] {
                    assert!(set.is_disjoint(&sets[c]), "a gather's children overlap");
                    set.extend(sets[c].iter().copied());
                }
                set
            }
        };
        sets.push(set);
    }
    sets
}

/// Checks the model's bookkeeping and every structural invariant of its assembly tree. Panics
/// with a message naming the broken invariant.
pub fn check_invariants(model: &Model) {
    check_bodies(model);
    check_tree_links(model);
    check_leaves(model);
    check_vertex_sets(model);
}

/// Bodies: parents before children, children lists consistent, coordinates contiguous.
fn check_bodies(model: &Model) {
    // Bodies: parents before children, children lists consistent, coordinates contiguous.
    let (mut nq, mut nv) = (0, 0);
    for (i, b) in model.bodies.iter().enumerate() {
        if let Some(p) = b.parent {
            assert!(p < i, "body {i}'s parent {p} is not stored before it");
            assert!(model.bodies[p].children.contains(&i));
        }
        for &c in &b.children {
            assert_eq!(model.bodies[c].parent, Some(i));
        }
        assert!(!b.joint.is_empty(), "body {i} has no joint");
        assert_eq!(b.q_offset, nq);
        assert_eq!(b.v_offset, nv);
        let (mut bq, mut bv) = (0, 0);
        for p in &b.joint {
            assert_eq!(p.q_offset, nq + bq);
            assert_eq!(p.v_offset, nv + bv);
            bq += p.nq();
            bv += p.nv();
        }
        assert_eq!((b.nq, b.nv), (bq, bv));
        // At least one massless link between consecutive parts (more when massless links are
        // welded together), none for a single joint.
        assert!(b.massless_links.len() >= b.joint.len() - 1);
        assert_eq!(b.massless_links.is_empty(), b.joint.len() == 1);
        assert_eq!(b.links[0].0, b.name, "a body's own link comes first");
        assert!(b.inertia.is_finite(), "body {i} has a non-finite inertia");
        // A point mass (singular spatial inertia) loads as written; a body never lacks mass.
        assert!(
            b.inertia.mass > 0.0,
            "body {i} has no mass: {:?} {:?}",
            b.inertia,
            b.links
        );
        for p in &b.joint {
            assert!(
                p.origin.e.is_finite() && p.origin.r.is_finite(),
                "joint {} has a non-finite origin",
                p.name
            );
            if matches!(
                p.kind,
                JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic
            ) {
                assert!(
                    (p.axis.length() - 1.0).abs() < 1e-9,
                    "joint {} has axis {:?}",
                    p.name,
                    p.axis
                );
            }
        }
        nq += bq;
        nv += bv;
    }
    // Locked joints: their coordinates after every body's, in order.
    for l in &model.locked {
        assert_eq!((l.joint.q_offset, l.joint.v_offset), (nq, nv));
        assert!(!l.links.is_empty());
        nq += l.joint.nq();
        nv += l.joint.nv();
    }
    assert_eq!((model.nq, model.nv), (nq, nv));
    assert_eq!(model.neutral_q().len(), model.nq);
    assert_eq!(model.locked_joints().len(), model.locked.len());
    if model.floating_base {
        assert!(model.ground_links.is_empty());
        assert_eq!(model.ground_mass, 0.0);
    }
}

/// The tree's node count and post-order links.
fn check_tree_links(model: &Model) {
    let n = model.bodies.len();
    let tree = &model.assembly;
    // A full binary tree over n + 1 leaves (without gather nodes); otherwise one node per body
    // and the ground (a leaf or a gather) plus one join per joint no gather absorbs.
    let gathered_joints = tree.gathered.len();
    assert_eq!(
        tree.nodes.len(),
        (n + 1) + (n - gathered_joints),
        "node count"
    );
    assert_eq!(tree.has_gather(), gathered_joints > 0);
    assert_eq!(tree.body_leaf.len(), n);
    assert_eq!(tree.joint_node.len(), n);

    // Post-order: children before parents, root last; parent links and depths consistent.
    let root = tree.root();
    assert_eq!(root, tree.nodes.len() - 1);
    assert_eq!(tree.nodes[root].parent, None, "the root has a parent");
    assert_eq!(tree.nodes[root].depth, 0);
    for (i, node) in tree.nodes.iter().enumerate() {
        if i != root {
            let p = node
                .parent
                .unwrap_or_else(|| panic!("node {i} has no parent"));
            assert!(
                p > i,
                "node {i}'s parent {p} comes before it (not post-order)"
            );
            assert_eq!(node.depth, tree.nodes[p].depth + 1, "depth of node {i}");
        }
        if let NodeKind::Join {
            parent_side,
            child_side,
            ..
        } = node.kind
        {
            assert!(
                parent_side < i && child_side < i,
                "join {i}: child after it"
            );
            assert_ne!(parent_side, child_side);
            assert_eq!(tree.nodes[parent_side].parent, Some(i));
            assert_eq!(tree.nodes[child_side].parent, Some(i));
        }
        if let NodeKind::Gather { .. } = node.kind {
            for &c in tree.gather_children(i) {
                assert!(c < i, "gather {i}: child after it");
                assert_eq!(tree.nodes[c].parent, Some(i));
            }
        }
    }
}

/// Each body in exactly one leaf, the ground in exactly one; each joint principal once.
fn check_leaves(model: &Model) {
    let n = model.bodies.len();
    let tree = &model.assembly;
    let ground = n;
    // Each body in exactly one leaf, the ground in exactly one; each joint principal once.
    let mut leaf_count = vec![0usize; n + 1];
    let mut principal_count = vec![0usize; n];
    for (i, node) in tree.nodes.iter().enumerate() {
        match node.kind {
            NodeKind::Cluster { .. } => panic!("`Model::assembly` has no leaf clusters"),
            NodeKind::Ground => {
                leaf_count[ground] += 1;
                assert_eq!(tree.ground_leaf, i);
            }
            NodeKind::Body(b) => {
                assert!(b < n);
                leaf_count[b] += 1;
                assert_eq!(tree.body_leaf[b], i);
            }
            NodeKind::Join { joint, .. } => {
                assert!(joint < n);
                principal_count[joint] += 1;
                assert_eq!(tree.joint_node[joint], i);
            }
            NodeKind::Gather { body, .. } => {
                leaf_count[body.unwrap_or(ground)] += 1;
                match body {
                    Some(b) => assert_eq!(tree.body_leaf[b], i),
                    None => assert_eq!(tree.ground_leaf, i),
                }
                // Each child's one handle, its joint to the hub, is absorbed here.
                for &c in tree.gather_children(i) {
                    let joint = tree.nodes[c].handles[0];
                    principal_count[joint] += 1;
                    assert_eq!(tree.joint_node[joint], i);
                }
            }
        }
    }
    assert!(
        leaf_count.iter().all(|&c| c == 1),
        "leaf counts {leaf_count:?}"
    );
    assert!(
        principal_count.iter().all(|&c| c == 1),
        "principal joint counts {principal_count:?}"
    );
}

/// Vertex sets; sizes; handles; principal joint sides; connectedness.
fn check_vertex_sets(model: &Model) {
    let n = model.bodies.len();
    let tree = &model.assembly;
    let ground = n;
    let vparent = |v: usize| model.bodies[v].parent.unwrap_or(ground);
    let root = tree.root();
    // Vertex sets; sizes; handles; principal joint sides; connectedness.
    let sets = vertex_sets(model);
    assert_eq!(
        sets[root].len(),
        n + 1,
        "the root holds every body and the ground"
    );
    for (i, node) in tree.nodes.iter().enumerate() {
        let set = &sets[i];
        assert_eq!(node.size, set.len(), "size of node {i}");
        assert!(
            node.handles.windows(2).all(|w| w[0] < w[1]),
            "handles sorted"
        );
        // Connected: exactly one vertex (the top) has its parent outside (or is the ground).
        let tops = set
            .iter()
            .filter(|&&v| v == ground || !set.contains(&vparent(v)))
            .count();
        assert_eq!(tops, 1, "node {i} is not a connected subtree");
        // Handles from the definition: joints (= child bodies) crossing the set's boundary.
        let crossing: Vec<usize> = (0..n)
            .filter(|&j| set.contains(&j) != set.contains(&vparent(j)))
            .collect();
        assert_eq!(node.handles, crossing, "handles of node {i}");
        match node.kind {
            NodeKind::Cluster { .. } => panic!("`Model::assembly` has no leaf clusters"),
            NodeKind::Body(b) => {
                let mut expect: Vec<usize> = model.bodies[b].children.clone();
                expect.push(b);
                expect.sort_unstable();
                assert_eq!(node.handles, expect, "handles of body leaf {b}");
            }
            NodeKind::Ground => {
                let expect: Vec<usize> = (0..n)
                    .filter(|&b| model.bodies[b].parent.is_none())
                    .collect();
                assert_eq!(node.handles, expect, "handles of the ground leaf");
            }
            NodeKind::Join {
                joint,
                parent_side,
                child_side,
            } => {
                let union: BTreeSet<usize> = tree.nodes[parent_side]
                    .handles
                    .iter()
                    .chain(&tree.nodes[child_side].handles)
                    .copied()
                    .filter(|&h| h != joint)
                    .collect();
                assert_eq!(
                    node.handles,
                    union.into_iter().collect::<Vec<_>>(),
                    "join {i}: handles ≠ (handles(A) ∪ handles(B)) ∖ principal"
                );
                assert!(
                    tree.nodes[parent_side].handles.contains(&joint)
                        && tree.nodes[child_side].handles.contains(&joint),
                    "join {i}: the principal joint is not a handle of both sides"
                );
                assert!(
                    sets[parent_side].contains(&vparent(joint)),
                    "join {i}: principal joint's parent body not in parent_side"
                );
                assert!(
                    sets[child_side].contains(&joint),
                    "join {i}: principal joint's child body not in child_side"
                );
            }
            NodeKind::Gather { body, .. } => {
                let hub = body.unwrap_or(ground);
                let children: Vec<usize> = (0..n).filter(|&b| vparent(b) == hub).collect();
                assert!(children.len() > articula_model::GATHER_ABOVE, "gather {i}");
                let kids = tree.gather_children(i);
                assert_eq!(kids.len(), children.len(), "gather {i}: one node per child");
                for (&c, &b) in kids.iter().zip(&children) {
                    assert_eq!(tree.nodes[c].handles, vec![b], "gather {i}: child {b}");
                    assert!(sets[c].contains(&b), "gather {i}: child {b}");
                }
            }
        }
    }
    assert!(tree.nodes[root].handles.is_empty(), "the root has handles");
}

/// Smallest `d` with `2^d >= x`.
pub fn ceil_log2(x: usize) -> usize {
    let mut d = 0;
    while (1usize << d) < x {
        d += 1;
    }
    d
}
