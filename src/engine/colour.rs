//! Colour management (issue #45): the OpenColorIO config every colour conversion reads, through
//! the pure-Rust `ocio` crate (OpenColorIO 2.5, no C++).
//!
//! A process has one current config, as OpenColorIO itself does (`SetCurrentConfig`): the
//! command line's `--ocio CONFIG` ([`set_current`]), else `$OCIO`, else the built-in
//! [`BUILTIN`]. A CONFIG is a file (`.ocio`, `.ocioz`) or a built-in `ocio://…` name, as
//! OpenColorIO accepts. A node's own `config` parameter names another one ([`load`], cached).
//! Names of colour spaces, displays, views and looks are checked against the config: a name it
//! does not have is [`ColourError::Unknown`], which lists what it has.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

use thiserror::Error;

/// The config used when neither `--ocio` nor `$OCIO` names one: the ACES 2.0 CG config of
/// OpenColorIO 2.5.
pub const BUILTIN: &str = "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5";

/// The working space when a graph names none: scene-linear Rec.709 primaries, what Tyndall's
/// colours have always been.
pub const WORKING_SPACE: &str = "Linear Rec.709 (sRGB)";

/// A config that cannot be used, or a name it does not have.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ColourError {
    /// The config could not be read.
    #[error("colour config `{config}`: {reason}")]
    Config {
        /// The CONFIG as given.
        config: String,
        /// What OpenColorIO said.
        reason: String,
    },
    /// A colour space, display, view or look the config does not have.
    #[error("colour config `{config}` has no {what} `{name}`; it has: {have}")]
    Unknown {
        /// The CONFIG as given.
        config: String,
        /// "colour space", "display", "view of display `…`" or "look".
        what: String,
        /// The name asked for.
        name: String,
        /// What the config has, comma-separated.
        have: String,
    },
    /// OpenColorIO could not build a processor between two names it has.
    #[error("colour config `{config}`: {what}: {reason}")]
    Processor {
        /// The CONFIG as given.
        config: String,
        /// The conversion asked for.
        what: String,
        /// What OpenColorIO said.
        reason: String,
    },
}

/// An OpenColorIO config and where it came from.
pub struct ColourConfig {
    source: String,
    config: ocio::Config,
}

impl std::fmt::Debug for ColourConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ColourConfig")
            .field("source", &self.source)
            .finish()
    }
}

impl ColourConfig {
    /// Read CONFIG: a file or a built-in `ocio://` name.
    pub fn read(spec: &str) -> Result<ColourConfig, ColourError> {
        let config = ocio::Config::create_from_file(spec).map_err(|e| ColourError::Config {
            config: spec.to_string(),
            reason: e.to_string(),
        })?;
        Ok(ColourConfig {
            source: spec.to_string(),
            config,
        })
    }

    /// The CONFIG it was read from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The `ocio` config itself.
    pub fn ocio(&self) -> &ocio::Config {
        &self.config
    }

    /// Its active colour spaces.
    pub fn colour_spaces(&self) -> Vec<String> {
        (0..self.config.num_color_spaces())
            .map(|i| self.config.color_space_name_by_index(i).to_string())
            .collect()
    }

    /// Its active displays, the default first.
    pub fn displays(&self) -> Vec<String> {
        (0..self.config.num_displays())
            .map(|i| self.config.display(i))
            .collect()
    }

    /// The active views of `display`, its default first.
    pub fn views(&self, display: &str) -> Vec<String> {
        (0..self.config.num_views(display))
            .map(|i| self.config.view(display, i))
            .collect()
    }

    /// Its looks.
    pub fn looks(&self) -> Vec<String> {
        (0..self.config.num_looks())
            .map(|i| self.config.look_name_by_index(i).to_string())
            .collect()
    }

    fn unknown(&self, what: &str, name: &str, have: &[String]) -> ColourError {
        ColourError::Unknown {
            config: self.source.clone(),
            what: what.to_string(),
            name: name.to_string(),
            have: have.join(", "),
        }
    }

