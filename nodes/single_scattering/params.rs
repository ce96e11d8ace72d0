//! SingleScattering's uniform structs (the WGSL `Params`, `SoftView`, `Levels`, `Build`,
//! `LightMapView`, `Epi` of `shaders/single_scattering/`) and how they are filled.

use super::{EpiGeometry, EpiKnobs, EpiSlice, Matrices, Params, Vec3};
use tyndall_engine::eval::LightBlock;

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/single_scattering/common.wgsl` (struct `Params`).
    pub struct ScatterParams as "Params" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Samples per ray.
        pub steps: u32,
        /// σt.
        pub sigma_t: f32,
        /// ρ.
        pub albedo: f32,
        /// HG g.
        pub g: f32,
        /// Jitter in intervals.
        pub jitter: f32,
        /// Shadow bias.
        pub bias: f32,
        /// MinMax: pyramid level at and below which mixed blocks are estimated, not refined
        /// (0 = exact).
        pub min_level: u32,
        /// Width of the connected phase table (0: Henyey–Greenstein `g`).
        pub phase_width: u32,
        /// Slices of the connected soft visibility volume (0: the hard shadow-map test).
        pub soft_slices: u32,
        /// Medium box, low corner (when `bounded`).
        pub box_min: [f32; 3],
        /// 1 when the medium is the box, 0 when it fills the view ray.
        pub bounded: u32,
        /// Medium box, high corner.
        pub box_max: [f32; 3],
        /// 1 when the light is attenuated on its way through the medium.
        pub light_extinction: u32,
        /// Added to the per-pixel jitter hash, modulo 1 (`jitter_pattern = frame`: a frame's
        /// phase, 0 otherwise).
        pub jitter_phase: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// The shadow map's light (the sun: parallel light; a spot or point light: BruteForce
        /// marches it with falloff, cone and per-sample phase), its radiance × `tint` ×
        /// `intensity`.
        pub light: LightBlock,
    }
}

impl ScatterParams {
    /// Build the uniforms from the camera and light metadata and the node's parameters (the
    /// medium and quality ones; bounds come with [`ScatterParams::with_bounds`]).
    pub fn new(camera: &Matrices, light: &Matrices, p: &Params) -> ScatterParams {
        let mut block = LightBlock::of_map(light);
        block.radiance = [0, 1, 2].map(|i| light.radiance[i] * p.tint[i] * p.intensity);
        ScatterParams {
            inv_view_proj: camera.view_proj().inverse().to_cols_array_2d(),
            eye: camera.eye().to_array(),
            steps: p.steps as u32,
            sigma_t: p.sigma_t,
            albedo: p.albedo,
            g: p.g,
            jitter: p.jitter,
            bias: p.bias,
            min_level: p.min_level as u32,
            box_min: [0.0; 3],
            bounded: 0,
            box_max: [0.0; 3],
            light_extinction: 0,
            phase_width: 0,
            soft_slices: 0,
            jitter_phase: 0.0,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
            light: block,
        }
    }

    /// The spot or point light these uniforms carry (`None`: the sun).
    pub fn local(&self) -> Option<tyndall_engine::scene::LocalLight> {
        self.light.local()
    }

    /// The unit direction towards the sun (meaningful for the sun's map).
    pub fn to_sun(&self) -> Vec3 {
        self.light.to_sun()
    }

    /// Bound the medium to the box `(min, max)` (`None`: it fills every view ray) and switch
    /// the sun's extinction on its way through it.
    pub fn with_bounds(mut self, bounds: Option<(Vec3, Vec3)>, light_extinction: bool) -> Self {
        if let Some((lo, hi)) = bounds {
            (self.box_min, self.box_max, self.bounded) = (lo.to_array(), hi.to_array(), 1);
        }
        self.light_extinction = light_extinction as u32;
        self
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the soft visibility lookup (struct `SoftView`).
    pub struct SoftView as "SoftView" {
        /// World → light clip of the soft volume.
        pub view_proj: [[f32; 4]; 4],
        /// A point light's position, m (`persp` = 2).
        pub position: [f32; 3],
        /// 1: a spot's perspective volume (uv divided by w, slices in q = 1 − near / w); 2: a
        /// point light's six faces, 3 × 2, each such a volume over 90°; 0: the sun's box.
        pub persp: u32,
        /// Where a lamp's slices start (q = 0), m.
        pub near: f32,
        /// A lamp map's depth-1 distance, m.
        pub far: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the light-map lookup (struct `LightMapView`).
    pub struct LightMapView as "LightMapView" {
        /// World → light clip of the light map.
        pub view_proj: [[f32; 4]; 4],
        /// 1 when a light map is connected (BruteForce multiplies each sample by it).
        pub enabled: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the MinMax traversal (struct `Levels`): level k ≥ 1 of the pyramid lives in
    /// the atlas at `rect[k] = (x, y, width, height)`.
    pub struct LevelsParams as "Levels" {
        /// Number of levels above the map (the top one is 1×1).
        pub count: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// Atlas rectangles; entry 0 unused (level 0 is the map).
        pub rect: [[u32; 4]; 16],
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the pyramid build pass (struct `Build`).
    pub struct BuildParams as "Build" {
        /// Level being built (≥ 1).
        pub level: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// Source rectangle (the map for level 1, else level − 1 in the atlas).
        pub src: [u32; 4],
        /// Destination rectangle in the atlas.
        pub dst: [u32; 4],
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of method `Epipolar` (struct `Epi`); the slices themselves are in a texture.
    pub struct EpiParams as "Epi" {
        /// The epipole, pixels.
        pub epipole: [f32; 2],
        /// Border coordinate where the slices' arc starts.
        pub u_start: f32,
        /// Length of the arc in border coordinates.
        pub arc: f32,
        /// The view, pixels.
        pub size: [f32; 2],
        /// Slices.
        pub slices: u32,
        /// Samples per slice.
        pub samples: u32,
        /// 1 when the epipole is on screen (slices wrap around).
        pub inside: u32,
        /// Leaves per rectified row (a power of two).
        pub tree_n: u32,
        /// log2 of `tree_n`: the root's level.
        pub tree_top: u32,
        /// Tree level at and below which mixed nodes are estimated (0 = exact).
        pub tree_level: u32,
        /// Relative depth / medium-length threshold of a usable sample.
        pub threshold: f32,
        /// Level being built (pass `epi_tree`); pixels in the fall-back list (`epi_fallback`).
        pub level: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

impl EpiParams {
    /// The uniforms of geometry `g` with `knobs`.
    pub fn new(g: &EpiGeometry, knobs: EpiKnobs) -> EpiParams {
        EpiParams {
            epipole: g.epipole,
            u_start: g.u_start,
            arc: g.arc,
            size: g.size,
            slices: knobs.slices,
            samples: knobs.samples,
            inside: g.inside as u32,
            tree_n: g.tree_n,
            tree_top: g.tree_n.trailing_zeros(),
            tree_level: knobs.tree_level,
            threshold: knobs.threshold,
            level: 0,
            _pad0: 0,
            _pad1: 0,
        }
    }

    /// The slice table texture's texels (width = slices, 3 rows of RGBA): entry and direction;
    /// length, chord; the map line's origin and direction.
    pub fn slice_texels(g: &EpiGeometry) -> Vec<f32> {
        let row = |f: fn(&EpiSlice) -> [f32; 4]| g.slices.iter().flat_map(f);
        row(|s| [s.entry[0], s.entry[1], s.dir[0], s.dir[1]])
            .chain(row(|s| [s.len, s.chord, 0.0, 0.0]))
            .chain(row(|s| {
                [s.line_o[0], s.line_o[1], s.line_d[0], s.line_d[1]]
            }))
            .collect()
    }
}

impl LightMapView {
    /// The light map's world → light-clip matrix (column-major) and whether one is connected.
    pub fn new(view_proj: [[f32; 4]; 4], enabled: u32) -> Self {
        Self {
            view_proj,
            enabled,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }
}

/// The atlas layout of a min-max pyramid over a `w × h` map: `(levels, atlas width, atlas
/// height)`. Level k has size ⌈w/2^k⌉ × ⌈h/2^k⌉ and they are stacked vertically.
pub fn pyramid_layout(w: u32, h: u32) -> (LevelsParams, u32, u32) {
    let mut p = LevelsParams {
        count: 0,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
        rect: [[0; 4]; 16],
    };
    let (mut lw, mut lh, mut y) = (w, h, 0u32);
    let mut width = 1;
    while (lw > 1 || lh > 1) && (p.count as usize) < 15 {
        lw = lw.div_ceil(2);
        lh = lh.div_ceil(2);
        p.count += 1;
        p.rect[p.count as usize] = [0, y, lw, lh];
        width = width.max(lw);
        y += lh;
    }
    (p, width, y.max(1))
}
