//! Loads a URDF and prints its bodies, composed joints and assembly tree.
//!
//! `cargo run -p articula-model --example load -- models/humanoid.urdf`

use articula_model::{LoadOptions, Model};

fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/humanoid.urdf").to_string()
    });
    let model = match Model::from_urdf_file(&path, &LoadOptions::default()) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    println!(
        "{}: {} bodies, {} DOF, moving mass {:.3} kg, tree depth {}, max handles {}",
        model.name,
        model.bodies.len(),
        model.nv,
        model.moving_mass(),
        model.assembly.depth(),
        model.assembly.max_handles()
    );
    for b in model.bodies.iter().filter(|b| b.joint.len() > 1) {
        println!("  composed joint {} -> body {}", b.joint_name(), b.name);
    }
    print!("{}", model.assembly.outline(&model));
}
