//! Grey levels from pressures (thesis eq. 3.1).

/// The pressure K_bar that maps to grey level 255 (thesis eq. 3.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalisation {
    /// The sensor's full scale, in the frame's units: images of different touches compare.
    FullScale(f32),
    /// The largest pressure in the current image: the contact's shape at full contrast
    /// (thesis Ch. 4.2, for classification).
    ContactMax,
}

/// Which pressure [`Normalisation`] takes as white, by name (`"contact_max"` or `"full_scale"`,
/// read with [`str::parse`]); a full-scale normalisation also needs its full scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormKind {
    /// [`Normalisation::FullScale`].
    FullScale,
    /// [`Normalisation::ContactMax`].
    ContactMax,
}

skin_core::by_name!(NormKind, UnknownNorm, "\"contact_max\" or \"full_scale\"", {
    ContactMax => "contact_max",
    FullScale => "full_scale",
});

impl Normalisation {
    /// Its kind.
    pub fn kind(self) -> NormKind {
        match self {
            Normalisation::FullScale(_) => NormKind::FullScale,
            Normalisation::ContactMax => NormKind::ContactMax,
        }
    }
}

/// Grey levels from pressures: I = floor(255 K / K_bar), clamped to 0..=255 (thesis eq. 3.1).
/// With [`Normalisation::ContactMax`] and no positive pressure, the image is black.
pub fn to_grey(pressure: &[f32], norm: Normalisation, grey: &mut [u8]) {
    let k_bar = match norm {
        Normalisation::FullScale(k) => k,
        Normalisation::ContactMax => pressure.iter().copied().fold(0.0f32, f32::max),
    };
    let n = pressure.len().min(grey.len());
    quantise(&pressure[..n], k_bar, &mut grey[..n]);
}

/// Grey levels floor(255 K / K_bar) clamped to 0..=255 (thesis eq. 3.1), eight pixels at a time;
/// all black when K_bar is not positive. The float-to-integer step is what the compiler cannot
/// vectorise on its own (Rust's `as` saturates and maps NaN to 0, which takes scalar code):
/// `wide` truncates eight lanes in one instruction once the values are clamped (NaN included) to
/// 0..=255, so the result is the same.
pub(super) fn quantise(k: &[f32], k_bar: f32, grey: &mut [u8]) {
    use wide::f32x8;
    if !(k_bar > 0.0) {
        grey.fill(0);
        return;
    }
    let gain = 255.0 / k_bar;
    let (zero, top, gain8) = (f32x8::splat(0.0), f32x8::splat(255.0), f32x8::splat(gain));
    let mut chunks = k.chunks_exact(8);
    let mut out = grey.chunks_exact_mut(8);
    for (c, o) in (&mut chunks).zip(&mut out) {
        let mut a = [0.0f32; 8];
        a.copy_from_slice(c);
        let g = (f32x8::new(a) * gain8)
            .fast_max(zero)
            .fast_min(top)
            .fast_trunc_int()
            .to_array();
        for (o, &x) in o.iter_mut().zip(&g) {
            *o = x as u8;
        }
    }
    for (o, &v) in out.into_remainder().iter_mut().zip(chunks.remainder()) {
        *o = (v * gain) as u8;
    }
}
