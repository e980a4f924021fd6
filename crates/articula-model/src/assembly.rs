//! The binary assembly tree of the divide-and-conquer algorithm (docs/design.md#assembly-tree).
//!
//! Vertices are the model's bodies plus the ground; edges are the bodies' joints (joint `i`
//! is body `i`'s joint to its parent). Each internal node joins two subassemblies at one joint,
//! its *principal joint*; its *handles* are the joints by which it connects to the rest. The tree
//! is built by cutting, recursively, the joint that best balances the two sides (ties go to the
//! cut whose sides have fewer handles), so a chain of n links gets depth ⌈log2(n + 1)⌉ and two
//! handles per node at most.

use crate::Model;

/// What a node of the assembly tree is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// The ground (the world, or a fixed base's welded root): zero inverse inertia.
    Ground,
    /// A rigid body of the model.
    Body(usize),
    /// Two subassemblies joined at the joint of body `joint`.
    Join {
        /// The principal joint: the joint of this body (its parent is on the `parent_side`).
        joint: usize,
        /// The node holding the principal joint's parent body ("A" in docs/design.md#assembly-tree).
        parent_side: usize,
        /// The node holding the principal joint's child body ("B" in docs/design.md#assembly-tree).
        child_side: usize,
    },
}

/// A node of the assembly tree.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AssemblyNode {
    /// Leaf or join.
    pub kind: NodeKind,
    /// The joints connecting this subassembly to the rest, sorted (joint `i` = body `i`'s joint).
    pub handles: Vec<usize>,
    /// The parent node, `None` at the root.
    pub parent: Option<usize>,
    /// Distance from the root (the root has depth 0).
    pub depth: usize,
    /// Number of bodies (the ground included) in the subassembly.
    pub size: usize,
}

/// The assembly tree, nodes in post-order: children before parents, the root last. A bottom-up
/// pass is a forward loop over `nodes`; a top-down pass is a backward loop.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AssemblyTree {
    /// The nodes in post-order.
    pub nodes: Vec<AssemblyNode>,
    /// For each body, its leaf node.
    pub body_leaf: Vec<usize>,
    /// For each joint (= body), the node whose principal joint it is.
    pub joint_node: Vec<usize>,
    /// The ground's leaf node.
    pub ground_leaf: usize,
}

impl AssemblyTree {
    /// The root node (the last one).
    pub fn root(&self) -> usize {
        self.nodes.len() - 1
    }

    /// Height of the tree: the largest node depth.
    pub fn depth(&self) -> usize {
        self.nodes.iter().map(|n| n.depth).max().unwrap_or(0)
    }

    /// The largest handle count of any node.
    pub fn max_handles(&self) -> usize {
        self.nodes
            .iter()
            .map(|n| n.handles.len())
            .max()
            .unwrap_or(0)
    }

    /// Builds the tree by balanced cuts.
    pub fn build(model: &Model) -> AssemblyTree {
        let n = model.bodies.len();
        let ground = n;
        // Vertex parent (ground for the root bodies); the ground has none.
        let vparent = |v: usize| -> Option<usize> {
            if v == ground {
                None
            } else {
                Some(model.bodies[v].parent.unwrap_or(ground))
            }
        };

        struct Tmp {
            kind: NodeKind,
            handles: Vec<usize>,
            size: usize,
            children: Option<(usize, usize)>,
        }
        let mut tmp: Vec<Tmp> = Vec::with_capacity(2 * n + 1);
        // Scratch indexed by vertex: membership stamp, subtree size, handles inside subtree.
        let mut stamp = vec![usize::MAX; n + 1];
        let mut sub = vec![0usize; n + 1];
        let mut hsub = vec![0usize; n + 1];
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n + 1];
        for v in 0..n {
            children[vparent(v).unwrap()].push(v);
        }

