//! `tyndall pick`: what one pixel sees (see [`crate::eval::pick`]).

use super::*;

/// `tyndall pick`.
#[derive(Args, Debug)]
pub struct PickArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// The pixel, X,Y (x right, y down, in the evaluation size).
    #[arg(long, value_parser = parse_pixel)]
    pub pixel: (u32, u32),
    /// Time (frames) at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// The node to read (one with `visibility` and `depth` ports); default: the first that
    /// reads both through inputs (a transfer function), else the first that produces both (a
    /// scattering node).
    #[arg(long)]
    pub node: Option<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Evaluation size, WIDTHxHEIGHT (the pixel refers to it; default 960x540, as `render`).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Override a parameter: NODE.PARAM=VALUE (repeatable).
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    pub set: Vec<String>,
    /// Accepted as `eval` and `render` take it; pick writes no file, so it changes nothing.
    #[arg(long, value_name = "DIR")]
    pub output_dir: Option<PathBuf>,
    /// Accepted as `eval` and `render` take it; pick writes no file, so it changes nothing.
    #[arg(long)]
    pub allow_any_path: bool,
}

pub(super) fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("expected X,Y, got {s:?}"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("{v:?} is not a pixel coordinate"))
    };
    Ok((n(x)?, n(y)?))
}

pub(super) fn run_pick(registry: Arc<Registry>, a: PickArgs) -> Result<(), CliError> {
    let common = Common {
        size: a.size,
        stats: false,
        wedge: None,
        set: a.set.clone(),
        output_dir: None,
        // pick writes nothing: the graph's output paths do not matter.
        allow_any_path: true,
        proxy: 1,
    };
    let g = load_graph(&registry, &a.graph, &common)?;
    let gpu = gpu()?;
    let mut ev = Evaluator::new(registry, gpu);
    let opts = EvalOptions {
        time: a.time,
        size: a.size.unwrap_or((960, 540)),
        ..Default::default()
    };
    let p = crate::eval::pick::pick(&mut ev, &g, a.node.as_deref(), a.pixel, &opts)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&p).map_err(|e| bad(e.to_string()))?
        );
        return Ok(());
    }
    println!(
        "pixel {},{} of {}x{} at time {} (node {})",
        p.pixel[0], p.pixel[1], p.size[0], p.size[1], p.time, p.node
    );
    println!("visibility  {:.6}", p.visibility);
    println!("depth       {:.4} m", p.depth);
    if let Some(t) = &p.tf {
        println!(
            "tf          u {:.6}  v {:.6}  (depth range {} {:.4} … {:.4} m)",
            t.u, t.v, t.depth_range, t.depth_min, t.depth_max
        );
    }
    match &p.surface {
        Some(s) => {
            println!(
                "surface     object {:?} triangle {} bary ({:.6}, {:.6}, {:.6}) at ({:.4}, {:.4}, {:.4})",
                s.object, s.triangle, s.bary[0], s.bary[1], s.bary[2], s.position[0], s.position[1], s.position[2]
            );
            println!(
                "anchor      anchor: Some((object: {:?}, triangle: {}, bary: ({:.6}, {:.6}, {:.6})))",
                s.object, s.triangle, s.bary[0], s.bary[1], s.bary[2]
            );
        }
        None => println!("surface     none (sky, or no scene upstream of the depth)"),
    }
    Ok(())
}
