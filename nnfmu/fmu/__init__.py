"""ONNX step graph to FMI co-simulation FMU: the native C backend (default) and the pythonfmu fallback."""
