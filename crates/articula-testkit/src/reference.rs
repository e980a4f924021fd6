//! A high-precision reference for forward dynamics: the articulated-body algorithm in **body
//! coordinates** (Featherstone, RBDA Table 7.1, with explicit 6×6 Plücker transforms between
//! parent and child), generic over the scalar type. With [`Dd`](crate::dd::Dd) it carries ~32
//! digits, so its `q̈` is exact as far as any `f64` solver can tell.
//!
//! It shares no arithmetic with `articula-dca` (which works in world coordinates with its own
//! spatial types): it reads only the model's description (joint origins, axes, body inertias)
//! and treats those `f64` numbers as exact. Each URDF joint of a composed joint is its own
//! (massless) body here: the uncomposed model that composition (docs/design.md#composition) must
//! reproduce. Revolute, continuous and prismatic joints, ball joints (three degrees of freedom,
//! `q = [qw, qx, qy, qz]`, `q̇` the angular velocity in the moving frame) and a floating base
//! (six, `q = [x, y, z, qw, qx, qy, qz]`, `q̇ = [w; v]` in the moving frame): a multi-axis joint
//! is one body whose subspace is constant in its moving frame, solved with its `D⁻¹`.

use crate::dd::Real;
use articula_model::{JointKind, Model};
use articula_spatial::{Mat6, SpatialForce};

type V6<T> = [T; 6];
type M6<T> = [[T; 6]; 6];

/// The motion of one reference joint.
#[derive(Clone, Copy, Debug)]
enum RefJoint {
    /// Rotation about the unit axis (joint frame).
    Revolute([f64; 3]),
    /// Translation along the unit axis (joint frame).
    Prismatic([f64; 3]),
    /// Axis `e_k` of a ball joint: the joint is three bodies turning about the moving frame's
    /// x, y and z axes at zero angle after the quaternion's rotation (the first carries it),
    /// whose velocity products are taken with the velocity before the joint, so that the three
    /// act as one spherical joint whose subspace is constant in the moving frame.
    BallAxis(usize),
    /// Six degrees of freedom: position and unit quaternion in the joint frame; motion
    /// subspace the identity.
    Free,
}

impl RefJoint {
    fn nv(self) -> usize {
        match self {
            RefJoint::Revolute(_) | RefJoint::Prismatic(_) | RefJoint::BallAxis(_) => 1,
            RefJoint::Free => 6,
        }
    }
}

/// One joint and the (possibly massless) body it moves.
#[derive(Clone, Debug)]
struct RefBody {
    parent: Option<usize>,
    /// Joint frame in the preceding frame: axes (columns) and origin.
    rot: [[f64; 3]; 3],
    pos: [f64; 3],
    joint: RefJoint,
    /// Spatial inertia in the moving frame `[Ī, h×; h×ᵀ, m 1]`, zero for a massless link.
    inertia: Mat6,
    /// Index of the joint coordinate in `q` and of its velocity in `qd`.
    q_index: usize,
    v_index: usize,
    /// The model body whose frame this moving frame is (for external forces).
    model_body: Option<usize>,
}

/// A model flattened into single-axis joints, ready for [`ReferenceModel::aba`].
#[derive(Clone, Debug)]
pub struct ReferenceModel {
    bodies: Vec<RefBody>,
    nv: usize,
    gravity: [f64; 3],
}

