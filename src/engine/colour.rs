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
    /// `working`.
    pub fn colour_space(&self, name: &str, working: &str) -> Result<String, ColourError> {
        let name = if name.is_empty() { working } else { name };
        match self.config.get_color_space(name) {
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
        out.push_str(&format!("  working space (default): {WORKING_SPACE}\n"));
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
