//! How a proxy evaluation changes a parameter ([`ProxyScale`]) and the [`ParamSpec`] builders
//! that declare it (see [`crate::eval::proxy`]).

use super::types::ParamSpec;

/// How a proxy evaluation at 1/f changes a parameter (see [`crate::eval::proxy`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProxyScale {
    /// By its unit: divided by f when in screen pixels (`px`), else unchanged (the default).
    ByUnit,
    /// A size in light-space texels (a shadow map's side, a radius or length on the map):
    /// divided by f, with the map, so the look holds.
    LightTexels,
    /// As [`ProxyScale::LightTexels`] only while parameter `.0` is one of `.1` (a radius whose
    /// unit is another parameter: in metres it does not follow the map's resolution).
    LightTexelsWhen(&'static str, &'static [&'static str]),
    /// A size in texels of the node's input, whatever space that is in (a screen picture or a
    /// light-space map: a proxy divides both): divided by f, so a blur keeps its width on the
    /// picture.
    InputTexels,
    /// A reduction factor: multiplied by f (an input file read at 1/f of its size, so it stays
    /// the size of the proxied pictures it is combined with).
    Reduction,
}

impl ParamSpec {
    /// A size in light-space texels, divided with the map by a proxy evaluation (see
    /// [`ProxyScale::LightTexels`]).
    pub const fn light_texels(self) -> Self {
        Self {
            proxy: ProxyScale::LightTexels,
            ..self
        }
    }

    /// A size in light-space texels while parameter `param` is one of `values` (see
    /// [`ProxyScale::LightTexelsWhen`]).
    pub const fn light_texels_when(
        self,
        param: &'static str,
        values: &'static [&'static str],
    ) -> Self {
        Self {
            proxy: ProxyScale::LightTexelsWhen(param, values),
            ..self
        }
    }

    /// A size in texels of the node's input, divided by a proxy evaluation's factor (see
    /// [`ProxyScale::InputTexels`]).
    pub const fn input_texels(self) -> Self {
        Self {
            proxy: ProxyScale::InputTexels,
            ..self
        }
    }

    /// A reduction factor, multiplied by a proxy evaluation's factor (see
    /// [`ProxyScale::Reduction`]).
    pub const fn proxy_reduction(self) -> Self {
        Self {
            proxy: ProxyScale::Reduction,
            ..self
        }
    }
}
