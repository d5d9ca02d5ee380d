"""The paper's experiment, the peer benchmark, profiling, the direct method."""
