//! Who stands and who falls in a scene of pushed characters: the figures behind the crowd's
//! story in README.md and docs/view.md.
//!
//! ```text
//! cargo run --release -p articula-view --example crowd_falls -- SCENE.json [SECONDS] [--exact]
//! cargo run --release -p articula-view --example crowd_falls -- SCENE.json [SECONDS] [--exact] --alone N F...
//! ```
//!
//! The first form steps the scene as `articula scene` does and prints, at every whole second,
//! how many characters are down (pelvis below 0.5 m; a standing humanoid's is at 1.02 m),
//! counted apart for the characters that get the scene's first push only ("light") and those
//! that get more than one ("strong").
//!
//! The second form builds one-character scenes from the same file: each of the first `N`
//! characters alone, at its place and yaw, with the file's springs, floor, time step and
//! budget, pushed at the first push's link and point by `F` newtons along the first push's
//! direction for the first push's duration, and prints for every force how many of the `N`
//! are down at each whole second.
//!
//! `--exact` steps the scene's exact reference instead (DCA on every character, every joint
//! moving: `articula scene --method dca`).
use std::error::Error;

use articula_dca::Method;
use articula_view::{load_scene, LoadedScene, Push, SceneMethod, SceneSim};

/// Pelvis height (m) below which a character counts as down.
const DOWN_BELOW_M: f64 = 0.5;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: crowd_falls SCENE.json [SECONDS] [--exact] [--alone N FORCE...]";
    let exact = args.iter().any(|a| a == "--exact");
    let args: Vec<String> = args.into_iter().filter(|a| a != "--exact").collect();
    let file = args.first().ok_or(usage)?;
    let scene = load_scene(file)?;
    let seconds: usize = match args.get(1) {
        Some(s) if s != "--alone" => s.parse()?,
        _ => 4,
    };
    match args.iter().position(|a| a == "--alone") {
        None => crowd(&scene, seconds, exact),
        Some(i) => {
            let n: usize = args.get(i + 1).ok_or(usage)?.parse()?;
            let forces = args[i + 2..]
                .iter()
                .map(|f| f.parse::<f64>())
                .collect::<Result<Vec<_>, _>>()?;
            alone(&scene, seconds, exact, n, &forces)
        }
    }
}

/// Whether each character is down at every whole second, and each one's visibility class at
/// the end (adaptive dynamics: an invisible character moves as one rigid body).
type Falls = (Vec<Vec<bool>>, Vec<String>);

/// Steps `scene` (its exact reference with `exact`) for `seconds`: see [`Falls`].
fn down_each_second(
    scene: &LoadedScene,
    seconds: usize,
    exact: bool,
) -> Result<Falls, Box<dyn Error>> {
    let steps_per_second = (1.0 / scene.dt).round() as usize;
    let mut sim = SceneSim::new(scene)?;
    if exact {
        sim.set_method(SceneMethod::Exact(Method::Dca));
    }
    let mut out = Vec::with_capacity(seconds);
    for _ in 0..seconds {
        for _ in 0..steps_per_second {
            sim.step()?;
        }
        out.push(
            sim.bodies
                .iter()
                .map(|b| b.state.q[2] < DOWN_BELOW_M)
                .collect(),
        );
    }
    let classes = if exact {
        vec!["exact".to_string(); sim.bodies.len()]
    } else {
        sim.views
            .iter()
            .map(|v| format!("{:?}", v.summary()).to_lowercase())
            .collect()
    };
    Ok((out, classes))
}

/// The whole scene: down counts by push group at every whole second.
fn crowd(scene: &LoadedScene, seconds: usize, exact: bool) -> Result<(), Box<dyn Error>> {
    let n = scene.placements.len();
    let mut pushes = vec![0usize; n];
    for p in &scene.pushes {
        pushes[p.body] += 1;
    }
    let light: Vec<bool> = pushes.iter().map(|&k| k == 1).collect();
    let n_light = light.iter().filter(|&&l| l).count();
    println!(
        "{}: {n} characters, {n_light} pushed once (light), {} more than once (strong)",
        scene.path.display(),
        pushes.iter().filter(|&&k| k > 1).count()
    );
    let (falls, classes) = down_each_second(scene, seconds, exact)?;
    for (s, down) in falls.iter().enumerate() {
        let d_light = down.iter().zip(&light).filter(|(&d, &l)| d && l).count();
        let d_all = down.iter().filter(|&&d| d).count();
        println!(
            "t = {} s: {d_all} down ({d_light} of {n_light} light, {} strong)",
            s + 1,
            d_all - d_light
        );
    }
    // The light ones at the end, by their class at the last re-selection.
    let mut by_class = std::collections::BTreeMap::<&str, (usize, usize)>::new();
    if let Some(last) = falls.last() {
        for i in (0..n).filter(|&i| light[i]) {
            let e = by_class.entry(classes[i].as_str()).or_default();
            if last[i] {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    for (class, (down, up)) in by_class {
        println!("light, {class} at the end: {down} down, {up} standing");
    }
    Ok(())
}

/// One-character scenes: for every force, how many of the first `n` characters, each alone,
/// are down at every whole second.
fn alone(
    scene: &LoadedScene,
    seconds: usize,
    exact: bool,
    n: usize,
    forces: &[f64],
) -> Result<(), Box<dyn Error>> {
    let first = *scene.pushes.first().ok_or("the scene has no push")?;
    let direction = first.force.normalize();
    println!(
        "{}: each of the first {n} characters alone, pushed at model body {} for {}..{} s",
        scene.path.display(),
        first.link_body,
        first.t0,
        first.t1
    );
    for &f in forces {
        let mut down = vec![0usize; seconds];
        for placement in scene.placements.iter().take(n) {
            let mut one = scene.clone();
            one.placements = vec![placement.clone()];
            one.pushes = vec![Push {
                body: 0,
                force: direction * f,
                ..first
            }];
            for (s, d) in down_each_second(&one, seconds, exact)?.0.iter().enumerate() {
                down[s] += usize::from(d[0]);
            }
        }
        let by_second: Vec<String> = down
            .iter()
            .enumerate()
            .map(|(s, d)| format!("{d} at {} s", s + 1))
            .collect();
        println!("{f} N: down {}", by_second.join(", "));
    }
    Ok(())
}
