//! Built-in procedural scenes, each deterministic from a seed.
//!
//! | name | what | tags |
//! |---|---|---|
//! | `torus` | a torus floating over a ground plane, lit from above (seed 000 Fig. 3) | `torus`, `ground` |
//! | `tree` | a trunk and a canopy of many small leaves with gaps: many thin shafts | `trunk`, `foliage`, `ground` |
//! | `window` | a room whose wall has window openings: classic shafts | `wall`, `floor` |
//! | `fence` | vertical poles and a horizontal bar (seed 004 Fig. 20) | `fence`, `ground` |
//! | `figure` | a solid figure standing in light, for silhouette enhancement | `figure`, `ground` |

use glam::{Quat, Vec3};

use super::{Camera, Light, Object, Scene, SceneError, Sun};

/// Names of the built-in scenes.
pub const BUILTIN_SCENES: &[&str] = Builtin::NAMES;

crate::choice_enum! {
    /// The built-in scenes.
    pub enum Builtin { Torus = "torus", Tree = "tree", Window = "window", Fence = "fence", Figure = "figure" }
}

/// SplitMix64: small, seedable, deterministic across platforms.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn f(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
}

fn object(name: &str, colour: [f32; 4], tags: &[&str]) -> Object {
    Object {
        name: name.to_string(),
        node: name.to_string(),
        material: String::new(),
        positions: Vec::new(),
        normals: Vec::new(),
        indices: Vec::new(),
        colour,
        tags: tags.iter().map(|t| t.to_string()).collect(),
        placement: None,
    }
}

/// Append a quad (corners counter-clockwise seen from the normal's side).
fn quad(o: &mut Object, corners: [Vec3; 4]) {
    let n = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize_or(Vec3::Y);
    let base = o.positions.len() as u32;
    for c in corners {
        o.positions.push(c);
        o.normals.push(n);
    }
    o.indices
        .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// Append an oriented box: centre, half extents, rotation.
fn cuboid(o: &mut Object, centre: Vec3, half: Vec3, rot: Quat) {
    let p = |x: f32, y: f32, z: f32| centre + rot * Vec3::new(x * half.x, y * half.y, z * half.z);
    let faces = [
        [
            p(-1., -1., 1.),
            p(1., -1., 1.),
            p(1., 1., 1.),
            p(-1., 1., 1.),
        ],
        [
            p(1., -1., -1.),
            p(-1., -1., -1.),
            p(-1., 1., -1.),
            p(1., 1., -1.),
        ],
        [
            p(1., -1., 1.),
            p(1., -1., -1.),
            p(1., 1., -1.),
            p(1., 1., 1.),
        ],
        [
            p(-1., -1., -1.),
            p(-1., -1., 1.),
            p(-1., 1., 1.),
            p(-1., 1., -1.),
        ],
        [
            p(-1., 1., 1.),
            p(1., 1., 1.),
            p(1., 1., -1.),
            p(-1., 1., -1.),
        ],
        [
            p(-1., -1., -1.),
            p(1., -1., -1.),
            p(1., -1., 1.),
            p(-1., -1., 1.),
        ],
    ];
    for f in faces {
        quad(o, f);
    }
}

/// Append a UV sphere.
fn sphere(o: &mut Object, centre: Vec3, radius: Vec3, segments: u32) {
    let rings = segments / 2;
    let base = o.positions.len() as u32;
    for r in 0..=rings {
        let phi = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let theta = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin());
            o.positions.push(centre + n * radius);
            o.normals.push((n / radius).normalize_or(n));
        }
    }
    let stride = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = base + r * stride + s;
            let b = a + stride;
            o.indices.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
        }
    }
}

/// Append a torus around +Y.
fn torus(o: &mut Object, centre: Vec3, major: f32, minor: f32, seg_major: u32, seg_minor: u32) {
    let base = o.positions.len() as u32;
    for i in 0..=seg_major {
        let u = std::f32::consts::TAU * i as f32 / seg_major as f32;
        let ring = Vec3::new(u.cos(), 0.0, u.sin());
        for j in 0..=seg_minor {
            let v = std::f32::consts::TAU * j as f32 / seg_minor as f32;
            let n = ring * v.cos() + Vec3::Y * v.sin();
            o.positions.push(centre + ring * major + n * minor);
            o.normals.push(n);
        }
    }
    let stride = seg_minor + 1;
    for i in 0..seg_major {
        for j in 0..seg_minor {
            let a = base + i * stride + j;
            let b = a + stride;
            o.indices.extend_from_slice(&[a, a + 1, b, a + 1, b + 1, b]);
        }
    }
}

