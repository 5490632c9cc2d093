//! The direct convolution against the definition of a convolution and against tract.

#![allow(clippy::unwrap_used)]

use super::geometry::Geometry;
use super::op::{DirectConv, available};
use super::swap::swap_convolutions;
use proptest::prelude::*;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;
use tract_onnx::tract_core::ops::cnn::{Conv, KernelFormat, PaddingSpec, PoolSpec};
use tract_onnx::tract_core::ops::nn::DataFormat;

/// A stride-1 convolution's shape and parameters, as ONNX states them.
struct Spec {
    c_in: usize,
    c_out: usize,
    h: usize,
    w: usize,
    kh: usize,
    kw: usize,
    dh: usize,
    dw: usize,
    /// Top, bottom, left, right.
    pads: [usize; 4],
}

impl Spec {
    /// Output height and width, by ONNX's formula.
    fn output(&self) -> (usize, usize) {
        let [top, bottom, left, right] = self.pads;
        (
            self.h + top + bottom - (self.kh - 1) * self.dh,
            self.w + left + right - (self.kw - 1) * self.dw,
        )
    }
}

/// The definition of a stride-1 convolution (ONNX Conv, one group), one output at a time,
/// in f64, from the parameters alone (not the op's geometry).
fn reference(input: &[f32], weights: &[f32], bias: &[f32], s: &Spec, relu: bool) -> Vec<f32> {
    let (ho, wo) = s.output();
    let [top, _, left, _] = s.pads;
    let mut out = Vec::new();
    for o in 0..s.c_out {
        for y in 0..ho {
            for x in 0..wo {
                let mut sum = f64::from(if bias.len() == 1 { bias[0] } else { bias[o] });
                for c in 0..s.c_in {
                    for i in 0..s.kh {
                        for j in 0..s.kw {
                            let (r, q) = (
                                (y + i * s.dh) as isize - top as isize,
                                (x + j * s.dw) as isize - left as isize,
                            );
                            if r < 0 || q < 0 || r >= s.h as isize || q >= s.w as isize {
                                continue;
                            }
                            let v = input[(c * s.h + r as usize) * s.w + q as usize];
                            let k = weights[((o * s.c_in + c) * s.kh + i) * s.kw + j];
                            sum += f64::from(v) * f64::from(k);
                        }
                    }
                }
                out.push(if relu { sum.max(0.0) } else { sum } as f32);
            }
        }
    }
    out
}

/// The op's output for `n` images `[c_in, h, w]`: its shape and values.
fn run(op: &DirectConv, n: usize, input: &[f32]) -> (Vec<usize>, Vec<f32>) {
    let g = &op.geometry;
    let input = Tensor::from_shape(&[n, g.c_in, g.h, g.w], input).unwrap();
    let out = op
        .eval(&EvalContext::out_of_plan(), tvec!(input.into_tvalue()))
        .unwrap();
    let values = out[0]
        .try_as_plain_ram()
        .unwrap()
        .as_slice::<f32>()
        .unwrap()
        .to_vec();
    (out[0].shape().to_vec(), values)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Any channel counts (blocks of four or not, one chunk of input channels or several), image and kernel sizes, dilations,
    /// asymmetric padding, bias and ReLU: the definition's values.
    #[test]
    fn matches_the_definition(
        c_in in prop_oneof![1usize..5, 15usize..40], c_out in 1usize..10, h in 1usize..12, w in 1usize..14,
        kh in 1usize..6, kw in 1usize..6, dh in 1usize..4, dw in 1usize..4,
        pads in prop::array::uniform4(0usize..6), relu: bool, one_bias: bool, seed: u64,
    ) {
        if !available() {
            // tract keeps its convolutions on this CPU (`swap_convolutions` swaps none).
            return Ok(());
        }
        let [top, bottom, left, right] = pads;
        let Some(g) = Geometry::new((c_in, c_out), (h, w), (kh, kw), (dh, dw), (top, bottom, left, right)) else {
            // No output, or padding past the kernel's reach: tract keeps such convolutions.
            let no_output = h + top + bottom <= (kh - 1) * dh || w + left + right <= (kw - 1) * dw;
            prop_assert!(no_output || left.min(right) > (kw - 1) * dw, "refused {pads:?}");
            return Ok(());
        };
        let spec = Spec { c_in, c_out, h, w, kh, kw, dh, dw, pads };
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13; state ^= state >> 7; state ^= state << 17;
            (state % 2001) as f32 / 1000.0 - 1.0
        };
        let n = 2;
        let input: Vec<f32> = (0..n * c_in * h * w).map(|_| next()).collect();
        let weights: Vec<f32> = (0..c_out * c_in * kh * kw).map(|_| next()).collect();
        let bias: Vec<f32> = (0..if one_bias { 1 } else { c_out }).map(|_| next()).collect();
        let op = DirectConv::new(g.clone(), &weights, &bias, relu).unwrap();
        let (shape, got) = run(&op, n, &input);
        let (ho, wo) = spec.output();
        prop_assert_eq!(shape, vec![n, c_out, ho, wo]);
        let per_image = c_in * h * w;
        let want: Vec<f32> = input
            .chunks_exact(per_image)
            .flat_map(|image| reference(image, &weights, &bias, &spec, relu))
            .collect();
        prop_assert_eq!(got.len(), want.len());
        for (i, (a, b)) in got.iter().zip(&want).enumerate() {
            prop_assert!((a - b).abs() <= 1e-4 * (1.0 + b.abs()), "output {i}: {a} against {b}");
        }
    }
}

