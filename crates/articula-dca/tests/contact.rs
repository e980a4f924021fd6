//! Ground contact and joint limits with known answers (`docs/contact.md`): rest heights of a
//! dropped sphere and box, the slide-or-stick law on an incline and its acceleration
//! `g (sin θ − μ cos θ)`, a pendulum stopped by its joint limit, no energy gain through contact,
//! a floating humanoid dropped onto the floor, no creep under static friction.

use articula_dca::{
    forward_kinematics, step_with_contact, ContactData, ContactSettings, ContactSolver, Data,
    Ground, Method, State,
};
use articula_model::{LoadOptions, Model};
use glam::{DQuat, DVec3};

const DT: f64 = 1e-3;

/// A free-floating rigid body of mass `mass` and diagonal inertia `inertia`, with one
/// `<collision>` `geometry` element.
fn free_body(mass: f64, inertia: DVec3, geometry: &str) -> Model {
    let urdf = format!(
        r#"<robot name="body"><link name="b"><inertial><mass value="{mass}"/>
        <inertia ixx="{}" iyy="{}" izz="{}" ixy="0" ixz="0" iyz="0"/></inertial>
        <collision><geometry>{geometry}</geometry></collision></link></robot>"#,
        inertia.x, inertia.y, inertia.z
    );
    Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap()
}

