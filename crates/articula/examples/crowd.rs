//! A crowd built in code: 50 humanoids pushed away from a camera, one scene-wide budget of 400
//! joints spent where the camera looks, a PNG frame every 10 steps.
//! `cargo run --release --example crowd [-- OUT_DIR]` (default `target/crowd`).
use articula::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "target/crowd".into());
    let urdf = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/humanoid.urdf");
    let humanoid = Model::from_urdf_file(urdf, &LoadOptions::default().with_floating_base(true))?;
    let crowd = CrowdSpec {
        origin: [4.0, -4.5, 1.0],
        spacing: [1.2, 0.9],
        jitter: 0.3,
        ..CrowdSpec::new("humanoid", 5, 10)
    };
    let scene = SceneBuilder::new()
        .model("humanoid", humanoid)
        .crowd(CrowdSpec {
            yaw: std::f64::consts::PI,
            seed: 2005,
            ..crowd
        })
        .camera(CameraSpec::look_at([0.0, 0.0, 1.4], [12.0, 0.0, 1.1]))
        .budget(400)
        .dt(1.0 / 600.0)
        .reselect_every(10)
        .gravity([0.0; 3])
        .push(PushSpec {
            point: [0.0, 0.0, 0.2],
            ..PushSpec::new("chest", [150.0, 0.0, 0.0], 0.0, 0.5)
        })
        .build()?;
    let mut sim = SceneSim::new(&scene)?;
    std::fs::create_dir_all(&out)?;
    for k in 0..=300 {
        if k % 10 == 0 {
            sim.save_frame(format!("{out}/frame_{k:05}.png"))?;
        }
        let s = sim.step()?;
        if k % 50 == 0 {
            println!(
                "t = {:.3} s: {} of {} joints active, visible / occluded / invisible bodies {:?}",
                sim.time(),
                s.active_total,
                sim.dof_total(),
                s.classes
            );
        }
    }
    println!("frames in {out}/");
    Ok(())
}
