//! What the brush knows of the scene: the camera and the depth per pixel of the viewer's
//! picture (rendered by a worker job), and the geometry of the painting plane in that view.

use glam::{Mat4, Quat, Vec3, Vec4};

use tyndall_engine::eval::{EvalOptions, Evaluator, Matrices, PortValue, Registry, Target};
use tyndall_engine::graph::{Graph, PortType};

/// What the brush knows of the scene at the viewer's size.
#[derive(Debug, Clone)]
pub struct BrushView {
    /// What it was rendered for (the scene node, its port and the size).
    pub key: String,
    /// Picture size (pixels).
    pub size: (u32, u32),
    /// The camera at that size.
    pub camera: Matrices,
    /// Linear depth along the view direction per pixel, row-major, y down (sky: the far
    /// distance).
    pub depth: Vec<f32>,
}

/// The scene output the brush's camera comes from: the volume's `scene` input, else the first
/// Scene output of the graph's nodes (by id).
fn scene_source(registry: &Registry, graph: &Graph, target: &str) -> Option<(String, String)> {
    graph
        .source_of(target, "scene")
        .map(|(n, p)| (n.to_string(), p.to_string()))
        .or_else(|| {
            graph.nodes().find_map(|n| {
                let out = registry.get(&n.kind)?.schema().outputs;
                let port = out.iter().find(|p| p.types.contains(&PortType::Scene))?;
                Some((n.id.clone(), port.name.to_string()))
            })
        })
}

/// A kind that renders a scene's depth: a required Scene input, a Depth output, no other
/// required input and no side effect (the G-buffer): `(kind, scene input, depth output)`.
fn depth_renderer(registry: &Registry) -> Option<(&'static str, &'static str, &'static str)> {
    registry.iter().find_map(|k| {
        let s = k.schema();
        let required: Vec<_> = s.inputs.iter().filter(|p| p.required).collect();
        let [scene] = required.as_slice() else {
            return None;
        };
        let depth = s.outputs.iter().find(|p| p.types == [PortType::Depth])?;
        (scene.types.contains(&PortType::Scene) && !k.is_sink())
            .then_some((s.kind, scene.name, depth.name))
    })
}

/// What a brush view of `target` at `size` depends on: the scene node feeding it (its
/// parameters included), its port and the size.
pub(super) fn view_key(
    registry: &Registry,
    graph: &Graph,
    target: &str,
    size: (u32, u32),
) -> String {
    scene_source(registry, graph, target)
        .map(|(s, p)| format!("{:?}/{p}@{size:?}", graph.node(&s)))
        .unwrap_or_default()
}

/// Render the scene's depth for the brush with `ev` (the editor worker's evaluator, as a
/// tool job): a `GBuffer` fed by the scene source, evaluated at `size` and `time`.
pub fn render_view(
    ev: &mut Evaluator,
    graph: &Graph,
    target: &str,
    size: (u32, u32),
    time: f64,
) -> Result<BrushView, String> {
    let registry = ev.registry().clone();
    let (scene, port) = scene_source(&registry, graph, target)
        .ok_or("the graph has no Scene: the brush needs a camera to paint from")?;
    let (kind, scene_in, depth_out) =
        depth_renderer(&registry).ok_or("no node kind renders a scene's depth")?;
    let key = view_key(&registry, graph, target, size);
    let mut g = graph.clone();
    let cat = registry.catalog();
    let gb = g.add_node(cat, kind).map_err(|e| e.to_string())?;
    g.connect(cat, &format!("{scene}.{port}"), &format!("{gb}.{scene_in}"))
        .map_err(|e| e.to_string())?;
    let opts = EvalOptions {
        size,
        time,
        ..Default::default()
    };
    let r = ev
        .evaluate(&g, &[Target::Port(gb.clone(), depth_out.into())], &opts)
        .map_err(|e| e.to_string())?;
    let value = r
        .outputs
        .get(&(gb, depth_out.to_string()))
        .ok_or("the scene's depth was not produced")?;
    let PortValue::Depth(_, camera) = value else {
        return Err("the GBuffer's depth is not a Depth value".into());
    };
    let camera = *camera;
    let depth =
        tyndall_engine::eval::download(&ev.gpu().recorder(), value).map_err(|e| e.to_string())?;
    Ok(BrushView {
        key,
        size: (depth.width, depth.height),
        camera,
        depth: depth.data,
    })
}

/// The camera's orientation: the rotation taking the splat frame's x, y, z to the camera's
/// right, up and backward (view-space) axes in world space.
pub fn camera_rotation(camera: &Matrices) -> Quat {
    let inv = Mat4::from_cols_array_2d(&camera.view).inverse();
    let (x, y, z) = (
        inv.transform_vector3(Vec3::X).normalize_or(Vec3::X),
        inv.transform_vector3(Vec3::Y).normalize_or(Vec3::Y),
        inv.transform_vector3(Vec3::Z).normalize_or(Vec3::Z),
    );
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}

/// The point of the painting plane (`depth` m along the view direction) under the continuous
/// picture position `p` (pixels, y down) of a `size` picture; `None` where the ray does not
/// meet the plane in front of the camera.
pub fn plane_point(camera: &Matrices, p: [f32; 2], size: (u32, u32), depth: f32) -> Option<Vec3> {
    let inv = camera.view_proj().inverse();
    let ndc = Vec4::new(
        p[0] / size.0.max(1) as f32 * 2.0 - 1.0,
        1.0 - p[1] / size.1.max(1) as f32 * 2.0,
        1.0,
        1.0,
    );
    let far = inv * ndc;
    let eye = camera.eye();
    let dir = (far.truncate() / far.w - eye).normalize_or_zero();
    let forward = -camera.backward();
    let along = dir.dot(forward);
    (along > 1e-4 && depth > 0.0 && depth.is_finite()).then(|| eye + dir * (depth / along))
}

/// Distance of a world point along the camera's view direction.
pub fn view_depth(camera: &Matrices, p: Vec3) -> f32 {
    (p - camera.eye()).dot(-camera.backward())
}

/// Which pixels show the plane (their surface lies behind it), row-major.
pub fn plane_mask(view: &BrushView, depth: f32) -> Vec<bool> {
    view.depth.iter().map(|d| *d > depth).collect()
}