        // Components keep their vertices in this order: the ground first, then the bodies
        // (stored parents first), so a forward loop visits parents before children.
        let mut all: Vec<usize> = Vec::with_capacity(n + 1);
        all.push(ground);
        all.extend(0..n);
        // Work items: (component vertices sorted by key, index of its Tmp node).
        tmp.push(Tmp {
            kind: NodeKind::Ground,
            handles: Vec::new(),
            size: n + 1,
            children: None,
        });
        let mut work = vec![(all, 0usize)];
        while let Some((comp, id)) = work.pop() {
            for &v in &comp {
                stamp[v] = id;
            }
            // Handles: the top vertex's own joint if its parent is outside, plus joints to
            // children outside.
            let mut handles = Vec::new();
            for &v in &comp {
                hsub[v] = 0;
                sub[v] = 1;
                if let Some(p) = vparent(v) {
                    if stamp[p] != id {
                        handles.push(v);
                    }
                }
                for &ch in &children[v] {
                    if stamp[ch] != id {
                        handles.push(ch);
                        hsub[v] += 1;
                    }
                }
            }
            handles.sort_unstable();
            tmp[id].handles = handles;
            tmp[id].size = comp.len();
            if comp.len() == 1 {
                let v = comp[0];
                tmp[id].kind = if v == ground {
                    NodeKind::Ground
                } else {
                    NodeKind::Body(v)
                };
                continue;
            }
            // Subtree sizes within the component, children before parents.
            for &v in comp.iter().rev() {
                if let Some(p) = vparent(v) {
                    if stamp[p] == id {
                        sub[p] += sub[v];
                        hsub[p] += hsub[v];
                    }
                }
            }
            let m = comp.len();
            let total_h = tmp[id].handles.len();
            let mut best: Option<((usize, usize), usize)> = None;
            for &v in &comp {
                let Some(p) = vparent(v) else { continue };
                if stamp[p] != id {
                    continue;
                }
                let balance = sub[v].max(m - sub[v]);
                let h_child = hsub[v] + 1;
                let h_parent = total_h - hsub[v] + 1;
                let score = (balance, h_child.max(h_parent));
                if best.is_none_or(|(s, _)| score < s) {
                    best = Some((score, v));
                }
            }
            let (_, mut cut) =
                best.expect("a connected component of two or more vertices has an inner joint");
            // A floating base's 6-DOF joint is the root cut: the free body is then one subtree
            // of the root, so an adaptive hybrid body can keep it moving as one rigid body
            // (articula-adaptive) while every internal joint is frozen.
            if id == 0 && model.floating_base && n > 0 {
                cut = 0;
            }
            // Split: the child side is the subtree of `cut` inside the component.
            let mut in_child = Vec::with_capacity(sub[cut]);
            let mut parent_side = Vec::with_capacity(m - sub[cut]);
            // Mark the child side by walking the component in order (parents first).
            let child_mark = usize::MAX - 1;
            for &v in &comp {
                let inside = v == cut || vparent(v).is_some_and(|p| stamp[p] == child_mark);
                if inside {
                    in_child.push(v);
                } else {
                    parent_side.push(v);
                }
                if inside {
                    stamp[v] = child_mark;
                }
            }
            for &v in &comp {
                stamp[v] = id;
            }
            let a = tmp.len();
            let b = a + 1;
            for _ in 0..2 {
                tmp.push(Tmp {
                    kind: NodeKind::Ground,
                    handles: Vec::new(),
                    size: 0,
                    children: None,
                });
            }
            tmp[id].kind = NodeKind::Join {
                joint: cut,
                parent_side: a,
                child_side: b,
            };
            tmp[id].children = Some((a, b));
            work.push((parent_side, a));
            work.push((in_child, b));
        }

