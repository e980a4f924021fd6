//! Writes the URDF of an n-link chain (the bodies of `models/chainN.urdf`) to stdout:
//! `cargo run --release -p articula-benches --example chain_urdf -- 100000 > /tmp/chain100k.urdf`
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("a link count"))
        .unwrap_or(300);
    print!("{}", articula_benches::chain_urdf(n));
}