impl ReferenceModel {
    /// Flattens `model` (gravity (0, 0, −9.81), the library's default).
    pub fn new(model: &Model) -> Result<ReferenceModel, String> {
        let mut bodies: Vec<RefBody> = Vec::new();
        // The reference index of each model body's moving frame (its last part).
        let mut last_of: Vec<usize> = vec![usize::MAX; model.bodies.len()];
        for (bi, body) in model.bodies.iter().enumerate() {
            let mut parent = body.parent.map(|p| last_of[p]);
            for (pi, part) in body.joint.iter().enumerate() {
                let axis = part.axis.to_array();
                let joints = match part.kind {
                    JointKind::Revolute | JointKind::Continuous => vec![RefJoint::Revolute(axis)],
                    JointKind::Prismatic => vec![RefJoint::Prismatic(axis)],
                    JointKind::Ball => (0..3).map(RefJoint::BallAxis).collect(),
                    JointKind::Floating => vec![RefJoint::Free],
                    JointKind::Fixed => {
                        return Err(format!("joint {}: Fixed is not supported", part.name))
                    }
                    k => return Err(format!("joint {}: {k:?} is not known", part.name)),
                };
                let (r, p) = part.origin.to_pose();
                let last = pi + 1 == body.joint.len();
                let mut inertia = Mat6::ZERO;
                if last {
                    let i = &body.inertia;
                    let ib = i.ibar.to_cols_array_2d(); // [col][row]
                    let h = i.h;
                    let hx = [[0.0, -h.z, h.y], [h.z, 0.0, -h.x], [-h.y, h.x, 0.0]];
                    for a in 0..3 {
                        for b in 0..3 {
                            inertia.0[a][b] = ib[b][a];
                            inertia.0[a][3 + b] = hx[a][b];
                            inertia.0[3 + a][b] = hx[b][a];
                        }
                        inertia.0[3 + a][3 + a] = i.mass;
                    }
                }
                let rc = r.to_cols_array_2d();
                let count = joints.len();
                for (k, joint) in joints.into_iter().enumerate() {
                    // Only the first of a ball's three bodies has the joint's origin, only the
                    // last the body's inertia.
                    let (first, end) = (k == 0, k + 1 == count);
                    bodies.push(RefBody {
                        parent,
                        rot: if first {
                            [
                                [rc[0][0], rc[1][0], rc[2][0]],
                                [rc[0][1], rc[1][1], rc[2][1]],
                                [rc[0][2], rc[1][2], rc[2][2]],
                            ]
                        } else {
                            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                        },
                        pos: if first { p.to_array() } else { [0.0; 3] },
                        joint,
                        inertia: if end { inertia } else { Mat6::ZERO },
                        q_index: part.q_offset,
                        v_index: part.v_offset + k,
                        model_body: (last && end).then_some(bi),
                    });
                    parent = Some(bodies.len() - 1);
                }
            }
            last_of[bi] = bodies.len() - 1;
        }
        Ok(ReferenceModel {
            bodies,
            nv: model.nv,
            gravity: [0.0, 0.0, -9.81],
        })
    }