        // Renumber in post-order (iterative), fixing child references and depths.
        let mut new_index = vec![usize::MAX; tmp.len()];
        let mut post = Vec::with_capacity(tmp.len());
        let mut stack = vec![(0usize, false)];
        while let Some((t, expanded)) = stack.pop() {
            match (tmp[t].children, expanded) {
                (Some((a, b)), false) => {
                    stack.push((t, true));
                    stack.push((b, false));
                    stack.push((a, false));
                }
                _ => {
                    new_index[t] = post.len();
                    post.push(t);
                }
            }
        }
        let mut tree = AssemblyTree {
            nodes: Vec::with_capacity(post.len()),
            body_leaf: vec![0; n],
            joint_node: vec![0; n],
            ground_leaf: 0,
        };
        for &t in &post {
            let kind = match tmp[t].kind {
                NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } => NodeKind::Join {
                    joint,
                    parent_side: new_index[parent_side],
                    child_side: new_index[child_side],
                },
                k => k,
            };
            tree.nodes.push(AssemblyNode {
                kind,
                handles: std::mem::take(&mut tmp[t].handles),
                parent: None,
                depth: 0,
                size: tmp[t].size,
            });
        }
        for i in (0..tree.nodes.len()).rev() {
            let depth = tree.nodes[i].depth;
            match tree.nodes[i].kind {
                NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } => {
                    tree.joint_node[joint] = i;
                    for c in [parent_side, child_side] {
                        tree.nodes[c].parent = Some(i);
                        tree.nodes[c].depth = depth + 1;
                    }
                }
                NodeKind::Body(b) => tree.body_leaf[b] = i,
                NodeKind::Ground => tree.ground_leaf = i,
            }
        }
        tree
    }

    /// The tree as an indented outline, one node a line, for people and snapshot tests.
    pub fn outline(&self, model: &Model) -> String {
        let mut out = String::new();
        let mut stack = vec![(self.root(), 0usize)];
        while let Some((i, indent)) = stack.pop() {
            let node = &self.nodes[i];
            let handles: Vec<String> = node
                .handles
                .iter()
                .map(|&j| model.bodies[j].joint_name())
                .collect();
            let line = match node.kind {
                NodeKind::Ground => "ground".to_string(),
                NodeKind::Body(b) => format!("body {}", model.bodies[b].name),
                NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } => {
                    stack.push((child_side, indent + 1));
                    stack.push((parent_side, indent + 1));
                    format!("join {}", model.bodies[joint].joint_name())
                }
            };
            out.push_str(&"  ".repeat(indent));
            out.push_str(&line);
            if !handles.is_empty() {
                out.push_str(&format!("  [handles: {}]", handles.join(", ")));
            }
            out.push('\n');
        }
        out
    }
}

/// Where each node's per-handle data lives in flat arrays, and how a join's handles come from
/// its two children — the bookkeeping every pass over the tree shares.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct HandleLayout {
    /// Per node: offset of its handles in flat per-handle arrays.
    pub hoff: Vec<usize>,
    /// Per node: offset of its `nh × nh` handle-pair blocks (row-major) in flat arrays.
    pub boff: Vec<usize>,
    /// Total number of handles (all nodes).
    pub handles: usize,
    /// Total number of handle-pair blocks (all nodes).
    pub blocks: usize,
    /// Per join node: index of the principal joint among the parent side's handles (0 otherwise).
    pub ja: Vec<usize>,
    /// Per join node: index of the principal joint among the child side's handles (0 otherwise).
    pub jb: Vec<usize>,
    /// Per handle of a join node (flat, `hoff`): `(true, i)` when it is handle `i` of the parent
    /// side, `(false, i)` when it is handle `i` of the child side.
    pub from: Vec<(bool, usize)>,
}

impl AssemblyTree {
    /// The flat-array layout of the tree's handles.
    pub fn handle_layout(&self) -> HandleLayout {
        let nn = self.nodes.len();
        let mut l = HandleLayout {
            hoff: Vec::with_capacity(nn),
            boff: Vec::with_capacity(nn),
            ja: vec![0; nn],
            jb: vec![0; nn],
            ..HandleLayout::default()
        };
        for node in &self.nodes {
            l.hoff.push(l.handles);
            l.boff.push(l.blocks);
            l.handles += node.handles.len();
            l.blocks += node.handles.len() * node.handles.len();
        }
        l.from = vec![(true, 0); l.handles];
        for (i, node) in self.nodes.iter().enumerate() {
            if let NodeKind::Join {
                joint,
                parent_side,
                child_side,
            } = node.kind
            {
                let (ha, hb) = (
                    &self.nodes[parent_side].handles,
                    &self.nodes[child_side].handles,
                );
                let pos = |hs: &[usize], j: usize| hs.iter().position(|&x| x == j);
                l.ja[i] = pos(ha, joint).expect("principal joint is a handle of A");
                l.jb[i] = pos(hb, joint).expect("principal joint is a handle of B");
                for (k, &hc) in node.handles.iter().enumerate() {
                    l.from[l.hoff[i] + k] = match pos(ha, hc) {
                        Some(p) => (true, p),
                        None => (
                            false,
                            pos(hb, hc).expect("handle of C is a handle of A or B"),
                        ),
                    };
                }
            }
        }
        l
    }
}
