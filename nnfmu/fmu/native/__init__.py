"""Native FMU backend: C code generated from the ONNX step graph, compiled with the generic FMI glue."""