    /// Joint accelerations at `q`, `q̇`, `τ` with the external forces `f_ext` (world wrenches
    /// about the world origin, one per model body; empty for none).
    pub fn aba<T: Real>(
        &self,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Vec<T> {
        let mut w = AbaWork::<T>::new(self.bodies.len());
        self.aba_outward(&mut w, q, qd, f_ext);
        self.aba_inward(&mut w, tau);
        self.aba_accelerations(&w)
    }

    /// The first pass of [`Self::aba`].
    fn aba_outward<T: Real>(
        &self,
        w: &mut AbaWork<T>,
        q: &[f64],
        qd: &[f64],
        f_ext: &[SpatialForce],
    ) {
        let n = self.bodies.len();
        let z = T::zero();
        let f = T::from_f64;
        let AbaWork {
            x,
            v,
            c,
            vbase,
            s,
            ia,
            pa,
            world,
            ..
        } = w;
        let eye = identity3::<T>();
        // Pass 1, root to leaves: X_i (parent → child), v_i, c_i, Iᴬ_i = I_i,
        // pᴬ_i = v_i ×* I_i v_i − f_ext,i.
        for i in 0..n {
            let b = &self.bodies[i];
            let nv = b.joint.nv();
            let qd_i: Vec<T> = qd[b.v_index..b.v_index + nv]
                .iter()
                .map(|&e| f(e))
                .collect();
            // Pose of the moving frame in the parent frame: R = R_origin R_q,
            // p = p_origin + R_origin p_q.
            let r0 = b.rot.map(|row| row.map(f));
            let p0 = b.pos.map(f);
            let (rq, pq) = joint_pose::<T>(b.joint, &q[b.q_index..]);
            let rot = mat3_mul(&r0, &rq);
            let pos = add3(p0, mat3_vec(&r0, pq));
            x[i] = plucker(&rot, pos);
            s[i] = subspace::<T>(b.joint);
            let mut vj = [z; 6];
            for (col, &rate) in s[i].iter().zip(&qd_i) {
                vj = add6(vj, col.map(|e| e * rate));
            }
            let vp = match b.parent {
                Some(p) => mat6_vec(&x[i], &v[p]),
                None => [z; 6],
            };
            v[i] = add6(vp, vj);
            vbase[i] = match (b.joint, b.parent) {
                (RefJoint::BallAxis(1 | 2), Some(p)) => mat6_vec(&x[i], &vbase[p]),
                _ => vp,
            };
            c[i] = crm(&vbase[i], &vj);
            ia[i] = b.inertia.0.map(|row| row.map(f));
            let iv = mat6_vec(&ia[i], &v[i]);
            pa[i] = crf(&v[i], &iv);
            let (pr, pp) = match b.parent {
                Some(p) => world[p],
                None => (eye, [z; 3]),
            };
            world[i] = (mat3_mul(&pr, &rot), add3(pp, mat3_vec(&pr, pos)));
            if let Some(fe) = b.model_body.and_then(|mb| f_ext.get(mb)) {
                // Local = X*_{i←0} f: n' = Rᵀ (n − p × f), f' = Rᵀ f.
                let (rw, pw) = &world[i];
                let nw = [f(fe.n.x), f(fe.n.y), f(fe.n.z)];
                let fw = [f(fe.f.x), f(fe.f.y), f(fe.f.z)];
                let rt = transpose3(rw);
                let nl = mat3_vec(&rt, sub3(nw, cross3(*pw, fw)));
                let fl = mat3_vec(&rt, fw);
                for k in 0..3 {
                    pa[i][k] -= nl[k];
                    pa[i][3 + k] -= fl[k];
                }
            }
        }
    }

    /// The second pass of [`Self::aba`].
    fn aba_inward<T: Real>(&self, w: &mut AbaWork<T>, tau: &[f64]) {
        let n = self.bodies.len();
        let z = T::zero();
        let f = T::from_f64;
        let AbaWork {
            x,
            c,
            s,
            ia,
            pa,
            uvec,
            dinv,
            uu,
            ..
        } = w;
        // Pass 2, leaves to root: U = Iᴬ S, D = SᵀU, u = τ − Sᵀpᴬ, Iᵃ = Iᴬ − U D⁻¹ Uᵀ,
        // pᵃ = pᴬ + Iᵃ c + U D⁻¹ u; Iᴬ_parent += Xᵀ Iᵃ X, pᴬ_parent += Xᵀ pᵃ.
        for i in (0..n).rev() {
            let b = &self.bodies[i];
            let u: Vec<V6<T>> = s[i].iter().map(|col| mat6_vec(&ia[i], col)).collect();
            let d: Vec<Vec<T>> = s[i]
                .iter()
                .map(|si| u.iter().map(|uj| dot6(si, uj)).collect())
                .collect();
            let d_inv = invert(d);
            let small_u: Vec<T> = s[i]
                .iter()
                .enumerate()
                .map(|(k, col)| f(tau[b.v_index + k]) - dot6(col, &pa[i]))
                .collect();
            // U D⁻¹ (6 × nv) and D⁻¹ u.
            let udi: Vec<V6<T>> = (0..u.len())
                .map(|k| {
                    let mut col = [z; 6];
                    for (l, ul) in u.iter().enumerate() {
                        col = add6(col, ul.map(|e| e * d_inv[l][k]));
                    }
                    col
                })
                .collect();
            let du: Vec<T> = d_inv.iter().map(|row| dotn(row, &small_u)).collect();
            if let Some(p) = b.parent {
                let mut iaa = ia[i];
                for r in 0..6 {
                    for cc in 0..6 {
                        for (ul, udl) in u.iter().zip(&udi) {
                            iaa[r][cc] -= udl[r] * ul[cc];
                        }
                    }
                }
                let mut pav = add6(pa[i], mat6_vec(&iaa, &c[i]));
                for (ul, &dl) in u.iter().zip(&du) {
                    pav = add6(pav, ul.map(|e| e * dl));
                }
                let xt = transpose6(&x[i]);
                let add = mat6_mul(&mat6_mul(&xt, &iaa), &x[i]);
                for r in 0..6 {
                    for cc in 0..6 {
                        ia[p][r][cc] += add[r][cc];
                    }
                }
                pa[p] = add6(pa[p], mat6_vec(&xt, &pav));
            }
            uvec[i] = u;
            dinv[i] = d_inv;
            uu[i] = small_u;
        }
    }

    /// The third pass of [`Self::aba`]: the joint accelerations.
    fn aba_accelerations<T: Real>(&self, w: &AbaWork<T>) -> Vec<T> {
        let n = self.bodies.len();
        let z = T::zero();
        let f = T::from_f64;
        let AbaWork {
            x,
            c,
            s,
            uvec,
            dinv,
            uu,
            ..
        } = w;
        // Pass 3, root to leaves: a' = X a_parent + c, q̈ = D⁻¹(u − Uᵀa'), a = a' + S q̈,
        // with a_0 = −a_g.
        let a0 = [
            z,
            z,
            z,
            f(-self.gravity[0]),
            f(-self.gravity[1]),
            f(-self.gravity[2]),
        ];
        let mut a: Vec<V6<T>> = vec![[z; 6]; n];
        let mut qdd = vec![z; self.nv];
        for i in 0..n {
            let b = &self.bodies[i];
            let ap = match b.parent {
                Some(p) => mat6_vec(&x[i], &a[p]),
                None => mat6_vec(&x[i], &a0),
            };
            let ap = add6(ap, c[i]);
            let rhs: Vec<T> = uu[i]
                .iter()
                .zip(&uvec[i])
                .map(|(&uk, col)| uk - dot6(col, &ap))
                .collect();
            a[i] = ap;
            for (k, row) in dinv[i].iter().enumerate() {
                let acc = dotn(row, &rhs);
                qdd[b.v_index + k] = acc;
                a[i] = add6(a[i], s[i][k].map(|e| e * acc));
            }
        }
        qdd
    }
}

/// The per-body quantities of [`ReferenceModel::aba`]'s three passes, in each body's frame.
struct AbaWork<T> {
    /// Parent → child transform.
    x: Vec<M6<T>>,
    /// Velocity.
    v: Vec<V6<T>>,
    /// Velocity-product acceleration.
    c: Vec<V6<T>>,
    /// The velocity before each body's joint (for a ball's second and third axes: before
    /// the ball).
    vbase: Vec<V6<T>>,
    /// Motion subspace columns.
    s: Vec<Vec<V6<T>>>,
    /// Articulated inertia.
    ia: Vec<M6<T>>,
    /// Articulated bias force.
    pa: Vec<V6<T>>,
    /// World pose of each moving frame (for the external forces).
    world: Vec<([[T; 3]; 3], [T; 3])>,
    /// U = Iᴬ S.
    uvec: Vec<Vec<V6<T>>>,
    /// D⁻¹.
    dinv: Vec<Vec<Vec<T>>>,
    /// u = τ − Sᵀpᴬ.
    uu: Vec<Vec<T>>,
}

impl<T: Real> AbaWork<T> {
    fn new(n: usize) -> AbaWork<T> {
        let z = T::zero();
        AbaWork {
            x: vec![[[z; 6]; 6]; n],
            v: vec![[z; 6]; n],
            c: vec![[z; 6]; n],
            vbase: vec![[z; 6]; n],
            s: vec![Vec::new(); n],
            ia: vec![[[z; 6]; 6]; n],
            pa: vec![[z; 6]; n],
            world: vec![([[z; 3]; 3], [z; 3]); n],
            uvec: vec![Vec::new(); n],
            dinv: vec![Vec::new(); n],
            uu: vec![Vec::new(); n],
        }
    }
}

/// The joint's own motion (moving frame in the joint frame) at its coordinates `q`.
fn joint_pose<T: Real>(joint: RefJoint, q: &[f64]) -> ([[T; 3]; 3], [T; 3]) {
    let f = T::from_f64;
    let z = T::zero();
    match joint {
        RefJoint::Revolute(axis) => (rodrigues(axis.map(f), f(q[0])), [z; 3]),
        RefJoint::Prismatic(axis) => (identity3(), axis.map(|a| f(a) * f(q[0]))),
        RefJoint::BallAxis(0) => (quat_matrix([f(q[0]), f(q[1]), f(q[2]), f(q[3])]), [z; 3]),
        RefJoint::BallAxis(_) => (identity3(), [z; 3]),
        RefJoint::Free => (
            quat_matrix([f(q[3]), f(q[4]), f(q[5]), f(q[6])]),
            [f(q[0]), f(q[1]), f(q[2])],
        ),
    }
}

/// The motion subspace's columns in the moving frame.
fn subspace<T: Real>(joint: RefJoint) -> Vec<V6<T>> {
    let f = T::from_f64;
    let z = T::zero();
    match joint {
        RefJoint::Revolute(a) => vec![[f(a[0]), f(a[1]), f(a[2]), z, z, z]],
        RefJoint::Prismatic(a) => vec![[z, z, z, f(a[0]), f(a[1]), f(a[2])]],
        RefJoint::BallAxis(k) => {
            let mut col = [z; 6];
            col[k] = f(1.0);
            vec![col]
        }
        RefJoint::Free => (0..6)
            .map(|k| {
                let mut col = [z; 6];
                col[k] = f(1.0);
                col
            })
            .collect(),
    }
}

/// The rotation of the quaternion `[w, x, y, z]`, divided by its squared norm (so a quaternion
/// normalised in `f64` is normalised exactly here).
fn quat_matrix<T: Real>([w, x, y, z]: [T; 4]) -> [[T; 3]; 3] {
    let n2 = w * w + x * x + y * y + z * z;
    let two = T::from_f64(2.0) / n2;
    let one = T::from_f64(1.0);
    [
        [
            one - two * (y * y + z * z),
            two * (x * y - w * z),
            two * (x * z + w * y),
        ],
        [
            two * (x * y + w * z),
            one - two * (x * x + z * z),
            two * (y * z - w * x),
        ],
        [
            two * (x * z - w * y),
            two * (y * z + w * x),
            one - two * (x * x + y * y),
        ],
    ]
}

fn identity3<T: Real>() -> [[T; 3]; 3] {
    let mut m = [[T::zero(); 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = T::from_f64(1.0);
    }
    m
}

/// The inverse of a small symmetric positive definite matrix by Gauss–Jordan elimination
/// (pivots on the diagonal, which positive definiteness keeps non-zero).
fn invert<T: Real>(mut d: Vec<Vec<T>>) -> Vec<Vec<T>> {
    let n = d.len();
    let mut inv: Vec<Vec<T>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| T::from_f64(if i == j { 1.0 } else { 0.0 }))
                .collect()
        })
        .collect();
    for k in 0..n {
        let pivot = d[k][k];
        for j in 0..n {
            d[k][j] = d[k][j] / pivot;
            inv[k][j] = inv[k][j] / pivot;
        }
        for r in 0..n {
            if r == k {
                continue;
            }
            let factor = d[r][k];
            for j in 0..n {
                let (dk, ik) = (d[k][j], inv[k][j]);
                d[r][j] -= factor * dk;
                inv[r][j] -= factor * ik;
            }
        }
    }
    inv
}

