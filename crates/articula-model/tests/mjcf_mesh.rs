//! Mesh inertia in MJCF models: volumes, centres and inertias of meshes written by the tests
//! (a box, a tetrahedron) against their closed forms, and clean errors on hostile mesh files.
//! (Agreement with MuJoCo on the dm-control meshes: `cargo xtask mjcf-corpus`.)

use articula_model::{LoadOptions, Model, ModelError};
use articula_spatial::skew;
use glam::{DMat3, DVec3};
use std::path::PathBuf;

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-mesh-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A binary STL of these triangles, its header claiming `claimed` of them.
fn binary_stl(tris: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend_from_slice(&claimed.to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for v in t {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        b.extend_from_slice(&[0u8; 2]);
    }
    b
}

/// A closed box of half-sizes `h` centred at `c`, faces counter-clockwise from outside.
fn box_triangles(h: [f32; 3], c: [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    let v = |i: usize| {
        [
            c[0] + if i & 1 == 0 { -h[0] } else { h[0] },
            c[1] + if i & 2 == 0 { -h[1] } else { h[1] },
            c[2] + if i & 4 == 0 { -h[2] } else { h[2] },
        ]
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| [[v(q[0]), v(q[1]), v(q[2])], [v(q[0]), v(q[2]), v(q[3])]])
        .collect()
}

/// A model of one hinged body whose only geom is mesh `file` (in `meshdir="meshes"`).
fn model_with(dir: &std::path::Path, file: &str, mesh_attrs: &str, geom_attrs: &str) -> PathBuf {
    let xml = format!(
        r#"<mujoco><compiler meshdir="meshes"/>
  <asset><mesh name="m" file="{file}" {mesh_attrs}/></asset>
  <worldbody><body name="b"><joint name="j" axis="0 1 0"/>
    <geom name="g" type="mesh" mesh="m" {geom_attrs}/></body></worldbody></mujoco>"#
    );
    let path = dir.join("model.xml");
    std::fs::write(&path, xml).unwrap();
    path
}

fn write_mesh(dir: &std::path::Path, file: &str, bytes: &[u8]) {
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::write(dir.join("meshes").join(file), bytes).unwrap();
}

/// The loaded body's mass, centre and inertia about the centre (body frame).
fn body_inertia(path: &std::path::Path) -> (f64, DVec3, DMat3) {
    let m = Model::from_mjcf_file(path, &LoadOptions::default()).unwrap();
    let b = m.bodies.iter().find(|b| b.name == "b").unwrap();
    let c = b.inertia.com();
    let s = skew(c);
    (b.inertia.mass, c, b.inertia.ibar + s * s * b.inertia.mass)
}

fn close(a: DMat3, b: DMat3, tol: f64) -> bool {
    (a - b).to_cols_array().iter().all(|x| x.abs() <= tol)
}

/// A box mesh, scaled and placed off the origin, has the box's closed-form mass, centre and
/// inertia (density × volume; m/3 (b² + c²) …), the same as a primitive box geom.
#[test]
fn box_mesh_matches_closed_form() {
    let d = dir("box");
    write_mesh(
        &d,
        "box.stl",
        &binary_stl(&box_triangles([0.5, 1.0, 1.5], [1.0, 2.0, 3.0]), 12),
    );
    let path = model_with(
        &d,
        "box.stl",
        r#"scale="0.1 0.2 0.3""#,
        r#"density="500" pos="0.1 0 0""#,
    );
    let (mass, com, ic) = body_inertia(&path);
    let h = DVec3::new(0.05, 0.2, 0.45);
    let volume = 8.0 * h.x * h.y * h.z;
    assert!((mass - 500.0 * volume).abs() < 1e-12 * mass, "{mass}");
    // The mesh's centre (1, 2, 3) scaled, plus the geom's pos.
    let c = DVec3::new(0.1 + 0.1, 0.4, 0.9);
    assert!((com - c).length() < 1e-12, "{com}");
    let expect = DMat3::from_diagonal(
        DVec3::new(
            h.y * h.y + h.z * h.z,
            h.x * h.x + h.z * h.z,
            h.x * h.x + h.y * h.y,
        ) * mass
            / 3.0,
    );
    assert!(close(ic, expect, 1e-12 * mass), "{ic} vs {expect}");
    // The same box as a primitive geom.
    let prim = Model::from_mjcf_str(
        r#"<mujoco><worldbody><body name="b"><joint name="j" axis="0 1 0"/>
        <geom type="box" size="0.05 0.2 0.45" pos="0.2 0.4 0.9" density="500"/></body>
        </worldbody></mujoco>"#,
        &LoadOptions::default(),
    )
    .unwrap();
    let p = prim.bodies.iter().find(|b| b.name == "b").unwrap().inertia;
    assert!((p.mass - mass).abs() < 1e-12 * mass);
}

/// A tetrahedron (0, e₁, e₂, e₃) in ASCII STL: volume 1/6, centre (¼, ¼, ¼), inertia about
/// the centre ρ·[1/80 on the diagonal, 1/480 off it]; and `mass=` overrides density.
#[test]
fn tetrahedron_ascii_matches_closed_form() {
    let d = dir("tet");
    let [o, x, y, z] = ["0 0 0", "1 0 0", "0 1 0", "0 0 1"];
    let facet = |a: &str, b: &str, c: &str| {
        format!("facet normal 0 0 0\n outer loop\n  vertex {a}\n  vertex {b}\n  vertex {c}\n endloop\nendfacet\n")
    };
    let text = format!(
        "solid tet\n{}{}{}{}endsolid tet\n",
        facet(o, y, x),
        facet(o, x, z),
        facet(o, z, y),
        facet(x, y, z)
    );
    write_mesh(&d, "tet.stl", text.as_bytes());
    for (mesh, geom, rho) in [
        ("", r#"density="2""#, 2.0),
        (r#"inertia="exact""#, r#"mass="3""#, 18.0),
    ] {
        let path = model_with(&d, "tet.stl", mesh, geom);
        let (mass, com, ic) = body_inertia(&path);
        assert!((mass - rho / 6.0).abs() < 1e-14, "{mass}");
        assert!((com - DVec3::splat(0.25)).length() < 1e-14, "{com}");
        let a = rho / 80.0;
        let b = rho / 480.0;
        let expect = DMat3::from_cols(
            DVec3::new(a, b, b),
            DVec3::new(b, a, b),
            DVec3::new(b, b, a),
        );
        assert!(close(ic, expect, 1e-13 * rho), "{ic} vs {expect}");
    }
}

/// MuJoCo 4 diagonalises a mesh's inertia only until the off-diagonal is 1e-7 of the largest
/// entry, and the body keeps that frame. A box mesh (half-sizes 0.5, 1, 1.5, density 1000)
/// turned by `refquat` through θ about z has the off-diagonal ρ(I_xx − I_yy) sin θ cos θ, 2.3e-9
/// of the largest moment for θ = 1e-8: MuJoCo keeps the file's axes (its `body_iquat` is
/// [1, 0, 0, 0] and `body_inertia` (6500, 5000, 2500) exactly), so the body's inertia is diagonal
/// and the turn is lost. For θ = 1e-6 and 1e-3 the off-diagonal is above the tolerance: MuJoCo
/// turns the axes, and the inertia is the rotated box's closed form.
#[test]
fn mesh_axes_follow_mujocos_tolerance() {
    let d = dir("turn");
    write_mesh(
        &d,
        "box.stl",
        &binary_stl(&box_triangles([0.5, 1.0, 1.5], [0.0; 3]), 12),
    );
    let moments = DVec3::new(6500.0, 5000.0, 2500.0);
    for theta in [1e-8f64, 1e-6, 1e-3] {
        let (s, c) = (theta / 2.0).sin_cos();
        let path = model_with(&d, "box.stl", &format!(r#"refquat="{c:?} 0 0 {s:?}""#), "");
        let (mass, _, ic) = body_inertia(&path);
        assert!((mass - 6000.0).abs() < 1e-9, "{mass}");
        // refquat turns the mesh frame by θ, so the box turns by −θ in it.
        let r = DMat3::from_rotation_z(-theta);
        let exact = r * DMat3::from_diagonal(moments) * r.transpose();
        if theta < 1e-7 {
            assert!(exact.y_axis.x.abs() > 1e-5, "{exact}");
            assert_eq!(ic.y_axis.x, 0.0, "{ic}");
            assert!(
                close(ic, DMat3::from_diagonal(moments), 1e-12 * 6500.0),
                "{ic}"
            );
        } else {
            assert!(close(ic, exact, 1e-12 * 6500.0), "{theta}: {ic} vs {exact}");
        }
    }
}

fn load_err(path: &std::path::Path) -> String {
    match Model::from_mjcf_file(path, &LoadOptions::default()) {
        Err(e @ ModelError::Mjcf { .. }) => e.to_string(),
        other => panic!("expected an MJCF error, got {other:?}"),
    }
}

/// Truncated files, lying headers, missing files and flat meshes are errors that name the
/// model file, the `<mesh>` element, its attribute and the mesh file.
#[test]
fn hostile_meshes_are_clean_errors() {
    let d = dir("hostile");
    let good = binary_stl(&box_triangles([1.0; 3], [0.0; 3]), 12);
    write_mesh(&d, "truncated.stl", &good[..good.len() - 7]);
    write_mesh(
        &d,
        "liar.stl",
        &binary_stl(&box_triangles([1.0; 3], [0.0; 3]), 1_000_000_000),
    );
    let flat: Vec<_> = box_triangles([1.0, 1.0, 0.0], [0.0; 3]);
    write_mesh(&d, "flat.stl", &binary_stl(&flat, 12));
    for (file, what) in [
        ("truncated.stl", "truncated"),
        ("liar.stl", "1000000000 triangles"),
        ("missing.stl", "missing.stl"),
        ("flat.stl", "too small"),
        ("box.obj", "STL"),
    ] {
        let path = model_with(&d, file, "", "");
        let e = load_err(&path);
        assert!(
            e.contains("model.xml")
                && e.contains("<mesh name=\"m\">")
                && e.contains("attribute 'file'")
                && e.contains(file)
                && e.contains(what),
            "{file}: {e}"
        );
    }
}

/// `springdamper="τ ζ"` on a pendulum: MuJoCo's stiffness `m/(τ²ζ²)` and damping `2m/τ` with
/// `m` the joint's inertia at `qpos0` (here `m L² + ⅖ m r² + armature`, the bob a sphere at
/// distance L), and `ref` moving `qpos0` does not change it for a lone pendulum.
#[test]
fn springdamper_uses_the_joint_inertia() {
    let (mass, l, r, arm) = (2.0, 0.5, 0.1, 0.03);
    let (tc, dr) = (0.2, 0.7);
    let xml = format!(
        r#"<mujoco><worldbody><body name="b"><joint name="j" axis="0 1 0" ref="30"
        springdamper="{tc} {dr}" armature="{arm}"/>
        <geom type="sphere" size="{r}" pos="{l} 0 0" mass="{mass}"/></body></worldbody></mujoco>"#
    );
    let m = Model::from_mjcf_str(&xml, &LoadOptions::default()).unwrap();
    let inertia = mass * l * l + 0.4 * mass * r * r + arm;
    let k = m.dynamics.stiffness[0];
    let b = m.dynamics.damping[0];
    assert!((k - inertia / (tc * tc * dr * dr)).abs() < 1e-12 * k, "{k}");
    assert!((b - 2.0 * inertia / tc).abs() < 1e-12 * b, "{b}");
}