fn sphere(radius: f64) -> Model {
    let i = 0.4 * radius * radius;
    free_body(
        1.0,
        DVec3::splat(i),
        &format!(r#"<sphere radius="{radius}"/>"#),
    )
}

fn cuboid(size: DVec3, mass: f64) -> Model {
    let i = mass / 12.0
        * DVec3::new(
            size.y * size.y + size.z * size.z,
            size.x * size.x + size.z * size.z,
            size.x * size.x + size.y * size.y,
        );
    free_body(
        mass,
        i,
        &format!(r#"<box size="{} {} {}"/>"#, size.x, size.y, size.z),
    )
}

/// The floating base's pose in `q`.
fn set_pose(state: &mut State, p: DVec3, r: DQuat) {
    state.q[..7].copy_from_slice(&[p.x, p.y, p.z, r.w, r.x, r.y, r.z]);
}

/// `T + V` of `state`.
fn energy(model: &Model, data: &mut Data, state: &State) -> f64 {
    forward_kinematics(model, &state.q, &state.qd, data).unwrap();
    data.kinetic_energy() + data.potential_energy()
}

struct Sim {
    model: Model,
    data: Data,
    contact: ContactData,
    state: State,
    settings: ContactSettings,
}

impl Sim {
    fn new(model: Model, ground: Ground) -> Sim {
        Sim {
            data: Data::new(&model),
            contact: ContactData::new(&model),
            state: State::neutral(&model),
            settings: ContactSettings {
                ground: Some(ground),
                ..ContactSettings::default()
            },
            model,
        }
    }
    fn step(&mut self, method: Method) {
        step_with_contact(
            &self.model,
            &mut self.data,
            &mut self.contact,
            &mut self.state,
            method,
            DT,
            &self.settings,
        )
        .unwrap();
    }
    fn run(&mut self, seconds: f64, method: Method) {
        for _ in 0..(seconds / DT).round() as usize {
            self.step(method);
        }
    }
    fn energy(&mut self) -> f64 {
        energy(&self.model, &mut self.data, &self.state)
    }
}

/// A sphere (r = 0.1 m) dropped from 0.5 m comes to rest with its centre at 0.1 m (± 1 mm),
/// on a floor at z = 0.2 at 0.3 m, with DCA and ABA.
#[test]
fn dropped_sphere_rests_at_its_radius() {
    for method in [Method::Dca, Method::Aba] {
        for floor in [0.0, 0.2] {
            let mut sim = Sim::new(sphere(0.1), Ground::horizontal(floor));
            set_pose(
                &mut sim.state,
                DVec3::new(0.0, 0.0, floor + 0.5),
                DQuat::IDENTITY,
            );
            sim.run(1.5, method);
            let z = sim.state.q[2] - floor;
            eprintln!("sphere {method:?} floor {floor}: rest height {z:.7} m (0.1 expected)");
            assert!((z - 0.1).abs() < 1e-3, "{method:?} floor {floor}: z = {z}");
            let speed = sim.state.qd.iter().map(|x| x.abs()).fold(0.0, f64::max);
            assert!(speed < 1e-6, "{method:?}: still moving {speed}");
            assert!(sim.contact.stats.max_penetration < 1e-3);
        }
    }
}

/// A box (0.2 × 0.3 × 0.4 m) dropped from 0.3 m above its resting height, tilted by 0.3 rad
/// about x, lands on an edge, falls flat and rests with its centre at half its height.
#[test]
fn dropped_box_rests_on_a_face() {
    for method in [Method::Dca, Method::Aba] {
        let mut sim = Sim::new(
            cuboid(DVec3::new(0.2, 0.3, 0.4), 2.0),
            Ground::horizontal(0.0),
        );
        set_pose(
            &mut sim.state,
            DVec3::new(0.0, 0.0, 0.5),
            DQuat::from_rotation_x(0.3),
        );
        sim.run(2.0, method);
        let z = sim.state.q[2];
        eprintln!("box {method:?}: rest height {z:.7} m (0.2 expected)");
        assert!((z - 0.2).abs() < 1e-3, "{method:?}: z = {z}");
        let r = DQuat::from_xyzw(
            sim.state.q[4],
            sim.state.q[5],
            sim.state.q[6],
            sim.state.q[3],
        );
        assert!((r * DVec3::Z).z > 1.0 - 1e-6, "{method:?}: not flat {r}");
        assert!(sim.contact.stats.contacts >= 3, "{:?}", sim.contact.stats);
        // At rest the floor's wrench balances gravity acting at the centre of mass: the
        // force m g up, the moment about the world origin c × f.
        let forces = sim.contact.forces();
        assert!(forces.torques.is_empty(), "{forces:?}");
        let [(body, w)] = forces.wrenches[..] else {
            panic!("{method:?}: one body in contact expected, {forces:?}");
        };
        let c = DVec3::new(sim.state.q[0], sim.state.q[1], sim.state.q[2]);
        let weight = DVec3::new(0.0, 0.0, 2.0 * 9.81);
        eprintln!("box {method:?}: floor force {:?}, moment {:?}", w.f, w.n);
        assert_eq!(body, 0);
        assert!(
            (w.f - weight).length() < 1e-6 * weight.z,
            "{method:?}: {w:?}"
        );
        assert!(
            (w.n - c.cross(weight)).length() < 1e-6 * weight.z,
            "{method:?}: {w:?}"
        );
        assert_eq!(forces.total(), w);
    }
}

/// A flat block placed on an incline of angle θ with friction μ: at rest it stays at rest iff
/// tan θ ≤ μ; sliding, its acceleration along the slope is g (sin θ − μ cos θ) to 1e-3.
fn incline(theta: f64, mu: f64, seconds: f64) -> (f64, f64) {
    let size = DVec3::new(0.4, 0.4, 0.1);
    let mut sim = Sim::new(cuboid(size, 1.0), Ground::incline(theta, mu));
    let n = DVec3::new(theta.sin(), 0.0, theta.cos());
    set_pose(
        &mut sim.state,
        n * (0.5 * size.z),
        DQuat::from_rotation_y(theta),
    );
    let start = DVec3::new(sim.state.q[0], sim.state.q[1], sim.state.q[2]);
    // The body's x axis is the downhill direction; q̇[3] the velocity along it.
    sim.run(0.5 * seconds, Method::Dca);
    let v1 = sim.state.qd[3];
    sim.run(0.5 * seconds, Method::Dca);
    let v2 = sim.state.qd[3];
    let end = DVec3::new(sim.state.q[0], sim.state.q[1], sim.state.q[2]);
    ((v2 - v1) / (0.5 * seconds), (end - start).length())
}

#[test]
fn block_slides_on_an_incline_iff_tan_theta_exceeds_mu() {
    let g = 9.81;
    for (theta, mu) in [(30f64.to_radians(), 0.3), (0.55f64.atan(), 0.5), (0.4, 0.0)] {
        let (a, _) = incline(theta, mu, 1.0);
        let want = g * (theta.sin() - mu * theta.cos());
        eprintln!(
            "incline θ = {:.4} rad, μ = {mu}: a = {a:.6} m/s², g(sin θ − μ cos θ) = {want:.6}, relative error {:.2e}",
            theta,
            (a - want) / want
        );
        assert!(
            ((a - want) / want).abs() < 1e-3,
            "θ = {theta}, μ = {mu}: a = {a}, want {want}"
        );
    }
    // tan θ = 0.45 < μ = 0.5: it sticks.
    let (a, moved) = incline(0.45f64.atan(), 0.5, 1.0);
    eprintln!("incline tan θ = 0.45, μ = 0.5: a = {a:.2e} m/s², moved {moved:.2e} m in 1 s");
    assert!(a.abs() < 1e-6 && moved < 1e-3, "a = {a}, moved {moved}");
}

/// No creep under static friction: a box on a 10° incline with μ = 0.5 moves < 1 mm in 2 s.
#[test]
fn no_creep_under_static_friction() {
    let (_, moved) = incline(10f64.to_radians(), 0.5, 2.0);
    eprintln!("creep: 10° incline, μ = 0.5: moved {moved:.2e} m in 2 s");
    assert!(moved < 1e-3, "moved {moved} m");
}

/// A horizontal pendulum (1 m, 1 kg bob) falls onto its upper limit 0.5 rad and stops there;
/// with limits off it swings past.
#[test]
fn pendulum_stops_at_its_joint_limit() {
    let urdf = r#"<robot name="p"><link name="base"/>
      <link name="bob"><inertial><origin xyz="1 0 0"/><mass value="1"/>
        <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="swing" type="revolute"><parent link="base"/><child link="bob"/>
        <axis xyz="0 1 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
    </robot>"#;
    let model = Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap();
    assert_eq!(model.bodies[0].joint[0].limits, Some([-0.5, 0.5]));
    for method in [Method::Dca, Method::Aba] {
        let mut data = Data::new(&model);
        let mut contact = ContactData::new(&model);
        let mut state = State::neutral(&model);
        let mut settings = ContactSettings::default();
        let mut max_q = 0.0f64;
        let mut run = |contact: &mut ContactData,
                       state: &mut State,
                       settings: &ContactSettings,
                       steps: usize| {
            let mut max_q = f64::NEG_INFINITY;
            for _ in 0..steps {
                step_with_contact(&model, &mut data, contact, state, method, DT, settings).unwrap();
                max_q = max_q.max(state.q[0]);
            }
            max_q
        };
        max_q = max_q.max(run(&mut contact, &mut state, &settings, 2000));
        // Gravity pushes q up (the bob falls): it rests on the bound, within the slop.
        eprintln!(
            "pendulum {method:?}: q = {:.7} (bound 0.5), max {max_q:.7}, q̇ = {:.1e}",
            state.q[0], state.qd[0]
        );
        assert!(
            (state.q[0] - 0.5).abs() < 2e-4,
            "{method:?}: q = {}",
            state.q[0]
        );
        assert!(max_q < 0.5 + 2e-3, "{method:?}: overshoot to {max_q}");
        assert!(state.qd[0].abs() < 1e-6, "{method:?}: q̇ = {}", state.qd[0]);
        // Resting on its bound, the limit's torque balances gravity's, g cos q about y.
        let tau = -9.81 * state.q[0].cos();
        let torques = &contact.forces().torques;
        assert_eq!(torques.len(), 1, "{torques:?}");
        assert_eq!(torques[0].0, 0);
        assert!(
            (torques[0].1 - tau).abs() < 1e-6 * tau.abs(),
            "{method:?}: limit torque {torques:?}, gravity's {tau}"
        );
        assert!(contact.forces().wrenches.is_empty());
        settings.joint_limits = false;
        let mut state = State::neutral(&model);
        run(&mut contact, &mut state, &settings, 1000);
        assert!(state.q[0] > 1.0, "without limits: q = {}", state.q[0]);
    }
}

/// Kinetic + potential energy never grows through contact: a box dropped tilted with e = 0 and
/// a sphere with e = 0.5 (which bounces), checked at every step.
#[test]
fn energy_never_grows_through_contact() {
    for (model, e, tilt) in [
        (cuboid(DVec3::new(0.2, 0.3, 0.4), 2.0), 0.0, 0.3),
        (cuboid(DVec3::new(0.2, 0.3, 0.4), 2.0), 0.5, 0.3),
        (sphere(0.1), 0.5, 0.0),
        (sphere(0.1), 0.0, 0.0),
    ] {
        let mut ground = Ground::horizontal(0.0);
        ground.restitution = e;
        let mut sim = Sim::new(model, ground);
        set_pose(
            &mut sim.state,
            DVec3::new(0.0, 0.0, 0.6),
            DQuat::from_rotation_x(tilt),
        );
        let e0 = sim.energy();
        let mut last = e0;
        let mut worst = f64::NEG_INFINITY;
        let mut bounces = 0;
        let mut was_up = false;
        let (mut landed, mut apex) = (false, 0.0f64);
        for _ in 0..1500 {
            sim.step(Method::Dca);
            let now = sim.energy();
            worst = worst.max(now - last);
            last = now;
            // World vertical velocity of the centre.
            let r = DQuat::from_xyzw(
                sim.state.q[4],
                sim.state.q[5],
                sim.state.q[6],
                sim.state.q[3],
            );
            let vz = (r * DVec3::new(sim.state.qd[3], sim.state.qd[4], sim.state.qd[5])).z;
            let up = vz > 0.1;
            bounces += (up && !was_up) as usize;
            was_up = up;
            landed |= up;
            if landed {
                apex = apex.max(sim.state.q[2]);
            }
        }
        eprintln!(
            "energy e = {e}, tilt {tilt}: start {e0:.6} J, end {last:.6} J, largest rise in a step {worst:.2e} J, {bounces} bounce(s), first apex {apex:.4} m"
        );
        assert!(
            worst <= 1e-9 * e0.abs(),
            "e = {e}, tilt {tilt}: energy grew by {worst} J in a step"
        );
        assert!(last < e0);
        // The sphere (a tilted box may hop as it tips over, whatever e).
        if tilt != 0.0 {
            continue;
        }
        if e == 0.0 {
            assert_eq!(bounces, 0, "e = 0 bounced");
        } else {
            // The sphere falls 0.5 m and rebounds to e² · 0.5 m above its rest height (within
            // the early turn of one step, |v| dt ≈ 3 mm, and the integrator's O(dt)).
            assert!(bounces >= 2, "{bounces} bounces");
            let rise = apex - 0.1;
            assert!((rise - e * e * 0.5).abs() < 0.01, "rebound {rise} m");
        }
    }
}

/// The bundled humanoid, floating, dropped with its lowest point 1 m above the floor, comes to
/// rest: kinetic energy < 0.01 J after 3 s (6 s with the subspace solver), penetration < 5 mm
/// throughout. It lands on its feet and falls over; with the subspace solver the fall ends
/// later and at a time that rounding decides: under 1e-9 m changes of the drop height its
/// kinetic energy at 3 s ranges from 1e-4 J to over 1 J, at 6 s it is below 1e-3 J.
#[test]
fn dropped_humanoid_comes_to_rest() {
    // With either solver.
    for solver in [ContactSolver::GaussSeidel, ContactSolver::Subspace] {
        let model = articula_testkit::bundled_with("humanoid", true);
        let mut sim = Sim::new(model, Ground::horizontal(0.0));
        sim.settings.solver = solver;
        // Lowest contact sphere at the neutral pose.
        forward_kinematics(&sim.model, &sim.state.q, &sim.state.qd, &mut sim.data).unwrap();
        let lowest = sim.contact.lowest_point(&sim.data);
        sim.state.q[2] += 1.0 - lowest;
        let mut worst = 0.0f64;
        let mut rows = 0usize;
        let (mut iterations, mut capped) = (0usize, 0usize);
        let steps = 3000;
        for _ in 0..steps {
            sim.step(Method::Dca);
            worst = worst.max(sim.contact.stats.max_penetration);
            rows = rows.max(sim.contact.stats.rows);
            iterations += sim.contact.stats.iterations;
            capped += !sim.contact.stats.converged as usize;
        }
        forward_kinematics(&sim.model, &sim.state.q, &sim.state.qd, &mut sim.data).unwrap();
        let mut kinetic = sim.data.kinetic_energy();
        let mut settle = 0;
        if solver == ContactSolver::Subspace {
            // Three seconds more (not in the figures below).
            for _ in 0..3000 {
                sim.step(Method::Dca);
                worst = worst.max(sim.contact.stats.max_penetration);
            }
            forward_kinematics(&sim.model, &sim.state.q, &sim.state.qd, &mut sim.data).unwrap();
            (settle, kinetic) = (3, sim.data.kinetic_energy());
        }
        eprintln!(
            "humanoid {solver:?}: kinetic {kinetic:.3e} J, max penetration {worst:.3e} m, max rows {rows}, \
             iterations per step {:.1}, not converged {capped} of {steps} steps, last {:?}",
            iterations as f64 / steps as f64,
            sim.contact.stats
        );
        assert!(
            kinetic < 0.01,
            "{solver:?}: kinetic energy {kinetic} J after {} s",
            3 + settle
        );
        assert!(worst < 5e-3, "{solver:?}: penetration {worst} m");
    }
}