fn dotn<T: Real>(a: &[T], b: &[T]) -> T {
    let mut s = T::zero();
    for (&x, &y) in a.iter().zip(b) {
        s += x * y;
    }
    s
}

/// Rotation by `q` about the unit axis `a`: `cos q 1 + sin q [a]× + (1 − cos q) a aᵀ`.
fn rodrigues<T: Real>(a: [T; 3], q: T) -> [[T; 3]; 3] {
    let (s, c) = q.sin_cos();
    let one_c = T::from_f64(1.0) - c;
    let mut m = [[T::zero(); 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = one_c * a[i] * a[j];
        }
        m[i][i] += c;
    }
    m[0][1] -= s * a[2];
    m[0][2] += s * a[1];
    m[1][0] += s * a[2];
    m[1][2] -= s * a[0];
    m[2][0] -= s * a[1];
    m[2][1] += s * a[0];
    m
}

/// Motion transform from parent to child coordinates for a child frame with axes `r` and
/// origin `p` in the parent: `[Rᵀ, 0; −Rᵀ[p]×, Rᵀ]`.
fn plucker<T: Real>(r: &[[T; 3]; 3], p: [T; 3]) -> M6<T> {
    let z = T::zero();
    let rt = transpose3(r);
    let px = [[z, -p[2], p[1]], [p[2], z, -p[0]], [-p[1], p[0], z]];
    let lower = mat3_mul(&rt, &px);
    let mut x = [[z; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            x[i][j] = rt[i][j];
            x[3 + i][3 + j] = rt[i][j];
            x[3 + i][j] = -lower[i][j];
        }
    }
    x
}