/// Append a vertical cylinder (with caps).
fn cylinder(o: &mut Object, bottom: Vec3, radius: f32, height: f32, segments: u32) {
    let base = o.positions.len() as u32;
    for i in 0..=segments {
        let a = std::f32::consts::TAU * i as f32 / segments as f32;
        let n = Vec3::new(a.cos(), 0.0, a.sin());
        o.positions.push(bottom + n * radius);
        o.normals.push(n);
        o.positions.push(bottom + n * radius + Vec3::Y * height);
        o.normals.push(n);
    }
    for i in 0..segments {
        let a = base + i * 2;
        o.indices
            .extend_from_slice(&[a, a + 1, a + 2, a + 1, a + 3, a + 2]);
    }
    let top = bottom + Vec3::Y * height;
    let c = o.positions.len() as u32;
    o.positions.push(top);
    o.normals.push(Vec3::Y);
    for i in 0..=segments {
        let a = std::f32::consts::TAU * i as f32 / segments as f32;
        o.positions
            .push(top + Vec3::new(a.cos(), 0.0, a.sin()) * radius);
        o.normals.push(Vec3::Y);
    }
    for i in 0..segments {
        o.indices.extend_from_slice(&[c, c + 2 + i, c + 1 + i]);
    }
}

fn ground(size: f32) -> Object {
    let mut g = object("ground", [0.55, 0.53, 0.5, 1.0], &["ground"]);
    let s = size;
    quad(
        &mut g,
        [
            Vec3::new(-s, 0.0, s),
            Vec3::new(s, 0.0, s),
            Vec3::new(s, 0.0, -s),
            Vec3::new(-s, 0.0, -s),
        ],
    );
    g
}

/// Build the built-in scene `name` (one of [`BUILTIN_SCENES`]) from `seed`.
pub fn builtin(name: &str, seed: u64) -> Result<Scene, SceneError> {
    let which =
        Builtin::from_name(name).ok_or_else(|| SceneError::UnknownBuiltin(name.to_string()))?;
    let mut rng = Rng(seed ^ 0x7479_6e64_616c_6c00);
    Ok(match which {
        Builtin::Torus => torus_scene(),
        Builtin::Tree => tree_scene(&mut rng, seed),
        Builtin::Window => window_scene(&mut rng),
        Builtin::Fence => fence_scene(&mut rng),
        Builtin::Figure => figure_scene(&mut rng),
    })
}

/// A torus hovering over the ground: one clean ring of shafts.
fn torus_scene() -> Scene {
    let mut t = object("torus", [0.8, 0.35, 0.2, 1.0], &["torus"]);
    torus(&mut t, Vec3::new(0.0, 3.0, 0.0), 2.0, 0.6, 64, 24);
    Scene {
        objects: vec![ground(10.0), t],
        camera: Camera {
            position: Vec3::new(8.0, 1.2, 9.0),
            target: Vec3::new(0.0, 2.2, 0.0),
            fov_y: 50.0,
            near: 0.1,
            far: 60.0,
        },
        lights: vec![Light::sun(
            "sun",
            Sun {
                azimuth: 225.0,
                elevation: 50.0,
                colour: [1.0, 0.95, 0.85],
                intensity: 3.0,
            },
        )],
        medium: None,
        volumes: Vec::new(),
    }
}

