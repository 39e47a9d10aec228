//! `cargo bench --bench kdtree`: kd-tree build time, size and SAH cost on the Stanford dragon at
//! 11k, 48k, 100k, 202k and 871k triangles (from ../shared/seed/mesh; skipped when absent),
//! beside the original's median tree. The build runs on the host CPU, single-threaded.
//! BENCHMARKS.md records the figures with the machine.

#[path = "../tests/common/mod.rs"]
mod common;

use clpt::accel::kdtree::{KdParams, KdTree};
use clpt::scene::mesh::TriangleMesh;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), clpt::Error> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/seed/mesh");
    println!(
        "| mesh | triangles | SAH build s | ns per n log2 n | nodes | max depth | bytes/triangle (tree) | bytes/triangle (all) | SAH cost | median-tree SAH cost |\n\
         |---|---|---|---|---|---|---|---|---|---|"
    );
    for name in common::DRAGONS {
        let path = dir.join(format!("{name}.obj"));
        if !path.is_file() {
            eprintln!("SKIPPED {name}: {} not found", path.display());
            continue;
        }
        let mesh = TriangleMesh::load(&path)?;
        let n = mesh.triangles.len();
        // Best of three builds.
        let mut best = f64::INFINITY;
        let mut tree = None;
        for _ in 0..3 {
            let start = Instant::now();
            let t = KdTree::build(&mesh.positions, &mesh.triangles, &KdParams::default());
            best = best.min(start.elapsed().as_secs_f64());
            tree = Some(t);
        }
        let Some(tree) = tree else { continue };
        let stats = tree.stats(&mesh.positions, &mesh.triangles);
        let median = KdTree::build_median(&mesh.positions, &mesh.triangles);
        let median_stats = median.stats(&mesh.positions, &mesh.triangles);
        // Everything a mesh puts on the device: tree, index triples, vertices (12 bytes each).
        let all = stats.bytes + n * 12 + mesh.positions.len() * 12;
        println!(
            "| {name} | {n} | {best:.3} | {:.1} | {} | {} | {:.1} | {:.1} | {:.2} | {:.2} |",
            best * 1e9 / (n as f64 * (n as f64).log2()),
            stats.nodes,
            stats.max_depth,
            stats.bytes as f64 / n as f64,
            all as f64 / n as f64,
            stats.sah_cost,
            median_stats.sah_cost
        );
    }
    Ok(())
}
