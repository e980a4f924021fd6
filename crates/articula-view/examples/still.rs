//! Renders the first frame of a scene with every joint inactive (one colour per body) and its
//! top-down map: `cargo run -p articula-view --example still -- SCENE.json OUT_DIR`.

use articula_view::render::{render_map, render_view, rigid_groups, save_png, FrameBody};
use articula_view::{body_poses, Classifier, Placed};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let (scene, out) = match args.as_slice() {
        [_, s, o] => (s, std::path::PathBuf::from(o)),
        _ => return Err("usage: still SCENE.json OUT_DIR".into()),
    };
    let scene = articula_view::load_scene(scene).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
    let cam = scene.camera.at(0.0);
    let mut poses = Vec::new();
    let mut groups = Vec::new();
    let mut parents = Vec::new();
    for p in &scene.placements {
        let m = &scene.models[p.model].model;
        let mut ps = Vec::new();
        body_poses(m, &p.q, &mut ps);
        poses.push(ps);
        let par: Vec<Option<usize>> = m.bodies.iter().map(|b| b.parent).collect();
        let mut g = Vec::new();
        rigid_groups(&par, &vec![false; par.len()], &mut g);
        groups.push(g);
        parents.push(par);
    }
    let placed: Vec<Placed> = scene
        .placements
        .iter()
        .enumerate()
        .map(|(i, p)| Placed {
            volumes: &scene.models[p.model].volumes,
            poses: &poses[i],
            parents: &parents[i],
            margin: 0.0,
        })
        .collect();
    let mut cl = Classifier::new(&scene.visibility);
    let mut views = Vec::new();
    cl.classify(&cam, &scene.visibility, &placed, &mut views);
    let bodies: Vec<FrameBody> = scene
        .placements
        .iter()
        .enumerate()
        .map(|(i, p)| FrameBody {
            volumes: &scene.models[p.model].volumes,
            poses: &poses[i],
            groups: &groups[i],
            seed: i as u64,
            class: views[i].summary(),
            active_joints: i % 40,
        })
        .collect();
    let img = render_view(&cam, scene.image.width, scene.image.height, &bodies, 1234)?;
    save_png(&img, &out.join("view.png"))?;
    let map = render_map(&cam, 800, &bodies)?;
    save_png(&map, &out.join("map.png"))?;
    let mut counts = [0; 3];
    for v in &views {
        counts[v.summary() as usize] += 1;
    }
    println!(
        "visible {} occluded {} invisible {}",
        counts[0], counts[1], counts[2]
    );
    let mut links = [0; 3];
    for v in &views {
        for l in &v.links {
            links[*l as usize] += 1;
        }
    }
    println!(
        "links: visible {} occluded {} invisible {}",
        links[0], links[1], links[2]
    );
    let cov = cl.buffer.depth.iter().filter(|d| d.is_finite()).count();
    println!("depth cells covered {cov} of {}", cl.buffer.depth.len());
    Ok(())
}
