#[derive(Debug)]
pub enum Map {
    /// Patch: a scale without a translation.
    ScaleMap {
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
    /// Patch: a translation (voxel size 1).
    TranslationMap { translation: glam::DVec3 },
    /// Patch: an affine (or unitary) map: OpenVDB's `Mat4d`, row-major, applied to row vectors
    /// (world = index · M, the translation in the last row).
    AffineMap { matrix: [f64; 16] },
    UniformScaleMap {
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
    ScaleTranslateMap {
        translation: glam::DVec3,
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
}

impl Map {
    /// Patch: index space → world space as a column-vector matrix (world = M · index).
    pub fn index_to_world(&self) -> glam::DMat4 {
        match self {
            Map::UniformScaleMap { scale_values, .. } | Map::ScaleMap { scale_values, .. } => {
                glam::DMat4::from_scale(*scale_values)
            }
            Map::ScaleTranslateMap {
                translation,
                scale_values,
                ..
            } => glam::DMat4::from_scale_rotation_translation(
                *scale_values,
                glam::DQuat::IDENTITY,
                *translation,
            ),
            Map::TranslationMap { translation } => glam::DMat4::from_translation(*translation),
            // Row-major rows of a row-vector matrix are the columns of the column-vector one.
            Map::AffineMap { matrix } => glam::DMat4::from_cols_array(matrix),
        }
    }
}