fn cross3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn add3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn transpose3<T: Real>(m: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let mut t = *m;
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = m[j][i];
        }
    }
    t
}

fn mat3_mul<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let mut m = [[T::zero(); 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                m[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    m
}

fn mat3_vec<T: Real>(a: &[[T; 3]; 3], v: [T; 3]) -> [T; 3] {
    let mut r = [T::zero(); 3];
    for i in 0..3 {
        for k in 0..3 {
            r[i] += a[i][k] * v[k];
        }
    }
    r
}

fn add6<T: Real>(a: V6<T>, b: V6<T>) -> V6<T> {
    let mut r = a;
    for k in 0..6 {
        r[k] += b[k];
    }
    r
}

fn dot6<T: Real>(a: &V6<T>, b: &V6<T>) -> T {
    let mut s = T::zero();
    for k in 0..6 {
        s += a[k] * b[k];
    }
    s
}

fn mat6_vec<T: Real>(m: &M6<T>, v: &V6<T>) -> V6<T> {
    let mut r = [T::zero(); 6];
    for i in 0..6 {
        r[i] = dot6(&m[i], v);
    }
    r
}

fn mat6_mul<T: Real>(a: &M6<T>, b: &M6<T>) -> M6<T> {
    let mut m = [[T::zero(); 6]; 6];
    for i in 0..6 {
        for k in 0..6 {
            let aik = a[i][k];
            if aik.to_f64() == 0.0 {
                continue; // exact zero: the Plücker blocks are a quarter zeros
            }
            for j in 0..6 {
                m[i][j] += aik * b[k][j];
            }
        }
    }
    m
}

fn transpose6<T: Real>(m: &M6<T>) -> M6<T> {
    let mut t = *m;
    for i in 0..6 {
        for j in 0..6 {
            t[i][j] = m[j][i];
        }
    }
    t
}

/// Motion cross product `v × m` (`crm(v) m`).
fn crm<T: Real>(v: &V6<T>, m: &V6<T>) -> V6<T> {
    let (w, vl) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
    let (mw, mv) = ([m[0], m[1], m[2]], [m[3], m[4], m[5]]);
    let a = cross3(w, mw);
    let b = add3(cross3(w, mv), cross3(vl, mw));
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// Force cross product `v ×* f` (`crf(v) f`).
fn crf<T: Real>(v: &V6<T>, f: &V6<T>) -> V6<T> {
    let (w, vl) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
    let (n, fl) = ([f[0], f[1], f[2]], [f[3], f[4], f[5]]);
    let a = add3(cross3(w, n), cross3(vl, fl));
    let b = cross3(w, fl);
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// Relative error `max |a − b| / max |b|`: how far `a` is from the reference `b`, in units
/// of `b`'s largest entry (the measure of docs/stability.md).
pub fn rel_error(a: &[f64], b: &[f64]) -> f64 {
    let num = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    let den = b.iter().map(|x| x.abs()).fold(0.0, f64::max);
    num / den
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dd::Dd;
    use crate::fixtures::bundled_with;
    use articula_dca::{forward_dynamics_slices, Data, Method, State};

    /// The reference agrees with the library's ABA (an independent formulation) in f64 and in
    /// double-double, with torques and external forces, on a chain and on the humanoid
    /// (composed 3-DOF joints become massless intermediate bodies here), fixed and floating.
    #[test]
    fn reference_agrees_with_library_aba() {
        let names = ["chain10", "humanoid", "plant"];
        for (name, floating) in names.iter().flat_map(|n| [(*n, false), (*n, true)]) {
            let m = bundled_with(name, floating);
            let r = ReferenceModel::new(&m).unwrap();
            let mut data = Data::new(&m);
            for seed in 0..3 {
                let mut st = State::random(&m, seed, 2.0);
                st.randomize_forces(seed, 0.5);
                let lib = forward_dynamics_slices(
                    &m,
                    &mut data,
                    &st.q,
                    &st.qd,
                    &st.tau,
                    &st.f_ext,
                    Method::Aba,
                )
                .unwrap()
                .to_vec();
                let ours: Vec<f64> = r.aba::<f64>(&st.q, &st.qd, &st.tau, &st.f_ext);
                assert!(
                    rel_error(&ours, &lib) < 1e-10,
                    "{name} f64: {}",
                    rel_error(&ours, &lib)
                );
                let hp: Vec<f64> = r
                    .aba::<Dd>(&st.q, &st.qd, &st.tau, &st.f_ext)
                    .iter()
                    .map(|x| x.to_f64())
                    .collect();
                assert!(
                    rel_error(&hp, &lib) < 1e-10,
                    "{name} dd: {}",
                    rel_error(&hp, &lib)
                );
            }
        }
    }
}
