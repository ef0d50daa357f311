"""One C emitter per ONNX operator family."""
