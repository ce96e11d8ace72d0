//! How long reading one OpenVDB grid takes (issue #61's loading goal): `read_vdb_grid` — parse,
//! decompress, densify — timed over several runs, without the GPU upload.
//!
//!     /usr/bin/python3 scripts/make_vdb_256.py /tmp/big256.vdb   # a 256³ half-float Blosc grid
//!     cargo run --release --example vdb_load -- /tmp/big256.vdb [GRID] [RUNS]

use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: vdb_load FILE.vdb [GRID] [RUNS]");
        std::process::exit(2);
    };
    let grid = args.get(2).map_or("density", String::as_str);
    let runs: usize = args.get(3).and_then(|r| r.parse().ok()).unwrap_or(5);
    let mut times = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        match tyndall::io::read_vdb_grid(Path::new(path), grid, 1024) {
            Ok(g) => {
                times.push(t.elapsed().as_secs_f64());
                if times.len() == 1 {
                    println!(
                        "{path}: grid '{}' ({}), {}×{}×{} texels, {} active voxels",
                        g.name, g.grid_type, g.dims[0], g.dims[1], g.dims[2], g.active_voxels
                    );
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(2);
            }
        }
    }
    times.sort_by(|a, b| a.total_cmp(b));
    println!(
        "read_vdb_grid: median {:.3} s, min {:.3} s over {runs} runs",
        times[times.len() / 2],
        times[0]
    );
}