/// Each shipped model gives tract's own outputs with its convolutions swapped, and the swap
/// covers all of its 3 x 3 and 5 x 5 convolutions.
#[test]
fn shipped_models_give_tracts_outputs() {
    if !available() {
        eprintln!("skipped: this CPU has no AVX2 and FMA, tract keeps its convolutions");
        return;
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/models");
    for (name, convolutions) in [("handsnet", 4), ("handseg", 13), ("handseg_wide", 13)] {
        let model = tract_onnx::onnx()
            .model_for_path(root.join(format!("{name}.onnx")))
            .unwrap()
            .with_input_fact(0, f32::fact([1, 1, 68, 100]).into())
            .unwrap()
            .into_typed()
            .unwrap()
            .into_decluttered()
            .unwrap();
        let mut swapped = model.clone();
        assert_eq!(swap_convolutions(&mut swapped).unwrap(), convolutions, "{name}");
        let input = tract_ndarray::Array4::from_shape_fn((1, 1, 68, 100), |(_, _, r, c)| {
            ((r * 7 + c * 13) % 17) as f32 / 17.0
                * f32::from(u8::from((r as f32 - 34.0).hypot(c as f32 - 50.0) < 20.0))
        });
        let input: Tensor = input.into();
        let outputs = |m: TypedModel| {
            let out = m
                .into_optimized()
                .unwrap()
                .into_runnable()
                .unwrap()
                .run(tvec!(input.clone().into()))
                .unwrap();
            out[0]
                .try_as_plain_ram()
                .unwrap()
                .as_slice::<f32>()
                .unwrap()
                .to_vec()
        };
        let (want, got) = (outputs(model), outputs(swapped));
        assert_eq!(want.len(), got.len(), "{name}");
        let worst = want
            .iter()
            .zip(&got)
            .map(|(a, b)| (a - b).abs() / (1.0 + a.abs()))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "{name}: outputs differ by up to {worst}");
    }
}

/// A decluttered model of one convolution of a `[1, c_in, h, w]` input; a ReLU after it
/// where `relu` is set; the convolution's own output a model output too where `keep` is.
fn one_convolution(conv: Conv, (h, w): (usize, usize), relu: bool, keep: bool) -> TypedModel {
    use tract_onnx::tract_core::ops::change_axes::wire_with_rank_broadcast;
    let spec = &conv.pool_spec;
    let (c_in, c_out) = (spec.input_channels, spec.output_channels);
    let (kh, kw) = (spec.kernel_shape[0], spec.kernel_shape[1]);
    let per_group = c_in / conv.group;
    let values = |n: usize, step: usize| -> Vec<f32> {
        (0..n).map(|k| (k * step % 101) as f32 / 50.0 - 1.0).collect()
    };
    let mut model = TypedModel::default();
    let x = model.add_source("x", f32::fact([1, c_in, h, w])).unwrap();
    let weights = Tensor::from_shape(
        &[c_out, per_group, kh, kw],
        &values(c_out * per_group * kh * kw, 37),
    );
    let bias = Tensor::from_shape(&[c_out], &values(c_out, 13));
    let weights = model.add_const("weights", weights.unwrap()).unwrap();
    let bias = model.add_const("bias", bias.unwrap()).unwrap();
    let y = model.wire_node("conv", conv, &[x, weights, bias]).unwrap()[0];
    let mut outputs = vec![];
    if relu {
        let zero = model.add_const("zero", tensor0(0f32)).unwrap();
        let max = tract_onnx::tract_core::ops::math::max();
        outputs.push(wire_with_rank_broadcast("relu", &mut model, max, &[y, zero]).unwrap()[0]);
    }
    if keep || !relu {
        outputs.push(y);
    }
    model.select_output_outlets(&outputs).unwrap();
    model.into_decluttered().unwrap()
}

/// An f32 convolution of `c.0` into `c.1` channels by a `k` kernel, dilated by (1, 2).
fn conv(c: (usize, usize), k: (usize, usize), padding: PaddingSpec, stride: usize, group: usize) -> Conv {
    Conv {
        pool_spec: PoolSpec {
            data_format: DataFormat::NCHW,
            kernel_shape: tvec![k.0, k.1],
            padding,
            dilations: Some(tvec![1, 2]),
            strides: Some(tvec![stride, stride]),
            input_channels: c.0,
            output_channels: c.1,
        },
        kernel_fmt: KernelFormat::OIHW,
        group,
        q_params: None,
    }
}