/// A tree whose canopy of 2200 leaf quads has gaps (varied by `seed`): dappled shafts.
fn tree_scene(rng: &mut Rng, seed: u64) -> Scene {
    let mut trunk = object("trunk", [0.35, 0.25, 0.18, 1.0], &["trunk"]);
    cylinder(&mut trunk, Vec3::ZERO, 0.35, 5.0, 16);
    for k in 0..5 {
        let a = k as f32 * 1.3 + rng.range(0.0, 0.5);
        let dir = Vec3::new(a.cos(), 0.8, a.sin()).normalize();
        let c = Vec3::new(0.0, 3.8 + k as f32 * 0.3, 0.0) + dir * 1.0;
        cuboid(
            &mut trunk,
            c,
            Vec3::new(0.09, 1.1, 0.09),
            Quat::from_rotation_arc(Vec3::Y, dir),
        );
    }
    let mut leaves = object("canopy", [0.25, 0.5, 0.18, 1.0], &["foliage"]);
    let centre = Vec3::new(0.0, 6.2, 0.0);
    let mut placed = 0;
    while placed < 2200 {
        let p = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if p.length() > 1.0 {
            continue;
        }
        // Gaps: a few empty lobes inside the canopy so light breaks through.
        let gap =
            (p.x * 3.1 + seed as f32 * 0.37).sin() * (p.z * 2.7).cos() * (p.y * 2.3 + 1.0).sin();
        if gap > 0.35 {
            continue;
        }
        let pos = centre + p * Vec3::new(3.2, 2.0, 3.2);
        let rot = Quat::from_euler(
            glam::EulerRot::XYZ,
            rng.range(0.0, 6.3),
            rng.range(0.0, 6.3),
            rng.range(0.0, 6.3),
        );
        let s = rng.range(0.12, 0.22);
        let corners = [
            Vec3::new(-s, 0.0, -s),
            Vec3::new(s, 0.0, -s),
            Vec3::new(s, 0.0, s),
            Vec3::new(-s, 0.0, s),
        ]
        .map(|c| pos + rot * c);
        quad(&mut leaves, corners);
        placed += 1;
    }
    Scene {
        objects: vec![ground(12.0), trunk, leaves],
        camera: Camera {
            position: Vec3::new(9.0, 2.2, 9.5),
            target: Vec3::new(0.0, 3.5, 0.0),
            fov_y: 50.0,
            near: 0.1,
            far: 60.0,
        },
        lights: vec![Light::sun(
            "sun",
            Sun {
                azimuth: 225.0,
                elevation: 38.0,
                colour: [1.0, 0.92, 0.78],
                intensity: 3.0,
            },
        )],
        medium: None,
        volumes: Vec::new(),
    }
}

/// A room lit through three windows in its +x wall (their spacing varied by `seed`).
fn window_scene(rng: &mut Rng) -> Scene {
    let mut walls = object("walls", [0.75, 0.72, 0.68, 1.0], &["wall"]);
    let (w, h, d) = (6.0f32, 3.5f32, 8.0f32);
    let t = 0.15;
    let mut floor = object("floor", [0.5, 0.42, 0.35, 1.0], &["floor"]);
    cuboid(
        &mut floor,
        Vec3::new(0.0, -t, 0.0),
        Vec3::new(w, t, d),
        Quat::IDENTITY,
    );
    cuboid(
        &mut walls,
        Vec3::new(0.0, h + t, 0.0),
        Vec3::new(w, t, d),
        Quat::IDENTITY,
    );
    cuboid(
        &mut walls,
        Vec3::new(0.0, h / 2.0, -d),
        Vec3::new(w, h / 2.0, t),
        Quat::IDENTITY,
    );
    cuboid(
        &mut walls,
        Vec3::new(0.0, h / 2.0, d),
        Vec3::new(w, h / 2.0, t),
        Quat::IDENTITY,
    );
    cuboid(
        &mut walls,
        Vec3::new(-w, h / 2.0, 0.0),
        Vec3::new(t, h / 2.0, d),
        Quat::IDENTITY,
    );
    // The +x wall has three windows: built from a lower band, an upper band and piers.
    let (sill, lintel) = (1.0f32, 2.7f32);
    cuboid(
        &mut walls,
        Vec3::new(w, sill / 2.0, 0.0),
        Vec3::new(t, sill / 2.0, d),
        Quat::IDENTITY,
    );
    cuboid(
        &mut walls,
        Vec3::new(w, (lintel + h) / 2.0, 0.0),
        Vec3::new(t, (h - lintel) / 2.0, d),
        Quat::IDENTITY,
    );
    let jitter = rng.range(-0.3, 0.3);
    let windows = [-4.0 + jitter, 0.0, 4.0 - jitter];
    let half_w = 0.8;
    let mut edges = vec![-d];
    for c in windows {
        edges.push(c - half_w);
        edges.push(c + half_w);
    }
    edges.push(d);
    for pair in edges.chunks(2) {
        let (z0, z1) = (pair[0], pair[1]);
        let hm = (lintel - sill) / 2.0;
        cuboid(
            &mut walls,
            Vec3::new(w, sill + hm, (z0 + z1) / 2.0),
            Vec3::new(t, hm, (z1 - z0) / 2.0),
            Quat::IDENTITY,
        );
    }
    Scene {
        objects: vec![floor, walls],
        camera: Camera {
            position: Vec3::new(-4.8, 1.7, -6.5),
            target: Vec3::new(2.0, 1.2, 1.0),
            fov_y: 60.0,
            near: 0.05,
            far: 40.0,
        },
        lights: vec![Light::sun(
            "sun",
            Sun {
                azimuth: 70.0,
                elevation: 30.0,
                colour: [1.0, 0.9, 0.75],
                intensity: 4.0,
            },
        )],
        medium: None,
        volumes: Vec::new(),
    }
}

