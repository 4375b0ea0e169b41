"""Aggregated tables of the benchmark (per scene and average), written with provenance."""
