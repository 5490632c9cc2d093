//! Running ONNX classifiers with tract (feature `onnx`): the MATLAB-exported HandsNet from the
//! shared data, batches against single images, and clear errors for wrong files and inputs.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use shared_data::shared;
use skin_test_support::shared_data;

use prost::Message;
use skin_learn::classify::{Classifier, InputScale, ModelError};
use tract_onnx::prelude::*;

const HANDSNET: &str = "cyskin/HandsNet_handles_finetuned.onnx";

/// A 68 x 100 test pattern: a blob of `level` centred at (r, c).
fn blob(r0: f64, c0: f64, radius: f64, level: u8) -> Vec<u8> {
    let mut im = vec![0u8; 68 * 100];
    for r in 0..68 {
        for c in 0..100 {
            if ((r as f64 - r0).powi(2) + (c as f64 - c0).powi(2)).sqrt() <= radius {
                im[r * 100 + c] = level;
            }
        }
    }
    im
}

#[test]
fn the_matlab_handsnet_loads_and_gives_two_class_probabilities() {
    let Some(path) = shared(HANDSNET) else { return };
    let mut net = Classifier::load(&path, InputScale::Bytes).unwrap();
    assert_eq!(
        net.input_size(),
        skin_core::image::ImageSize { rows: 68, cols: 100 }
    );
    assert_eq!(net.classes(), 2);
    let images = [
        blob(34.0, 50.0, 10.0, 255),
        blob(20.0, 30.0, 25.0, 180),
        vec![0u8; 6800],
    ];
    let mut singles = Vec::new();
    for im in &images {
        let p = net.classify(im).unwrap();
        assert_eq!(p.len(), 2);
        assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-4, "{p:?}");
        assert!(p.iter().all(|v| (0.0..=1.0).contains(v)));
        singles.push(p);
    }
    // The same answers in one batch, and again (the reused state keeps nothing between calls).
    let refs: Vec<&[u8]> = images.iter().map(|v| v.as_slice()).collect();
    for _ in 0..2 {
        let batch = net.classify_batch(&refs).unwrap();
        for (b, s) in batch.iter().zip(&singles) {
            for (x, y) in b.iter().zip(s) {
                assert!((x - y).abs() < 1e-4, "{b:?} vs {s:?}");
            }
        }
    }
    // Different inputs, different answers: the network is really run.
    assert!((singles[0][0] - singles[2][0]).abs() > 1e-6 || (singles[1][0] - singles[2][0]).abs() > 1e-6);
}

#[test]
fn an_image_of_the_wrong_size_is_refused() {
    let Some(path) = shared(HANDSNET) else { return };
    let mut net = Classifier::load(&path, InputScale::Bytes).unwrap();
    let err = net.classify(&[0u8; 100]).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::Image {
                got: 100,
                want: 6800,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("68 x 100"), "{err}");
}

#[test]
fn a_corrupt_file_and_a_colour_model_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    // Not ONNX at all.
    let junk = dir.path().join("junk.onnx");
    std::fs::write(&junk, b"this is not a protobuf model").unwrap();
    let err = Classifier::load(&junk, InputScale::Unit).unwrap_err();
    assert!(matches!(err, ModelError::Load { .. }), "{err}");
    assert!(err.to_string().contains("junk.onnx"), "{err}");
    // Truncated.
    let Some(path) = shared(HANDSNET) else { return };
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.onnx");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = Classifier::load(&cut, InputScale::Bytes).unwrap_err();
    assert!(matches!(err, ModelError::Load { .. }), "{err}");
    // The same network declaring a 3-channel input.
    let mut proto = tract_onnx::onnx().proto_model_for_path(&path).unwrap();
    let graph = proto.graph.as_mut().unwrap();
    let input = graph.input.iter_mut().find(|i| i.name == "imageinput").unwrap();
    let Some(tract_onnx::pb::type_proto::Value::TensorType(t)) =
        input.r#type.as_mut().and_then(|t| t.value.as_mut())
    else {
        panic!("imageinput is not a tensor")
    };
    let dim = &mut t.shape.as_mut().unwrap().dim[1];
    dim.value = Some(tract_onnx::pb::tensor_shape_proto::dimension::Value::DimValue(3));
    let colour = dir.path().join("colour.onnx");
    std::fs::write(&colour, proto.encode_to_vec()).unwrap();
    let err = Classifier::load(&colour, InputScale::Bytes).unwrap_err();
    assert!(matches!(err, ModelError::Shape { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("colour.onnx") && text.contains("[N, 1, H, W]") && text.contains('3'),
        "{text}"
    );
}

/// A model whose output for one image is empty ([N, 0]: the flattened image sliced to nothing)
/// is refused at load, naming the file; it must not load and then fail on the first image.
#[test]
fn a_model_with_an_empty_output_is_a_clear_error() {
    use tract_onnx::pb;
    let ints = |name: &str, v: i64| pb::TensorProto {
        name: name.into(),
        dims: vec![1],
        data_type: 7, // INT64
        int64_data: vec![v],
        ..Default::default()
    };
    let dim = |v: pb::tensor_shape_proto::dimension::Value| pb::tensor_shape_proto::Dimension {
        value: Some(v),
        ..Default::default()
    };
    use pb::tensor_shape_proto::dimension::Value::{DimParam, DimValue};
    let image = pb::ValueInfoProto {
        name: "image".into(),
        r#type: Some(pb::TypeProto {
            value: Some(pb::type_proto::Value::TensorType(pb::type_proto::Tensor {
                elem_type: 1, // FLOAT
                shape: Some(pb::TensorShapeProto {
                    dim: vec![
                        dim(DimParam("N".into())),
                        dim(DimValue(1)),
                        dim(DimValue(68)),
                        dim(DimValue(100)),
                    ],
                }),
            })),
            ..Default::default()
        }),
        ..Default::default()
    };
    let node = |op: &str, inputs: &[&str], output: &str, attribute: Vec<pb::AttributeProto>| pb::NodeProto {
        op_type: op.into(),
        input: inputs.iter().map(|s| s.to_string()).collect(),
        output: vec![output.into()],
        attribute,
        ..Default::default()
    };
    let axis = pb::AttributeProto {
        name: "axis".into(),
        r#type: 2, // INT
        i: 1,
        ..Default::default()
    };
    let model = pb::ModelProto {
        ir_version: 8,
        opset_import: vec![pb::OperatorSetIdProto {
            domain: String::new(),
            version: 17,
        }],
        graph: Some(pb::GraphProto {
            name: "empty".into(),
            node: vec![
                node("Flatten", &["image"], "flat", vec![axis]),
                node("Slice", &["flat", "starts", "ends", "axes"], "scores", vec![]),
            ],
            initializer: vec![ints("starts", 0), ints("ends", 0), ints("axes", 1)],
            input: vec![image],
            output: vec![pb::ValueInfoProto {
                name: "scores".into(),
                ..Default::default()
            }],
            ..Default::default()
        }),
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.onnx");
    std::fs::write(&path, model.encode_to_vec()).unwrap();
    let err = Classifier::load(&path, InputScale::Unit).unwrap_err();
    assert!(matches!(err, ModelError::Shape { .. }), "{err}");
    assert!(
        err.to_string().contains("empty.onnx") && err.to_string().contains("empty"),
        "{err}"
    );
}