    /// The colour space `name` (a name, an alias or a role), as the config spells it; empty:
    /// `working`. The default working space, [`WORKING_SPACE`], in a config that has no space
    /// of that name (Blender's, a studio's) is the config's `scene_linear` role, OpenColorIO's
    /// name for the working space.
    pub fn colour_space(&self, name: &str, working: &str) -> Result<String, ColourError> {
        let name = if name.is_empty() { working } else { name };
        let found = self.config.get_color_space(name).or_else(|| {
            (name == WORKING_SPACE)
                .then(|| self.config.get_color_space("scene_linear"))
                .flatten()
        });
        match found {
            Some(cs) => Ok(cs.name().to_string()),
            None => Err(self.unknown("colour space", name, &self.colour_spaces())),
        }
    }

    /// The display `name` as the config spells it; empty: its default.
    pub fn display(&self, name: &str) -> Result<String, ColourError> {
        let all = self.displays();
        if name.is_empty() {
            return all
                .first()
                .cloned()
                .ok_or_else(|| self.unknown("display", "", &all));
        }
        all.iter()
            .find(|d| d.eq_ignore_ascii_case(name))
            .cloned()
            .ok_or_else(|| self.unknown("display", name, &all))
    }

    /// The view `name` of `display` as the config spells it; empty: the display's default.
    pub fn view(&self, display: &str, name: &str) -> Result<String, ColourError> {
        let all = self.views(display);
        let what = format!("view of display `{display}`");
        if name.is_empty() {
            return all
                .first()
                .cloned()
                .ok_or_else(|| self.unknown(&what, "", &all));
        }
        all.iter()
            .find(|v| v.eq_ignore_ascii_case(name))
            .cloned()
            .ok_or_else(|| self.unknown(&what, name, &all))
    }

    /// The look `name` as the config spells it.
    pub fn look(&self, name: &str) -> Result<String, ColourError> {
        let all = self.looks();
        all.iter()
            .find(|l| l.eq_ignore_ascii_case(name))
            .cloned()
            .ok_or_else(|| self.unknown("look", name, &all))
    }

    /// The processor from colour space `from` to `to` (names as the config spells them).
    pub fn processor(&self, from: &str, to: &str) -> Result<ocio::Processor, ColourError> {
        self.config
            .get_processor(from, to)
            .map_err(|e| ColourError::Processor {
                config: self.source.clone(),
                what: format!("`{from}` to `{to}`"),
                reason: e.to_string(),
            })
    }

    /// The processor from colour space `source` through `display` / `view`, with `look`
    /// (empty: none) applied in the look's process space first.
    pub fn display_view_processor(
        &self,
        source: &str,
        display: &str,
        view: &str,
        look: &str,
    ) -> Result<ocio::Processor, ColourError> {
        let what = format!("`{source}` to display `{display}`, view `{view}`");
        let err = |e: ocio::Error| ColourError::Processor {
            config: self.source.clone(),
            what: what.clone(),
            reason: e.to_string(),
        };
        let dvt = ocio::DisplayViewTransform {
            src: source.to_string(),
            display: display.to_string(),
            view: view.to_string(),
            ..Default::default()
        };
        // OpenColorIO's viewer pipeline: the look applied in its process space before the
        // display / view transform (what a viewer's look menu does).
        let mut pipeline = ocio::apphelpers::legacy_viewing_pipeline::LegacyViewingPipeline::new();
        pipeline.set_display_view_transform(Some(&dvt));
        if !look.is_empty() {
            pipeline.set_looks_override_enabled(true);
            pipeline.set_looks_override(look);
        }
        pipeline.get_processor(&self.config).map_err(err)
    }

    /// What `tyndall info` prints: the config, its displays with their views, and its looks.
    pub fn describe(&self) -> String {
        let mut out = format!("colour config: {}\n", self.source);
        let working = self
            .colour_space(WORKING_SPACE, WORKING_SPACE)
            .unwrap_or_else(|e| format!("none ({e})"));
        out.push_str(&format!("  working space (default): {working}\n"));
        for d in self.displays() {
            out.push_str(&format!(
                "  display `{d}`: views {}\n",
                self.views(&d).join(", ")
            ));
        }
        let looks = self.looks();
        out.push_str(&format!(
            "  looks: {}\n",
            if looks.is_empty() {
                "none".to_string()
            } else {
                looks.join(", ")
            }
        ));
        out
    }
}

/// The colour settings an evaluation runs under: its config and its graph's working space.
/// Nodes that read them declare it ([`crate::eval::NodeDecl::colour`]); their cache keys then
/// cover both.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct ColourCtx {
    /// The evaluation's CONFIG (`Evaluator::set_colour_config`); empty: the current config.
    pub config: String,
    /// The graph's working space (`colour: (working_space: …)`); empty: [`WORKING_SPACE`].
    pub working_space: String,
}

