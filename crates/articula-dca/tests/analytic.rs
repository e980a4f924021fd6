//! Closed-form checks: every method's q̈ against equations of motion written by hand in this
//! file (single and double pendulum, a tilted slider, a free rigid body).

use articula_dca::SplitMix64;
use articula_dca::{forward_dynamics_slices, forward_kinematics, Data, Method, State};
use articula_model::{LoadOptions, Model};
use glam::{DMat3, DQuat, DVec3};

const METHODS: [Method; 3] = [Method::Dca, Method::Aba, Method::Crba];

/// `max |a − e| / max(max |e|, 1)`.
fn rel_err(a: &[f64], e: &[f64]) -> f64 {
    assert_eq!(a.len(), e.len());
    let scale = e.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(e)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

fn qdd(model: &Model, data: &mut Data, s: &State, method: Method) -> Vec<f64> {
    forward_dynamics_slices(model, data, &s.q, &s.qd, &s.tau, &s.f_ext, method)
        .unwrap()
        .to_vec()
}

/// Solid-sphere moment of inertia `2/5 m r²`.
fn sphere(m: f64, r: f64) -> f64 {
    0.4 * m * r * r
}

fn inertial(m: f64, com: DVec3, i: [f64; 6]) -> String {
    format!(
        r#"<inertial><origin xyz="{} {} {}" rpy="0 0 0"/><mass value="{m}"/>
        <inertia ixx="{}" iyy="{}" izz="{}" ixy="{}" ixz="{}" iyz="{}"/></inertial>"#,
        com.x, com.y, com.z, i[0], i[1], i[2], i[3], i[4], i[5]
    )
}

// ---------------------------------------------------------------------------------------------
// (a) Single pendulum

const PEND_M: f64 = 1.3;
const PEND_L: f64 = 0.7;
const BOB_R: f64 = 0.01;

fn pendulum() -> Model {
    let i = sphere(PEND_M, BOB_R);
    // The joint origin is offset from the world origin: it must not change anything.
    let urdf = format!(
        r#"<robot name="pendulum">
          <link name="base"/>
          <link name="bob">{}</link>
          <joint name="swing" type="revolute">
            <origin xyz="0.3 -0.2 1.0" rpy="0 0 0"/>
            <parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>
            <limit lower="-3" upper="3" effort="10" velocity="10"/>
          </joint></robot>"#,
        inertial(
            PEND_M,
            DVec3::new(0.0, 0.0, -PEND_L),
            [i, i, i, 0.0, 0.0, 0.0]
        )
    );
    Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap()
}

/// The bob sits at `R_y(q) (0, 0, −l) = (−l sin q, 0, −l cos q)`; with gravity `g`, its potential
/// is `V = −m g·p = m l (g_x sin q + g_z cos q)`, so
/// `(m l² + I_yy) q̈ = τ − dV/dq = τ + m l (g_z sin q − g_x cos q)` (`g_y` does nothing).
fn pendulum_closed_form(q: f64, tau: f64, g: DVec3) -> f64 {
    let (m, l) = (PEND_M, PEND_L);
    (tau + m * l * (g.z * q.sin() - g.x * q.cos())) / (m * l * l + sphere(m, BOB_R))
}

/// Per method (DCA, ABA, CRBA), relative to `max(|q̈|, |g|/l)`. ABA and CRBA are exact to
/// rounding (measured 2.4e-15); DCA loses a few digits on a point-like bob 1–1.7 m from the
/// computation origin (measured 2.6e-12; see `dca_conditioning`).
const PENDULUM_TOL: [f64; 3] = [1e-11, 1e-13, 1e-13];

#[test]
fn single_pendulum() {
    let model = pendulum();
    assert_eq!((model.nq, model.nv, model.bodies.len()), (1, 1, 1));
    let mut data = Data::new(&model);
    let mut s = State::neutral(&model);
    let gravities = [
        DVec3::new(0.0, 0.0, -9.81),
        DVec3::new(0.0, 0.0, -1.62),
        DVec3::new(3.0, -7.0, -4.0),
        DVec3::new(-2.5, 0.0, 6.0),
    ];
    let mut worst = [0.0f64; 3];
    let mut checked = 0;
    for g in gravities {
        data.gravity = g;
        for q in [0.0, 0.3, -1.1, 2.0, 3.1, -2.7] {
            for tau in [0.0, 1.5, -4.0] {
                // q̈ of a one-DOF joint does not depend on q̇.
                for qd in [0.0, 2.5] {
                    s.q[0] = q;
                    s.qd[0] = qd;
                    s.tau[0] = tau;
                    let expected = pendulum_closed_form(q, tau, g);
                    // Relative to the natural scale |g| / l (q̈ may be 0).
                    let scale = expected.abs().max(g.length() / PEND_L).max(1.0);
                    for (k, method) in METHODS.into_iter().enumerate() {
                        let got = qdd(&model, &mut data, &s, method)[0];
                        let e = (got - expected).abs() / scale;
                        worst[k] = worst[k].max(e);
                        assert!(
                            e < PENDULUM_TOL[k],
                            "{method:?} g={g} q={q} tau={tau} qd={qd}: got {got} expected {expected}"
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    eprintln!(
        "single pendulum: {checked} cases, worst relative error DCA {:e}, ABA {:e}, CRBA {:e}",
        worst[0], worst[1], worst[2]
    );
    // Gravity really is read from `data.gravity`: switching it off leaves τ / (m l² + I).
    data.gravity = DVec3::ZERO;
    s.q[0] = 0.9;
    s.tau[0] = 2.0;
    let expected = 2.0 / (PEND_M * PEND_L * PEND_L + sphere(PEND_M, BOB_R));
    for (k, method) in METHODS.into_iter().enumerate() {
        let got = qdd(&model, &mut data, &s, method)[0];
        assert!(
            (got - expected).abs() < PENDULUM_TOL[k] * expected,
            "{method:?} without gravity: {got} vs {expected}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// (b) Double pendulum

const M1: f64 = 0.8;
const M2: f64 = 1.7;
const L1: f64 = 0.6;
const L2: f64 = 0.45;

fn double_pendulum(r: f64) -> Model {
    let (i1, i2) = (sphere(M1, r), sphere(M2, r));
    let urdf = format!(
        r#"<robot name="double_pendulum">
          <link name="base"/>
          <link name="upper">{}</link>
          <link name="lower">{}</link>
          <joint name="shoulder" type="revolute">
            <parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
            <limit lower="-3" upper="3" effort="10" velocity="10"/>
          </joint>
          <joint name="elbow" type="continuous">
            <origin xyz="0 0 -{L1}" rpy="0 0 0"/>
            <parent link="upper"/><child link="lower"/><axis xyz="0 1 0"/>
          </joint></robot>"#,
        inertial(M1, DVec3::new(0.0, 0.0, -L1), [i1, i1, i1, 0.0, 0.0, 0.0]),
        inertial(M2, DVec3::new(0.0, 0.0, -L2), [i2, i2, i2, 0.0, 0.0, 0.0]),
    );
    Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap()
}

/// Textbook double pendulum in relative angles (q2 measured from link 1), point masses plus
/// each bob's own inertia `I_k` about the (parallel) axes:
/// `x_k = −(…) sin`, `z_1 = −l1 cos q1`, `z_2 = z_1 − l2 cos(q1 + q2)`;
/// `T = ½ m1 l1² q̇1² + ½ m2 |ṗ2|² + ½ I1 q̇1² + ½ I2 (q̇1 + q̇2)²`, `V = g (m1 z1 + m2 z2)`.
/// `M q̈ + C + G = τ`, solved by Cramer's rule.
fn double_pendulum_closed_form(
    r: f64,
    q: [f64; 2],
    qd: [f64; 2],
    tau: [f64; 2],
    g: f64,
) -> [f64; 2] {
    let (i1, i2) = (sphere(M1, r), sphere(M2, r));
    let (c2, s2) = (q[1].cos(), q[1].sin());
    let m11 = i1 + i2 + M1 * L1 * L1 + M2 * (L1 * L1 + L2 * L2 + 2.0 * L1 * L2 * c2);
    let m12 = i2 + M2 * (L2 * L2 + L1 * L2 * c2);
    let m22 = i2 + M2 * L2 * L2;
    let h = M2 * L1 * L2 * s2;
    let c = [
        -h * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]),
        h * qd[0] * qd[0],
    ];
    let gr = [
        g * (M1 * L1 * q[0].sin() + M2 * (L1 * q[0].sin() + L2 * (q[0] + q[1]).sin())),
        g * M2 * L2 * (q[0] + q[1]).sin(),
    ];
    let r = [tau[0] - c[0] - gr[0], tau[1] - c[1] - gr[1]];
    let det = m11 * m22 - m12 * m12;
    [
        (r[0] * m22 - m12 * r[1]) / det,
        (m11 * r[1] - m12 * r[0]) / det,
    ]
}

/// Largest relative error `max|q̈ − q̈_textbook| / max(max|q̈_textbook|, 1)` of each method
/// (DCA, ABA, CRBA) over 50 seeded random states of the double pendulum with bobs of radius `r`.
fn double_pendulum_errors(r: f64) -> [f64; 3] {
    let model = double_pendulum(r);
    assert_eq!(model.nv, 2);
    let (sh, el) = (
        model.find_joint("shoulder").unwrap().1.v_offset,
        model.find_joint("elbow").unwrap().1.v_offset,
    );
    let mut data = Data::new(&model);
    let mut s = State::neutral(&model);
    let mut rng = SplitMix64(2024);
    let mut worst = [0.0f64; 3];
    for _ in 0..50 {
        let q = [rng.uniform(-3.1, 3.1), rng.uniform(-3.1, 3.1)];
        let qd = [rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 4.0)];
        let tau = [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)];
        (s.q[sh], s.q[el]) = (q[0], q[1]);
        (s.qd[sh], s.qd[el]) = (qd[0], qd[1]);
        (s.tau[sh], s.tau[el]) = (tau[0], tau[1]);
        let e = double_pendulum_closed_form(r, q, qd, tau, 9.81);
        for (k, method) in METHODS.into_iter().enumerate() {
            let got = qdd(&model, &mut data, &s, method);
            worst[k] = worst[k].max(rel_err(&[got[sh], got[el]], &e));
        }
    }
    worst
}

/// Point-like bobs (solid spheres of radius 1 cm at 0.45–1.05 m from the axis).
/// Measured worst relative errors over these 50 states: DCA 1.3e-11, ABA 6.5e-15,
/// CRBA 6.3e-15. DCA is held to the 1e-9 asked of it, ABA and CRBA to 1e-12; see
/// `dca_conditioning` for how DCA's error scales with the bob's size.
#[test]
fn double_pendulum_matches_textbook() {
    let [dca, aba, crba] = double_pendulum_errors(BOB_R);
    eprintln!(
        "double pendulum r = {BOB_R}: 50 states, worst relative error DCA {dca:e}, ABA {aba:e}, CRBA {crba:e}"
    );
    assert!(aba < 1e-12, "ABA {aba:e}");
    assert!(crba < 1e-12, "CRBA {crba:e}");
    assert!(dca < 1e-9, "DCA {dca:e}");
}

/// DCA works with inverse inertias: a leaf's `Φ = I⁻¹` has a rotational block
/// `(I_c)⁻¹ ~ 1/(m r²)` beside a translational `1/m`, so its condition number grows like
/// `κ ~ l² / r²` as the bob shrinks, and DCA loses digits where ABA and CRBA stay at rounding.
/// Measured DCA errors (50 states each): r = 0.003: 1.8e-10, 0.01: 1.3e-11, 0.03: 1.1e-12,
/// 0.1: 1.1e-13, 0.3: 2.5e-14 — about `κ ε` (∝ r⁻²); ABA and CRBA ≤ 1e-14 throughout.
/// (Before commit 5cd285a reworked DCA — handle vectors about their own points, leaf Φ in
/// closed form about the centre of mass — it grew like `κ² ε` ∝ r⁻⁴: 5.4e-6 at r = 0.003,
/// 1.1e-7 at r = 0.01.) The bounds sit ~3–5x above the measurements.
#[test]
fn dca_conditioning() {
    // (radius, DCA bound)
    for (r, bound) in [(0.003, 1e-9), (0.03, 5e-12), (0.1, 5e-13), (0.3, 1e-13)] {
        let [dca, aba, crba] = double_pendulum_errors(r);
        eprintln!("double pendulum r = {r}: DCA {dca:e}, ABA {aba:e}, CRBA {crba:e}");
        assert!(
            aba < 1e-12 && crba < 1e-12,
            "r = {r}: ABA {aba:e}, CRBA {crba:e}"
        );
        assert!(dca < bound, "r = {r}: DCA {dca:e} (bound {bound:e})");
    }
    // The loss is real and grows as the bob shrinks (so the bounds above are not slack).
    assert!(double_pendulum_errors(0.003)[0] > 100.0 * double_pendulum_errors(0.1)[0]);
}

// ---------------------------------------------------------------------------------------------
// (c) Tilted slider

#[test]
fn tilted_slider() {
    let m = 2.5;
    let (roll, pitch, yaw): (f64, f64, f64) = (0.3, 0.5, 0.7);
    // An off-centre, non-diagonal inertia: a pure translation must not care.
    let urdf = format!(
        r#"<robot name="slider">
          <link name="rail"/>
          <link name="carriage">{}</link>
          <joint name="slide" type="prismatic">
            <origin xyz="0.1 0.2 0.3" rpy="{roll} {pitch} {yaw}"/>
            <parent link="rail"/><child link="carriage"/><axis xyz="1 0 0"/>
            <limit lower="-1" upper="1" effort="10" velocity="10"/>
          </joint></robot>"#,
        inertial(
            m,
            DVec3::new(0.05, -0.02, 0.1),
            [0.02, 0.03, 0.04, 0.001, -0.002, 0.003]
        )
    );
    let model = Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap();
    // The x axis of the joint frame, R = Rz(yaw) Ry(pitch) Rx(roll): Rx leaves it alone,
    // Ry(p) x = (cos p, 0, −sin p), then Rz(y) turns that about z.
    let axis = DVec3::new(
        yaw.cos() * pitch.cos(),
        yaw.sin() * pitch.cos(),
        -pitch.sin(),
    );
    let mut data = Data::new(&model);
    let mut s = State::neutral(&model);
    for g in [
        DVec3::new(0.0, 0.0, -9.81),
        DVec3::new(1.0, -2.0, 3.0),
        DVec3::ZERO,
    ] {
        data.gravity = g;
        for (q, qd, tau) in [(0.0, 0.0, 0.0), (0.4, -1.5, 3.0), (-0.7, 2.0, -10.0)] {
            s.q[0] = q;
            s.qd[0] = qd;
            s.tau[0] = tau;
            let expected = g.dot(axis) + tau / m;
            for method in METHODS {
                let got = qdd(&model, &mut data, &s, method)[0];
                assert!(
                    (got - expected).abs() < 1e-12 * expected.abs().max(1.0),
                    "{method:?} g={g} q={q} tau={tau}: got {got}, expected {expected}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (d) Free rigid body (floating base)

const FREE_M: f64 = 3.2;
/// Rotational inertia about the centre of mass: ixx iyy izz ixy ixz iyz.
const FREE_I: [f64; 6] = [0.30, 0.45, 0.52, 0.02, -0.01, 0.03];

fn free_body(com: DVec3) -> Model {
    let urdf = format!(
        r#"<robot name="free"><link name="block">{}</link></robot>"#,
        inertial(FREE_M, com, FREE_I)
    );
    let model =
        Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    assert_eq!((model.nq, model.nv), (7, 6));
    assert_eq!(model.bodies[0].joint[0].name, "floating_base");
    model
}

fn free_inertia() -> DMat3 {
    let [xx, yy, zz, xy, xz, yz] = FREE_I;
    DMat3::from_cols(
        DVec3::new(xx, xy, xz),
        DVec3::new(xy, yy, yz),
        DVec3::new(xz, yz, zz),
    )
}

/// The floating-base pose from `q = [x, y, z, qw, qx, qy, qz]` (docs/conventions.md): the
/// body's axes `R` (columns, world coordinates) and origin `p`.
fn pose(q: &[f64]) -> (DMat3, DVec3) {
    let rot = DQuat::from_xyzw(q[4], q[5], q[6], q[3]).normalize();
    (DMat3::from_quat(rot), DVec3::new(q[0], q[1], q[2]))
}

/// At rest, no gravity, a world wrench `[n; F]` about the world origin. In body coordinates
/// `F_b = Rᵀ F`, `n_b = Rᵀ (n − p × F)` (moment about the body origin). With the centre of mass
/// at `c` and `a_o` the acceleration of the body origin, Newton–Euler at zero velocity:
/// `F_b = m (a_o + α × c)`, `n_b = I_c α + c × F_b`, so
/// `α = I_c⁻¹ (n_b − c × F_b)`, `a_o = F_b / m − α × c`; and `q̈ = [α; a_o]` (the floating
/// base's `qd` is the body's spatial velocity in body coordinates).
#[test]
fn free_body_under_a_wrench() {
    let mut worst = 0.0f64;
    for com in [DVec3::ZERO, DVec3::new(0.12, -0.07, 0.2)] {
        let model = free_body(com);
        let mut data = Data::new(&model);
        data.gravity = DVec3::ZERO;
        let ic_inv = free_inertia().inverse();
        for seed in 0..20 {
            let mut s = State::random(&model, seed, 0.0);
            s.qd.iter_mut().for_each(|x| *x = 0.0);
            s.tau.iter_mut().for_each(|x| *x = 0.0);
            s.randomize_forces(seed, 5.0);
            let f = s.f_ext[0];
            let (r, p) = pose(&s.q);
            let fb = r.transpose() * f.f;
            let nb = r.transpose() * (f.n - p.cross(f.f));
            let alpha = ic_inv * (nb - com.cross(fb));
            let a_o = fb / FREE_M - alpha.cross(com);
            let e = [alpha.x, alpha.y, alpha.z, a_o.x, a_o.y, a_o.z];
            for method in METHODS {
                let got = qdd(&model, &mut data, &s, method);
                let err = rel_err(&got, &e);
                worst = worst.max(err);
                assert!(
                    err < 1e-12,
                    "{method:?} com={com} seed {seed}: got {got:?}, expected {e:?}"
                );
            }
            // A force through the centre of mass only translates the body.
            let mut s2 = s.clone();
            let force = f.f;
            forward_kinematics(&model, &s2.q, &s2.qd, &mut data).unwrap();
            s2.f_ext[0] = data.point_force(0, com, force);
            let got = qdd(&model, &mut data, &s2, Method::Dca);
            let fb = r.transpose() * force;
            let e = [0.0, 0.0, 0.0, fb.x / FREE_M, fb.y / FREE_M, fb.z / FREE_M];
            assert!(rel_err(&got, &e) < 1e-12, "point force: {got:?} vs {e:?}");
        }
    }
    eprintln!("free body under a wrench: worst relative error {worst:e}");
}

/// Torque-free rigid body, centre of mass at the body origin, no gravity: Euler's equations
/// `I ω̇ = −ω × I ω`, and the origin moves in a straight line, so the body-coordinate linear
/// velocity `v_b = Rᵀ ṗ` changes as `v̇_b = −ω × v_b`.
#[test]
fn torque_free_body_follows_euler() {
    let model = free_body(DVec3::ZERO);
    let mut data = Data::new(&model);
    data.gravity = DVec3::ZERO;
    let inertia = free_inertia();
    let (mut worst, mut euler) = (0.0f64, 0.0f64);
    for seed in 0..20 {
        let s = State::random(&model, seed, 0.0);
        let w = DVec3::new(s.qd[0], s.qd[1], s.qd[2]);
        let v = DVec3::new(s.qd[3], s.qd[4], s.qd[5]);
        let wd = inertia.inverse() * -w.cross(inertia * w);
        let vd = -w.cross(v);
        let e = [wd.x, wd.y, wd.z, vd.x, vd.y, vd.z];
        euler = euler.max(wd.length());
        for method in METHODS {
            let got = qdd(&model, &mut data, &s, method);
            let err = rel_err(&got, &e);
            worst = worst.max(err);
            assert!(
                err < 1e-12,
                "{method:?} seed {seed}: got {got:?}, Euler {e:?}"
            );
        }
    }
    eprintln!("torque-free body: worst relative error {worst:e}; largest |ω̇| {euler}");
    assert!(euler > 0.1, "the Euler term must matter");
}

/// In uniform gravity a free body at rest falls without turning, whatever its centre of mass:
/// `q̈ = [0; Rᵀ g]`.
#[test]
fn free_fall() {
    let model = free_body(DVec3::new(0.12, -0.07, 0.2));
    let mut data = Data::new(&model);
    data.gravity = DVec3::new(0.5, -1.0, -9.81);
    for seed in 0..10 {
        let mut s = State::random(&model, seed, 0.0);
        s.qd.iter_mut().for_each(|x| *x = 0.0);
        let (r, _) = pose(&s.q);
        let g = r.transpose() * data.gravity;
        let e = [0.0, 0.0, 0.0, g.x, g.y, g.z];
        for method in METHODS {
            let got = qdd(&model, &mut data, &s, method);
            assert!(
                rel_err(&got, &e) < 1e-12,
                "{method:?} seed {seed}: {got:?} vs {e:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (e) The floating joint's position update

/// `integrate_q` moves a floating joint along the exact motion at constant body twist: a body
/// spinning at `ω` about a point `r` fixed in the body (body origin velocity `v = −ω × r`)
/// keeps that point where it was, `p' + R' r = p + R r`, for any step; and two half steps
/// equal one full step (a one-parameter subgroup).
#[test]
fn floating_joint_update_is_the_exponential() {
    let model = free_body(DVec3::ZERO);
    let mut rng = SplitMix64(99);
    for seed in 0..10 {
        let s = State::random(&model, seed, 0.0);
        let w = DVec3::new(
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
        );
        let r = DVec3::new(
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        );
        let v = -w.cross(r);
        let twist = [w.x, w.y, w.z, v.x, v.y, v.z];
        let (r0, p0) = pose(&s.q);
        let pivot = p0 + r0 * r;
        for h in [1e-4, 1e-2, 0.3, 2.0] {
            let mut q = s.q.clone();
            articula_dca::integrate_q(&model, &mut q, &twist, h);
            let (r1, p1) = pose(&q);
            let moved = (p1 + r1 * r - pivot).length();
            assert!(
                moved < 1e-13,
                "seed {seed} h {h}: the pivot moved by {moved:e}"
            );
            let mut q2 = s.q.clone();
            articula_dca::integrate_q(&model, &mut q2, &twist, h / 2.0);
            articula_dca::integrate_q(&model, &mut q2, &twist, h / 2.0);
            let (r2, p2) = pose(&q2);
            assert!(
                (p2 - p1).length() < 1e-13
                    && (r2 - r1).to_cols_array().iter().all(|x| x.abs() < 1e-13)
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (e) A point mass near a revolute axis, with an absolute inertia bound

/// A point mass `m` whose centre of mass is `d` from a revolute axis, loaded under
/// `InertiaPolicy::Repair` with `bound_inertia = b`, has the isotropic rotational inertia `b`
/// about its centre of mass (the relative floor `1e-9 · m d²` is far below `b`); by the
/// parallel-axis theorem its joint-space inertia is `b + m d²`, so without gravity
/// `q̈ = τ / (b + m d²)` at every angle and speed (one revolute joint: no velocity terms).
#[test]
fn point_mass_with_bound_inertia() {
    use articula_model::InertiaPolicy;
    let (m, b) = (1.34, 1e-4);
    for d in [4e-4, 0.03, 0.5] {
        // Centre of mass `d` from the z axis, 5 cm along it (the along-axis offset does not
        // count), the joint away from the world origin.
        let com = DVec3::new(0.6 * d, 0.8 * d, 0.05);
        let urdf = format!(
            r#"<robot name="point">
              <link name="base"/>
              <link name="head">{}</link>
              <joint name="neck" type="revolute">
                <origin xyz="0.2 -0.1 0.4" rpy="0.3 0 0"/>
                <parent link="base"/><child link="head"/><axis xyz="0 0 1"/>
                <limit lower="-3" upper="3" effort="10" velocity="10"/>
              </joint></robot>"#,
            inertial(m, com, [0.0; 6])
        );
        let options = LoadOptions::default()
            .with_inertia(InertiaPolicy::Repair)
            .with_bound_inertia(b);
        let model = Model::from_urdf_str(&urdf, &options).unwrap();
        let mut data = Data::new(&model);
        data.gravity = DVec3::ZERO;
        let tau = 0.37;
        let expected = tau / (b + m * d * d);
        for (q, qd) in [(0.0, 0.0), (1.1, -2.5), (-2.9, 6.0)] {
            let mut s = State::neutral(&model);
            s.q[0] = q;
            s.qd[0] = qd;
            s.tau[0] = tau;
            for method in METHODS {
                let got = qdd(&model, &mut data, &s, method)[0];
                let rel = (got - expected).abs() / expected;
                assert!(
                    rel < 1e-10,
                    "{method:?} d = {d}: q̈ = {got}, τ/(b + m d²) = {expected} (rel {rel:.2e})"
                );
            }
        }
    }
}
