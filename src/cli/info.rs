//! `tyndall info`: what this machine offers Tyndall, as a bug report should contain it.

use std::fmt::Write as _;

use crate::eval::Registry;
use crate::gpu::adapter::{self, AdapterReport, Chosen, ShaderNeeds};

/// The nodes of `registry` that an adapter cannot run, with what it lacks for each.
fn unavailable_nodes(registry: &Registry, r: &AdapterReport) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for k in registry.iter() {
        let decl = k.decl();
        let mut lacks = Vec::new();
        for shader in decl.shaders {
            let more = shader
                .wgsl()
                .and_then(ShaderNeeds::of)
                .map(|n| r.caps.lacks_for(&n))
                .unwrap_or_else(|e| vec![format!("shader {} does not parse: {e}", shader.stem)]);
            // A shader only some parameter values dispatch refuses those values, not the kind.
            let on_demand = decl.on_demand.iter().any(|s| s.stem == shader.stem);
            for l in more {
                let l = if on_demand {
                    format!("{l} (only for the method using {}.wgsl)", shader.stem)
                } else {
                    l
                };
                if !lacks.contains(&l) {
                    lacks.push(l);
                }
            }
        }
        if !lacks.is_empty() {
            out.push((decl.schema.kind.to_string(), lacks.join("; ")));
        }
    }
    out
}

/// The substitutes `src/engine/gpu/` uses on this adapter, in words.
fn substitutes(r: &AdapterReport) -> Vec<String> {
    let mut out = Vec::new();
    let caps = &r.caps;
    if caps.stored(wgpu::TextureFormat::Rg32Float) != wgpu::TextureFormat::Rg32Float {
        out.push("Rg32Float textures stored as Rgba32Float (no rg32float storage)".to_string());
    }
    for f in [
        wgpu::TextureFormat::R32Float,
        wgpu::TextureFormat::Rgba32Float,
    ] {
        match caps.render_format(f) {
            Some(r) if r != f => out.push(format!(
                "{f:?} rasterised as {r:?} bit patterns (no renderable 32-bit float format)"
            )),
            _ => {}
        }
    }
    if caps.volume_rows() {
        out.push(
            "volume levels written through storage buffers copied into the 3D texture (no layered 3D storage images)"
                .to_string(),
        );
    }
    out
}

/// The report, as text or JSON.
pub fn report(registry: &Registry, json: bool) -> String {
    let survey = adapter::survey(crate::gpu::instance(false), crate::gpu::env_backends());
    let pick = crate::gpu::adapter_choice();
    let chosen = survey.choose(pick.as_deref());
    let version = env!("CARGO_PKG_VERSION");
    let format = crate::graph::FORMAT_VERSION;
    let backends = std::env::var("WGPU_BACKEND").ok().filter(|v| !v.is_empty());
    if json {
        let adapters: Vec<serde_json::Value> = survey
            .reports
            .iter()
            .map(|r| adapter_json(registry, r))
            .collect();
        let (used, why, error) = match &chosen {
            Ok((i, c)) => (Some(*i), Some(why_chosen(c)), None),
            Err(e) => (None, None, Some(e.message.clone())),
        };
        let colour = match tyndall_engine::colour::current() {
            Ok(c) => serde_json::json!({
                "config": c.source(),
                "working_space": c
                    .colour_space("", tyndall_engine::colour::WORKING_SPACE)
                    .ok(),
                "displays": c.displays().iter().map(|d| serde_json::json!({
                    "name": d, "views": c.views(d)})).collect::<Vec<_>>(),
                "looks": c.looks(),
            }),
            Err(e) => serde_json::json!({ "error": e.to_string() }),
        };
        let v = serde_json::json!({
            "tyndall": version,
            "colour": colour,
            "graph_format": format,
            "wgpu_backend": backends,
            "tyndall_adapter": pick,
            "adapters": adapters,
            "used": used,
            "why": why,
            "error": error,
            "memory_budget_bytes": memory_budget(&survey, used).0,
            "memory_budget_from": memory_budget(&survey, used).1,
        });
        return serde_json::to_string_pretty(&v).unwrap_or_default() + "\n";
    }
    let mut s = String::new();
    let _ = writeln!(s, "tyndall {version} (graph format v{format})");
    let _ = writeln!(
        s,
        "backends: {}{}",
        backends.as_deref().unwrap_or("all (WGPU_BACKEND unset)"),
        pick.as_deref().map_or(String::new(), |p| format!(
            "; adapter chosen by hand: '{p}'"
        ))
    );
    if survey.reports.is_empty() {
        let _ = writeln!(s, "adapters: none found");
    } else {
        let _ = writeln!(s, "adapters:");
    }
    for r in &survey.reports {
        let used = matches!(&chosen, Ok((i, _)) if *i == r.index);
        adapter_text(&mut s, registry, r, used);
    }
    match &chosen {
        Ok((i, c)) => {
            let r = &survey.reports[*i];
            let l = &r.caps.limits;
            let _ = writeln!(s, "used: [{i}] {}: {}", r.describe(), why_chosen(c));
            let _ = writeln!(
                s,
                "limits: 2D texture side {}, 3D texture side {}, largest buffer {} MiB, largest storage binding {} MiB",
                l.max_texture_dimension_2d,
                l.max_texture_dimension_3d,
                l.max_buffer_size >> 20,
                l.max_storage_buffer_binding_size >> 20
            );
            let (budget, from) = memory_budget(&survey, Some(*i));
            let _ = writeln!(
                s,
                "memory budget in use: {} MiB per allocation (from {from})",
                budget.unwrap_or(0) >> 20
            );
        }
        Err(e) => {
            let _ = writeln!(s, "used: none\n{}", e.message);
        }
    }
    match tyndall_engine::colour::current() {
        Ok(c) => s.push_str(&c.describe()),
        Err(e) => {
            let _ = writeln!(s, "colour config: {e}");
        }
    }
    s
}