impl ColourCtx {
    /// The config a node uses: its own `config` parameter when set, else the evaluation's,
    /// else the current one.
    pub fn config(&self, node_config: &str) -> Result<Arc<ColourConfig>, ColourError> {
        load(if node_config.is_empty() {
            &self.config
        } else {
            node_config
        })
    }

    /// The working space's name as the graph gives it ([`WORKING_SPACE`] when it gives none).
    pub fn working_space(&self) -> &str {
        if self.working_space.is_empty() {
            WORKING_SPACE
        } else {
            &self.working_space
        }
    }

    /// Whether colours need no conversion from linear Rec.709: the working space is the
    /// default one.
    pub fn is_default_space(&self) -> bool {
        self.working_space() == WORKING_SPACE
    }

    /// The CPU processor from linear Rec.709 (what glTF base and light colours are) to the
    /// working space, in the evaluation's config; `None` when the working space is that space.
    pub fn from_rec709(&self) -> Result<Option<ocio::CpuProcessor>, ColourError> {
        if self.is_default_space() {
            return Ok(None);
        }
        let config = self.config("")?;
        let from = config.colour_space(WORKING_SPACE, WORKING_SPACE)?;
        let to = config.colour_space(self.working_space(), WORKING_SPACE)?;
        Ok(Some(config.processor(&from, &to)?.default_cpu_processor()))
    }

    /// The working space's primaries and white point as CIE xy — the EXR `chromaticities`
    /// attribute, `[rx, ry, gx, gy, bx, by, wx, wy]` — for a working space other than the
    /// default (whose Rec.709 / D65 is what an EXR without the attribute means). They are the
    /// primaries as the config's `cie_xyz_d65_interchange` space sees them (chromatically
    /// adapted to D65, as the config adapts them), with the D65 white: a reader converting to
    /// any D65 space from them reproduces the config's own conversion. `None` as well when the
    /// config has no such role or the space is not linear.
    pub fn chromaticities(&self) -> Result<Option<[f32; 8]>, ColourError> {
        if self.is_default_space() {
            return Ok(None);
        }
        let config = self.config("")?;
        let Ok(xyz) = config.colour_space("cie_xyz_d65_interchange", WORKING_SPACE) else {
            return Ok(None);
        };
        let from = config.colour_space(self.working_space(), WORKING_SPACE)?;
        let cpu = config.processor(&from, &xyz)?.default_cpu_processor();
        let xy = |rgb: [f32; 3]| -> Option<[f32; 2]> {
            let v = convert_rgb(&cpu, rgb);
            let half = convert_rgb(&cpu, rgb.map(|c| c * 0.5));
            let linear = v
                .iter()
                .zip(half)
                .all(|(a, h)| (a * 0.5 - h).abs() <= 1e-5 * (1.0 + a.abs()));
            let sum = v[0] + v[1] + v[2];
            (linear && sum.abs() > 1e-9).then(|| [v[0] / sum, v[1] / sum])
        };
        let mut out = [0.0; 8];
        for (i, rgb) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0; 3]]
            .into_iter()
            .enumerate()
        {
            let Some(p) = xy(rgb) else {
                return Ok(None);
            };
            out[2 * i..2 * i + 2].copy_from_slice(&p);
        }
        Ok(Some(out))
    }

    /// Check that the config has the working space (an error names both and lists the spaces).
    pub fn check(&self) -> Result<(), ColourError> {
        if self.is_default_space() && self.config.is_empty() {
            return Ok(());
        }
        self.config("")?
            .colour_space(self.working_space(), WORKING_SPACE)
            .map(|_| ())
    }
}

/// Convert a linear RGB colour with `processor` (see [`ColourCtx::from_rec709`]).
pub fn convert_rgb(processor: &ocio::CpuProcessor, rgb: [f32; 3]) -> [f32; 3] {
    let mut px = [rgb[0], rgb[1], rgb[2], 1.0];
    processor.apply_rgba_slice(&mut px);
    [px[0], px[1], px[2]]
}

/// The current config's CONFIG, set once by the command line (`--ocio`).
static CURRENT_SPEC: OnceLock<String> = OnceLock::new();

