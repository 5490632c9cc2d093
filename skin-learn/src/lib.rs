//! # skin-learn: touch understanding for robot skin
//!
//! Planned: Gaussian spatial calibration of taxels from probe contacts (thesis Ch. 7), tactile image
//! classification (hand / non-hand, HandsNet, Ch. 4) and hand-part segmentation through ONNX models,
//! evaluation metrics, and synthetic contact data on a skin layout. Nothing is implemented yet.
