"""The paper's protocols and the benchmarks on real data, each a function returning data and figures of merit."""