/// Configs read so far, by CONFIG.
fn cache() -> &'static Mutex<BTreeMap<String, Arc<ColourConfig>>> {
    static CACHE: OnceLock<Mutex<BTreeMap<String, Arc<ColourConfig>>>> = OnceLock::new();
    CACHE.get_or_init(Default::default)
}

/// Make CONFIG the process's current config (`--ocio`), reading it now so a bad one is
/// reported before any work. A second call keeps the first CONFIG and says so.
pub fn set_current(spec: &str) -> Result<Arc<ColourConfig>, ColourError> {
    let config = load(spec)?;
    if CURRENT_SPEC.set(spec.to_string()).is_err() && current_spec() != spec {
        return Err(ColourError::Config {
            config: spec.to_string(),
            reason: format!("the current config is already `{}`", current_spec()),
        });
    }
    Ok(config)
}

/// The current config's CONFIG: `--ocio`, else `$OCIO` (when set and not empty), else
/// [`BUILTIN`].
pub fn current_spec() -> String {
    if let Some(s) = CURRENT_SPEC.get() {
        return s.clone();
    }
    match std::env::var("OCIO") {
        Ok(s) if !s.trim().is_empty() => s,
        _ => BUILTIN.to_string(),
    }
}

/// The current config.
pub fn current() -> Result<Arc<ColourConfig>, ColourError> {
    load(&current_spec())
}

/// CONFIG read once per process; empty: the current config.
pub fn load(spec: &str) -> Result<Arc<ColourConfig>, ColourError> {
    if spec.is_empty() {
        return current();
    }
    let mut cache = cache().lock().unwrap_or_else(|e| e.into_inner());
    if let Some(c) = cache.get(spec) {
        return Ok(c.clone());
    }
    let c = Arc::new(ColourConfig::read(spec)?);
    cache.insert(spec.to_string(), c.clone());
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_config_has_the_working_space_and_an_srgb_display() {
        let c = load(BUILTIN).expect("built-in config");
        assert_eq!(
            c.colour_space("", WORKING_SPACE).expect("working space"),
            WORKING_SPACE
        );
        assert_eq!(c.display("").expect("default"), "sRGB - Display");
        assert!(c
            .views("sRGB - Display")
            .iter()
            .any(|v| v == "Un-tone-mapped"));
    }

    #[test]
    fn acescg_chromaticities_reproduce_the_published_acescg_to_rec709_matrix() {
        let ctx = ColourCtx {
            config: BUILTIN.into(),
            working_space: "ACEScg".into(),
        };
        let c = ctx.chromaticities().expect("xy").expect("linear");
        // RGB → XYZ from the chromaticities (SMPTE RP 177), then XYZ → linear Rec.709 (D65,
        // IEC 61966-2-1): the ACEScg → Rec.709 matrix, which ACES publishes (Bradford D60 →
        // D65). 2e-3: the published matrices are rounded to 4–5 digits.
        let xyz = |x: f32, y: f32| glam::Vec3::new(x / y, 1.0, (1.0 - x - y) / y);
        let p = glam::Mat3::from_cols(xyz(c[0], c[1]), xyz(c[2], c[3]), xyz(c[4], c[5]));
        let s = p.inverse() * xyz(c[6], c[7]);
        let to_xyz = p * glam::Mat3::from_diagonal(s);
        let xyz_to_709 = glam::Mat3::from_cols_array(&[
            3.240_454, -0.969_266, 0.055_643, -1.537_139, 1.876_011, -0.204_026, -0.498_531,
            0.041_556, 1.057_225,
        ]);
        let got = (xyz_to_709 * to_xyz).to_cols_array();
        let want = [
            1.70505, -0.13026, -0.02400, -0.62179, 1.14080, -0.12897, -0.08326, -0.01055, 1.15297,
        ];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 2e-3, "{got:?}");
        }
        assert_eq!(
            ColourCtx::default().chromaticities().expect("default"),
            None
        );
    }

    #[test]
    fn unknown_names_list_what_the_config_has() {
        let c = load(BUILTIN).expect("built-in config");
        let e = c
            .colour_space("Nope", WORKING_SPACE)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`Nope`") && e.contains("ACEScg"), "{e}");
        let e = c.view("sRGB - Display", "Nope").unwrap_err().to_string();
        assert!(e.contains("Un-tone-mapped"), "{e}");
        let e = ColourConfig::read("/nonexistent/config.ocio")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/config.ocio"), "{e}");
    }
}