/// Every output of `model` run by tract as it is, and with its convolutions swapped:
/// how many were swapped, which of them took in a ReLU, and the largest difference.
fn swapped_against_tract(model: TypedModel, (c, h, w): (usize, usize, usize)) -> (usize, Vec<bool>, f32) {
    let mut swapped = model.clone();
    let count = swap_convolutions(&mut swapped).unwrap();
    let fused = swapped
        .nodes
        .iter()
        .filter_map(|n| n.op_as::<DirectConv>().map(|op| op.relu))
        .collect();
    let input: Tensor = tract_ndarray::Array4::from_shape_fn((1, c, h, w), |(_, k, r, q)| {
        ((k * 31 + r * 7 + q * 13) % 17) as f32 / 8.0 - 1.0
    })
    .into();
    let outputs = |m: TypedModel| {
        let runnable = m.into_optimized().unwrap().into_runnable().unwrap();
        let out = runnable.run(tvec!(input.clone().into())).unwrap();
        out.iter()
            .map(|t| t.try_as_plain_ram().unwrap().as_slice::<f32>().unwrap().to_vec())
            .collect::<Vec<_>>()
    };
    let (want, got) = (outputs(model), outputs(swapped));
    assert_eq!(want.len(), got.len());
    let mut worst = 0.0f32;
    for (want, got) in want.iter().zip(&got) {
        assert_eq!(want.len(), got.len());
        for (a, b) in want.iter().zip(got) {
            worst = worst.max((a - b).abs() / (1.0 + a.abs()));
        }
    }
    (count, fused, worst)
}

/// Built models, against tract on the same input: asymmetric padding of each kind reaches
/// the right sides; a ReLU is taken in only where nothing else reads the convolution; the
/// strided and grouped convolutions stay with tract.
#[test]
fn swaps_only_what_it_covers_and_keeps_tracts_outputs() {
    if !available() {
        eprintln!("skipped: this CPU has no AVX2 and FMA, tract keeps its convolutions");
        return;
    }
    let (c_in, h, w) = (5, 9, 11);
    // Two rows above and none below, none left and one right.
    let explicit = || PaddingSpec::Explicit(tvec![2, 0], tvec![0, 1]);
    let cases = [
        (
            "explicit, ReLU",
            conv((c_in, 6), (3, 3), explicit(), 1, 1),
            true,
            false,
            1,
            vec![true],
        ),
        (
            "explicit, ReLU, convolution read too",
            conv((c_in, 6), (3, 3), explicit(), 1, 1),
            true,
            true,
            1,
            vec![false],
        ),
        (
            "same lower, even kernel",
            conv((c_in, 8), (4, 2), PaddingSpec::SameLower, 1, 1),
            false,
            false,
            1,
            vec![false],
        ),
        (
            "same upper, even kernel, ReLU",
            conv((c_in, 3), (2, 4), PaddingSpec::SameUpper, 1, 1),
            true,
            false,
            1,
            vec![true],
        ),
        (
            "stride 2",
            conv((c_in, 6), (3, 3), explicit(), 2, 1),
            true,
            false,
            0,
            vec![],
        ),
        (
            "two groups",
            conv((4, 6), (3, 3), explicit(), 1, 2),
            true,
            false,
            0,
            vec![],
        ),
    ];
    for (name, conv, relu, keep, count, fused) in cases {
        let c = conv.pool_spec.input_channels;
        let model = one_convolution(conv, (h, w), relu, keep);
        let (swapped, took_in, worst) = swapped_against_tract(model, (c, h, w));
        assert_eq!((swapped, took_in), (count, fused), "{name}");
        assert!(worst < 1e-4, "{name}: outputs differ by up to {worst}");
    }
}

/// Shapes a model file may declare that leave nothing to compute or overflow a buffer's
/// size are tract's to handle (or refuse), never a panic here.
#[test]
fn refuses_empty_and_unaddressable_shapes() {
    let pads = (2, 2, 2, 2);
    assert!(Geometry::new((1, 1), (0, 5), (3, 3), (1, 1), pads).is_none());
    assert!(Geometry::new((1, 1), (5, 0), (3, 3), (1, 1), pads).is_none());
    assert!(Geometry::new((0, 1), (5, 5), (3, 3), (1, 1), pads).is_none());
    assert!(Geometry::new((1, 1), (5, 5), (0, 3), (1, 1), pads).is_none());
    let huge = usize::MAX / 2;
    assert!(Geometry::new((1, 1), (huge, huge), (3, 3), (1, 1), pads).is_none());
    assert!(Geometry::new((huge, 1), (5, 5), (3, 3), (1, 1), pads).is_none());
    assert!(Geometry::new((1, 1), (5, 5), (3, 3), (huge, 1), (huge, huge, 1, 1)).is_none());
    assert!(Geometry::new((1, 1), (5, 5), (3, 3), (1, 1), pads).is_some());
}