/// A picket fence: eleven posts and a rail, low sun behind it.
fn fence_scene(rng: &mut Rng) -> Scene {
    let mut f = object("fence", [0.45, 0.33, 0.22, 1.0], &["fence"]);
    for i in 0..11 {
        let x = -5.0 + i as f32 + rng.range(-0.05, 0.05);
        let hgt = 2.0 + rng.range(-0.1, 0.1);
        cuboid(
            &mut f,
            Vec3::new(x, hgt / 2.0, 0.0),
            Vec3::new(0.12, hgt / 2.0, 0.12),
            Quat::IDENTITY,
        );
    }
    cuboid(
        &mut f,
        Vec3::new(0.0, 1.4, 0.16),
        Vec3::new(5.4, 0.1, 0.04),
        Quat::IDENTITY,
    );
    Scene {
        objects: vec![ground(10.0), f],
        camera: Camera {
            position: Vec3::new(2.5, 1.6, 8.0),
            target: Vec3::new(0.0, 1.0, -1.0),
            fov_y: 50.0,
            near: 0.1,
            far: 50.0,
        },
        lights: vec![Light::sun(
            "sun",
            Sun {
                azimuth: 180.0,
                elevation: 25.0,
                colour: [1.0, 0.85, 0.65],
                intensity: 3.0,
            },
        )],
        medium: None,
        volumes: Vec::new(),
    }
}

/// A standing figure of boxes and a head, sun behind it.
fn figure_scene(rng: &mut Rng) -> Scene {
    let mut fig = object("figure", [0.6, 0.6, 0.65, 1.0], &["figure"]);
    let lean = rng.range(-0.05, 0.05);
    let r = Quat::from_rotation_z(lean);
    cuboid(
        &mut fig,
        Vec3::new(-0.2, 0.9, 0.0),
        Vec3::new(0.12, 0.45, 0.12),
        Quat::IDENTITY,
    );
    cuboid(
        &mut fig,
        Vec3::new(0.2, 0.9, 0.0),
        Vec3::new(0.12, 0.45, 0.12),
        Quat::IDENTITY,
    );
    cuboid(
        &mut fig,
        Vec3::new(0.0, 1.75, 0.0),
        Vec3::new(0.38, 0.45, 0.2),
        r,
    );
    cuboid(
        &mut fig,
        Vec3::new(-0.55, 1.75, 0.0),
        Vec3::new(0.1, 0.42, 0.1),
        Quat::from_rotation_z(-0.25),
    );
    cuboid(
        &mut fig,
        Vec3::new(0.55, 1.75, 0.0),
        Vec3::new(0.1, 0.42, 0.1),
        Quat::from_rotation_z(0.25),
    );
    sphere(&mut fig, Vec3::new(0.0, 2.5, 0.0), Vec3::splat(0.22), 24);
    Scene {
        objects: vec![ground(8.0), fig],
        camera: Camera {
            position: Vec3::new(0.8, 1.5, 6.0),
            target: Vec3::new(0.0, 1.6, 0.0),
            fov_y: 50.0,
            near: 0.1,
            far: 40.0,
        },
        lights: vec![Light::sun(
            "sun",
            Sun {
                azimuth: 190.0,
                elevation: 30.0,
                colour: [1.0, 0.93, 0.8],
                intensity: 3.0,
            },
        )],
        medium: None,
        volumes: Vec::new(),
    }
}