/// One adapter of the survey, as JSON.
fn adapter_json(registry: &Registry, r: &AdapterReport) -> serde_json::Value {
    let l = &r.caps.limits;
    serde_json::json!({
        "index": r.index,
        "name": r.info.name,
        "backend": adapter::backend_name(r.info.backend),
        "device_type": adapter::device_type_name(r.info.device_type),
        "driver": r.info.driver,
        "driver_info": r.info.driver_info,
        "qualifies": r.qualifies(),
        "lacks": r.lacks,
        "substitutes": substitutes(r),
        "nodes_unavailable": unavailable_nodes(registry, r)
            .into_iter()
            .map(|(k, why)| serde_json::json!({"kind": k, "lacks": why}))
            .collect::<Vec<_>>(),
        "limits": {
            "max_texture_dimension_2d": l.max_texture_dimension_2d,
            "max_texture_dimension_3d": l.max_texture_dimension_3d,
            "max_buffer_size": l.max_buffer_size,
            "max_storage_buffer_binding_size": l.max_storage_buffer_binding_size,
            "max_storage_textures_per_shader_stage": l.max_storage_textures_per_shader_stage,
            "max_sampled_textures_per_shader_stage": l.max_sampled_textures_per_shader_stage,
        },
    })
}

/// One adapter of the survey, as text lines (`used`: the one chosen).
fn adapter_text(s: &mut String, registry: &Registry, r: &AdapterReport, used: bool) {
    let _ = writeln!(
        s,
        "  [{}] {}{}",
        r.index,
        r.describe(),
        if used { "  <- used" } else { "" }
    );
    let _ = writeln!(s, "      driver: {} {}", r.info.driver, r.info.driver_info);
    if r.qualifies() {
        let _ = writeln!(s, "      qualifies");
    } else {
        let _ = writeln!(s, "      does not qualify: lacks {}", r.lacks.join("; "));
    }
    for sub in substitutes(r) {
        let _ = writeln!(s, "      substitute: {sub}");
    }
    if r.qualifies() {
        for (kind, why) in unavailable_nodes(registry, r) {
            let _ = writeln!(s, "      cannot run {kind}: lacks {why}");
        }
    }
}

fn why_chosen(c: &Chosen) -> String {
    match c {
        Chosen::ByHand(p) => format!("chosen by hand ('{p}', --adapter or TYNDALL_ADAPTER)"),
        Chosen::Best => "the best that qualifies (discrete, integrated, virtual, then CPU; Vulkan/Metal/DX12 before GL)".to_string(),
    }
}

/// The per-allocation budget the evaluator enforces on adapter `used` (see
/// [`crate::gpu::Gpu::allocation_limit`]), and where it comes from.
fn memory_budget(survey: &adapter::Survey, used: Option<usize>) -> (Option<u64>, &'static str) {
    let env = std::env::var("TYNDALL_GPU_MEMORY_MB")
        .ok()
        .and_then(|v| v.parse::<u64>().ok());
    match (env, used) {
        (Some(mb), _) => (Some(mb.saturating_mul(1 << 20)), "TYNDALL_GPU_MEMORY_MB"),
        (None, Some(i)) => (
            Some(survey.reports[i].caps.limits.max_buffer_size),
            "the adapter's max_buffer_size",
        ),
        (None, None) => (None, "no adapter"),
    }
}
