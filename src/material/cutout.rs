//! Cut-outs: where a surface is absent — leaves on a card, a fence, a
//! decal's edges. glTF's `alphaMode` MASK (alpha tested against
//! `alphaCutoff`) and BLEND (stochastic transparency: the surface is there
//! with probability alpha, which is unbiased for a path tracer and needs no
//! sorting), and MTL's dissolve `d` and `map_d` on surfaces that are not
//! glass. The scene consults it in every intersection and shadow ray.

use glam::Vec2;

use crate::texture::TextureRef;

#[derive(Clone, Debug, PartialEq)]
pub struct Cutout {
    /// Alpha where no texture says otherwise (glTF baseColorFactor's alpha,
    /// MTL `d`).
    pub factor: f32,
    /// Multiplies `factor`: a coverage texture (alpha channel, or a matte).
    pub texture: Option<TextureRef>,
    pub mode: CutoutMode,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CutoutMode {
    /// Present where alpha ≥ cutoff.
    Mask { cutoff: f32 },
    /// Present with probability alpha.
    Blend,
}

impl Cutout {
    pub fn alpha(&self, uv: Vec2) -> f32 {
        self.factor * self.texture.as_ref().map_or(1.0, |t| t.linear(uv).x)
    }

    /// The probability that a ray meets the surface at `uv`: 0 or 1 for a
    /// mask, alpha for blending. What an emissive cut-out emits there, on
    /// average, relative to the whole surface.
    #[inline]
    pub fn coverage(&self, uv: Vec2) -> f32 {
        let alpha = self.alpha(uv);
        match self.mode {
            CutoutMode::Mask { cutoff } => f32::from(u8::from(alpha >= cutoff)),
            CutoutMode::Blend => alpha.clamp(0.0, 1.0),
        }
    }

    /// Whether a ray meets the surface at `uv`; `u`, a uniform number in
    /// [0, 1), decides blending.
    #[inline]
    pub fn present(&self, uv: Vec2, u: f32) -> bool {
        u < self.coverage(uv)
    }
}
